"""The scene: the body every analysis builds, and what loads it, as data.

A scene is the body (a ``W x H`` rectangle of soil, ``-mpm_size``), its background grid
(``-mpm_element``, ``-mpm_cells``), its material points (``-mpm_ppc``, ``-mpm_points``), the
fixed displacement components on its sides (``-mpm_bc_*``) and its materials (the soil's
``-mpm_E``, ``-mpm_nu``, the solid and liquid densities and the porosity, per layer of
``-mpm_layers`` in the eigen model). The analyses
(:mod:`solver.eigen.driver`, :mod:`solver.consolidation.driver`) and the modules that serve them
(:mod:`solver.stepping.timestep`,
:mod:`solver.stepping.twophase`, the scripts) build it here, so that they
build the same thing and none of them depends on another analysis.

Lifetimes: whatever a function here returns belongs to the caller, which destroys it
(:func:`destroy`); a function that fails half-way destroys what it made itself.
"""

from __future__ import annotations

import math
from contextlib import ExitStack
from dataclasses import dataclass

import numpy as np

from ..common.errors import InputError
from . import assembly, shapes
from .grid import Grid
from .points import place

SIDES = ("left", "right", "bottom", "top")
NORMAL = {"left": "x", "right": "x", "bottom": "y", "top": "y"}


@dataclass(frozen=True)
class Body:
    """The rectangle [0, W] x [0, H] (``size``, m), its grid and points, its sides.

    ``element`` q4 | q8 | q9 and ``cells`` (NX, NY) make the background grid; ``ppc``
    points per cell per direction, placed ``placement`` (uniform | gauss); ``bcs`` maps
    each side to its fixed displacement components ('x', 'y', 'xy', 'none'); ``drained``
    names the sides where the pore pressure is held at 0 (the others are impermeable).
    """

    element: str = "q4"
    cells: tuple = (1, 10)
    size: tuple = (0.1, 1.0)
    ppc: int = 2
    placement: str = "uniform"
    bcs: tuple = (("left", "x"), ("right", "x"), ("bottom", "xy"), ("top", "none"))
    drained: tuple = ("top",)

    @classmethod
    def from_options(cls, p) -> "Body":
        """The body of the ``-mpm_`` options ``p``."""
        return cls(element=p.element, cells=tuple(p.cells), size=tuple(p.size), ppc=p.ppc,
                   placement=p.points,
                   bcs=tuple((side, getattr(p, f"bc_{side}")) for side in SIDES),
                   drained=tuple(s for s in p.drained if s != "none"))

    @property
    def height(self) -> float:
        """H (m)."""
        return self.size[1]

    @property
    def supports(self) -> dict:
        """The fixed displacement components per side: {side: 'x' | 'y' | 'xy' | 'none'}."""
        return dict(self.bcs)

    @property
    def impermeable(self) -> dict:
        """The liquid's components tied to the solid's on the impermeable sides (no flow
        relative to the skeleton across them): the normal one, in the form of supports."""
        return {side: comp for side, comp in NORMAL.items() if side not in self.drained}

    def cell_size(self) -> tuple:
        """(h_x, h_y) (m)."""
        return tuple(self.size[d] / self.cells[d] for d in (0, 1))

    def point_columns(self) -> np.ndarray:
        """The abscissae (m) of the columns of material points, ascending, computed as
        :func:`points.place` places them."""
        s, _ = shapes.uniform_1d(self.ppc) if self.placement == "uniform" else \
            shapes.gauss_1d(self.ppc)
        hx = self.cell_size()[0]
        return ((np.arange(self.cells[0])[:, None] + (s[None, :] + 1) / 2) * hx).ravel()


