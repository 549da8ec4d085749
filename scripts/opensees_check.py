#!/usr/bin/env python3
"""The hyperbolic soil's site response against OpenSees: a layered column shaken at its
rigid base, run by the solver and by OpenSees (openseespy), compared at the surface.

    .venv/bin/pip install openseespylinux        # OpenSees for Python, once (not a dependency)
    .venv/bin/python scripts/opensees-check
    .venv/bin/python scripts/opensees-check --publish   # also tests/data's reference

The column: the 30 m deposit of cases/dynamic-layers.opts (three dry layers, Vs 150, 250,
400 m/s from the surface down) on a rigid base, 60 Q4 cells of 0.5 m (2 x 2 points), the
hyperbolic soil of gamma_r 1e-3 in every layer (25 surfaces), 2 % small-strain damping
(Rayleigh at f1 and 5 f1), the first 8 s of cases/motions/three-layers.csv as the base's
motion, samples every 1 ms.

OpenSees models the same column as a one-dimensional shear beam: a node a row with the
row's lumped mass, a zeroLength element between rows whose material is the soil's Iwan
polygon as OpenSees' own parts (uniaxial ElasticPP springs in a Parallel material, spring i
of stiffness G_i / h and yield force tau_i per m2: the surfaces of
solver.materials.hyperbolic), Rayleigh damping a0 M + a1 K_initial with the solver's a0,
a1, the base motion as a UniformExcitation, Newmark's average acceleration with Newton
iterations at a quarter of a millisecond. What the check tests is the solver's engine (the
points' strains and stresses through B, the parallel assembly, the explicit step with its
damping) against OpenSees' elements, springs and integrator; the backbone polygon is the
same by construction.

Prints and writes opensees-check.json, .txt and .png into output/studies/opensees-check/
(``--publish``: docs/results/, and the OpenSees surface histories with the solver options
into tests/data/opensees-hyperbolic-column.csv, which tests/test_dynamic_nonlinear.py
reads): the surface PGA of both, the largest difference of the surface PSA (5 %, 0.01 to
10 s), and of the surface's displacement and acceleration histories (% of their peaks).
Exit code 2 with one line when OpenSees is not installed.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

from solver.studies import study  # noqa: E402

REFERENCE = os.path.join(ROOT, "tests", "data", "opensees-hyperbolic-column.csv")
RECORD = "cases/motions/three-layers.csv"
THICKNESS, E, POROSITY = (10.0, 10.0, 10.0), (76.05e6, 237.65625e6, 676e6), (0.5, 0.4375,
                                                                              0.375)
NU, RHO_S, GAMMA_R, CELLS, T_END, SAMPLE, OPENSEES_DT = 0.3, 2600.0, 1e-3, 60, 8.0, 1e-3, \
    2.5e-4
OPTIONS = ["-mpm_analysis", "dynamic", "-mpm_element", "q4", "-mpm_cells", f"1,{CELLS}",
           "-mpm_size", f"1,{sum(THICKNESS):g}",
           "-mpm_layers", ",".join(f"{t:g}" for t in THICKNESS),
           "-mpm_E", ",".join(repr(e) for e in E), "-mpm_nu", f"{NU:g}",
           "-mpm_rho_s", f"{RHO_S:g}", "-mpm_rho_l", "0",
           "-mpm_porosity", ",".join(f"{n:g}" for n in POROSITY), "-mpm_base", "rigid",
           "-mpm_base_motion", RECORD, "-mpm_t_end", f"{T_END:g}",
           "-mpm_record_dt", f"{SAMPLE:g}", "-mpm_material", "hyperbolic",
           "-mpm_reference_strain", f"{GAMMA_R:g}", "-mpm_small_strain_damping", "0.02",
           "-mpm_linear_twin", "0", "-mpm_figures", "0", "-mpm_progress", "0"]


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    study.add_destination(ap, "opensees-check", "opensees-check.json, .txt and .png",
                          "and the OpenSees reference into tests/data")
    args = ap.parse_args(argv)
    args.out = study.destination(ap, args)
    return args


def opensees():
    """OpenSees for Python's module, or SystemExit(2) with what to install."""
    for name in ("openseespy.opensees", "openseespylinux.opensees"):
        try:
            return __import__(name, fromlist=["opensees"])
        except ImportError:
            continue
    print("opensees-check: needs OpenSees for Python: .venv/bin/pip install openseespylinux",
          file=sys.stderr)
    raise SystemExit(2)


