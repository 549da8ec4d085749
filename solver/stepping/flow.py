"""The explicit updated-Lagrangian step of one phase on a fixed background grid, whose points
flow across its cells (:mod:`solver.model.lattice`; no analysis runs it yet).

Each step (update stress last, FLIP with a share of PIC):

1. points to grid: masses m_a = sum N m_p, momenta sum N m_p v_p, forces
   f_a = -sum V_p sigma_p grad N + sum N m_p g, with the current volume V_p = J_p V_p0;
2. the nodes: v_a = momentum / m_a, local damping of the force against v_a
   (-alpha |f| sign v, which vanishes at rest), a_a = f_a / m_a, held components zero on
   the walls and the floor, the ghost nodes beyond them mirroring the nodes inside
   (:func:`lattice.walls`), v_a' = v_a + dt a_a; nodes without mass are left out;
3. grid to points: v_p <- flip (v_p + dt sum N a) + (1 - flip) sum N v', x_p += dt sum N v',
   the velocity gradient L = sum v' (x) grad N, the incremental deformation gradient
   f = (I - dt L / 2)^-1 (I + dt L / 2) (:func:`increment`), with F-bar over cells if
   asked, and the stress from Hencky's elasticity with the material's return
   (:class:`solver.materials.hencky.Hencky`): objective without a stress rate.

Vectorised over the points (NumPy; bincount for the sums): no loop per point or node.
"""

from __future__ import annotations

import numpy as np

from ..materials.hencky import Hencky
from ..model import lattice


def increment(L, dt):
    """The incremental deformation gradients (np, 2, 2) of the velocity gradients L over dt:
    Hughes and Winget's (I - dt L / 2)^-1 (I + dt L / 2), second order and exactly
    orthogonal where L is skew (a rigid spin turns b_e without stretching it; I + dt L
    would stretch it by 1 + (w dt)^2 / 2 every step)."""
    A = np.eye(2)[None] - 0.5 * dt * L
    B = np.eye(2)[None] + 0.5 * dt * L
    det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
    inv = np.empty_like(A)
    inv[:, 0, 0], inv[:, 1, 1] = A[:, 1, 1] / det, A[:, 0, 0] / det
    inv[:, 0, 1], inv[:, 1, 0] = -A[:, 0, 1] / det, -A[:, 1, 0] / det
    return inv @ B


