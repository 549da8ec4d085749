"""The scene: what every analysis builds from the options, described by them as data.

A scene is the body (a ``W x H`` rectangle of soil, ``-mpm_size``), its background grid
(``-mpm_element``, ``-mpm_cells``), its material points (``-mpm_ppc``, ``-mpm_points``), the
fixed displacement components on its sides (``-mpm_bc_*``) and its materials (the soil's
``-mpm_E``, ``-mpm_nu``, the solid and liquid densities and the porosity). The analyses
(:mod:`solver.eigen`, :mod:`solver.consolidation`) and the modules that serve them
(:mod:`solver.timestep`, :mod:`solver.twophase`, the scripts) build it here, so that they
build the same thing and none of them depends on another analysis.

Lifetimes: whatever a function here returns belongs to the caller, which destroys it
(:func:`destroy`); a function that fails half-way destroys what it made itself.
"""

from __future__ import annotations

from contextlib import ExitStack

import numpy as np

from . import assembly
from .grid import Grid
from .points import place


def mixture_density(p) -> float:
    """Saturated density (1 - n) rho_s + n rho_l (kg/m3)."""
    return (1 - p.porosity) * p.rho_s + p.porosity * p.rho_l


def boundary_conditions(p) -> dict:
    """The fixed displacement components per side (``-mpm_bc_*``): 'x', 'y', 'xy' or
    'none' for each of left, right, bottom, top."""
    return {"left": p.bc_left, "right": p.bc_right, "bottom": p.bc_bottom, "top": p.bc_top}


def destroy(*objects) -> None:
    """Destroy PETSc objects and the solver's owners of them (Grid, MaterialPoints,
    TwoPhase) in the order given; None is skipped. Local: no communication."""
    for obj in objects:
        if obj is not None:
            obj.destroy()


def build(comm, p, placement=None, ppc=None):
    """Grid, points and the free-DOF K, M of the scene ``p`` (see
    :func:`assembly.stiffness_and_mass`); ``placement`` and ``ppc`` replace the scene's
    (the plain FE model: 'gauss'). The caller destroys all five."""
    with ExitStack() as undo:        # a failure destroys what was made before it
        grid = Grid(comm, p.element, p.cells, p.size)
        undo.callback(grid.destroy)
        points = place(grid, ppc or p.ppc, mixture_density(p), placement or p.points)
        undo.callback(points.destroy)
        K, M, free = assembly.stiffness_and_mass(grid, points, p.E, p.nu,
                                                 boundary_conditions(p))
        undo.pop_all()
    return grid, points, K, M, free


def two_phase_body(comm, p):
    """Grid and material points of the two-phase (consolidation) scene ``p``: uniform
    points with the fields of :func:`twophase.point_fields`, numbered over the ranks
    (``id``, for messages and the ordered field output), volume ratio J = 1 and the
    reference positions x0 = x. The run and ``scripts/benchmark`` build it alike. The
    caller destroys both (collective)."""
    # Imported here: twophase imports timestep, which imports this module.
    from .twophase import point_fields

    with ExitStack() as undo:
        grid = Grid(comm, p.element, p.cells, p.size)
        undo.callback(grid.destroy)
        points = place(grid, p.ppc, mixture_density(p), "uniform", point_fields(p))
        undo.callback(points.destroy)
        offset = comm.tompi4py().exscan(points.n_local) or 0
        with points.fields("x", "x0", "id", "J") as (x, x0, ids, J):
            ids[:] = offset + np.arange(len(ids))     # global numbers
            J[:] = 1.0
            x0[:] = x
        undo.pop_all()
    return grid, points