def opensees_column(ops, a0: float, a1: float) -> np.ndarray:
    """(t (s), surface absolute acceleration (m/s2), surface displacement relative to the
    base (m)) every SAMPLE s from OpenSees' shear beam of the column (module docstring)."""
    from solver.io import records
    from solver.materials.hyperbolic import Hyperbolic

    H, n = sum(THICKNESS), CELLS
    h = H / n
    bottoms = H - np.cumsum(THICKNESS)
    layer = [int(np.argmax((k + 0.5) * h >= bottoms)) for k in range(n)]   # from the top
    rho = [(1 - p) * RHO_S for p in POROSITY]
    record = np.column_stack(records.read(os.path.join(ROOT, RECORD)))
    ops.wipe()
    ops.model("basic", "-ndm", 1, "-ndf", 1)
    for j in range(n + 1):
        ops.node(j + 1, 0.0)
    ops.fix(1, 1)
    tag = 1
    for k in range(n):                       # the element between rows k and k + 1
        G, tau = Hyperbolic(E[layer[k]], NU, GAMMA_R).elements()
        springs = []
        for Gi, ti in zip(G, tau):
            ops.uniaxialMaterial("ElasticPP", tag, Gi / h, ti / (Gi / h))
            springs.append(tag)
            tag += 1
        ops.uniaxialMaterial("Parallel", tag, *springs)
        ops.element("zeroLength", k + 1, k + 1, k + 2, "-mat", tag, "-dir", 1,
                    "-doRayleigh", 1)
        tag += 1
    for j in range(1, n + 1):
        above = 0.5 * h * rho[layer[j]] if j < n else 0.0
        ops.mass(j + 1, 0.5 * h * rho[layer[j - 1]] + above)
    ops.timeSeries("Path", 1, "-time", *record[:, 0].tolist(), "-values",
                   *record[:, 1].tolist())
    ops.pattern("UniformExcitation", 1, 1, "-accel", 1)
    ops.rayleigh(a0, 0.0, a1, 0.0)
    ops.constraints("Plain")
    ops.numberer("Plain")
    ops.system("BandGeneral")
    ops.test("NormDispIncr", 1e-12, 50)
    ops.algorithm("Newton")
    ops.integrator("Newmark", 0.5, 0.25)
    ops.analysis("Transient")
    every = int(round(SAMPLE / OPENSEES_DT))
    count = int(round(T_END / SAMPLE))
    out = np.zeros((count + 1, 3))
    for k in range(1, count + 1):
        if ops.analyze(every, OPENSEES_DT) != 0:
            raise SystemExit(f"opensees-check: OpenSees failed to converge by t = {k * SAMPLE}")
        t = k * SAMPLE
        out[k] = (t, ops.nodeAccel(n + 1, 1) + np.interp(t, record[:, 0], record[:, 1]),
                  ops.nodeDisp(n + 1, 1))
    return out


def surface(folder) -> np.ndarray:
    """(t, a_x, u_x) at the surface of a solver run's histories.csv."""
    rows = np.loadtxt(os.path.join(folder, "histories.csv"), delimiter=",", skiprows=1)
    top = rows[:, 1] == 0
    return rows[top][:, [0, 2, 4]]


