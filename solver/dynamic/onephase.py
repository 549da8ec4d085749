"""One phase on the nodes as the loop (:mod:`solver.run.loop`) drives it: the shaken body
(:class:`solver.stepping.onephase.ShakenBody`: the solid with the mixture's density, a dry
or total-stress analysis) under a base motion and a sudden surface load, its row means at
the recorded depths, the state of a checkpoint and the nodal fields of the XDMF series.

Its step k (from 1) is the central-difference step from t_(k-1) = (k - 1) dt, which
computes the acceleration at t_(k-1): the samples and fields of step k are of t_(k-1) (the
cadence's offset 1)."""

from __future__ import annotations

import math

import numpy as np

from ..common import signals
from ..common.errors import NumericalError
from ..io import checkpoint
from ..model import scene
from ..stepping.onephase import ShakenBody
from . import histories
from .plan import DynamicPlan


class NodalModel:
    """One phase on the nodes (:class:`ShakenBody`) as the time loop drives it: the step,
    the row means of a sample, the state of a checkpoint, the fields of the XDMF series."""

    water = False
    lag = 0.0               # a sample is of the step's start

    def __init__(self, comm, plan: DynamicPlan):
        signals.stage("set-up: the body")
        self.plan = plan
        self.body = ShakenBody(comm, plan.body, plan.ground, plan.shaking, plan.sides,
                               plan.loading, plan.materials)
        b = self.body
        self.dt, self.every = histories.sample_step(plan.record_dt, b.dt)
        b.start(self.dt)
        ny, nx = b.grid.nodes[1], b.grid.nodes[0]
        self.heights = np.linspace(0.0, plan.body.height, ny)
        self.key, self.nx = b.row * 2 + b.comp, nx
        self.full = b.T.createVecLeft() if b.T is not None else None
        self.vec = b.K.createVecRight()
        self.mpi = comm.tompi4py()
        self.a = np.zeros(len(b.m))
        # A hysteretic soil's points carry their state (stresses, the elements'): the
        # checkpoint keeps those; a linear soil's state is the nodes' alone.
        self.points = b.points if b.hysteretic is None else \
            checkpoint.ArrayPoints(b.hysteretic.arrays)
        self.loops = histories.Loops(b.hysteretic, self.heights, plan.body.height,
                                     plan.depths, self.mpi, plan.shaking.direction) \
            if b.hysteretic is not None else None
        self._rows(nx)
        self.spectra = histories.StepSpectra(plan.motion, self.dt,
                                             frame=b.shaking.base == "rigid", psa=plan.psa,
                                             depths=self.nrows)

    def _rows(self, nx: int) -> None:
        """The weights of this rank's reduced DOFs in the recorded rows' mean accelerations
        in the shaking direction, the surface first (``dofs``, ``weights``, ``group``: the
        row each weight adds to): 1 / nx each node, a tied DOF counting for every node it
        stands for."""
        b = self.body
        rows = histories.record_rows(self.heights, self.plan.body.height,
                                     self.plan.depths)[0]
        w = np.zeros((len(rows), len(b.row)))                   # the full free DOFs
        for i, r in enumerate(rows):
            w[i] = np.where(b.along_full & (b.row == r), 1.0 / nx, 0.0)
        if b.T is not None:
            full, red = b.T.createVecLeft(), b.K.createVecRight()
            reduced = []
            for wi in w:
                full.setArray(wi)
                b.T.multTranspose(full, red)
                reduced.append(red.getArray().copy())
            w = np.array(reduced).reshape(len(rows), -1)
            scene.destroy(full, red)
        self.group, self.dofs = np.nonzero(w)
        self.weights = w[self.group, self.dofs]
        self.nrows = len(rows)

    def step(self, t: float) -> None:
        m = self.plan.motion
        self.a = self.body.step(t, m.velocity, m.acceleration)
        self.spectra.keep(t, np.bincount(self.group, self.a[self.dofs] * self.weights,
                                         minlength=self.nrows), self.mpi)

    def _full(self, values) -> np.ndarray:
        self.vec.setArray(values)
        return self.body.expand(self.vec, self.full).copy()

    def means(self, t: float) -> np.ndarray:
        """The row means (rows x COLUMNS) at t (s), the step from t just taken."""
        a = self.a
        if self.loops is not None:        # the points' state is of t: the step's start
            self.loops.sample(t)
        u, v = self._at_step_start()
        ny = len(self.heights)
        b = self.body
        sums = np.stack([np.bincount(self.key, weights=self._full(x), minlength=2 * ny)
                         for x in (a, v, u)])
        sums = self.mpi.allreduce(sums) / self.nx
        out = np.full((ny, 7), np.nan)
        for c in (0, 1):
            out[:, 3 * c:3 * c + 3] = sums[:, c::2].T
        comp = 3 * (0 if b.shaking.direction == "x" else 1)
        if b.shaking.base == "rigid":        # the frame of the base: absolute a and v
            m = self.plan.motion
            out[:, comp] += m.acceleration(t)
            out[:, comp + 1] += m.velocity(t)
        else:                                # displacements relative to the base
            out[:, [2, 5]] -= out[0, [2, 5]]
        return out

    def _at_step_start(self) -> tuple:
        """(u, v) at the time t of the step just taken (this rank's reduced values): the
        step left u at t + dt and v at t + dt / 2."""
        v_half = self.body.v.getArray()
        return self.body.u.getArray() - self.dt * v_half, v_half - self.a * self.dt / 2

    def check(self, step: int, t: float) -> None:
        local = float(np.max(np.abs(self.body.v.getArray()), initial=0.0))
        if not math.isfinite(self.mpi.allreduce(local, op=_max())):
            raise NumericalError(f"the run blew up at step {step} (t = {t:.6g} s)")

    def _gathered(self, *values):
        """Rows (natural DOF number, each of ``values`` on the free DOFs: this rank's
        reduced values) of every free DOF, in natural order, on rank 0; None elsewhere."""
        columns = [self.body.free.getIndices()] + [self._full(x) for x in values]
        parts = self.mpi.gather(np.column_stack(columns), root=0)
        if parts is None:
            return None
        whole = np.concatenate(parts)
        return whole[np.argsort(whole[:, 0])]

    def state(self) -> dict:
        """u, v of every free DOF (natural numbers, gathered on rank 0) and the state of
        the spectra from the steps."""
        steps = self.spectra.state(self.mpi)           # collective, as the gather
        loops = {} if self.loops is None else {"loops": self.loops.to_dict()}
        whole = self._gathered(*self.body.state())
        return {} if whole is None else {"nodal": whole.tolist(), **steps, **loops}

    def restore(self, ckpt) -> None:
        """Take up the state of a checkpoint (:class:`solver.io.checkpoint.Checkpoint`)."""
        whole = np.array(ckpt.state["nodal"], dtype=float)
        idx = self.body.free.getIndices()
        at = np.searchsorted(whole[:, 0], idx)
        self.body.u.setArray(whole[at, 1][self.body.kept])
        self.body.v.setArray(whole[at, 2][self.body.kept])
        self.spectra.restore(ckpt.state, ckpt.state["step"])
        if self.body.hysteretic is not None:
            self.body.hysteretic.restore(ckpt.columns())
            self.loops.restore(ckpt.state["loops"])

    def fields(self) -> tuple:
        """(node coordinates (N, 2), {name: (N, 3)}) of every node at the time of the step
        just taken, natural order (rank 0; None elsewhere): displacement, velocity and
        acceleration (relative to a rigid base)."""
        b = self.body
        whole = self._gathered(*self._at_step_start(), self.a)
        if whole is None:
            return None
        nx, ny = b.grid.nodes
        n = nx * ny
        out = {name: np.zeros((n, 3)) for name in ("displacement", "velocity",
                                                    "acceleration")}
        node, comp = whole[:, 0].astype(int) // 2, whole[:, 0].astype(int) % 2
        for col, name in enumerate(("displacement", "velocity", "acceleration")):
            out[name][node, comp] = whole[:, col + 1]
        j, i = np.divmod(np.arange(n), nx)
        xy = np.column_stack([i * b.grid.size[0] / (nx - 1), self.heights[j]])
        return xy, out

    def destroy(self):
        scene.destroy(self.vec, self.full, self.body)


def _max():
    from mpi4py import MPI

    return MPI.MAX
