"""The explicit updated-Lagrangian step of one phase on a fixed background grid, whose points
flow across its cells (:mod:`solver.model.lattice`; the dynamic analysis's flowing body,
:mod:`solver.dynamic.flowing`).

Each step (update stress last, FLIP with a share of PIC):

1. points to grid: masses m_a = sum N m_p, momenta sum N m_p v_p, forces
   f_a = -sum V_p sigma_p grad N + sum N m_p g, with the current volume V_p = J_p V_p0;
2. the nodes: v_a = momentum / m_a, local damping of the force against v_a
   (-alpha |f| sign v, which vanishes at rest), a_a = f_a / m_a, held components brought
   to rest on the walls and the floor (a_a = -v_a / dt: the wall takes their momentum,
   and FLIP hands that change to the points as it does every node's), a footing's
   constraint (:mod:`solver.stepping.footing`), the ghost nodes beyond the walls
   mirroring the nodes inside (:func:`lattice.walls`), v_a' = v_a + dt a_a; nodes
   without mass are left out;
3. grid to points: v_p <- flip (v_p + dt sum N a) + (1 - flip) sum N v', x_p += dt sum N v',
   the velocity gradient L = sum v' (x) grad N, the incremental deformation gradient
   f = (I - dt L / 2)^-1 (I + dt L / 2) (:func:`increment`), with F-bar over cells if
   asked, and the stress from Hencky's elasticity with the material's return
   (:class:`solver.materials.hencky.Hencky`): objective without a stress rate.

Vectorised over the points (NumPy; bincount for the sums): no loop per point or node.
"""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from ..materials.hencky import Hencky, det2
from ..common.errors import NumericalError
from ..model import lattice
from . import transfer


def increment(L, dt):
    """The incremental deformation gradients (np, 2, 2) of the velocity gradients L over dt:
    Hughes and Winget's (I - dt L / 2)^-1 (I + dt L / 2), second order and exactly
    orthogonal where L is skew (a rigid spin turns b_e without stretching it; I + dt L
    would stretch it by 1 + (w dt)^2 / 2 every step)."""
    # (I - dt L / 2)^-1 (I + dt L / 2), written out for 2 x 2 blocks.
    h = 0.5 * dt
    a00, a01, a10, a11 = 1 - h * L[:, 0, 0], -h * L[:, 0, 1], -h * L[:, 1, 0], 1 - h * L[:, 1, 1]
    b00, b01, b10, b11 = 1 + h * L[:, 0, 0], h * L[:, 0, 1], h * L[:, 1, 0], 1 + h * L[:, 1, 1]
    det = a00 * a11 - a01 * a10
    out = np.empty_like(L)
    out[:, 0, 0] = (a11 * b00 - a01 * b10) / det
    out[:, 0, 1] = (a11 * b01 - a01 * b11) / det
    out[:, 1, 0] = (a00 * b10 - a10 * b00) / det
    out[:, 1, 1] = (a00 * b11 - a10 * b01) / det
    return out


