"""Consolidation of a soil body (paper Section 5, Tables 1, 4, 5, Figs 3-5).

:func:`run` reads the options once, in the set-up (:mod:`solver.consolidation.setup`), and
turns them into a :class:`solver.consolidation.plan.Plan`: the soil, the body and its
loading, the time scheme and its steps (the explicit step's critical time steps, or the
implicit scheme's steps graded from the load), and the references. The loop of
:mod:`solver.run.loop` then drives the consolidating body
(:class:`solver.consolidation.model.Consolidation`: the explicit v-w step or the implicit
scheme) from t = 0 to T_v = ``-mpm_Tv_end``, and :mod:`solver.consolidation.results` compares
the monitor point and whole profiles at the report times with two analytic references:

- classic Terzaghi: p0 = q, c_v = k E_c / gamma_w (what the paper compares against);
- consistent Terzaghi: p0 = q (K_l/n) / (K_l/n + E_c), diffusivity c2 (compressible water),
  which isolates the numerical error.

The run's record (:mod:`solver.run.record`) writes the summary, also for a run that fails
or is stopped after its set-up began, with a checkpoint where the state was whole.
"""

from __future__ import annotations

import os

from ..common import signals
from ..run.loop import Saving, drive
from ..run.record import Record, guarded, owned
from . import largestrain, results, setup
from .model import Consolidation


def run(p, comm) -> int:
    """Run the consolidation scene of the options ``p`` on ``comm``; returns 0 (a failure
    raises, after the record has written what it can)."""
    large = p.kinematics == "large" and p.scheme == "implicit"
    largestrain.check_given(p.given, p.from_file, large)
    if large:
        return largestrain.run(largestrain.plan_of(p, comm), comm)
    record = Record("consolidation", comm)
    with owned(comm) as stack:
        guarded(record, lambda: _run(setup.set_up(p, comm, record, stack), comm, record,
                                     stack))
    return 0


def _run(made, comm, record, stack) -> None:
    """The run after its set-up (``made``: the plan, grid, points and first state)."""
    plan, grid, points, state = made
    signals.stage("set-up: the model")
    model = Consolidation(plan, grid, points, state, comm)
    stack.callback(model.destroy)
    record.results = results.keys(plan, points, state)
    model.begin()
    saving = Saving(os.path.join(plan.outputs.folder, "checkpoint.npz"), plan.signature,
                    plan.run)
    drive(model, plan.schedule.cadence(), record, saving, first=state.step + 1)
    results.finish(plan, model, record, comm)