class Flow:
    """Material points of one material on ``grid`` (a :class:`lattice.Lattice`): positions
    ``x`` (np, 2) (m), volumes ``volume`` (np,) (m3 per m), density ``rho`` (kg/m3),
    ``material`` one of the materials room's (its elasticity Hencky's), gravity ``g``
    (m/s2, downwards), ``walls`` {side: components held} of the grid
    (:func:`lattice.walls`), ``damping`` alpha (-), ``flip`` (-) and ``fbar`` (F-bar over
    cells, :meth:`_fbar`)."""

    def __init__(self, grid, x, volume, rho, material, g=9.81, walls=None,
                 damping=0.0, flip=1.0, fbar=False):
        self.grid = grid
        self.x = np.array(x, dtype=float)
        self.x0 = self.x.copy()
        self.v = np.zeros_like(self.x)
        self.V0 = np.asarray(volume, dtype=float) * np.ones(len(self.x))
        self.m = rho * self.V0
        self.g, self.damping, self.flip, self.fbar = g, damping, flip, fbar
        self.held, self.source, self.sign = lattice.walls(grid, walls or {})
        self.ghosts = np.flatnonzero(self.source != np.arange(grid.n_nodes))
        self.hencky = Hencky(material)
        self.state = self.hencky.initial_state(len(self.x))
        self.sigma = np.zeros((len(self.x), 4))      # Cauchy: xx, yy, zz, xy (Pa)
        self.time = 0.0

    @property
    def J(self) -> np.ndarray:
        return self.state["J"]

    def kinetic_energy(self) -> float:
        """The points' kinetic energy (J per m)."""
        return 0.5 * float(np.sum(self.m * np.sum(self.v * self.v, axis=1)))

    def _fbar(self, f, V):
        """F-bar over cells: each point's incremental dilation det f replaced by its cell's
        volume-weighted mean (the cell the point is in now), the in-plane f scaled by
        sqrt(mean / det f): the volume then changes cell by cell, which takes out the
        point-to-point volumetric modes the nodes do not see (and volumetric locking)."""
        lat = self.grid
        cell = (np.floor(self.x[:, 1] / lat.h[1]).astype(np.int64) * lat.cells[0]
                + np.floor(self.x[:, 0] / lat.h[0]).astype(np.int64))
        det = np.linalg.det(f)
        n = lat.cells[0] * lat.cells[1]
        num = np.bincount(cell, weights=V * det, minlength=n)
        den = np.bincount(cell, weights=V, minlength=n)
        mean = num[cell] / den[cell]
        return f * np.sqrt(mean / det)[:, None, None]

    def step(self, dt: float) -> None:
        """One explicit step of dt (s)."""
        nodes, N, G = lattice.evaluate(self.grid, self.x)
        nn, flat = self.grid.n_nodes, nodes.ravel()

        def gather(values):
            return np.bincount(flat, weights=values.ravel(), minlength=nn)

        mN = N * self.m[:, None]
        mass = gather(mN)
        mom = np.stack([gather(mN * self.v[:, d:d + 1]) for d in range(2)], axis=1)
        V = self.V0 * self.J
        s = self.sigma
        force = np.stack([
            gather(-(s[:, 0:1] * G[..., 0] + s[:, 3:4] * G[..., 1]) * V[:, None]),
            gather(-(s[:, 3:4] * G[..., 0] + s[:, 1:2] * G[..., 1]) * V[:, None])
            - self.g * mass], axis=1)
        # A ghost node's sums belong to the node it mirrors (its test function is part of
        # that node's: N_a + sign N_ghost), folded in with the mirror's sign.
        src, sgn = self.source[self.ghosts], self.sign[self.ghosts]
        np.add.at(mass, src, mass[self.ghosts])
        np.add.at(mom, src, sgn * mom[self.ghosts])
        np.add.at(force, src, sgn * force[self.ghosts])
        active = mass > 1e-12 * mass.max()
        inv = np.where(active, 1.0 / np.where(active, mass, 1.0), 0.0)[:, None]
        vn = mom * inv
        if self.damping:
            force -= self.damping * np.abs(force) * np.sign(vn)
        a = force * inv
        a[self.held] = 0.0
        vn[self.held] = 0.0
        # Beyond a wall the nodes mirror the nodes inside (lattice.walls).
        a[self.ghosts], vn[self.ghosts] = sgn * a[src], sgn * vn[src]
        vnew = vn + dt * a
        self._advance(nodes, N, G, a, vnew, V, dt)

    def move(self, velocity, dt: float) -> None:
        """Move the points by the nodal velocities ``velocity`` (n_nodes, 2) (m/s) over dt
        (s), as grid to points does after a step: a prescribed motion of the grid (a
        rigid rotation, a test of objectivity)."""
        nodes, N, G = lattice.evaluate(self.grid, self.x)
        self._advance(nodes, N, G, np.zeros_like(velocity), velocity, self.V0 * self.J, dt)

    def _advance(self, nodes, N, G, a, vnew, V, dt):
        """Grid to points: velocities (FLIP/PIC), positions, the deformation and the stress,
        from the nodal accelerations a and new velocities vnew (n_nodes, 2)."""
        ap = np.einsum("pa,pad->pd", N, a[nodes])
        vp = np.einsum("pa,pad->pd", N, vnew[nodes])
        self.v = self.flip * (self.v + dt * ap) + (1 - self.flip) * vp
        self.x += dt * vp
        L = np.einsum("pai,paj->pij", vnew[nodes], G)
        f = increment(L, dt)
        if self.fbar:
            f = self._fbar(f, V)
        self.sigma, self.state = self.hencky.update(f, self.state)
        self.time += dt