class Flow:
    """Material points of one material on ``grid`` (a :class:`lattice.Lattice`): positions
    ``x`` (np, 2) (m), volumes ``volume`` (np,) (m3 per m), density ``rho`` (kg/m3),
    ``material`` one of the materials room's (its elasticity Hencky's), gravity ``g``
    (m/s2, downwards), ``walls`` {side: components held} of the grid
    (:func:`lattice.walls`), ``damping`` alpha (-), ``flip`` (-), ``fbar`` (F-bar over
    cells, :meth:`_fbar`) and a ``footing`` pushed into it (:mod:`solver.stepping.footing`)."""

    def __init__(self, grid, x, volume, rho, material, g=9.81, walls=None,
                 damping=0.0, flip=1.0, fbar=False, friction=0.0, comm=None, footing=None):
        self.grid = grid
        self.x = np.array(x, dtype=float)
        self.x0 = self.x.copy()
        self.v = np.zeros_like(self.x)
        self.V0 = np.asarray(volume, dtype=float) * np.ones(len(self.x))
        self.m = rho * self.V0
        self.g, self.damping, self.flip, self.fbar = g, damping, flip, fbar
        self.held, self.source, self.sign = lattice.walls(grid, walls or {})
        self.ghosts = np.flatnonzero(self.source != np.arange(grid.n_nodes))
        self.friction = friction
        self.footing = footing      # a footing.Footing pushed into the body, or None
        # The floor's own nodes (y = 0, its y held): where Coulomb friction acts.
        on_floor = np.isclose(grid.positions()[:, 1], 0.0) & self.held[:, 1]
        self.floor = np.flatnonzero(on_floor & (self.source == np.arange(grid.n_nodes)))
        # The ghost node under each (B-splines: the row below; hat functions have none).
        self.under = self.floor - grid.shape[0] if grid.ghost else None
        self.mpi = comm.tompi4py() if comm is not None and comm.getSize() > 1 else None
        self.extent = np.array(grid.cells, dtype=float) * np.array(grid.h)
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
        det = det2(f)
        n = lat.cells[0] * lat.cells[1]
        num = np.bincount(cell, weights=V * det, minlength=n)
        den = np.bincount(cell, weights=V, minlength=n)
        mean = num[cell] / den[cell]
        return f * np.sqrt(mean / det)[:, None, None]

    def _args(self) -> tuple:
        """The grid's data the transfers take: (the functions' form, uGIMP's half widths in
        cells, ghost layers, the cell sizes (m), nodes per row)."""
        lat = self.grid
        h = np.asarray(lat.h, dtype=float)
        return (lattice.KINDS.index(lat.kind), np.asarray(lat.lp) / h, lat.ghost, h,
                lat.shape[0])

    def _left(self, p: int) -> None:
        """NumericalError: point p of this rank (-1: of another) left the grid, where it
        has no nodes."""
        where = "" if p < 0 else " at ({:.4g}, {:.4g}) m".format(*self.x[p])
        raise NumericalError(f"a material point left the grid{where} (t = {self.time:.4g} "
                             "s): enlarge -mpm_grid_size")

    def step(self, dt: float) -> None:
        """One explicit step of dt (s)."""
        sums = np.empty((self.grid.n_nodes, transfer.NS))
        V = self.V0 * self.J
        out = transfer.points_to_grid(self.x, self.v, self.m, V, self.sigma, *self._args(),
                                      self.extent, sums)
        # Every rank stops where a point of any one has left the grid.
        left = out >= 0 if self.mpi is None else self.mpi.allreduce(out >= 0, op=MPI.LOR)
        if left:
            self._left(out)
        if self.mpi is not None:      # each rank's points, one grid: the sums over all ranks
            self.mpi.Allreduce(MPI.IN_PLACE, sums)
        mass, mom, force = sums[:, 0], sums[:, 1:3], sums[:, 3:5]
        force[:, 1] -= self.g * mass
        # The y-forces of the rows beside the floor (B-splines: the ghost row below it and
        # the row above), before the mirror folds them: the floor's reaction holds them too.
        beside = (force[self.under, 1] + force[self.floor + self.grid.shape[0], 1]) \
            if self.friction and self.under is not None else 0.0
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
        if self.friction:
            self._floor_friction(vn, a, dt, beside, mass)
        # The walls stop their held components within the step. Zeroing a there as well
        # as v would leave the points the momentum they carried into the wall (FLIP adds
        # only sum N a), and the body would move otherwise than its points' momenta say
        # (tests/test_flow.py).
        a[self.held] = -vn[self.held] / dt
        if self.footing is not None:
            self.footing.constrain(vn, a, np.where(active, mass, 0.0), dt, self.held,
                                   self.source, self.sign)
        # Beyond a wall the nodes mirror the nodes inside (lattice.walls).
        a[self.ghosts], vn[self.ghosts] = sgn * a[src], sgn * vn[src]
        self._advance(a, vn + dt * a, V, dt)

    def _floor_friction(self, vn, a, dt, beside, mass) -> None:
        """Coulomb friction on the floor's nodes, in place on the accelerations a: the
        floor takes away the normal momentum the body would have into it over the step
        and with it at most ``friction`` times as much of the sliding momentum of each
        node (the impulses' ratio is the forces' over the step; Bardenhagen, Brackbill
        and Sulsky 2000); a node leaving the floor or at rest on it keeps its own.

        The normal impulse is the floor's whole reaction, -dt (sum over the floor's nodes
        of m a_y, plus the y-forces ``beside`` of the rows beside it), shared among the
        nodes pressed into it as each is pressed (-m (v_y + dt a_y)). With B-splines the
        mirror (lattice.walls) folds the ghost row's y-force, negated, into the row above
        the floor: the floor's nodes alone then hold three quarters of a resting body's
        weight, and friction from their own reactions, or from each column's (whose
        signs alternate where the body shears), gave a sliding block 0.84 and 1.8 times
        mu g (measured); from the whole reaction it is mu g (tests/test_collapse.py)."""
        f = self.floor
        slide = vn[f, 0] + dt * a[f, 0]
        m = mass[f]
        share = m * np.maximum(-(vn[f, 1] + dt * a[f, 1]), 0.0)
        total = max(-dt * float(np.sum(m * a[f, 1] + beside)), 0.0)
        safe = np.where(share > 0, m, 1.0)
        pressed = total * share / max(float(share.sum()), 1e-300) / safe
        kept = np.sign(slide) * np.maximum(np.abs(slide) - self.friction * pressed, 0.0)
        a[f, 0] = (kept - vn[f, 0]) / dt

    def move(self, velocity, dt: float) -> None:
        """Move the points by the nodal velocities ``velocity`` (n_nodes, 2) (m/s) over dt
        (s), as grid to points does after a step: a prescribed motion of the grid (a
        rigid rotation, a test of objectivity)."""
        self._advance(np.zeros_like(velocity), velocity, self.V0 * self.J, dt)

    def _advance(self, a, vnew, V, dt):
        """Grid to points: velocities (FLIP/PIC), positions, the deformation and the stress,
        from the nodal accelerations a and new velocities vnew (n_nodes, 2)."""
        n = len(self.x)
        ap, vp, L = np.empty((n, 2)), np.empty((n, 2)), np.empty((n, 2, 2))
        transfer.grid_to_points(self.x, a, vnew, *self._args(), ap, vp, L)
        self.v = self.flip * (self.v + dt * ap) + (1 - self.flip) * vp
        self.x += dt * vp
        f = increment(L, dt)
        if self.fbar:
            f = self._fbar(f, V)
        self.sigma, self.state = self.hencky.update(f, self.state)
        self.time += dt
