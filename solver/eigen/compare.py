"""What the eigen analysis sets beside its solvers' frequencies: the 1D rod (analytic, or
the layered rod's transfer-matrix solution), the plain FE model of the same mesh (points at
the Gauss points), the paper's Table 3 on its own scene, the cross-check of Jacobi and SLEPc
(relative eigenvalue difference, modal assurance criterion), and the table printed."""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..materials.history import elasticity_of
from ..model.scene import build, destroy
from ..modal.frequency import frequencies, slepc_solve
from ..references import analytic, layered
from .plots import hz, rigid

# Table 3 of the paper (Hz): the MP models of a 1 x 10 grid over the 0.1 m x 1 m column.
PAPER_TABLE3 = {"q4": [16.92, 51.27, 87.24, 126.03, 168.95],
                "q8": [16.89, 50.62, 84.20, 117.62, 150.94],
                "q9": [16.89, 50.62, 84.20, 117.62, 150.94]}
PAPER_ABAQUS_CPE8 = [16.89, 50.68, 84.49, 118.37, 152.42]


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


def cross_check(freq, vecs, scale) -> dict:
    """Jacobi against SLEPc, mode by mode: relative eigenvalue difference and MAC; None for
    a rigid-body mode (of either), whose eigenvalue is rounding and whose shape is any
    combination of the rigid motions."""
    fj, fs = freq["jacobi"], freq["slepc"]
    skip = rigid(fj, scale) | rigid(fs, scale)
    rel = [None if r else float(abs(a * a - b * b) / (b * b))
           for a, b, r in zip(fj, fs, skip)]
    macs = [None if r else mac(a, b) for a, b, r in zip(vecs["jacobi"], vecs["slepc"], skip)]
    return {"relative_eigenvalue_difference": rel, "mac": macs}


def references(plan, comm, rod, owned) -> dict:
    """The references of :func:`_analysis`: the 1D rod's frequencies ``rod``, the plain FE
    model (Gauss points) of the same mesh, and on the paper's scene its Table 3 (Hz)."""
    body, nmodes = plan.body, plan.nmodes
    fe_ppc = 2 if body.element == "q4" else 3
    gauss = build(comm, body, plan.ground, placement="gauss", ppc=fe_ppc,
                  D=elasticity_of(plan.ground))
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


def print_table(comm, freq, refs, cross, scale):
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
