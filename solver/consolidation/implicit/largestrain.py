"""Large-strain consolidation of a column by the implicit u-p scheme on moving points
(``-mpm_scheme implicit -mpm_kinematics large``): updated Lagrangian, the grid reset at
every step to the body as it then is.

A column loaded over its whole top on rollers settles as a column: its rows of points stay
rows. The grid is remade at each step over the body, its rows of cells following the
material (their edges moved by the step's displacement, so that a point keeps its cell and
the points of a cell weigh the cell's own volume): the top row of nodes is the body's
surface, where the load acts and the water drains. Reset on a uniform grid instead, the
points crossed cells as the column compressed unevenly, a cell's points then weighed more
or less than the cell, and the cells' stresses balanced in proportion to their fill: the
column did not come to rest at its final settlement (3.8 to 4.0 m against 3.297 m).

Each step h, from the state n:

1. the operators K, Q, S, H (:class:`.operators.Operators`) on the current grid from the
   points' current positions, volumes V = J V0, porosities n = 1 - (1 - n0) / J
   (incompressible grains) and permeabilities (``-mpm_k_law``: constant; power:A,
   k0 ((1 + e) / (1 + e0))^A; kozeny-carman, k0 (e^3 / (1 + e)) / (e0^3 / (1 + e0)));
2. backward Euler on the increments, the equilibrium at the step's end linearised about
   the current stress (its residual carried to the next step: no drift),

       [ K      -Q      ] [du]   [F(t + h) - sum V B^T sigma'_n]
       [ -Q^T   -(S+hH) ] [p ] = [-S p_n                       ]

   (p the excess pore pressure at the nodes at the step's end, p_n the step before's, node
   for node; h = 0 the undrained start, the drained sides' pressure left free);
3. the points: x += N du, the step's deformation gradient f = I + grad du (that of the
   displacement itself), the effective stress by Hencky's law (``-mpm_large_strain_stress``:
   kirchhoff, tau = D ln V; cauchy, sigma' = D ln V, the law of a constant m_vl that Xie
   and Leo take), p at the points from the nodes, the rows' edges moved by du.

With gravity (a fresh deposit: ``-mpm_initial_state deposited``) each point's solids weigh
(1 - n0)(rho_s - rho_l) g V0 on the grid, buoyant (the excess pore pressure leaves out the
water's hydrostatic weight), from the undrained start on: the column consolidates under its
own weight. Q4 cells, an elastic soil: what the column needs. On more than one rank every
rank holds every point (a column has few) and moves them alike, each assembling the
operators of the points of the cells it owns; the solution is gathered to all.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from ...common.errors import InputError
from ...common.linalg import direct_solver
from ...materials.hencky import Hencky
from ...materials.model import Elastic
from ...model import assembly, lattice
from ...model.grid import Grid
from ...model.scene import top_forces
from ...model.soil import Soil
from .operators import Operators

def parse_k_law(text: str) -> tuple:
    """(kind, A) of ``-mpm_k_law``: constant, power:A, kozeny-carman."""
    kind, _, value = text.partition(":")
    if kind == "power":
        try:
            return "power", float(value)
        except ValueError:
            raise InputError(f"-mpm_k_law {text}: give power:A (A a number)") from None
    if kind in ("constant", "kozeny-carman") and not value:
        return kind, 0.0
    raise InputError(f"-mpm_k_law {text}: choose constant, power:A or kozeny-carman")


def permeability(k0: float, e0: float, e, law: tuple):
    """k (m/s) at void ratios e of a soil of k0 at e0 by ``law`` (:func:`parse_k_law`)."""
    kind, A = law
    e = np.asarray(e, dtype=float)
    if kind == "power":
        return k0 * ((1 + e) / (1 + e0)) ** A
    if kind == "kozeny-carman":
        return k0 * (e ** 3 / (1 + e)) / (e0 ** 3 / (1 + e0))
    return np.full_like(e, k0)


class _PerPoint:
    """A ground of one soil per point (Operators reads each point's own)."""

    def __init__(self, soils):
        self.soils = soils


class LargeStrain:
    """The column of ``body`` (its cells, points per cell; loaded over its whole top,
    drained where it says) of ``soil`` (E, nu, porosity n0, k0, the water) under
    ``loading`` (q, gravity on a fresh deposit), its permeability law and stress
    measure."""

    def __init__(self, comm, body, soil, loading, k_law: tuple, stress: str,
                 stabilize: bool = True):
        self.comm, self.body, self.soil, self.loading = comm, body, soil, loading
        self.k_law, self.stabilize = k_law, stabilize
        self.x, volume = lattice.fill(body.size, body.cells, body.ppc)
        self.V0 = np.full(len(self.x), volume)
        self.hencky = Hencky(Elastic(soil.E, soil.nu), cauchy=stress == "cauchy")
        self.state = self.hencky.initial_state(len(self.x))
        self.sigma = np.zeros((len(self.x), 4))
        self.p = np.zeros(len(self.x))
        self.p_nodes = 0.0
        self.height = body.size[1]
        # The rows' edges: the grid moves with the body (a point keeps its cell).
        self.edges = np.linspace(0.0, self.height, body.cells[1] + 1)
        self.e0 = soil.porosity / (1 - soil.porosity)
        # The buoyant weight (N per m) of each point's solids, (1 - n0)(rho_s - rho_l) g V0:
        # the water's weight is the hydrostatic pressure's, which p (the excess) leaves out.
        self.weight = (1 - soil.porosity) * (soil.rho_s - soil.rho_l) * loading.gravity \
            * self.V0

    @property
    def J(self) -> np.ndarray:
        return self.state["J"]

    @property
    def settlement(self) -> float:
        """The surface's settlement (m, downwards positive)."""
        return self.body.size[1] - self.height

    def void_ratio(self) -> np.ndarray:
        """e at the points: (1 + e) = J (1 + e0), the grains incompressible."""
        return self.J * (1 + self.e0) - 1

    def _soils(self, mine) -> _PerPoint:
        s = self.soil
        e = self.void_ratio()[mine]
        k = permeability(s.k, self.e0, e, self.k_law)
        return _PerPoint([Soil(E=s.E, nu=s.nu, rho_s=s.rho_s, porosity=float(ei / (1 + ei)),
                               k=float(ki), rho_l=s.rho_l, K_l=s.K_l, mu_l=s.mu_l)
                          for ei, ki in zip(e, k)])

    def step(self, h: float, q: float) -> None:
        """One step of h (s; 0: the undrained start) to the load q (Pa). Every rank holds
        every point and moves them alike; each assembles the operators of the points in
        the cells it owns, and the solution is gathered to all."""
        body = self.body
        grid = Grid(self.comm, body.element, body.cells, (body.size[0], self.height))
        grid.edges_y = self.edges
        V = self.V0 * self.J
        at = _everywhere(grid, self.x)
        mine = grid.cell_owner(at[3], at[4]) == self.comm.getRank()
        ops = Operators(grid, self.x[mine], V[mine], np.arange(int(mine.sum())),
                        self._soils(mine), self.stabilize)
        try:
            du, p = self._solve(grid, ops, V, h, q, at)
            self.p_nodes = p
            self._advance(grid, at, du, p)
        finally:
            ops.destroy()
            grid.destroy()

    def _solve(self, grid, ops, V, h, q, at) -> tuple:
        """(du (n_nodes, 2) (m), p (n_nodes,) (Pa)) of the step's linear system, on every
        rank in natural node order."""
        N, dNdx, nodes = at[:3]
        nn = grid.nodes[0] * grid.nodes[1]
        rhs = np.zeros((nn, 3))
        # The load on the top row (downwards), less the effective stress's nodal forces.
        rhs[nn - grid.nodes[0]:, 1] -= top_forces(grid, _whole_top(self.loading, q))
        if self.loading.gravity > 0:     # the skeleton's buoyant weight, constant a point
            np.add.at(rhs[:, 1], nodes, -self.weight[:, None] * N)
        s = self.sigma
        np.add.at(rhs[:, 0], nodes, -V[:, None] * (s[:, None, 0] * dNdx[..., 0]
                                                   + s[:, None, 3] * dNdx[..., 1]))
        np.add.at(rhs[:, 1], nodes, -V[:, None] * (s[:, None, 3] * dNdx[..., 0]
                                                   + s[:, None, 1] * dNdx[..., 1]))
        # -S p_n: the nodes' pressures of the step before, node for node (the grid is the
        # one before, stretched to the body: node j of a column stays the j-th up).
        nat = ops.da.createNaturalVec()
        lo, hi = nat.getOwnershipRange()
        y_n = ops.da.createGlobalVec()
        before = np.zeros((nn, 3))
        before[:, 2] = self.p_nodes
        nat.getArray()[:] = before.ravel()[lo:hi]
        ops.da.naturalToGlobal(nat, y_n)
        Sp = y_n.duplicate()
        ops.M.mult(y_n, Sp)
        b = y_n.duplicate()
        nat.getArray()[:] = rhs.ravel()[lo:hi]
        ops.da.naturalToGlobal(nat, b)
        b.getArray().reshape(-1, 3)[:, 2] = -Sp.getArray().reshape(-1, 3)[:, 2]
        J = ops.J0.copy()
        if h > 0:
            J.axpy(-h, ops.H)
        # The undrained start leaves the drained sides' pressure free (as the small-strain
        # scheme's): the water has had no time to leave.
        held = ops.rows(ops.mask(self.body.supports, self.body.drained if h > 0 else ()))
        start = b.getOwnershipRange()[0]
        b.getArray()[held - start] = 0.0
        J.zeroRowsColumns(held, 1.0)
        ksp = direct_solver(self.comm, J, "mpm_")
        y = y_n.duplicate()
        ksp.solve(b, y)
        ops.da.globalToNatural(y, nat)
        out = np.concatenate(self.comm.tompi4py().allgather(nat.getArray().copy()))
        out = out.reshape(-1, 3)
        for obj in (ksp, J, y, y_n, Sp, b, nat):
            obj.destroy()
        return out[:, :2], out[:, 2]

    def _advance(self, grid, at, du, p) -> None:
        """The points moved, strained and stressed by du; their pressure p; the surface."""
        N, dNdx, nodes = at[:3]
        self.x += np.einsum("pa,pad->pd", N, du[nodes])
        G = np.einsum("pai,paj->pij", du[nodes], dNdx)
        # The step's deformation gradient is that of its displacement, exactly: I + G.
        self.sigma, self.state = self.hencky.update(np.eye(2)[None] + G, self.state)
        self.p = np.einsum("pa,pa->p", N, p[nodes])
        self.edges = self.edges + du[::grid.nodes[0], 1]
        self.height = float(self.edges[-1])


def _everywhere(grid, x) -> tuple:
    """(N (np, nen), dN/dx (np, nen, 2) (1/m), the natural node numbers (np, nen), the
    cells cx, cy (np,)) of every point x (np, 2) (m), whichever rank owns its cell (the
    interpolation's own node numbers are this rank's ghosted-local ones)."""
    it = assembly.interpolation(grid, x)
    cx, cy = it.cells
    i, j = grid.cell_nodes(cx, cy)
    return it.N, it.dNdx, j * grid.nodes[0] + i, cx, cy


def _whole_top(loading, q: float):
    """``loading`` with the load q (Pa), whole top."""
    return dataclasses.replace(loading, load=q, extent=())