@dataclass(frozen=True)
class Loading:
    """What drives consolidation: the surface pressure ``load`` q (Pa, downwards) on the
    top, reached linearly over ``ramp`` (s; 0: a step), and ``gravity`` (m/s2, down).
    ``geostatic``: the body starts at rest under gravity (hydrostatic pore pressure,
    effective stress K0 times the vertical one sideways; ``K0`` one value or one per layer,
    NaN: nu / (1 - nu)), so
    that only the load drives consolidation; else it starts unstressed (a fresh deposit)."""

    load: float = 10.0e3
    ramp: float = 0.0
    gravity: float = 0.0
    geostatic: bool = False
    K0: object = math.nan   # a float, or a tuple: one per layer
    extent: tuple = ()      # (x0, x1) (m) of the loaded part of the top; (): all of it

    @classmethod
    def from_options(cls, p) -> "Loading":
        return cls(load=p.load, ramp=p.load_ramp, gravity=p.gravity,
                   geostatic=p.initial_state == "geostatic", K0=p.K0,
                   extent=tuple(p.load_extent))

    def check_extent(self, body: "Body") -> None:
        """InputError for a load over part of the top that covers no column of ``body``'s
        material points: the settlement under it is measured at those points (and the
        static ends at their abscissae), so there would be nothing to measure. Names the
        narrowest extent that works, reached by moving one end to the nearest column."""
        if not self.partial(body.size[0]):
            return
        x0, x1 = self.extent
        xs = body.point_columns()
        if np.any((xs >= x0) & (xs <= x1)):
            return
        # Nearest columns right of x0 and left of x1 (one of them exists: x0 < x1 in [0, W]).
        wider = [(right - x0, x0, right) for right in xs[xs > x1][:1]] \
            + [(x1 - left, left, x1) for left in xs[xs < x0][-1:]]
        width, a, b = min(wider)
        raise InputError(f"-mpm_load_extent {x0:g},{x1:g}: covers no column of material "
                         "points, where the settlement under the load is measured; the "
                         f"narrowest load that works from there is -mpm_load_extent "
                         f"{a:g},{b:g} ({width:g} m wide, to the points at x = "
                         f"{b if b != x1 else a:g} m)")

    def partial(self, width: float) -> bool:
        """Whether the load covers only part of a top of this width (m)."""
        return bool(self.extent) and not (self.extent[0] <= 0 and self.extent[1] >= width)

    @property
    def self_weight(self) -> bool:
        """Whether the body's own weight drives consolidation (gravity on a fresh deposit)."""
        return self.gravity > 0 and not self.geostatic

    def scale(self, soil, H: float) -> float:
        """The pressure that normalises p (Pa): the surface load q, or without one the
        weight of the column per unit area, rho_m g H (``soil``, height H in m)."""
        return self.load if self.load > 0 else soil.density * self.gravity * H

    def factor(self, t: float) -> float:
        """The share of q applied at time t (s)."""
        return 1.0 if self.ramp <= 0 else min(1.0, t / self.ramp)


def geostatic_state(points, body, soil, loading) -> None:
    """Set the points' pore pressure p = rho_l g d (Pa) and effective stress (tension
    positive) sigma'_yy = -gamma' d, sigma'_xx = K0 sigma'_yy, sigma'_xy = 0 at depth
    d = H - y0 (m), gamma' = (1 - n)(rho_s - rho_l) g the buoyant weight (in layered
    ground, sigma'_yy the buoyant weight above, K0 each layer's): the state at rest
    under gravity with the water table at the surface. It is in equilibrium with the step's
    body forces (the mixture's weight, the liquid's) whatever K0 (rollers on the sides).
    Points that carry the pressure's gradient (the corner projection) get (0, -rho_l g)."""
    with points.fields("x0", "p", "stress") as (x0, pp, sig):
        pp[:], sig[:] = geostatic_fields(x0, body, soil, loading)
    if "gradp" in points.layout:
        # The pressure's gradient (Pa/m), for the corner projection's liquid force.
        with points.fields("gradp") as gradp:
            gradp[:] = (0.0, -soil.rho_l * loading.gravity)


def geostatic_fields(x0, body, soil, loading) -> tuple:
    """(p (Pa), effective stress (Pa; xx, yy, xy)) of :func:`geostatic_state` at the
    reference positions x0 (np, 2) (m)."""
    g, layers = loading.gravity, soil.soils
    given = loading.K0 if isinstance(loading.K0, tuple) else (loading.K0,) * len(layers)
    K0 = np.array([s.nu / (1 - s.nu) if math.isnan(k) else k for s, k in zip(layers, given)])
    buoyant = np.array([(1 - s.porosity) * (s.rho_s - s.rho_l) * g for s in layers])
    thickness = np.asarray(getattr(soil, "thickness", (body.height,)), dtype=float)
    # The effective stress at each layer's top: the buoyant weight of the layers above.
    above = np.concatenate([[0.0], np.cumsum(buoyant * thickness)[:-1]])
    tops = body.height - np.concatenate([[0.0], np.cumsum(thickness)[:-1]])
    depth = body.height - x0[:, 1]
    layer = soil.layer_of(x0[:, 1]) if len(layers) > 1 else np.zeros(len(depth), int)
    sig = np.zeros((len(depth), 3))
    if len(layers) == 1:        # one layer: as before layers, bit for bit
        sig[:, 1] = -buoyant[0] * depth
    else:
        sig[:, 1] = -(above[layer] + buoyant[layer] * (tops[layer] - x0[:, 1]))
    sig[:, 0] = K0[layer] * sig[:, 1]
    return soil.rho_l * g * depth, sig


def top_forces(grid, loading) -> np.ndarray:
    """The nodal forces (N per m depth, downwards positive) of the load on the nodes of the
    top row, (grid.nodes[0],): the integral of the pressure q times each node's 1D shape
    function over the loaded part of the top edge (3-point Gauss on each cell's loaded
    part, exact for the element's polynomials)."""
    s, w = shapes.gauss_1d(3)
    order, h, cells = grid.order, grid.h[0], grid.cells[0]
    top = np.zeros(grid.nodes[0])
    if not loading.partial(grid.size[0]):
        N = shapes.lagrange1d(order, s)[0]                   # 1D edge shape functions
        edge = (w[:, None] * N).sum(axis=0) * h / 2          # integral of each over one edge
        for a in range(order + 1):
            top[a:a + order * cells:order] += edge[a]
        return loading.load * top
    x0, x1 = loading.extent
    left = np.arange(cells) * h
    a, b = np.maximum(left, x0), np.minimum(left + h, x1)
    for c in np.flatnonzero(b > a):          # the loaded cells (set-up: once per run)
        x = (a[c] + b[c]) / 2 + (b[c] - a[c]) / 2 * s
        N = shapes.lagrange1d(order, 2 * (x - left[c]) / h - 1)[0]
        top[order * c:order * c + order + 1] += (w[:, None] * N).sum(axis=0) * (b[c] - a[c]) / 2
    return loading.load * top


