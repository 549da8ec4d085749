"""The ends of consolidation by static solves: references for scenes without a closed form.

Just after a load is applied, before water moves, the saturated soil responds as one
undrained body: effective stress D eps plus the pore pressure -(K_l / n) div u, a plane-strain
stiffness D + (K_l / n) m m^T (m = (1, 1, 0)). When consolidation has ended the excess has
drained and the skeleton alone, D, carries the load. Both settlements are solved here on
the body's cells as quadratic Lagrange cells integrated at 3 x 3 Gauss points (the plain
FE model, which passes the patch test; the undrained soil is nearly incompressible, K_l / n
some 40 E, which locks Q4 with 2 x 2 points: on a strip footing's 8 x 4 to 64 x 32 cells
those give 0.142 to 0.207 mm of undrained settlement where Q9 gives 0.2054 to 0.2095 mm)
with the same supports, by PETSc's KSP (a direct LU of MUMPS by default;
options prefix ``static_``): an implicit solve apart from the explicit step. The
settlement is the mean downward displacement of the top under the load, taken at the
abscissae of the run's own top-row points in the loaded part (the run measures it there).
"""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..common.errors import check_converged
from ..common.linalg import direct_solver
from ..model import assembly, shapes
from ..model.grid import Grid
from ..model.points import place
from ..model.scene import top_forces


def loaded_points(points, body, loading) -> np.ndarray:
    """Which of the points are in the top cell row under the load (boolean, local)."""
    x0 = points.views("x0") if "x0" in points.layout else points.views("x")
    h = body.size[1] / body.cells[1]
    inside = x0[:, 1] > body.height - h
    if loading.partial(body.size[0]):
        inside &= (x0[:, 0] >= loading.extent[0]) & (x0[:, 0] <= loading.extent[1])
    return inside


class Ends(NamedTuple):
    """The ends of consolidation: the mean settlement (m, downwards positive) under the
    load undrained and final, and the whole surface's: the top nodes' x (m) and their
    settlements (m) undrained and final."""
    undrained: float
    final: float
    x: tuple
    undrained_top: tuple
    final_top: tuple


def settlements(comm, body, soil, loading, element="q9", ppc=3) -> Ends:
    """The :class:`Ends` of the load of ``loading`` on ``body`` of ``soil`` (a soil.Soil,
    or a soil.Ground of layers, each point with its layer's moduli), solved on the body's
    cells of type ``element`` with ``ppc`` x ``ppc`` points: the mean settlements over the
    abscissae of the run's top-row points under the load (collective; every rank gets
    them)."""
    m = np.array([1.0, 1.0, 0.0])
    if len(soil.soils) == 1:
        D = soil.soils[0].elasticity()
        stiffness = {"undrained": D + (soil.K_l / soil.soils[0].porosity) * np.outer(m, m),
                     "drained": D}
    else:
        stiffness = {"undrained": lambda y: (soil.elasticity_at(y) + (
                         soil.K_l / soil.at("porosity", y))[:, None, None] * np.outer(m, m)),
                     "drained": soil.elasticity_at}
    density = soil.point_density
    out = {}
    with Grid(comm, body.element, body.cells, body.size) as grid, \
            place(grid, body.ppc, density, body.placement) as points:
        inside = loaded_points(points, body, loading)
        xs = np.concatenate(comm.tompi4py().allgather(points.views("x")[inside, 0].copy()))
    body = replace(body, element=element, ppc=ppc, placement="gauss")
    with Grid(comm, body.element, body.cells, body.size) as grid, \
            place(grid, body.ppc, density, body.placement) as points:
        nodes = np.linspace(0.0, body.size[0], grid.nodes[0])
        for name, Dk in stiffness.items():
            top = _top_displacement(grid, points, Dk, body, loading, name)
            out[name] = None if top is None else (
                -float(np.mean(_along_top(grid, top, xs))), tuple(-top))
    u, d = comm.tompi4py().bcast((out["undrained"], out["drained"]), root=0)
    return Ends(u[0], d[0], tuple(nodes), u[1], d[1])


def _top_displacement(grid, points, D, body, loading, name):
    """The vertical displacement (m) of the top row's nodes under the load with the
    stiffness D (Pa), solved by KSP; on rank 0 (None elsewhere). NumericalError (on every
    rank) when the KSP did not converge; ``name`` (undrained, drained) says which."""
    K, M, free = assembly.stiffness_and_mass(grid, points, D, body.supports)
    M.destroy()
    f = grid.da.createGlobalVec()
    rows = f.getArray().reshape(grid.ye - grid.ys, grid.xe - grid.xs, 2)
    rows[:] = 0.0
    if grid.ye == grid.nodes[1]:
        rows[-1, :, 1] = -top_forces(grid, loading)[grid.xs:grid.xe]
    sub = f.getSubVector(free)
    rhs = sub.copy()
    f.restoreSubVector(free, sub)
    u = K.createVecRight()
    ksp = direct_solver(grid.comm, K, "static_")
    try:
        ksp.solve(rhs, u)
        check_converged(ksp, f"the static {name} settlement (options -static_ksp_*, "
                             "-static_pc_*)")
        f.set(0.0)
        f.setValues(free.getIndices(), u.getArray())
        f.assemble()
        full = grid.gather_natural(f)
    finally:
        for obj in (ksp, u, rhs, f, K, free):
            obj.destroy()
    if full is None:
        return None
    return full[(grid.nodes[1] - 1) * grid.nodes[0]:, 1]


def _along_top(grid, top, xs) -> np.ndarray:
    """The top row's nodal values ``top`` interpolated at the abscissae xs (m)."""
    order, h = grid.order, grid.h[0]
    c = np.minimum((xs / h).astype(int), grid.cells[0] - 1)
    N = shapes.lagrange1d(order, 2 * (xs - c * h) / h - 1)[0]
    idx = order * c[:, None] + np.arange(order + 1)
    return np.sum(N * top[idx], axis=1)
