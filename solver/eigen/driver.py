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
from contextlib import ExitStack
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError, InternalError, Interrupted, NumericalError, agree
from ..io import figures, memory, output, provenance
from ..io.failure import RunFailure
from ..io.output import Outputs
from ..model.scene import Body, build, destroy
from ..model.soil import Ground
from ..references import analytic, layered
from ..modal import jacobi
from ..modal.frequency import frequencies, slepc_solve

# Table 3 of the paper (Hz): the MP models of a 1 x 10 grid over the 0.1 m x 1 m column.
PAPER_TABLE3 = {"q4": [16.92, 51.27, 87.24, 126.03, 168.95],
                "q8": [16.89, 50.62, 84.20, 117.62, 150.94],
                "q9": [16.89, 50.62, 84.20, 117.62, 150.94]}
PAPER_ABAQUS_CPE8 = [16.89, 50.68, 84.49, 118.37, 152.42]


# Relative residual of a Jacobi mode above which the run prints a warning (a converged run
# at the paper's tolerance reaches 1e-13 to 1e-9, set by rounding and the spread of K).
RESIDUAL_WARNING = 1e-6
# SLEPc-only runs check the mass (densely, on rank 0) up to this size; Jacobi runs always do.
MASS_CHECK_MAX_DOFS = 5000
NODES_PER_CELL = {"q4": 4, "q8": 8, "q9": 9}
# A mode below this fraction of the rod's first frequency counts as a zero-energy mode.
ZERO_HZ = 1e-3


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


def rod_applies(body) -> bool:
    """Whether the analytic 1D rod (fixed at the base, free at the top) is the reference of
    ``body``: rollers on both sides, the base fixed vertically, the top free."""
    bcs = body.supports
    return (bcs["left"] == bcs["right"] == "x" and "y" in bcs["bottom"]
            and bcs["top"] == "none")


def rod_frequencies(ground, nmodes) -> np.ndarray:
    """The 1D rod's natural frequencies (Hz) of a column of ``ground`` (soil.Ground): the
    analytic rod for one layer, the transfer-matrix rod of :mod:`solver.references.layered`
    for more."""
    if ground.count == 1:
        soil = ground.soils[0]
        return analytic.rod_frequencies(soil.constrained_modulus, soil.density, ground.height,
                                        nmodes)
    return layered.rod_frequencies(ground.thickness, ground.per_layer("constrained_modulus"),
                                   ground.per_layer("density"), nmodes)


def rod_shapes(ground, nmodes, y) -> np.ndarray:
    """The rod's mode shapes (nmodes x heights, 1 at the top) at heights ``y`` (m)."""
    if ground.count == 1:
        return np.array([analytic.rod_mode(y, ground.height, k + 1) for k in range(nmodes)])
    return layered.rod_modes(ground.thickness, ground.per_layer("constrained_modulus"),
                             ground.per_layer("density"), nmodes, y)


def rigid(freq, scale) -> np.ndarray:
    """Which of the frequencies ``freq`` (Hz) are rigid-body modes: below ZERO_HZ x ``scale``
    (the rod's first frequency c / 4H, the column's own frequency scale, Hz)."""
    return np.asarray(freq) < ZERO_HZ * scale


def hz(value, width: int = 0) -> str:
    """A frequency (Hz) as printed: at least four significant digits (two decimals from
    10 Hz up), so that a tall column's 0.03387 Hz does not read 0.03; "-" for None."""
    if value is None:
        return f"{'-':>{width}s}"
    v = float(value)
    decimals = 2 if v == 0 or abs(v) >= 10 else 3 - int(np.floor(np.log10(abs(v))))
    return f"{v:{width}.{decimals}f}"


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


def mac(a, b) -> float:
    """Modal assurance criterion (a.b)^2 / ((a.a)(b.b)) of two PETSc Vecs (1: same shape)."""
    return a.dot(b) ** 2 / (a.dot(a) * b.dot(b))


