"""``-mpm_analysis dynamic``: the body shaken at its base, or loaded suddenly, stepped in time.

One phase (:class:`solver.dynamic.onephase.NodalModel`: the solid with the mixture's
density, a dry or total-stress analysis) under a base motion and a sudden surface load; two
phases (:class:`solver.dynamic.saturated.SaturatedColumn`: the explicit v-w step without its
damping) shaken on a rigid base or loaded suddenly. The set-up reads the options once and
plans the run (:mod:`solver.dynamic.plan`); the loop of :mod:`solver.run.loop` then steps
the model (:class:`Shaken`), recording the row means at the recorded depths every
``-mpm_record_dt`` and the peaks of every row (:mod:`solver.dynamic.histories`),
checkpointing as asked and on SIGTERM; the reporting writes the histories, spectra, peaks
with depth, figures, the nodal or point fields (XDMF) and the summary's ``dynamic`` block.
"""

from __future__ import annotations

import math
import os

from ..common import signals
from ..common.errors import InputError
from ..io import checkpoint
from ..run.loop import Cadence, Saving, drive
from ..run.record import Record, guarded, owned
from . import histories, reporting
from . import flowing
from .flowing import check_given
from .plan import Request, plan_of

MAX_STEPS = 5e7


def run(p, comm) -> int:
    """Run the dynamic scene of the options ``p`` on ``comm``; returns 0 (a failure raises,
    after the record has written what it can)."""
    signals.stage("set-up: the options' checks")
    check_given(p.given, p.kinematics)
    if p.kinematics == "large":
        return flowing.run(flowing.plan_of(p), comm)
    req = Request.from_options(p)
    record = Record("dynamic", comm)
    with owned(comm) as stack:
        guarded(record, lambda: _run(req, comm, record, stack))
    return 0


def _run(req, comm, record, stack) -> None:
    """The run of the request ``req`` (:class:`solver.dynamic.plan.Request`)."""
    ckpt, run_id = checkpoint.take_up(req.restart, req.overwrite, req.signature, req.outputs,
                                      comm)
    record.begin(req.outputs, run_id, req.provenance)
    plan = plan_of(req, comm)
    plan.run["id"] = run_id
    if plan.phases == 2:
        from .saturated import SaturatedColumn as Model
    else:
        from .onephase import NodalModel as Model
    engine = Model(comm, plan)
    stack.callback(engine.destroy)
    model = Shaken(plan, engine, comm, ckpt)
    record.results = reporting.keys(plan, engine)
    reporting.print_plan(plan, engine, model.nsteps, comm)
    output_every, ckpt_every, ckpt_seconds, progress = plan.cadence
    cadence = Cadence(model.nsteps, sample_every=engine.every,
                      output_every=output_every or max(1, (model.nsteps - 1) // 50),
                      checkpoint_every=ckpt_every, checkpoint_seconds=ckpt_seconds,
                      progress_seconds=progress, offset=1)
    saving = Saving(os.path.join(plan.outputs.folder, "checkpoint.npz"), plan.signature,
                    plan.run)
    drive(model, cadence, record, saving, first=model.first)
    reporting.finish(plan, engine, model.rec, model.series, record, comm, model.nsteps)


class Shaken:
    """A dynamic model (``engine``: one phase or two) as the loop drives it, with the
    records of its samples (:class:`histories.Recorder`) and its field series.

    Step k (from 1) is the engine's step from t_(k-1) = (k - 1) dt: the one-phase engine's
    samples are of that time (it computes the acceleration there), the two-phase engine's of
    the step's end (its ``lag``, dt); the fields are of t_(k-1). The last step starts at
    the first multiple of dt at or after -mpm_t_end."""

    log_stage = "Dynamic steps"

    def __init__(self, plan, engine, comm, ckpt=None):
        self.plan, self.engine = plan, engine
        self.dt, self.points = engine.dt, engine.points
        self.nsteps = int(math.ceil(plan.t_end / self.dt - 1e-9)) + 1
        if self.nsteps > MAX_STEPS:
            raise InputError(f"-mpm_t_end {plan.t_end:g}: {self.nsteps:.3g} steps of "
                             f"{self.dt:.3g} s; more than {MAX_STEPS:.0e} is not a run that "
                             "finishes")
        self.rec = histories.Recorder(engine.heights, plan.body.height, plan.depths,
                                      plan.shaking.direction)
        self.first = 1
        if ckpt is not None:
            done = ckpt.state["step"]
            if done > self.nsteps:
                raise InputError(f"-mpm_t_end {plan.t_end:g}: before the state of "
                                 f"-mpm_restart {plan.restart} (t = {done * self.dt:.6g} s)")
            engine.restore(ckpt)
            self.rec.restore(ckpt.state["records"])
            self.first = done + 1
        self.series = reporting.Series(plan, engine, comm, ckpt)

    def time(self, k: int) -> float:
        """The time (s) the samples and fields of step ``k`` are of (its start)."""
        return (k - 1) * self.dt

    def advance(self, k: int) -> None:
        self.engine.step(self.time(k))

    def check(self, k: int) -> None:
        self.engine.check(k, self.time(k))

    def sample(self, k: int) -> None:
        t = self.time(k)
        self.rec.sample(t + self.engine.lag, self.engine.means(t))

    def write_fields(self, k: int) -> None:
        self.series.write(k - 1, self.time(k))

    def state(self) -> dict:
        return {"dt": self.dt, "records": self.rec.to_dict(), "series": self.series.entries(),
                **self.engine.state()}

    def progress(self, k: int) -> str:
        return reporting.progress_words(self.rec, self.time(k))
