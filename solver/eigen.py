"""Eigenfrequency analysis of the soil model (paper Section 4, Table 3, Figure 2).

K phi = omega^2 M phi with the material-point K and consistent M, solved by our generalized
Jacobi solver (:mod:`solver.jacobi`) and by SLEPc's Krylov-Schur, cross-checked (relative
eigenvalue difference, modal assurance criterion), and set beside the analytic 1D rod and the
plain FE model of the same mesh (points at Gauss points).
"""

from __future__ import annotations

import os
import time
from contextlib import ExitStack
from typing import NamedTuple

import numpy as np
from petsc4py import PETSc
from slepc4py import SLEPc

from . import analytic, assembly, jacobi, memory, output, provenance, signals
from .errors import (InputError, InternalError, Interrupted, NumericalError, agree, describe,
                     entry)
from .scene import boundary_conditions, build, destroy, mixture_density

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


def mass_diagnosis(p, exc) -> str:
    """One line naming why the consistent mass of scene ``p`` is not positive definite."""
    what = {"singular": f"singular (numerical rank {exc.rank} of {exc.n})",
            "indefinite": f"indefinite ({exc.negative} negative eigenvalues of {exc.n})",
            "diagonal": f"zero on {exc.n - exc.rank} diagonal entries"}[exc.kind]
    nen, need = NODES_PER_CELL[p.element], _points_needed(p.element)
    if p.ppc < need:
        return (f"Jacobi: {p.element.upper()} with {_points(p.ppc)} (fewer "
                f"than its {nen} nodes): the consistent mass is {what}; use -mpm_ppc {need} "
                "or more")
    return (f"Jacobi: the consistent mass of {p.element.upper()} with {_points(p.ppc)} is "
            f"{what}; check -mpm_ppc and -mpm_points")


def rod_applies(p) -> bool:
    """Whether the analytic 1D rod (fixed at the base, free at the top) is this scene's
    reference: rollers on both sides, the base fixed vertically, the top free."""
    bcs = boundary_conditions(p)
    return (bcs["left"] == bcs["right"] == "x" and "y" in bcs["bottom"]
            and bcs["top"] == "none")


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


def zero_energy_diagnosis(p, freq, rod):
    """None, or a warning about modes at (about) 0 Hz; an error (NumericalError) when they
    are hourglass modes of too few points per cell, whose frequencies would be wrong."""
    zero = max((int(np.count_nonzero(rigid(f, rod[0]))) for f in freq.values()), default=0)
    if not zero:
        return None
    if p.ppc < _points_needed(p.element):
        raise NumericalError(
            f"{p.element.upper()} with {_points(p.ppc)}: {zero} zero-energy "
            f"(hourglass) modes at 0 Hz among the lowest {p.nmodes}: the stiffness is "
            f"singular; use -mpm_ppc {_points_needed(p.element)} or more")
    return (f"{zero} of the lowest {p.nmodes} modes at about 0 Hz: rigid-body modes, motion "
            "that the boundary conditions (-mpm_bc_*) leave free (listed as \"rigid\")")


# The scene (grid, points, boundary conditions, densities) is built by solver.scene.


class SlepcResult(NamedTuple):
    """What :func:`slepc_solve` found, and with which solver."""
    values: np.ndarray     # eigenvalues (rad2/s2), ascending ('largest': descending)
    vectors: list          # their eigenvectors (PETSc Vecs)
    seconds: float         # wall time of set-up and solve
    eps_type: str          # the EPS type that solved (e.g. "krylovschur", "lapack")
    st_type: str           # its spectral transformation (e.g. "sinvert", "shift")

    @property
    def label(self) -> str:
        """The solver as printed: "SLEPc krylovschur, ST sinvert"."""
        return f"SLEPc {self.eps_type}, ST {self.st_type}"


def slepc_solve(K, M, nmodes: int, which: str = "smallest", prefix: str = ""):
    """Eigenpairs of K x = lambda M x by SLEPc (GHEP, Krylov-Schur by default).

    ``which='smallest'``: shift-and-invert about 0 with a MUMPS LU (works in parallel);
    ``'largest'``: plain Krylov-Schur for the largest eigenvalues. Any option
    ``-{prefix}eps_*``/``-{prefix}st_*`` overrides these defaults: the prefix keeps a
    secondary solve (the FE reference's ``fe_``) apart from the main one's ``-eps_*``.
    Returns a :class:`SlepcResult` with the solver types actually used.
    """
    t0 = time.perf_counter()
    eps = SLEPc.EPS().create(K.getComm())
    vectors = []
    try:
        _configure(eps, K, M, nmodes, which, prefix)
        eps.solve()
        nconv = eps.getConverged()
        if nconv < nmodes:
            raise NumericalError(f"SLEPc converged {nconv} of {nmodes} eigenpairs "
                                 f"(reason {eps.getConvergedReason()})")
        values = []
        for k in range(nconv):
            vectors.append(K.createVecRight())
            values.append(eps.getEigenpair(k, vectors[-1]).real)
        order = np.argsort(values)
        if which == "largest":
            order = order[::-1]
        keep = order[:nmodes]
        result = SlepcResult(np.array(values)[keep], [vectors[k] for k in keep],
                             time.perf_counter() - t0, eps.getType(), eps.getST().getType())
        for k in order[nmodes:]:
            vectors[k].destroy()
        return result
    except BaseException:
        for v in vectors:
            v.destroy()
        raise
    finally:
        eps.destroy()