def water_forces(grid, drained, gamma_w: float, blend: float = 1.0) -> np.ndarray:
    """The nodal forces (N per m depth), (nodes_y, nodes_x, 2), of the water outside the
    ``drained`` left, right and bottom sides on the body, at its hydrostatic pressure
    gamma_w (H - y) (Pa; gamma_w in N/m3, the water table at the surface): -int N p n ds
    over each side (3-point Gauss per cell edge, exact for the element's polynomials). A
    drained side held at that pressure keeps the water table; without this force it would
    be held at p = 0 and drain it. ``blend`` < 1 gives the forces in the blended basis
    w N + (1 - w) N_Q4 (shapes.blended) of a quadratic cell's liquid."""
    s, w = shapes.gauss_1d(3)
    order, H = grid.order, grid.size[1]
    N = blend * shapes.lagrange1d(order, s)[0]                 # (3 Gauss points, order + 1)
    N[:, [0, order]] += (1 - blend) * shapes.lagrange1d(1, s)[0]
    F = np.zeros((grid.nodes[1], grid.nodes[0], 2))
    for side in ("left", "right", "bottom"):
        if side not in drained:
            continue
        d = 0 if side == "bottom" else 1                       # the direction along the side
        h, cells = grid.h[d], grid.cells[d]
        t = (np.arange(cells)[:, None] + (1 + s) / 2) * h      # along the side, per edge
        p = gamma_w * (H - t) if d == 1 else np.full_like(t, gamma_w * H)   # y = 0 on the base
        edge = np.einsum("g,cg,ga->ca", w * h / 2, p, N)       # (cells, order + 1)
        f = np.zeros(grid.nodes[d])
        for a in range(order + 1):
            f[a:a + order * cells:order] += edge[:, a]
        if side == "bottom":
            F[0, :, 1] += f                                    # n = -y: pushes up
        else:
            F[:, 0 if side == "left" else -1, 0] += f if side == "left" else -f
    return F


def destroy(*objects) -> None:
    """Destroy PETSc objects and the solver's owners of them (Grid, MaterialPoints,
    TwoPhase) in the order given; None is skipped. Local: no communication."""
    for obj in objects:
        if obj is not None:
            obj.destroy()


def build(comm, body: Body, soil, placement=None, ppc=None, D=None):
    """Grid, points and the free-DOF K, M of ``body`` made of ``soil`` (a soil.Soil, or a
    soil.Ground of layers: each point then takes its layer's density and D; see
    :func:`assembly.stiffness_and_mass`); ``placement`` and ``ppc`` replace the body's
    (the plain FE model: 'gauss'); ``D`` the stiffness as assembly takes it (the analyses
    pass the materials room's, :func:`solver.materials.history.elasticity_of`; None: the
    soil's own, the same numbers). The caller destroys all five."""
    if len(soil.soils) == 1:
        soil = soil.soils[0]
    with ExitStack() as undo:        # a failure destroys what was made before it
        grid = Grid(comm, body.element, body.cells, body.size)
        undo.callback(grid.destroy)
        points = place(grid, ppc or body.ppc, soil.point_density,
                       placement or body.placement)
        undo.callback(points.destroy)
        # One material keeps its one D: the same K, bit for bit, as before layers.
        K, M, free = assembly.stiffness_and_mass(
            grid, points, soil.point_elasticity if D is None else D, body.supports)
        undo.pop_all()
    return grid, points, K, M, free


def two_phase_body(comm, body: Body, soil, fields: dict):
    """Grid and material points of a two-phase (consolidation) ``body`` of ``soil`` (a
    soil.Soil, or a soil.Ground whose points get their ``layer``, a field of ``fields``):
    uniform points with ``fields`` ({name: components}, :func:`twophase.point_fields`),
    numbered over the ranks (``id``, for messages and the ordered field output), volume
    ratio J = 1 and the reference positions x0 = x. The run and ``scripts/benchmark``
    build it alike. The caller destroys both (collective)."""
    with ExitStack() as undo:
        grid = Grid(comm, body.element, body.cells, body.size)
        undo.callback(grid.destroy)
        points = place(grid, body.ppc, soil.point_density, "uniform", fields)
        undo.callback(points.destroy)
        offset = comm.tompi4py().exscan(points.n_local) or 0
        with points.fields("x", "x0", "id", "J") as (x, x0, ids, J):
            ids[:] = offset + np.arange(len(ids))     # global numbers
            J[:] = 1.0
            x0[:] = x
        if len(soil.soils) > 1:
            with points.fields("layer") as layer:
                layer[:] = soil.layer_of(x0[:, 1])
        undo.pop_all()
    return grid, points
