#!/usr/bin/env python3
"""Reproduce every table and figure of the paper in one command (2 cores, a few minutes).

    scripts/reproduce-paper [--cores 2] [--fresh] [--publish | --out FOLDER] [--formats png,pdf]

Runs the eight scenes of cases/ (eigen Q4/Q8/Q9, consolidation M1-Q4/Q8/Q9, M2-Q4, M3-Q4),
one rank each, as many at once as there are cores, the longest first. Their own output goes
to output/paper/<scene>/ (a re-run reuses finished scenes unless --fresh). Then writes into
output/studies/paper/ (or docs/results/ with --publish, the tracked copy the docs show):
paper.md (Tables 1, 3, 4 and 5, each with the paper's values beside ours, and the
figures), fig2-modes-q9.png, fig3-pressure-field-m3.png, fig4-m1-elements.png,
fig5-meshes.png, and paper.json with every number.
"""

import argparse
import os
import shutil
import sys
import time

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

from solver.consolidation import plots as figures  # noqa: E402
from solver.eigen.compare import PAPER_ABAQUS_CPE8, PAPER_TABLE3  # noqa: E402
from solver.io import output  # noqa: E402
from solver.references import analytic  # noqa: E402
from solver.studies import study  # noqa: E402

LOAD = 10e3                 # Pa: the paper's surface load q (cases/consolidation-*.opts)
MARKERS = ("o", "s", "^")
REF_CLASSIC = dict(ls="--", lw=0.9)
REF_COMPRESSIBLE = dict(ls=":", lw=1.1)
PAPER_SWEEPS = {"q4": 7, "q8": 9, "q9": 9}
# Tables 4 and 5: p/q at the monitor point (percent error against classic Terzaghi).
PAPER_TV = (0.02, 0.5, 1.0)
PAPER_P = {"m1-q4": [(0.996, 0.50), (0.289, 6.17), (0.086, 8.68)],
           "m1-q8": [(0.961, 2.92), (0.274, 1.85), (0.082, 4.64)],
           "m1-q9": [(0.974, 1.66), (0.273, 1.35), (0.082, 4.90)],
           "m2-q4": [(0.991, 0.10), (0.280, 4.59), (0.084, 7.33)],
           "m3-q4": [(0.990, 0.10), (0.275, 3.70), (0.082, 6.48)]}
# Section 5: dt_crit,1 (which the paper says governs) and the time steps it adopted.
PAPER_DT = {"m1": (2.31e-4, 1e-4), "m2": (1.16e-4, 1e-4), "m3": (5.78e-5, 5e-5)}
CONSOLIDATION = ["m3-q4", "m1-q8", "m1-q9", "m2-q4", "m1-q4"]      # longest first
EIGEN = ["q4", "q8", "q9"]


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cores", type=int, default=study.cores(),
                    help="scenes run at once, one rank each (default: the cores of this "
                         "machine, %(default)s)")
    study.add_destination(ap, "paper", "paper.md, paper.json and the figures")
    ap.add_argument("--runs", default=os.path.join(ROOT, "output", "paper"),
                    help="folder for the scenes' own output (default output/paper)")
    ap.add_argument("--fresh", action="store_true",
                    help="run again the scenes whose stored results an earlier run left")
    ap.add_argument("--formats", default="png",
                    help="comma-separated figure formats: png, pdf, svg (default png)")
    ap.add_argument("--dry-run", action="store_true",
                    help="print the scenes and where the results would go, run nothing")
    args = ap.parse_args(argv)
    args.out = study.destination(ap, args)
    try:
        args.formats = output.figure_formats(args.formats)
    except ValueError as exc:
        ap.error(f"--formats: {exc}")
    return args