def _configure(eps, K, M, nmodes, which, prefix):
    """The defaults of :func:`slepc_solve`, then the options database's word."""
    eps.setOptionsPrefix(prefix)
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setDimensions(nev=nmodes)
    eps.setTolerances(tol=1e-13, max_it=1000)
    if which == "smallest":
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        eps.setTarget(0.0)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        ksp = st.getKSP()
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        pc.setFactorSolverType("mumps")
    else:
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
    eps.setFromOptions()


def mac(a, b) -> float:
    """Modal assurance criterion (a.b)^2 / ((a.a)(b.b)) of two PETSc Vecs (1: same shape)."""
    return a.dot(b) ** 2 / (a.dot(a) * b.dot(b))


def frequencies(eigenvalues) -> np.ndarray:
    """omega^2 (rad2/s2) -> f (Hz)."""
    return np.sqrt(np.maximum(np.asarray(eigenvalues), 0.0)) / (2 * np.pi)


def is_paper_scene(p) -> bool:
    return (tuple(p.cells) == (1, 10) and np.allclose(p.size, (0.1, 1.0))
            and p.E == 10e6 and p.nu == 0.0 and p.points == "uniform"
            and p.ppc == (2 if p.element == "q4" else 3)
            and abs(mixture_density(p) - 2190.0) < 1e-9
            and boundary_conditions(p) == {"left": "x", "right": "x", "bottom": "xy",
                                           "top": "none"})


def run(p, comm) -> dict:
    """The eigen analysis of scene ``p``: solve, compare, print, write; returns the summary.

    A failure after the assembly still writes the summary, with what was computed so far,
    ``"completed": false`` and the ``error``: a NumericalError (solver not converged, a mass
    that is not positive definite) as it is, any other exception as an InternalError once
    the ranks agree on it (always on one rank; in parallel while the results are written,
    where rank 0 works alone). A failure elsewhere on some ranks of a parallel run reaches
    the caller as it is (to abort MPI: the others wait in a collective)."""
    ctx = {"phase": "analysis", "summary": None, "freq": {}}
    failure = None
    signals.stage("the eigen analysis")
    try:
        summary = _analyse(p, comm, ctx)
    except InputError:
        raise
    except Interrupted as exc:         # a signal: the summary says what was computed
        exc.args = (str(exc) + _write_failure(p, comm, ctx, entry(str(exc), 4, exc.stage)),)
        raise
    except NumericalError as exc:      # every rank raises it alike
        _write_failure(p, comm, ctx, entry(str(exc), exc.exit_code))
        raise
    except PETSc.Error as exc:         # a solver of PETSc or SLEPc failed: numerical too
        _write_failure(p, comm, ctx, entry(f"PETSc error {exc.ierr}: {exc}", 3))
        raise
    except Exception as exc:   # noqa: BLE001  (what the solver did not foresee)
        failure = exc
    if ctx["phase"] == "writing" or comm.getSize() == 1:
        message = agree(comm, failure)       # every rank gets here, failed or not
        if message is None:
            return summary
        said = _write_failure(p, comm, ctx, entry(f"internal error: {message}", 5))
        raise InternalError(f"internal error: {message}{said}") from failure
    _write_failure(p, comm, ctx, entry(f"internal error: {describe(failure)}", 5))
    raise failure


def _write_failure(p, comm, ctx, error) -> str:
    """Rank 0 writes the summary of a failed run: what was computed, ``"completed": false``
    and ``error``; returns "; summary PATH" for the error line (or why it was not written)."""
    if comm.getRank() != 0 or ctx["summary"] is None and error["kind"] == "numerical":
        return ""
    path = p.summary or os.path.join(p.output, "summary.json")
    summary = dict(ctx["summary"] or {"analysis": "eigen"})
    if ctx["freq"]:
        summary["frequencies_hz"] = dict(ctx["freq"])
    summary.update(completed=False, error=error, files={"summary": path})
    try:
        output.write_json(path, summary)
    except Exception as err:   # noqa: BLE001  (the disk may be what failed)
        return f"; no summary ({describe(err)})"
    return f"; summary {path}"