def compare(mpm: np.ndarray, ops: np.ndarray) -> dict:
    """The agreement of the solver's surface (t, a, u) with OpenSees' (the same times)."""
    from solver.references.spectra import pseudo_acceleration

    periods = np.logspace(-2, 1, 60)
    psa = [pseudo_acceleration(x[:, 1], SAMPLE, periods) for x in (mpm, ops)]
    peak_a, peak_u = np.max(np.abs(ops[:, 1])), np.max(np.abs(ops[:, 2]))
    da = np.abs(mpm[:, 1] - ops[:, 1])
    return {"pga_solver": float(np.max(np.abs(mpm[:, 1]))), "pga_opensees": float(peak_a),
            "pga_difference_pct": float(100 * (np.max(np.abs(mpm[:, 1])) / peak_a - 1)),
            "psa_largest_difference_pct": float(100 * np.max(np.abs(psa[0] / psa[1] - 1))),
            "u_largest_difference_pct_of_peak": float(
                100 * np.max(np.abs(mpm[:, 2] - ops[:, 2])) / peak_u),
            "a_rms_difference_pct_of_peak": float(100 * np.sqrt(np.mean(da ** 2)) / peak_a),
            "a_largest_difference_pct_of_peak": float(100 * np.max(da) / peak_a),
            "periods_s": periods.tolist(), "psa_solver": psa[0].tolist(),
            "psa_opensees": psa[1].tolist()}


def write_reference(ops_surface: np.ndarray) -> None:
    """tests/data's reference: OpenSees' surface histories, the solver options in its head."""
    from solver.io import output

    lines = ["# OpenSees (openseespy) shear beam of scripts/opensees_check.py; the solver "
             "options of the same column:",
             "# options: " + " ".join(OPTIONS), "t_s,a_x_m_s2,u_x_m"]
    lines += [f"{t:.6g},{a:.9e},{u:.9e}" for t, a, u in ops_surface]
    output.write_text(REFERENCE, "\n".join(lines) + "\n")


def figure(mpm, ops, r, path) -> None:
    from solver.io import output

    plt = output.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(12, 4))
    ax1.plot(ops[:, 0], ops[:, 1], lw=0.8, color="k", label="OpenSees")
    ax1.plot(mpm[:, 0], mpm[:, 1], lw=0.8, ls="--", color="tab:blue", label="solver (MPM)")
    ax1.set_xlabel("t (s)")
    ax1.set_ylabel("surface acceleration (m/s$^2$)")
    ax1.legend(fontsize=8)
    ax2.semilogx(r["periods_s"], r["psa_opensees"], color="k", label="OpenSees")
    ax2.semilogx(r["periods_s"], r["psa_solver"], ls="--", color="tab:blue",
                 label="solver (MPM)")
    ax2.set_xlabel("period (s)")
    ax2.set_ylabel("surface PSA, 5 % (m/s$^2$)")
    ax2.legend(fontsize=8)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    args = arguments(argv)
    ops = opensees()
    with tempfile.TemporaryDirectory(prefix="opensees-check-") as tmp:
        run = study.run_afresh("the solver's column", OPTIONS, tmp,
                               log=lambda m: print(m, flush=True))
        mpm = surface(tmp)
    ray = run.result["rayleigh"]
    print(f"OpenSees: the shear beam, Rayleigh a0 = {ray['a0']:.6g} 1/s, a1 = "
          f"{ray['a1']:.6g} s", flush=True)
    theirs = opensees_column(ops, ray["a0"], ray["a1"])
    r = compare(mpm, theirs)
    report = [
        "Hyperbolic column against OpenSees (surface, 8 s of the record on a rigid base)",
        f"  PGA: solver {r['pga_solver']:.4g} m/s2, OpenSees {r['pga_opensees']:.4g} m/s2 "
        f"({r['pga_difference_pct']:+.2f} %)",
        f"  PSA (5 %, 0.01-10 s): largest difference {r['psa_largest_difference_pct']:.2f} %",
        f"  displacement: largest difference {r['u_largest_difference_pct_of_peak']:.2f} % "
        "of its peak",
        f"  acceleration: RMS difference {r['a_rms_difference_pct_of_peak']:.2f} % of its "
        f"peak, largest {r['a_largest_difference_pct_of_peak']:.2f} %"]
    print("\n".join(report))
    os.makedirs(args.out, exist_ok=True)
    prefix = os.path.join(args.out, "opensees-check")
    study.write_results(prefix, r, report)
    figure(mpm, theirs, r, prefix + ".png")
    if args.publish:
        write_reference(theirs)
        print(f"Wrote {os.path.relpath(REFERENCE, ROOT)}")
    print(f"Wrote {prefix}.json, .txt and .png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