def main(argv=None):
    args = arguments(argv)
    t0 = time.perf_counter()
    os.chdir(ROOT)
    runs = [study.Run(f"consolidation-{c}", ["-options_file", f"cases/consolidation-{c}.opts"],
                      os.path.join(args.runs, f"consolidation-{c}")) for c in CONSOLIDATION]
    runs += [study.Run(f"eigen-{e}", ["-options_file", f"cases/eigen-{e}.opts"],
                       os.path.join(args.runs, f"eigen-{e}")) for e in EIGEN]
    print(f"Reproducing the paper: {len(runs)} scenes on {args.cores} core(s)", flush=True)
    if args.dry_run:
        for r in runs:
            print(f"  {r.name}: {' '.join(r.args)} -> {r.folder}")
        print(f"results: {args.out}")
        return 0
    study.execute_all(runs, args.cores, log=lambda m: print(m, flush=True), fresh=args.fresh)
    failed = [r for r in runs if r.code != 0 or r.result is None]
    if failed:
        for r in failed:
            print(f"error: {r.name} failed (exit {r.code}): {r.stderr.splitlines()[-1:]}",
                  file=sys.stderr)
        return 1
    res = {r.name: r.result for r in runs}
    os.makedirs(args.out, exist_ok=True)
    tables = [table3(res), table1(res), table45(res, "4", ["m1-q4", "m1-q8", "m1-q9"]),
              table45(res, "5", ["m1-q4", "m2-q4", "m3-q4"])]
    drawn = write_figures(res, args.runs, args.out, args.formats)
    wall = time.perf_counter() - t0
    reused = sum(1 for r in runs if r.reused)
    write_report(args.out, tables, drawn, res, wall, args.cores, reused, args.runs)
    print("\n\n".join(t for t in tables))
    print(f"\nWrote {os.path.join(args.out, 'paper.md')} and {len(drawn)} figures "
          f"in {wall:.0f} s")
    return 0


def table3(res):
    rows = ["**Table 3.** First five natural frequencies (Hz), Jacobi solver; paper values "
            "in brackets.", "",
            "| mode | Q4 | Q8 | Q9 | FE (Q9 mesh, Gauss points) | Abaqus CPE8 (paper) | "
            "1D rod |", "|---|---|---|---|---|---|---|"]
    f = {e: res[f"eigen-{e}"]["frequencies_hz"]["jacobi"] for e in EIGEN}
    fe = res["eigen-q9"]["references"]["fe_gauss_hz"]
    rod = res["eigen-q9"]["references"]["rod_hz"]
    for k in range(5):
        cells = [f"{f[e][k]:.2f} ({PAPER_TABLE3[e][k]:.2f})" for e in EIGEN]
        rows.append(f"| {k + 1} | " + " | ".join(cells)
                    + f" | {fe[k]:.2f} | {PAPER_ABAQUS_CPE8[k]:.2f} | {rod[k]:.2f} |")
    sweeps = ", ".join(f"{e.upper()} {res[f'eigen-{e}']['jacobi']['sweeps']} "
                       f"(paper {PAPER_SWEEPS[e]})" for e in EIGEN)
    check = max(max(res[f"eigen-{e}"]["cross_check"]["relative_eigenvalue_difference"])
                for e in EIGEN)
    rows += ["", f"Jacobi sweeps to xi = 1e-15: {sweeps}. Largest relative eigenvalue "
             f"difference Jacobi vs SLEPc Krylov-Schur: {check:.1e}."]
    return "\n".join(rows)


def table1(res):
    rows = ["**Table 1.** Critical time steps (s). The paper computes only the first four and "
            "states that dt_crit,1 (undrained) governs; the drag limit and the discrete "
            "limit of the step itself are ours.", "",
            "| mesh | CFL | undrained (paper) | diffusion | oscillator | drag | discrete | "
            "dt used (paper) |", "|---|---|---|---|---|---|---|---|"]
    for case in ["m1-q4", "m2-q4", "m3-q4", "m1-q8", "m1-q9"]:
        s = res[f"consolidation-{case}"]
        d = s["dt_critical"]
        mesh = case.split("-")[0]
        crit1, used = PAPER_DT[mesh]
        rows.append(f"| {case.upper()} | {d['cfl']:.3g} | {d['undrained']:.3g} ({crit1:.3g}) "
                    f"| {d['diffusion']:.3g} | {d['oscillator']:.3g} | {d['drag']:.3g} | "
                    f"{d['discrete']:.3g} | {s['dt']:.3g} ({used:.0e}) |")
    rows += ["", "The smallest of the paper's four criteria is the undrained one, as it says; "
             "but the step is stable only below the discrete limit, which is smaller on every "
             "mesh (on M1-Q4 the drag sets it). We run at half the smallest limit "
             "(-mpm_dt_safety 0.5); `scripts/stability-map` measures where runs blow up."]
    return "\n".join(rows)


