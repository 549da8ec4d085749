"""Checkpoints and restarts of the static analysis (``-mpm_checkpoint_every N``,
``-mpm_restart CK``): the points' stresses and history (point fields, as the consolidation's
yielding soil keeps them), the converged nodal displacement and the last step's increment
(the predictor) in natural order, and the stepping's own state (where it is, its step
lengths, the curve and Newton's residuals so far, the field series). A restart continues
with the same steps, so it ends where the uninterrupted run does; ``-mpm_footing_settlement``
may grow (the steps keep their length)."""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np

from ..io import checkpoint
from ..materials import history


def fields(material) -> dict:
    """The point fields a static run keeps: the stress (in-plane, and zz) and the
    material's state variables."""
    names = material.initial_state(np.zeros((1, 4)))
    return {"stress": 3, "stress_zz": 1, **{f"state_{k}": 1 for k in names}}


@dataclass
class Progress:
    """Where the stepping is: the value reached (settlement in m, or the load's share),
    the step length ``ds`` and the last one taken, the nominal step (the asked length), the
    curve (settlement, pressure) rows and Newton's residuals per step."""

    s: float
    ds: float
    last: float
    nominal: float
    curve: list
    residuals: list

    @classmethod
    def start(cls, nominal: float, first) -> "Progress":
        return cls(0.0, nominal, 0.0, nominal, [first], [])


def save(path, comm, points, problem, progress: Progress, series, plan, run: dict):
    """Write the checkpoint (collective): the points with the problem's stresses and
    history, the nodal state and the progress."""
    history.write(points, problem.stress, problem.state)
    da = problem.grid.da
    state = {"step": len(progress.residuals), "s": progress.s, "ds": progress.ds,
             "last": progress.last, "nominal": progress.nominal,
             "curve": [list(map(float, row)) for row in progress.curve],
             "residuals": progress.residuals, "u_n": checkpoint.natural(da, problem.u_n),
             "du": checkpoint.natural(da, problem.du),
             "series": series.entries}
    checkpoint.write(path, comm, points, state, plan.signature, run)


def resume(ckpt, points, problem, series, run_id) -> Progress:
    """The problem's stresses, history and nodal state from the checkpoint ``ckpt`` (its
    points already scattered onto ``points``), the field series taken up; the progress."""
    problem.stress, problem.state = history.read(points)
    problem.trial = (problem.stress, problem.state)
    state, da = ckpt.state, problem.grid.da
    checkpoint.from_natural(da, state["u_n"], problem.u_n)
    checkpoint.from_natural(da, state["du"], problem.du)
    problem.u_n.copy(problem.u)
    series.resume(state.get("series", []), run_id)
    return Progress(state["s"], state["ds"], state["last"], state["nominal"],
                    [tuple(r) for r in state["curve"]], state["residuals"])


def path_of(plan) -> str:
    return os.path.join(plan.outputs.folder, "checkpoint.npz")