def _analyse(p, comm, ctx) -> dict:
    """The analysis (see :func:`run`), which destroys the PETSc objects it made whether it
    finishes or fails (the failure handler needs none of them)."""
    with ExitStack() as owned:
        return _analysis(p, comm, ctx, owned)


def _analysis(p, comm, ctx, owned) -> dict:
    """The analysis itself; ``ctx`` follows it for the failure handler, and what it makes
    goes on ``owned`` (an ExitStack: destroyed last made, first)."""
    memory.check(p, comm)
    with PETSc.Log.Stage("Assembly"):
        made = build(comm, p)
    owned.callback(destroy, *reversed(made))
    grid, points, K, M, free = made
    n = K.getSize()[0]
    if n == 0:
        raise InputError("-mpm_bc_*: every DOF is fixed; nothing left to vibrate")
    if p.nmodes > n:
        raise InputError(f"-mpm_nmodes {p.nmodes}: the model has only {n} free DOFs")
    PETSc.Sys.Print(f"Eigen analysis: {p.element.upper()}, {p.cells[0]} x {p.cells[1]} cells, "
                    f"{points.n_global} material points, {n} free DOFs, {comm.getSize()} rank(s)",
                    comm=comm)

    freq, vecs, summary = {}, {}, {"analysis": "eigen", "ranks": comm.getSize(), "ndof": n,
                                   "element": p.element, "cells": list(p.cells),
                                   "size_m": list(p.size), "ppc": p.ppc, "points": p.points,
                                   "n_points": points.n_global,
                                   "density_kg_m3": mixture_density(p),
                                   "provenance": provenance.collect(comm, p)}
    ctx["summary"], ctx["freq"] = summary, freq
    E_c = assembly.constrained_modulus(p.E, p.nu)
    rod = analytic.rod_frequencies(E_c, mixture_density(p), p.size[1], p.nmodes)
    warnings = []          # Jacobi's, then the zero-energy modes'
    if "jacobi" in p.eigen_solver:
        freq["jacobi"], vecs["jacobi"], summary["jacobi"], warnings = _jacobi(
            p, comm, K, M, rod, owned)
    elif n <= MASS_CHECK_MAX_DOFS:
        # SLEPc's B-inner product needs M positive definite as much as Jacobi does: with a
        # singular M it may return modes at 0 Hz that are no eigenpairs (1 point per Q4 cell).
        try:
            jacobi.check_mass(M)
        except jacobi.MassError as exc:
            raise NumericalError(mass_diagnosis(p, exc).replace("Jacobi: ", "", 1)) from None
    if "slepc" in p.eigen_solver:
        with PETSc.Log.Stage("SLEPc"):
            res = slepc_solve(K, M, p.nmodes)
        owned.callback(destroy, *res.vectors)
        freq["slepc"], vecs["slepc"] = frequencies(res.values), res.vectors
        summary["slepc"] = {"seconds": res.seconds, "type": res.eps_type, "st": res.st_type}
        PETSc.Sys.Print(f"{res.label}: {res.seconds:.3f} s", comm=comm)
    zero = zero_energy_diagnosis(p, freq, rod)
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

    refs = _references(p, comm, rod, owned)
    summary["references"] = refs
    _print_table(comm, freq, refs, summary.get("cross_check"), scale)

    summary["completed"] = True
    ctx["phase"] = "writing"     # the last collectives come first in it: ranks can agree
    summary["files"] = _write_results(p, grid, free, vecs.get("jacobi") or vecs["slepc"],
                                      freq.get("jacobi", freq.get("slepc")),
                                      refs["rod_hz"], scale, summary)
    PETSc.Sys.Print(output.results_line(p.output, summary["files"]), comm=comm)
    return summary


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


def _jacobi(p, comm, K, M, rod, owned) -> tuple:
    """The Jacobi solve of :func:`_analysis` (its vectors go on ``owned``), printed:
    (frequencies (Hz), mode vectors, its summary entry, its warnings)."""
    try:
        with PETSc.Log.Stage("Jacobi"):
            res = jacobi.solve(K, M, p.nmodes, p.jacobi_tol, p.jacobi_max_sweeps)
    except jacobi.MassError as exc:
        raise NumericalError(mass_diagnosis(p, exc)) from None
    owned.callback(destroy, *res.vectors)
    freq = frequencies(res.eigenvalues[:p.nmodes])
    # Modes at about 0 Hz (rigid-body motion) have no meaningful relative residual;
    # zero_energy_diagnosis reports them.
    finite = freq >= ZERO_HZ * rod[0]
    worst = float(np.max(res.residual[finite], initial=0.0))
    summary = {"sweeps": res.sweeps, "seconds": res.seconds, "tol": p.jacobi_tol,
               "coupling": res.coupling, "eigenvalue_change": res.change,
               "residual": res.residual, "block_sizes": list(res.block)}
    PETSc.Sys.Print(f"Jacobi: {res.sweeps} sweeps to tolerance {p.jacobi_tol:.0e}, "
                    f"{res.seconds:.3f} s, largest relative residual {worst:.1e}", comm=comm)
    warnings = []
    if worst > RESIDUAL_WARNING:
        warnings.append(
            f"Jacobi: relative residuals up to {worst:.1e} in the reported modes at "
            f"-mpm_jacobi_tol {p.jacobi_tol:.0e}: mode shapes good to about {worst:.0e}, "
            f"frequencies to about {min(worst, worst ** 2 * 10):.0e} (relative); a "
            "smaller -mpm_jacobi_tol (the paper's 1e-15) costs a few more sweeps")
    return freq, res.vectors, summary, warnings