def is_paper_scene(body, ground) -> bool:
    """Whether ``body`` of ``ground`` is the paper's column (its Table 3 applies)."""
    if ground.count > 1:
        return False
    soil = ground.soils[0]
    return (tuple(body.cells) == (1, 10) and np.allclose(body.size, (0.1, 1.0))
            and soil.E == 10e6 and soil.nu == 0.0 and body.placement == "uniform"
            and body.ppc == (2 if body.element == "q4" else 3)
            and abs(soil.density - 2190.0) < 1e-9
            and body.supports == {"left": "x", "right": "x", "bottom": "xy", "top": "none"})


def run(p, comm) -> dict:
    """The eigen analysis of scene ``p``: solve, compare, print, write; returns the summary.

    A failure after the assembly still writes the summary, with what was computed so far,
    ``"completed": false`` and the ``error``: a NumericalError (solver not converged, a mass
    that is not positive definite) as it is, any other exception as an InternalError once
    the ranks agree on it (always on one rank; in parallel while the results are written,
    where rank 0 works alone). A failure elsewhere on some ranks of a parallel run reaches
    the caller as it is (to abort MPI: the others wait in a collective)."""
    plan = EigenPlan.from_options(p)
    ctx = RunFailure(comm, "eigen")
    ctx.begin(plan.outputs.summary, None, plan.provenance)
    ctx.freq = {}
    failure = None
    signals.stage("the eigen analysis")
    try:
        summary = _analyse(plan, comm, ctx)
    except InputError:
        raise
    except Interrupted as exc:         # a signal: the summary says what was computed
        exc.args = (str(exc) + _failed(comm, ctx, str(exc), 4, exc.stage),)
        raise
    except NumericalError as exc:      # every rank raises it alike
        _failed(comm, ctx, str(exc), exc.exit_code)
        raise
    except PETSc.Error as exc:         # a solver of PETSc or SLEPc failed: numerical too
        _failed(comm, ctx, f"PETSc error {exc.ierr}: {exc}", 3)
        raise
    except Exception as exc:   # noqa: BLE001  (what the solver did not foresee)
        failure = exc
    if ctx.phase == "writing" or comm.getSize() == 1:
        message = agree(comm, failure)       # every rank gets here, failed or not
        if message is None:
            return summary
        said = _failed(comm, ctx, f"internal error: {message}", 5)
        raise InternalError(f"internal error: {message}{said}") from failure
    ctx.record(comm, None, failure)
    raise failure


def _failed(comm, ctx, text, code, stage="") -> str:
    """The summary of a failed analysis, through the failure handler both analyses share
    (rank 0): what was computed, ``"completed": false`` and the error; returns
    "; summary PATH" for the error line (or why it was not written). A numerical failure
    before the assembly has nothing to write."""
    if comm.getRank() != 0 or ctx.summary is None and code == 3:
        return ""
    extra = {"frequencies_hz": dict(ctx.freq)} if ctx.freq else {}
    return "; " + ctx.write_summary(text, code, stage, extra=extra)


def _analyse(plan, comm, ctx) -> dict:
    """The analysis (see :func:`run`), which destroys the PETSc objects it made whether it
    finishes or fails (the failure handler needs none of them)."""
    with ExitStack() as owned:
        return _analysis(plan, comm, ctx, owned)


def _analysis(plan, comm, ctx, owned) -> dict:
    """The analysis itself; ``ctx`` follows it for the failure handler, and what it makes
    goes on ``owned`` (an ExitStack: destroyed last made, first)."""
    body, ground, nmodes = plan.body, plan.ground, plan.nmodes
    memory.check(body, "jacobi" in plan.solvers)
    with PETSc.Log.Stage("Assembly"):
        made = build(comm, body, ground)
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

    freq, vecs, summary = {}, {}, {"analysis": "eigen", "ranks": comm.getSize(), "ndof": n,
                                   "element": body.element, "cells": list(body.cells),
                                   "size_m": list(body.size), "ppc": body.ppc,
                                   "points": body.placement, "n_points": points.n_global,
                                   **_materials(ground),
                                   "provenance": provenance.collect(comm, plan.provenance)}
    ctx.summary, ctx.freq = summary, freq
    rod = rod_frequencies(ground, nmodes)
    warnings = []          # Jacobi's, then the zero-energy modes'
    if "jacobi" in plan.solvers:
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
    summary["warnings"] = warnings
    summary["frequencies_hz"] = {k: v for k, v in freq.items()}

    scale = rod[0]
    summary["rigid_modes"] = {k: [int(i) + 1 for i in np.flatnonzero(rigid(v, scale))]
                              for k, v in freq.items()}
    if len(freq) == 2:
        summary["cross_check"] = _cross_check(freq, vecs, scale)

    refs = _references(plan, comm, rod, owned)
    summary["references"] = refs
    _print_table(comm, freq, refs, summary.get("cross_check"), scale)

    summary["completed"] = True
    ctx.phase = "writing"     # the last collectives come first in it: ranks can agree
    summary["files"] = _write_results(plan, grid, free, vecs.get("jacobi") or vecs["slepc"],
                                      freq.get("jacobi", freq.get("slepc")),
                                      refs["rod_hz"], scale, summary)
    PETSc.Sys.Print(output.results_line(plan.outputs.folder, summary["files"]), comm=comm)
    return summary


