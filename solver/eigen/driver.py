"""Eigenfrequency analysis of the soil model (paper Section 4, Table 3, Figure 2).

K phi = omega^2 M phi with the material-point K and consistent M, solved by our generalized
Jacobi solver (:mod:`solver.modal.jacobi`) and by SLEPc's Krylov-Schur, cross-checked (relative
eigenvalue difference, modal assurance criterion), and set beside the 1D rod and the plain FE
model of the same mesh (points at Gauss points). A column of layers (``-mpm_layers``) gives
each point its layer's density and elasticity; its rod is the layered one of
:mod:`solver.references.layered` (a transfer-matrix solution).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError, NumericalError
from ..io import memory, output, provenance
from ..io.output import Outputs
from ..materials.history import elasticity_of
from ..model.scene import Body, build, destroy
from ..model.soil import Ground
from ..modal import jacobi
from ..modal.frequency import frequencies, slepc_solve
from ..run.record import Record, guarded, owned
from . import compare, plots
from .plots import ZERO_HZ, rigid


# Relative residual of a Jacobi mode above which the run prints a warning (a converged run
# at the paper's tolerance reaches 1e-13 to 1e-9, set by rounding and the spread of K).
RESIDUAL_WARNING = 1e-6
# SLEPc-only runs check the mass (densely, on rank 0) up to this size; Jacobi runs always do.
MASS_CHECK_MAX_DOFS = 5000
NODES_PER_CELL = {"q4": 4, "q8": 8, "q9": 9}


def _points(ppc) -> str:
    return f"{ppc} x {ppc} point{'s' if ppc > 1 else ''} per cell"


def _points_needed(element) -> int:
    """Points per cell per direction that give a cell at least as many points as nodes."""
    return int(np.ceil(np.sqrt(NODES_PER_CELL[element])))


def mass_diagnosis(body, exc) -> str:
    """One line naming why the consistent mass of ``body`` is not positive definite."""
    what = {"singular": f"singular (numerical rank {exc.rank} of {exc.n})",
            "indefinite": f"indefinite ({exc.negative} negative eigenvalues of {exc.n})",
            "diagonal": f"zero on {exc.n - exc.rank} diagonal entries"}[exc.kind]
    element, ppc = body.element, body.ppc
    nen, need = NODES_PER_CELL[element], _points_needed(element)
    if ppc < need:
        return (f"Jacobi: {element.upper()} with {_points(ppc)} (fewer "
                f"than its {nen} nodes): the consistent mass is {what}; use -mpm_ppc {need} "
                "or more")
    return (f"Jacobi: the consistent mass of {element.upper()} with {_points(ppc)} is "
            f"{what}; check -mpm_ppc and -mpm_points")


def zero_energy_diagnosis(body, nmodes, freq, rod):
    """None, or a warning about modes at (about) 0 Hz; an error (NumericalError) when they
    are hourglass modes of too few points per cell, whose frequencies would be wrong."""
    zero = max((int(np.count_nonzero(rigid(f, rod[0]))) for f in freq.values()), default=0)
    if not zero:
        return None
    if body.ppc < _points_needed(body.element):
        raise NumericalError(
            f"{body.element.upper()} with {_points(body.ppc)}: {zero} zero-energy "
            f"(hourglass) modes at 0 Hz among the lowest {nmodes}: the stiffness is "
            f"singular; use -mpm_ppc {_points_needed(body.element)} or more")
    return (f"{zero} of the lowest {nmodes} modes at about 0 Hz: rigid-body modes, motion "
            "that the boundary conditions (-mpm_bc_*) leave free (listed as \"rigid\")")


@dataclass(frozen=True)
class EigenPlan:
    """An eigen analysis, as typed values: the ``body`` (scene.Body) made of ``ground``
    (soil.Ground: its layers, one Soil each), the ``nmodes`` lowest modes by ``solvers``
    (jacobi, slepc), Jacobi's tolerance ``jacobi_tol`` and ``jacobi_max_sweeps``, where the
    results go (output.Outputs) and the options as the provenance records them."""

    body: Body
    ground: Ground
    nmodes: int
    solvers: tuple
    jacobi_tol: float
    jacobi_max_sweeps: int
    outputs: Outputs
    provenance: dict

    @classmethod
    def from_options(cls, p) -> "EigenPlan":
        return cls(Body.from_options(p), Ground.from_options(p), p.nmodes,
                   tuple(p.eigen_solver), p.jacobi_tol, p.jacobi_max_sweeps,
                   Outputs(p.output, p.summary or os.path.join(p.output, "summary.json"),
                           p.figures, p.figure_format), provenance.options(p))


def run(p, comm) -> int:
    """The eigen analysis of scene ``p``: solve, compare, print, write; returns 0.

    Its record (:mod:`solver.run.record`) writes the summary also for an analysis that
    fails after its options' checks, with what was computed so far (the frequencies of
    each solver that finished), ``"completed": false`` and the ``error``."""
    plan = EigenPlan.from_options(p)
    record = Record("eigen", comm)
    signals.stage("set-up: the eigen analysis")
    with owned(comm) as stack:
        guarded(record, lambda: _analysis(plan, comm, record, stack))
    return 0


def _analysis(plan, comm, record, owned) -> None:
    """The analysis itself; ``record`` follows it for the failure path, and what it makes
    goes on ``owned`` (an ExitStack: destroyed last made, first)."""
    record.begin(plan.outputs, None, plan.provenance)
    body, ground, nmodes = plan.body, plan.ground, plan.nmodes
    memory.check(body, "jacobi" in plan.solvers)
    with PETSc.Log.Stage("Assembly"):
        made = build(comm, body, ground, D=elasticity_of(ground))
    owned.callback(destroy, *reversed(made))
    grid, points, K, M, free = made
    n = K.getSize()[0]
    if n == 0:
        raise InputError("-mpm_bc_*: every DOF is fixed; nothing left to vibrate")
    if nmodes > n:
        raise InputError(f"-mpm_nmodes {nmodes}: the model has only {n} free DOFs")
    PETSc.Sys.Print(f"Eigen analysis: {body.element.upper()}, {body.cells[0]} x "
                    f"{body.cells[1]} cells, "
                    + (f"{ground.count} layers, " if ground.count > 1 else "") +
                    f"{points.n_global} material points, {n} free DOFs, {comm.getSize()} rank(s)",
                    comm=comm)
    freq, vecs = {}, {}
    summary = record.results
    summary.update({"ndof": n, "element": body.element, "cells": list(body.cells),
                    "size_m": list(body.size), "ppc": body.ppc, "points": body.placement,
                    "n_points": points.n_global, **_materials(ground),
                    "frequencies_hz": freq})
    record.enter("solving")
    rod = compare.rod_frequencies(ground, nmodes)
    warnings = _solve(plan, comm, (K, M, rod, owned), freq, vecs, summary)
    summary["warnings"] = warnings
    scale = rod[0]
    summary["rigid_modes"] = {k: [int(i) + 1 for i in np.flatnonzero(rigid(v, scale))]
                              for k, v in freq.items()}
    if len(freq) == 2:
        summary["cross_check"] = compare.cross_check(freq, vecs, scale)
    signals.stage("solving: the references")
    refs = compare.references(plan, comm, rod, owned)
    summary["references"] = refs
    compare.print_table(comm, freq, refs, summary.get("cross_check"), scale)
    record.enter("reporting")    # the last collectives come first in it: ranks can agree
    _write_results(plan, grid, free, vecs.get("jacobi") or vecs["slepc"],
                   freq.get("jacobi", freq.get("slepc")), refs["rod_hz"], scale, record)
    record.finish()


def _solve(plan, comm, model, freq, vecs, summary) -> list:
    """Jacobi's and SLEPc's solves of ``model`` (K, M, the rod's frequencies, the ExitStack
    their vectors go on), each one's frequencies into ``freq`` and shapes into ``vecs`` as
    it finishes (a failure after it still reports them); returns the warnings, printed."""
    K, M, rod, owned = model
    body, nmodes, n = plan.body, plan.nmodes, K.getSize()[0]
    warnings = []          # Jacobi's, then the zero-energy modes'
    if "jacobi" in plan.solvers:
        signals.stage("solving: Jacobi")
        freq["jacobi"], vecs["jacobi"], summary["jacobi"], warnings = _jacobi(
            plan, comm, K, M, rod, owned)
    elif n <= MASS_CHECK_MAX_DOFS:
        # SLEPc's B-inner product needs M positive definite as much as Jacobi does: with a
        # singular M it may return modes at 0 Hz that are no eigenpairs (1 point per Q4 cell).
        try:
            jacobi.check_mass(M)
        except jacobi.MassError as exc:
            raise NumericalError(mass_diagnosis(body, exc).replace("Jacobi: ", "", 1)) \
                from None
    if "slepc" in plan.solvers:
        signals.stage("solving: SLEPc")
        with PETSc.Log.Stage("SLEPc"):
            res = slepc_solve(K, M, nmodes)
        owned.callback(destroy, *res.vectors)
        freq["slepc"], vecs["slepc"] = frequencies(res.values), res.vectors
        summary["slepc"] = {"seconds": res.seconds, "type": res.eps_type, "st": res.st_type}
        PETSc.Sys.Print(f"{res.label}: {res.seconds:.3f} s", comm=comm)
    zero = zero_energy_diagnosis(body, nmodes, freq, rod)
    if zero:
        warnings.append(zero)
    for text in warnings:
        PETSc.Sys.Print("WARNING: " + text, comm=comm)
    return warnings


def _materials(ground) -> dict:
    """The summary's materials: the density (kg/m3), per layer with the thicknesses (m,
    from the surface down) for a layered column."""
    if ground.count == 1:
        return {"density_kg_m3": ground.soils[0].density}
    return {"density_kg_m3": list(ground.per_layer("density")),
            "layers_m": list(ground.thickness)}


def _jacobi(plan, comm, K, M, rod, owned) -> tuple:
    """The Jacobi solve of :func:`_analysis` (its vectors go on ``owned``), printed:
    (frequencies (Hz), mode vectors, its summary entry, its warnings)."""
    try:
        with PETSc.Log.Stage("Jacobi"):
            res = jacobi.solve(K, M, plan.nmodes, plan.jacobi_tol, plan.jacobi_max_sweeps)
    except jacobi.MassError as exc:
        raise NumericalError(mass_diagnosis(plan.body, exc)) from None
    owned.callback(destroy, *res.vectors)
    freq = frequencies(res.eigenvalues[:plan.nmodes])
    # Modes at about 0 Hz (rigid-body motion) have no meaningful relative residual;
    # zero_energy_diagnosis reports them.
    finite = freq >= ZERO_HZ * rod[0]
    worst = float(np.max(res.residual[finite], initial=0.0))
    tol = plan.jacobi_tol
    summary = {"sweeps": res.sweeps, "seconds": res.seconds, "tol": tol,
               "coupling": res.coupling, "eigenvalue_change": res.change,
               "residual": res.residual, "block_sizes": list(res.block)}
    PETSc.Sys.Print(f"Jacobi: {res.sweeps} sweeps to tolerance {tol:.0e}, "
                    f"{res.seconds:.3f} s, largest relative residual {worst:.1e}", comm=comm)
    warnings = []
    if worst > RESIDUAL_WARNING:
        warnings.append(
            f"Jacobi: relative residuals up to {worst:.1e} in the reported modes at "
            f"-mpm_jacobi_tol {tol:.0e}: mode shapes good to about {worst:.0e}, "
            f"frequencies to about {min(worst, worst ** 2 * 10):.0e} (relative); a "
            "smaller -mpm_jacobi_tol (the paper's 1e-15) costs a few more sweeps")
    return freq, res.vectors, summary, warnings


def _full_modes(grid, free, vectors):
    """Mode vectors of the free DOFs spread on the whole lattice, gathered on rank 0 (N, 2)."""
    full = grid.da.createGlobalVec()
    at = free.getIndices()
    modes = []
    for v in vectors:
        full.set(0.0)
        full.setValues(at, v.getArray())
        full.assemble()
        modes.append(grid.gather_natural(full))
    full.destroy()
    return modes


def _write_results(plan, grid, free, vectors, freqs, rod, scale, record):
    """modes.vtu and the mode figure (rank 0), into the record's files."""
    comm, out = grid.comm, plan.outputs
    modes = _full_modes(grid, free, vectors)
    if comm.getRank() != 0:
        return
    files = record.files
    coords = grid.lattice_coordinates()
    # A common sign: the largest vertical displacement of each mode points up.
    for k, u in enumerate(modes):
        big = np.argmax(np.abs(u).max(axis=1))
        comp = np.argmax(np.abs(u[big]))
        modes[k] = u * np.sign(u[big, comp] or 1.0)
    files["modes_vtu"] = os.path.join(out.folder, "modes.vtu")
    data = {f"mode_{k + 1}": np.column_stack([u, np.zeros(len(u))]) for k, u in enumerate(modes)}
    # Each mode's frequency travels with its shape: field data frequency_hz[k] is mode_{k+1}'s
    # (Hz, of the solver whose shapes these are: Jacobi's when it ran, else SLEPc's).
    output.write_vtu(files["modes_vtu"], coords, [output.grid_cells(grid)], point_data=data,
                     field_data={"frequency_hz": np.asarray(freqs[:len(modes)], dtype=float)})
    if out.figures:
        fig = plots.mode_figure(grid, coords, modes, freqs, rod, plan.ground, scale)
        files.update(output.save_figures(fig, out.folder, "modes", out.formats))