def table45(res, number, cases):
    what = "element orders (mesh M1)" if number == "4" else "meshes (Q4)"
    head = " | ".join(c.upper() for c in cases)
    rows = [f"**Table {number}.** Normalised pore pressure p/q at the monitor point, "
            f"{what}: ours (error against classic Terzaghi) and the paper's in brackets; "
            "the last rows give our error against the compressible-water Terzaghi "
            "solution, which isolates the numerical error.", "",
            f"| T_v | {head} |", "|---" * (len(cases) + 1) + "|"]
    for i, tv in enumerate(PAPER_TV):
        cells = []
        for c in cases:
            m = res[f"consolidation-{c}"]["monitor"]
            pp, pe = PAPER_P[c][i]
            cells.append(f"{m['p_over_q'][i]:.3f} ({m['error_pct'][i]:+.2f} %) "
                         f"[{pp:.3f} ({pe:.2f} %)]")
        rows.append(f"| {tv:g} | " + " | ".join(cells) + " |")
    for i, tv in enumerate(PAPER_TV):
        cells = [f"{res[f'consolidation-{c}']['monitor']['error_consistent_pct'][i]:+.2f} %"
                 for c in cases]
        rows.append(f"| {tv:g}, compressible water | " + " | ".join(cells) + " |")
    heights = ", ".join(f"{c.upper()} {res[f'consolidation-{c}']['monitor']['height']:.5g} m"
                        for c in cases)
    rows += ["", f"Monitor point (the highest material point below mid-height): {heights}. "
             "The paper quotes |error|; we keep the sign."]
    return "\n".join(rows)


def _profiles(folder):
    """profiles.csv of a scene: rows (Tv, t (s), x (m), y0 (m), p / q, volume (m3))."""
    return np.loadtxt(os.path.join(folder, "profiles.csv"), delimiter=",", skiprows=1,
                      ndmin=2)


def _isochrone_panel(ax, res, runs_dir, cases, labels, tvs=(0.02, 0.1, 0.3, 0.5, 1.0)):
    """p / q against height at ``tvs``: the scenes' points (one marker per scene, one colour
    per T_v) over both Terzaghi references (the scenes share the soil, so one set)."""
    plt = output.pyplot()
    colors = figures.tv_colors(plt, len(tvs))
    first = res[f"consolidation-{cases[0]}"]
    figures.isochrone_references(ax, tvs, colors, 1.0, first["c2"] / first["c_v"],
                                 first["p0_consistent_over_q"])
    for c, marker in zip(cases, MARKERS):
        prof = _profiles(os.path.join(runs_dir, f"consolidation-{c}"))
        for tv, col in zip(tvs, colors):
            rows = prof[np.isclose(prof[:, 0], tv)]
            if not len(rows):
                continue
            # One value per height: the points of a row share it in this 1D problem.
            ys, inv = np.unique(np.round(rows[:, 3], 9), return_inverse=True)
            pm = np.bincount(inv, rows[:, 4]) / np.bincount(inv)
            ax.plot(pm, ys, marker, ms=3.5, color=col, mfc="none", ls="none")
        ax.plot([], [], marker, ms=4, color="0.3", mfc="none", ls="none", label=labels[c])
    figures.legend_below(ax, ncol=3)
    ax.set_title("Isochrones (colour: T_v)", fontsize=9)


