"""A rigid strip footing pushed into the flowing body (:class:`solver.stepping.flow.Flow`) at
a prescribed velocity: its base a kinematic constraint on the grid's new velocities.

The base is a row of markers at the centres of the top row of points under it (half a
point's height under the base: at the base itself the pressure rose by 7 % each time the
base crossed half a cell, at every cell size measured, and stayed there; at the points'
centres the curve is smooth and the same as after that jump), one on each node column
between the edges and one half a cell inside each edge (on the edge where that is the
grid's side: the model's axis, a wall). There a marker holds the mean of the edge's two
columns (1/2 each, with every function here) and reaches nothing beyond the edge; a
marker on the edge held the column beyond it too (1/8 with B-splines, 1/16 with uGIMP),
and with it the soil beside the footing: the plateau 21 % over Prandtl's on 0.125 m cells
against 15 %. Markers in the middle of every cell width would hold only the cells' means
and leave the columns free to alternate (a checkerboard under the base half as large
again).

Each step, once the nodes' trial velocities v' = v + dt a are known, the markers'
interpolated velocities are made the footing's: v' <- v' + M^-1 C^T lambda, C the
markers' shape functions over the nodes (the walls' ghosts folded onto the nodes they
mirror), M the lumped masses, lambda from (C M^-1 C^T) lambda = v_footing - C v' (a
marker per column of nodes: the system is small and well conditioned). The impulse
C^T lambda over dt is the footing's force on the soil: smooth, the markers hold the
vertical velocity; rough, both. The constraint is exact each step (no penalty, so no
stiffness to shorten the step) and the same on every rank (each has the whole grid's
sums).

Its sides, where not on the model's axis, are columns of markers half a point outside
them from the base to the grid's top, which hold the horizontal velocity at zero where
the soil presses on them and let go where they would pull (without them the heave flowed
back over the base into the footing's place).

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
    ``inset`` (x, y) (m) outside its sides and under its base, at the centres of the
    soil's outer row of points."""

    def __init__(self, grid, x0, x1, top, rough, velocity, ramp, end, inset=(0.0, 0.0)):
        self.grid, self.top, self.rough, self.inset = grid, top, rough, inset
        self.width, self.edges = x1 - x0, (x0, x1)
        widths = int(round(self.width / grid.h[0]))
        step, self.span = self.width / widths, grid.cells[0] * grid.h[0]
        # An edge on the grid's side keeps its column's marker (the mirror there holds
        # nothing beyond it); an edge inside the grid has its marker half a cell in.
        self.x = np.concatenate([[x0 if x0 <= 0 else x0 + 0.5 * step],
                                 x0 + step * np.arange(1, widths),
                                 [x1 if x1 >= self.span else x1 - 0.5 * step]])
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
        inset_x, inset_y = self.inset
        level = self.top - inset_y - self.settlement(self.t)
        base = np.column_stack([self.x, np.full(len(self.x), level)])
        # The sides, where the footing is not on the axis: markers half a point outside
        # them from the base to the grid's top, holding the soil out (unilateral).
        h = self.grid.h[1]
        y = np.arange(level + 0.5 * h, self.grid.cells[1] * h - 0.5 * h, h)
        sides, push = [], []
        for x, out in ((self.edges[0] - inset_x, -1.0), (self.edges[1] + inset_x, 1.0)):
            if 0 < x < self.span:
                sides.append(np.column_stack([np.full(len(y), x), y]))
                push.append(np.full(len(y), out))
        inverse = np.divide(1.0, mass, out=np.zeros_like(mass), where=mass > 0)
        args = (vn, a, inverse, dt, held, source, sign)
        self.force = -self._hold(base, 1, -self.speed(self.t + dt), None, *args).sum() / dt
        across = [base] if self.rough else []
        push = [np.zeros(len(base))] * self.rough + push
        if across or sides:
            self._hold(np.vstack(across + sides), 0, 0.0, np.concatenate(push), *args)
        self.t += dt

    def _hold(self, markers, comp, target, push, vn, a, inverse, dt, held, source, sign):
        """Make component ``comp`` of the velocity after the step at ``markers`` (n, 2)
        (m) ``target`` (m/s), correcting a in place over the lumped masses (``inverse``:
        their reciprocals, 0 where a node has none); ``push`` (n,): +1 or -1 where a
        marker may only push the soil that way (those that pull are let go, and the rest
        solved again), 0 where it holds both ways (None: all).
        Returns the impulse on each node it moved (N s per m)."""
        nodes, N, _ = lattice.evaluate(self.grid, markers)
        real = source[nodes]                        # ghosts folded onto their mirrors
        used, local = np.unique(real, return_inverse=True)
        w = N * sign[nodes, comp] * (~held[real, comp]) * (inverse[real] > 0)
        C = np.zeros((len(markers), len(used)))
        np.add.at(C, (np.repeat(np.arange(len(markers)), N.shape[1]), local.ravel()),
                  w.ravel())
        m_inv = inverse[used]
        free = vn[used, comp] + dt * a[used, comp]
        on = np.abs(C).sum(axis=1) > 0              # markers that reach a node with mass
        push = np.zeros(len(markers)) if push is None else push
        for _ in range(20):
            Ca = C[on]
            # Least squares: markers that reach the same few nodes repeat a constraint.
            lam = np.linalg.lstsq((Ca * m_inv) @ Ca.T, target - Ca @ free, rcond=1e-12)[0] \
                if len(Ca) else np.zeros(0)
            pulls = push[on] * lam < 0
            if not pulls.any():
                break
            on[np.flatnonzero(on)[pulls]] = False
        kick = Ca.T @ lam                           # the impulse on each node (N s per m)
        a[used, comp] += m_inv * kick / dt
        return kick

    def state(self) -> dict:
        return {"t": self.t, "force": self.force}

    def restore(self, state) -> None:
        self.t, self.force = float(state["t"]), float(state["force"])