def _materials(ground) -> dict:
    """The summary's materials: the density (kg/m3), per layer with the thicknesses (m,
    from the surface down) for a layered column."""
    if ground.count == 1:
        return {"density_kg_m3": ground.soils[0].density}
    return {"density_kg_m3": list(ground.per_layer("density")),
            "layers_m": list(ground.thickness)}


def _cross_check(freq, vecs, scale) -> dict:
    """Jacobi against SLEPc, mode by mode: relative eigenvalue difference and MAC; None for
    a rigid-body mode (of either), whose eigenvalue is rounding and whose shape is any
    combination of the rigid motions."""
    fj, fs = freq["jacobi"], freq["slepc"]
    skip = rigid(fj, scale) | rigid(fs, scale)
    rel = [None if r else float(abs(a * a - b * b) / (b * b))
           for a, b, r in zip(fj, fs, skip)]
    macs = [None if r else mac(a, b) for a, b, r in zip(vecs["jacobi"], vecs["slepc"], skip)]
    return {"relative_eigenvalue_difference": rel, "mac": macs}


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


def _references(plan, comm, rod, owned) -> dict:
    """The references of :func:`_analysis`: the 1D rod's frequencies ``rod``, the plain FE
    model (Gauss points) of the same mesh, and on the paper's scene its Table 3 (Hz)."""
    body, nmodes = plan.body, plan.nmodes
    fe_ppc = 2 if body.element == "q4" else 3
    gauss = build(comm, body, plan.ground, placement="gauss", ppc=fe_ppc)
    owned.callback(destroy, *reversed(gauss))
    _, _, Kg, Mg, _ = gauss
    # Its own options prefix: -eps_* tune the main solve, -fe_eps_* this one.
    res = slepc_solve(Kg, Mg, nmodes, prefix="fe_")
    destroy(*res.vectors)
    fe = frequencies(res.values)
    # The rod column only where the rod is the scene (not for a free body, say).
    refs = {"rod_hz": rod if rod_applies(body) else None, "fe_gauss_hz": fe}
    if is_paper_scene(body, plan.ground):
        refs["paper_table3_hz"] = PAPER_TABLE3[body.element][:nmodes]
        refs["paper_abaqus_cpe8_hz"] = PAPER_ABAQUS_CPE8[:nmodes]
    return refs


def _print_table(comm, freq, refs, cross, scale):
    """The frequencies (Hz, four significant digits or more; "rigid" for a rigid-body
    mode) of each solver and reference, and the cross-check."""
    cols = [("Jacobi", freq.get("jacobi")), ("SLEPc", freq.get("slepc")),
            ("1D rod", refs["rod_hz"]), ("FE Gauss", refs["fe_gauss_hz"]),
            ("paper", refs.get("paper_table3_hz"))]
    cols = [(name, v) for name, v in cols if v is not None]
    head = "mode " + "".join(f"{name:>11s}" for name, _ in cols)
    if cross:
        head += f"{'rel diff':>11s}{'MAC':>9s}"
    lines = ["Natural frequencies (Hz)", head]
    for k in range(len(cols[0][1])):
        row = f"{k + 1:4d} " + "".join(
            " " * 11 if k >= len(v) else f"{'rigid':>11s}" if rigid(v[k], scale)
            and name != "1D rod" else hz(v[k], 11) for name, v in cols)
        if cross:
            rel, m = cross["relative_eigenvalue_difference"][k], cross["mac"][k]
            row += f"{'-':>11s}{'-':>9s}" if rel is None else f"{rel:11.1e}{m:9.5f}"
        lines.append(row)
    PETSc.Sys.Print("\n".join(lines), comm=comm)


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