def _references(p, comm, rod, owned) -> dict:
    """The references of :func:`_analysis`: the 1D rod's frequencies ``rod``, the plain FE
    model (Gauss points) of the same mesh, and on the paper's scene its Table 3 (Hz)."""
    fe_ppc = 2 if p.element == "q4" else 3
    gauss = build(comm, p, placement="gauss", ppc=fe_ppc)
    owned.callback(destroy, *reversed(gauss))
    _, _, Kg, Mg, _ = gauss
    # Its own options prefix: -eps_* tune the main solve, -fe_eps_* this one.
    res = slepc_solve(Kg, Mg, p.nmodes, prefix="fe_")
    destroy(*res.vectors)
    fe = frequencies(res.values)
    # The rod column only where the rod is the scene (not for a free body, say).
    refs = {"rod_hz": rod if rod_applies(p) else None, "fe_gauss_hz": fe}
    if is_paper_scene(p):
        refs["paper_table3_hz"] = PAPER_TABLE3[p.element][:p.nmodes]
        refs["paper_abaqus_cpe8_hz"] = PAPER_ABAQUS_CPE8[:p.nmodes]
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


def _write_results(p, grid, free, vectors, freqs, rod, scale, summary):
    comm = grid.comm
    modes = _full_modes(grid, free, vectors)
    summary_path = p.summary or os.path.join(p.output, "summary.json")
    files = {"summary": summary_path}
    if comm.getRank() != 0:
        return files
    coords = grid.lattice_coordinates()
    # A common sign: the largest vertical displacement of each mode points up.
    for k, u in enumerate(modes):
        big = np.argmax(np.abs(u).max(axis=1))
        comp = np.argmax(np.abs(u[big]))
        modes[k] = u * np.sign(u[big, comp] or 1.0)
    files["modes_vtu"] = os.path.join(p.output, "modes.vtu")
    data = {f"mode_{k + 1}": np.column_stack([u, np.zeros(len(u))]) for k, u in enumerate(modes)}
    # Each mode's frequency travels with its shape: field data frequency_hz[k] is mode_{k+1}'s
    # (Hz, of the solver whose shapes these are: Jacobi's when it ran, else SLEPc's).
    output.write_vtu(files["modes_vtu"], coords, [output.grid_cells(grid)], point_data=data,
                     field_data={"frequency_hz": np.asarray(freqs[:len(modes)], dtype=float)})
    if p.figures:
        fig = mode_figure(grid, coords, modes, freqs, rod, p.size[1], scale)
        files.update(output.save_figures(fig, p.output, "modes", p.figure_format))
    output.write_json(summary_path, dict(summary, files=files))
    return files


def mode_figure(grid, coords, modes, freqs, rod, H, scale):
    """Mode shapes like the paper's Figure 2: deformed grids coloured by the displacement
    magnitude (a colour bar: |u| over the mode's largest) and u_y along the column, beside
    the rod's mode where the rod is the scene (``rod`` None: not); the caller saves it."""
    plt = output.pyplot()
    nm = len(modes)
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
        if rod is not None:
            yy = np.linspace(0, H, 200)
            shape = analytic.rod_mode(yy, H, k + 1)
            shape *= np.sign(np.dot(analytic.rod_mode(y[order], H, k + 1), uy)) or 1.0
            ax.plot(shape, yy, "k--", lw=0.8,
                    label=f"rod {hz(rod[k])} Hz" if k < len(rod) else "rod")
        ax.set_xlabel("u_y (normalised)", fontsize=8)
        if k == 0:
            ax.set_ylabel("height y (m)")
        ax.legend(fontsize=6, loc="lower left")
        ax.tick_params(labelsize=7)
    fig.colorbar(dots, ax=list(axes[0]), fraction=0.04, pad=0.02,
                 label="|u| / largest |u| of the mode")
    fig.suptitle(f"Mode shapes, {grid.element.upper()} background grid")
    return fig
