"""A rigid strip footing pushed into the flowing body (:class:`solver.stepping.flow.Flow`) at
a prescribed velocity: its base a kinematic constraint on the grid's new velocities.

The base is a row of markers, one per cell width from x0 to x1, at the centres of the top
row of points under it (half a point's height under the base: at the base itself the
pressure rose by 7 % each time the base crossed half a cell, at every cell size measured,
and stayed there; at the points' centres the curve is smooth and the same as after that
jump). Each step, once the nodes' trial velocities v' = v + dt a are known, the markers'
interpolated velocities are made the footing's: v' <- v' + M^-1 C^T lambda, C the
markers' shape functions over the nodes (the walls' ghosts folded onto the nodes they
mirror), M the lumped masses, lambda from (C M^-1 C^T) lambda = v_footing - C v' (a
marker per column of nodes: the system is small and well conditioned). The impulse
C^T lambda over dt is the footing's force on the soil: smooth, the markers hold the
vertical velocity; rough, both. The constraint is exact each step (no penalty, so no
stiffness to shorten the step) and the same on every rank (each has the whole grid's
sums).

The push ramps up linearly over ``ramp`` seconds, then holds ``velocity``: a sudden start
would send a compression wave of rho c v into the soil.
"""

from __future__ import annotations

import numpy as np

from ..model import lattice


class Footing:
    """The footing from ``x0`` to ``x1`` (m) on a top at ``top`` (m) of ``grid`` (a
    :class:`lattice.Lattice`), ``rough`` or smooth, pushed down at ``velocity`` (m/s)
    after a linear ramp of ``ramp`` (s), to the settlement ``end`` (m); its markers
    ``inset`` (m) under its base, at the centres of the soil's top row of points."""

    def __init__(self, grid, x0, x1, top, rough, velocity, ramp, end, inset=0.0):
        self.grid, self.top, self.rough, self.inset = grid, top, rough, inset
        self.width = x1 - x0
        self.x = np.linspace(x0, x1, int(round(self.width / grid.h[0])) + 1)
        self.velocity, self.ramp, self.end = velocity, ramp, end
        self.t = 0.0
        self.force = 0.0            # on the soil, downwards positive (N per m), this step

    def speed(self, t: float) -> float:
        """The footing's downward speed at time t (m/s)."""
        return self.velocity * min(1.0, t / self.ramp) if self.ramp > 0 else self.velocity

    def settlement(self, t: float) -> float:
        """The footing's settlement at time t (m): the integral of :meth:`speed`."""
        v, r = self.velocity, self.ramp
        return v * t * t / (2 * r) if t < r else v * (t - 0.5 * r)

    def duration(self) -> float:
        """The time (s) at which the settlement reaches its end."""
        v, r = self.velocity, self.ramp
        return np.sqrt(2 * self.end * r / v) if self.end < 0.5 * v * r else self.end / v + 0.5 * r

    @property
    def pressure(self) -> float:
        """The mean contact pressure of this step (Pa): the force over the width."""
        return self.force / self.width

    def constrain(self, vn, a, mass, dt, held, source, sign) -> None:
        """Correct the nodal accelerations a (n_nodes, 2) in place so that the markers'
        velocities after the step are the footing's; vn the nodal velocities, mass the
        lumped masses (0 where a node has none), held/source/sign the walls'
        (:func:`lattice.walls`)."""
        level = self.top - self.inset - self.settlement(self.t)
        nodes, N, _ = lattice.evaluate(self.grid, np.column_stack(
            [self.x, np.full(len(self.x), level)]))
        real = source[nodes]                        # ghosts folded onto their mirrors
        inverse = np.divide(1.0, mass, out=np.zeros_like(mass), where=mass > 0)
        used, local = np.unique(real, return_inverse=True)
        rows = np.repeat(np.arange(len(self.x)), N.shape[1])
        impulse_y = 0.0
        for comp, target in ((1, -self.speed(self.t + dt)), (0, 0.0))[:2 if self.rough else 1]:
            w = N * sign[nodes, comp] * (~held[real, comp]) * (mass[real] > 0)
            C = np.zeros((len(self.x), len(used)))
            np.add.at(C, (rows, local.ravel()), w.ravel())
            m_inv = inverse[used]
            keep = np.abs(C).sum(axis=1) > 0        # markers that reach a node with mass
            C = C[keep]
            gap = target - C @ (vn[used, comp] + dt * a[used, comp])
            lam = np.linalg.solve((C * m_inv) @ C.T, gap)
            kick = C.T @ lam                        # the impulse on each node (N s per m)
            a[used, comp] += m_inv * kick / dt
            if comp == 1:
                impulse_y = float(kick.sum())
        self.force = -impulse_y / dt
        self.t += dt

    def state(self) -> dict:
        return {"t": self.t, "force": self.force}

    def restore(self, state) -> None:
        self.t, self.force = float(state["t"]), float(state["force"])