def _write_results(plan, grid, free, vectors, freqs, rod, scale, summary):
    """modes.vtu, the mode figure and the summary (rank 0); returns the files."""
    comm, out = grid.comm, plan.outputs
    modes = _full_modes(grid, free, vectors)
    summary_path = out.summary
    files = {"summary": summary_path}
    if comm.getRank() != 0:
        return files
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
        fig = mode_figure(grid, coords, modes, freqs, rod, plan.ground, scale)
        files.update(output.save_figures(fig, out.folder, "modes", out.formats))
    output.write_json(summary_path, dict(summary, files=files))
    return files


def mode_figure(grid, coords, modes, freqs, rod, ground, scale):
    """Mode shapes like the paper's Figure 2: deformed grids coloured by the displacement
    magnitude (a colour bar: |u| over the mode's largest) and u_y along the column, beside
    the rod's mode where the rod is the scene (``rod`` None: not), of the column of
    ``ground`` (soil.Ground: its layer interfaces are drawn); the caller saves it."""
    plt = output.pyplot()
    nm, H = len(modes), ground.height
    yy = np.linspace(0, H, 200)
    shapes = None
    if rod is not None:        # scaled as the MPM's u_y: the largest |u_y| is 1
        shapes = rod_shapes(ground, nm, yy)
        shapes /= np.abs(shapes).max(axis=1, keepdims=True)
    fig, axes = plt.subplots(2, nm, figsize=(2.2 * nm + 0.8, 7), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 2]})
    W = grid.size[0]
    conn = output.grid_cells(grid)[1]
    corners = conn[:, :4]
    for k, u in enumerate(modes):
        scale_u = 0.25 * max(W, 0.1 * H) / max(np.abs(u).max(), 1e-300)
        xy = coords + scale_u * u
        ax = axes[0, k]
        for cell in corners:
            ring = np.append(cell, cell[0])
            ax.plot(coords[ring, 0], coords[ring, 1], color="0.85", lw=0.6)
            ax.plot(xy[ring, 0], xy[ring, 1], color="tab:blue", lw=0.9)
        mag = np.hypot(u[:, 0], u[:, 1])
        dots = ax.scatter(xy[:, 0], xy[:, 1], c=mag / max(mag.max(), 1e-300), s=6,
                          cmap="viridis", vmin=0.0, vmax=1.0, zorder=3)
        what = "rigid" if rigid(freqs[k], scale) else f"{hz(freqs[k])} Hz"
        ax.set_title(f"mode {k + 1}\n{what}", fontsize=9)
        ax.set_aspect("equal")
        ax.axis("off")
        ax = axes[1, k]
        centre = np.isclose(coords[:, 0], coords[np.argmin(np.abs(coords[:, 0] - W / 2)), 0])
        y = coords[centre, 1]
        order = np.argsort(y)
        uy = u[centre, 1][order]
        ax.plot(uy / max(np.abs(uy).max(), 1e-300), y[order], "o-", ms=3, label="MPM")
        if shapes is not None:
            shape = shapes[k] * (np.sign(np.dot(np.interp(y[order], yy, shapes[k]), uy)) or 1.0)
            ax.plot(shape, yy, "k--", lw=0.8,
                    label=f"rod {hz(rod[k])} Hz" if k < len(rod) else "rod")
        figures.layer_interfaces(ax, ground)
        ax.set_xlabel("u_y (normalised)", fontsize=8)
        if k == 0:
            ax.set_ylabel("height y (m)")
        ax.legend(fontsize=6, loc="lower left")
        ax.tick_params(labelsize=7)
    fig.colorbar(dots, ax=list(axes[0]), fraction=0.04, pad=0.02,
                 label="|u| / largest |u| of the mode")
    fig.suptitle(f"Mode shapes, {grid.element.upper()} background grid")
    return fig