def _monitor_panel(ax, res, runs_dir, cases, labels):
    """p / q at each scene's monitor point against T_v, with both references at its depth."""
    colors = ["tab:blue", "tab:orange", "tab:green"]
    tv = np.geomspace(1e-3, 1, 300)
    for c, col in zip(cases, colors):
        hist = np.loadtxt(os.path.join(runs_dir, f"consolidation-{c}", "monitor.csv"),
                          delimiter=",", skiprows=1, ndmin=2)
        s = res[f"consolidation-{c}"]
        depth = 1 - s["monitor"]["height"]
        ax.plot(hist[:, 1], hist[:, 2], color=col, lw=0.9, label=labels[c])
        ax.plot(tv, analytic.terzaghi(depth, tv), color=col, alpha=0.8, **REF_CLASSIC)
        ax.plot(tv, analytic.terzaghi(depth, tv * s["c2"] / s["c_v"], 1.0,
                                      s["p0_consistent_over_q"]),
                color=col, alpha=0.8, **REF_COMPRESSIBLE)
    ax.plot([], [], color="k", label="Terzaghi, classic", **REF_CLASSIC)
    ax.plot([], [], color="k", label="Terzaghi, compressible water", **REF_COMPRESSIBLE)
    ax.set_xscale("log")
    ax.set_xlim(1e-3, 1)
    ax.set_xlabel("time factor T_v (-)")
    ax.set_ylabel("p / q at the monitor point (-)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, title="each at its monitor point", title_fontsize=7)


def _pressure_figure(res, runs_dir):
    """Figure 3 from M3's profiles.csv, at the report times."""
    prof = _profiles(os.path.join(runs_dir, "consolidation-m3-q4"))
    s = res["consolidation-m3-q4"]
    snaps = []
    for tv in s["monitor"]["Tv"]:
        rows = prof[np.isclose(prof[:, 0], tv)]
        snaps.append((tv, rows[:, 2], rows[:, 3], rows[:, 4] * LOAD))
    return figures.pressure_field(output.pyplot(), snaps, LOAD,
                                  f"Pore pressure field, M3 (Q4), {s['n_points']} MPs",
                                  width=s["scene"]["size"][0])


FIGURE_SETS = [
    ("fig4", "fig4-m1-elements.png", ["m1-q4", "m1-q8", "m1-q9"],
     {"m1-q4": "Q4 (2x2 MP/cell)", "m1-q8": "Q8 (3x3)", "m1-q9": "Q9 (3x3)"},
     "M1 (1 x 10 cells) with different element orders (paper Fig. 4)"),
    ("fig5", "fig5-meshes.png", ["m1-q4", "m2-q4", "m3-q4"],
     {"m1-q4": "M1, 40 MPs", "m2-q4": "M2, 160 MPs", "m3-q4": "M3, 640 MPs"},
     "Q4 on meshes M1, M2, M3 (paper Fig. 5)")]


def write_figures(res, runs_dir, out, formats=("png",)):
    """Figures 2 to 5 into ``out``: {key: [paths, the PNG first]}. Figure 2 is the Q9 scene's
    own PNG, copied; the others are drawn here in every format of ``formats``."""
    plt = output.pyplot()
    formats = ("png",) + tuple(f for f in formats if f != "png")   # paper.md shows the PNG
    files = {}
    src = res["eigen-q9"]["files"].get("modes_png")
    if src and os.path.exists(src):
        files["fig2"] = [os.path.join(out, "fig2-modes-q9.png")]
        shutil.copyfile(src, files["fig2"][0])
    files["fig3"] = output.save_figure(_pressure_figure(res, runs_dir),
                                       os.path.join(out, "fig3-pressure-field-m3.png"),
                                       formats=formats)
    for key, name, cases, labels, title in FIGURE_SETS:
        fig, axes = plt.subplots(1, 2, figsize=(12, 5.5))
        _isochrone_panel(axes[0], res, runs_dir, cases, labels)
        _monitor_panel(axes[1], res, runs_dir, cases, labels)
        fig.suptitle(title)
        files[key] = output.save_figure(fig, os.path.join(out, name), formats=formats)
    return files


def _shown(path):
    """``path`` relative to the repository when it lies inside it."""
    rel = os.path.relpath(path, ROOT)
    return path if rel.startswith("..") else rel


def write_report(out, tables, drawn, res, wall, cores, reused, runs_dir):
    captions = {"fig2": "Figure 2: the first five mode shapes of the Q9 model (Jacobi).",
                "fig3": "Figure 3: pore pressure field of M3 (640 MPs) at the report times.",
                "fig4": "Figure 4: M1 with Q4, Q8 and Q9 cells: isochrones and the monitor "
                        "point against Terzaghi (classic, solid; compressible water, dotted).",
                "fig5": "Figure 5: Q4 on M1, M2 and M3."}
    lines = ["# The paper, reproduced", "",
             "Written by `scripts/reproduce-paper` "
             f"({wall:.0f} s on {cores} core(s)"
             + (f", {reused} of {len(res)} scenes reused from an earlier run" if reused else "")
             + f"; each scene's own output is in `{_shown(runs_dir)}/`). Paper values are "
             "in brackets.", ""]
    for t in tables:
        lines += [t, ""]
    for key, paths in drawn.items():
        lines += [f"![{captions[key]}]({os.path.basename(paths[0])})", "", captions[key], ""]
        if len(paths) > 1:
            lines += ["Also as " + ", ".join(f"[{os.path.splitext(p)[1][1:].upper()}]"
                                            f"({os.path.basename(p)})" for p in paths[1:])
                      + ".", ""]
    output.write_text(os.path.join(out, "paper.md"), "\n".join(lines))
    keep = {name: {k: v for k, v in s.items() if k != "files"} for name, s in res.items()}
    output.write_json(os.path.join(out, "paper.json"),
                      {"wall_seconds": wall, "cores": cores, "scenes": keep})


if __name__ == "__main__":
    sys.exit(main())
