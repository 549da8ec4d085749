#!/usr/bin/env python3
"""Convergence study of the consolidation scene: work against precision.

    scripts/convergence-study [--ranks 1] [--cores 2] [--quick] [--publish]
                              [-options_file SCENE] [--formats png,pdf]

Runs the scene (default cases/consolidation-m1-q4.opts, the paper's column) over element
order (Q4, Q8, Q9), mesh (cells up the column; the paper's M1-M3 and finer), points per cell
and time step (-mpm_dt_safety), each run with `mpirun -n RANKS` (CORES // RANKS at once),
and charts the errors against wall-clock time and against cost (material points x steps),
log-log, one curve per element type with the observed convergence order in the legend
("not converging" where the error does not fall with the mesh). Into output/studies/
convergence/ (or, with --publish, docs/results/, the tracked copy the docs show):
- convergence-monitor.png: error at the monitor point (largest |error| over T_v = 0.5 and 1)
  against classic and against compressible-water Terzaghi;
- convergence-l2.png: the same for the L2 norm of the whole profile;
- convergence.md (table, orders, reading) and convergence.csv;
- work_precision.json, the measured data -mpm_target_error reads (with --publish:
  solver/data/work_precision.json, the file the solver ships; --publish takes the default
  scene and the whole study only).
Runs go to output/convergence/ and are reused by a re-run (a killed study continues).

    scripts/convergence-study --check        # do the shipped data still hold? (about 5 s)

makes the cheapest runs of solver/data/work_precision.json again, afresh, and compares: each
must give its stored row (all but the wall time), and the file must be what this command
makes of its rows (orders, measure, scene); exit 1, naming each difference, when not.
"""

import argparse
import json
import math
import os
import sys

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

from solver.common.errors import InputError  # noqa: E402
from solver.consolidation import workprecision  # noqa: E402
from solver.io import output  # noqa: E402
from solver.studies import study  # noqa: E402

DEFAULT_SCENE = "cases/consolidation-m1-q4.opts"
PPC = {"q4": 2, "q8": 3, "q9": 3}
SCHEME = ("kinematics", "pressure_projection", "liquid_basis", "lumping")
# The errors of a run: at the monitor point (%) and L2 of p / q over the profile (-), each
# against classic and against compressible-water Terzaghi.
ERRORS = ("monitor_classic", "monitor_consistent", "l2_classic", "l2_consistent")
COLORS = {"q4": "tab:blue", "q8": "tab:orange", "q9": "tab:green"}
CHART_TV = (0.5, 1.0)                  # the charts' errors: the largest over these T_v
REPORT_TV = (0.02, 0.2, 0.5, 1.0)      # every run reports here: -mpm_target_error's measure


# Schemes other than the defaults (-mpm_kinematics, -mpm_pressure_projection,
# -mpm_liquid_basis; docs/method.md), refined beside them: the choice of the defaults.
VARIANTS = {
    "q4": {"moving points, no projection": ["-mpm_kinematics", "large",
                                            "-mpm_pressure_projection", "none"],
           "no projection": ["-mpm_pressure_projection", "none"],
           "moving points": ["-mpm_kinematics", "large"]},
    "q9": {"moving points": ["-mpm_kinematics", "large"],
           "nodal projection": ["-mpm_pressure_projection", "nodal"],
           "no projection": ["-mpm_pressure_projection", "none"]},
    "q8": {"element basis, moving points": ["-mpm_liquid_basis", "element",
                                            "-mpm_kinematics", "large"],
           "moving points": ["-mpm_kinematics", "large"],
           "no projection": ["-mpm_pressure_projection", "none"]},
}


def plan(quick: bool):
    """(series, element, cells, ppc, dt_safety, variant) of every run, cheapest first; the
    variant names an entry of VARIANTS ("" for the defaults)."""
    runs = []
    refine = {"q4": [10, 20, 40, 80], "q9": [5, 10, 20, 40], "q8": [5, 10, 20, 40]}
    if quick:
        refine = {"q4": [10, 20], "q9": [5, 10], "q8": [5]}
    for e, nys in refine.items():
        runs += [("refine", e, (1, ny), PPC[e], 0.5, "") for ny in nys]
    runs += [("wide", "q4", (2, 20), 2, 0.5, "")]
    if not quick:
        runs += [("wide", "q4", (4, 40), 2, 0.5, ""), ("wide", "q9", (2, 10), 3, 0.5, "")]
        runs += [("ppc", "q4", (1, 20), k, 0.5, "") for k in (1, 3, 4)]
        runs += [("ppc", "q4", (1, ny), 1, 0.5, "") for ny in (10, 40)]
        runs += [("ppc", "q9", (1, 10), k, 0.5, "") for k in (2, 4)]
        runs += [("dt", "q4", (1, 20), 2, s, "") for s in (0.25, 0.9)]
        runs += [("dt", "q9", (1, 10), 3, s, "") for s in (0.25, 0.9)]
        for e, variants in VARIANTS.items():
            for name in variants:
                # The previous Q8 scheme is unstable on finer meshes (docs/studies.md);
                # point pressures were the quadratic cells' default before the corner
                # projection (Q8's on 1 x 40 cells alone took 4.8 minutes: left out).
                nys = ((10,) if name == "element basis, moving points" else
                       (10, 20, 40) if name == "no projection" and e == "q9" else
                       (10, 20) if e == "q8" else
                       (10, 20, 40) if name in ("moving points, no projection",
                                                "moving points") else (20,))
                runs += [("variant", e, (1, ny), PPC[e], 0.5, name) for ny in nys]
    return runs


def tag(e, cells, ppc, safety, variant=""):
    """The run's name (and folder), e.g. q4-1x20-ppc2-dt0.5-moving-points."""
    name = f"{e}-{cells[0]}x{cells[1]}-ppc{ppc}-dt{safety:g}"
    return name + ("-" + variant.replace(",", "").replace(" ", "-") if variant else "")


def errors(summary):
    """Monitor and L2 errors, largest over T_v = 0.5 and 1 (CHART_TV), against both
    references: the charts' errors, whose orders the early times would blur."""
    mon, l2 = summary["monitor"], summary["profile_l2"]
    pick = [i for i, tv in enumerate(mon["Tv"]) if round(tv, 9) in CHART_TV]
    return {"monitor_classic": max(abs(mon["error_pct"][i]) for i in pick),
            "monitor_consistent": max(abs(mon["error_consistent_pct"][i]) for i in pick),
            "l2_classic": max(l2["terzaghi"][i] for i in pick),
            "l2_consistent": max(l2["consistent"][i] for i in pick)}


def order(rows, key):
    """Observed order p of error ~ h^p over a refinement series (least squares)."""
    if len(rows) < 2:
        return math.nan
    h = np.array([1.0 / r["cells"][1] for r in rows])
    e = np.array([r[key] for r in rows])
    return float(np.polyfit(np.log(h), np.log(e), 1)[0])


def arguments(argv=None):
    """The command line, with the destinations resolved (``out``, ``data``) and the chart
    formats checked (``formats``)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-options_file", dest="scene", default=DEFAULT_SCENE,
                    help=f"the scene to refine (default {DEFAULT_SCENE})")
    # One rank per run, two runs at once: the study's models have 20 to 640 points, where
    # a second rank only adds a message exchange per step (see docs/performance.md).
    ap.add_argument("--ranks", type=int, default=1,
                    help="MPI ranks per run (default 1: the models are small)")
    ap.add_argument("--cores", type=int, default=study.cores(),
                    help="cores to fill: CORES // RANKS runs at once (default: this "
                         "machine's, %(default)s)")
    ap.add_argument("--quick", action="store_true",
                    help="a small subset (minutes instead of about an hour)")
    study.add_destination(ap, "convergence", "the charts, convergence.md and convergence.csv",
                          published=f"the data into "
                                    f"{os.path.relpath(workprecision.DEFAULT, ROOT)} "
                                    "(the default scene's whole study only)")
    ap.add_argument("--runs", default=os.path.join(ROOT, "output", "convergence"),
                    help="folder for the runs' own output, reused by a re-run (default "
                         "output/convergence)")
    ap.add_argument("--data", default=None,
                    help="work-precision file to write (default OUT/work_precision.json); "
                         "with --check, the file to check (default "
                         f"{os.path.relpath(workprecision.DEFAULT, ROOT)})")
    ap.add_argument("--check", action="store_true",
                    help="run the cheapest runs of the stored work-precision data again "
                         "(afresh, about 5 s) and compare: exit 1 when the data no longer "
                         "hold (the stored file is not what this command makes of its runs)")
    ap.add_argument("--formats", default="png",
                    help="comma-separated chart formats: png, pdf, svg (PNG always; "
                         "default png)")
    ap.add_argument("--dry-run", action="store_true",
                    help="print the runs and where the results would go, run nothing")
    return destinations(ap, ap.parse_args(argv))


def destinations(ap, args):
    """``args`` with ``out``, ``data`` and ``formats`` resolved; an argparse error for a
    --publish of less than the whole study of the default scene, or a bad format."""
    default = os.path.normpath(args.scene) == os.path.normpath(DEFAULT_SCENE)
    if args.publish and (args.quick or not default or args.out or args.data):
        ap.error("--publish writes the tracked results of the whole study of "
                 f"{DEFAULT_SCENE}: leave out --quick, -options_file, --out and --data")
    if args.check and (args.publish or args.quick or not default):
        ap.error("--check compares the stored data of the whole study of "
                 f"{DEFAULT_SCENE}: leave out --publish, --quick and -options_file")
    args.out = study.destination(ap, args)
    args.data = args.data or (workprecision.DEFAULT if args.publish or args.check
                              else os.path.join(args.out, "work_precision.json"))
    try:
        args.formats = output.figure_formats("png," + args.formats)
    except ValueError as exc:
        ap.error(f"--formats: {exc}")
    return args


def make_runs(args) -> list:
    """The study's runs (``study.Run``, each with its ``series`` and ``variant``), longest
    first."""
    runs = []
    for series, e, cells, ppc, safety, variant in plan(args.quick):
        opts = ["-options_file", args.scene, "-mpm_element", e,
                "-mpm_cells", f"{cells[0]},{cells[1]}", "-mpm_ppc", str(ppc),
                "-mpm_dt_safety", f"{safety:g}", "-mpm_figures", "0",
                "-mpm_Tv_end", "1",
                "-mpm_Tv_report", ",".join(f"{t:g}" for t in REPORT_TV),
                *(VARIANTS[e][variant] if variant else [])]
        name = tag(e, cells, ppc, safety, variant)
        run = study.Run(name, opts, os.path.join(args.runs, name), args.ranks)
        run.series, run.variant = series, variant
        runs.append(run)
    # Longest first, so that two cores finish together.
    runs.sort(key=lambda r: -float(r.args[r.args.index("-mpm_cells") + 1].split(",")[1])
              * (2 if "q4" not in r.name else 1))
    return runs


def dry_run(runs, args) -> None:
    """Print the runs and where the results would go."""
    for run in runs:
        print(f"  {run.name}: {' '.join(run.args)} -> {run.folder}")
    print(f"results: {args.out}\nwork-precision data: {args.data}")


def row_of(run) -> dict:
    """The table row of a finished run: its discretization, cost (points x steps), wall
    time (s) and, when stable, its errors (% at the monitor, L2 of p / q)."""
    s = run.result
    safety = float(run.args[run.args.index("-mpm_dt_safety") + 1])
    row = {"series": run.series, "variant": run.variant, "element": s["element"],
           "cells": s["cells"], "ppc": s["ppc"], "dt_safety": safety, "ranks": run.ranks,
           "n_points": s["n_points"], "steps": s["steps"], "dt": s["dt"],
           "cost": float(s["n_points"]) * s["steps"],
           "wall_seconds": study.wall_seconds(s), "stable": study.stable(s),
           **{k: s[k] for k in SCHEME}}
    if row["stable"]:
        row.update(errors(s))
        mon, deg = s["monitor"], s["consolidation_degree"]
        # Signed compressible-water errors at every report time: the monitor's (%), the
        # profile's L2 (of p / q), U from the settlement and from the pore pressure (%).
        row["by_tv"] = {f"{tv:g}": (e, l2, us, up) for tv, e, l2, us, up in zip(
            mon["Tv"], mon["error_consistent_pct"], s["profile_l2"]["consistent"],
            deg["error_settlement_consistent_pct"], deg["error_pressure_consistent_pct"])}
        row["measure"] = workprecision.measure(s)
        row["worst"] = workprecision.worst(workprecision.errors(s))
    else:
        row["measure"] = math.nan
    return row


def tabulate(runs):
    """The rows of the runs, or None (said on stderr) when one of them failed: a blow-up
    (exit 3) is a result, any other failure is not."""
    rows = []
    for run in runs:
        if run.code not in (0, 3) or run.result is None:
            print(f"error: {run.name}: exit {run.code}: {run.stderr[-300:]}", file=sys.stderr)
            return None
        rows.append(row_of(run))
    return rows


def refinement(rows, e) -> list:
    """The stable runs of element ``e``'s 1-cell-wide refinement series, in ``rows``' order."""
    return [r for r in rows if r["series"] == "refine" and r["element"] == e and r["stable"]]


def fit_orders(rows) -> dict:
    """Observed order of each error of each element over its refinement series."""
    return {e: {k: order(refinement(rows, e), k) for k in ERRORS} for e in PPC}


def scene_of(runs):
    """The scene signature (``summary["scene"]``) of the first stable run with the
    defaults' scheme (a variant's differs in its scheme options), or None."""
    for run in runs:
        if not getattr(run, "variant", "") and run.result and study.stable(run.result):
            return run.result["scene"]
    return None


def work_precision(scene, rows, orders, source) -> dict:
    """The work-precision data -mpm_target_error reads (``--publish``:
    solver/data/work_precision.json): the scene signature its runs share, the error measure
    and what it judges, the report times, the orders and the rows of the runs with the
    scene's own scheme (the defaults), among which it picks."""
    return {"scene": scene, "source": source,
            "measure": workprecision.__doc__.split("The error measure")[1].split("\n\n")[0]
            .strip(),
            "judged": list(workprecision.JUDGED), "Tv": list(REPORT_TV), "orders": orders,
            "runs": [r for r in rows if not r["variant"]]}


def write_data(path, runs, rows, orders, source) -> None:
    """:func:`work_precision` of the study, into ``path``."""
    output.write_json(path, work_precision(scene_of(runs), rows, orders, source))


# --check: the stored data's cheapest runs, made again (about 1.5 s each): Q4 with one point
# per cell and Q9 with the corner projection.
CHECKED = ("q4-1x10-ppc1-dt0.5", "q9-1x5-ppc3-dt0.5")
NOT_COMPARED = ("wall_seconds",)       # the machine's, not the method's


def _same(a, b, where, out) -> None:
    """Append to ``out`` where ``a`` (stored) and ``b`` (made now) differ: numbers within
    1e-6 relative (another CPU's SIMD rounds the last digits otherwise), all else equal."""
    if isinstance(a, dict) and isinstance(b, dict):
        for key in sorted(set(a) | set(b)):
            if key not in a or key not in b:
                out.append(f"{where}{key}: {'missing' if key not in a else 'not made'} "
                           "in the stored file")
            else:
                _same(a[key], b[key], f"{where}{key}.", out)
    elif isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)) and len(a) == len(b):
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}{k}.", out)
    elif isinstance(a, float) and isinstance(b, (int, float)) and not isinstance(b, bool):
        if not (math.isclose(a, b, rel_tol=1e-6, abs_tol=1e-12)
                or math.isnan(a) and math.isnan(b)):
            out.append(f"{where[:-1]}: stored {a!r}, made now {b!r}")
    elif a != b:
        out.append(f"{where[:-1]}: stored {a!r}, made now {b!r}")


def differences(stored: dict, runs) -> list:
    """What is wrong with the stored work-precision data ``stored`` (a dict as
    :func:`workprecision.load` reads it) against ``runs``, the :data:`CHECKED` runs made
    again (finished): one line each, none when they hold. The file must be what
    :func:`work_precision` makes of its own rows and of the scene the runs have now; its rows
    the study's runs with the defaults; each stable row's measure the largest of its errors
    (what the target is compared with), its cost points x steps; and each run made again
    must give its stored row (all but the wall time)."""
    out = []
    rows = stored.get("runs", [])
    _same(stored, work_precision(scene_of(runs), rows, fit_orders(rows), DEFAULT_SCENE), "",
          out)
    named = {tag(r["element"], r["cells"], r["ppc"], r["dt_safety"]): r for r in rows}
    planned = {tag(e, c, k, s) for _, e, c, k, s, v in plan(False) if not v}
    if set(named) != planned:
        out.append(f"runs: stored {sorted(set(named) - planned)} beyond the study's, "
                   f"{sorted(planned - set(named))} of the study missing")
    scales = [scale for _, _, scale in workprecision.JUDGED.values()]
    for name, r in named.items():
        if r.get("cost") != r["n_points"] * r["steps"]:
            out.append(f"{name}: cost {r.get('cost')} is not points x steps")
        if r["stable"]:
            largest = max(abs(s * e) for errs in r["by_tv"].values()
                          for s, e in zip(scales, errs))
            if not math.isclose(r["measure"], largest, rel_tol=1e-12):
                out.append(f"{name}: measure {r['measure']!r} is not the largest of its "
                           f"errors, {largest!r}")
    for run in runs:
        if run.result is None or run.code not in (0, 3):
            out.append(f"{run.name}: the run failed (exit {run.code}): {run.stderr[-300:]}")
        elif run.name not in named:
            out.append(f"{run.name}: not in the stored file")
        else:
            made = {k: v for k, v in row_of(run).items() if k not in NOT_COMPARED}
            mine = {k: v for k, v in named[run.name].items() if k not in NOT_COMPARED}
            _same(mine, json.loads(json.dumps(made)), f"{run.name}: ", out)
    return out


def check(args) -> int:
    """``--check``: the :data:`CHECKED` runs made afresh into ``--runs`` and
    :func:`differences` of ``--data`` against them, said; 0 when the data hold, 1 when
    not, 2 when ``--data`` is no work-precision file."""
    runs = [r for r in make_runs(args) if r.name in CHECKED]
    shown = os.path.relpath(args.data, ROOT) if os.path.abspath(args.data).startswith(
        ROOT + os.sep) else args.data
    print(f"Checking {shown}: {len(runs)} of its runs again "
          f"({', '.join(r.name for r in runs)})", flush=True)
    if args.dry_run:
        dry_run(runs, args)
        return 0
    try:
        stored = workprecision.load(args.data)
    except InputError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    study.execute_all(runs, args.cores, log=lambda m: print(m, flush=True), fresh=True)
    problems = differences(stored, runs)
    for line in problems:
        print("  " + line)
    print(f"{shown}: "
          + (f"{len(problems)} difference(s): make it again with "
             "scripts/convergence-study --publish" if problems else
             f"holds ({len(stored['runs'])} runs; the runs made again give their stored "
             "rows)"))
    return 1 if problems else 0


def main(argv=None):
    args = arguments(argv)
    os.chdir(ROOT)
    if args.check:
        return check(args)
    runs = make_runs(args)
    print(f"Convergence study of {args.scene}: {len(runs)} runs, {args.ranks} rank(s) each",
          flush=True)
    if args.dry_run:
        dry_run(runs, args)
        return 0
    study.execute_all(runs, args.cores, log=lambda m: print(m, flush=True))
    rows = tabulate(runs)
    if rows is None:
        return 1
    orders = fit_orders(rows)
    write_data(args.data, runs, rows, orders, args.scene)
    write_csv(rows, args.out)
    draw(rows, orders, args.out, args.formats)
    print(write_report(rows, orders, args, args.data))
    return 0


def write_csv(rows, out):
    """convergence.csv in ``out``: one line per run (dt in s, wall time in s, monitor errors
    in %, L2 errors of p / q)."""
    keys = ["series", "element", "cells", "ppc", "dt_safety", "ranks", "n_points", "steps",
            "dt", "cost", "wall_seconds", "stable", *ERRORS]
    lines = [",".join(keys)]
    for r in rows:
        lines.append(",".join("x".join(map(str, r[k])) if k == "cells" else
                              str(r.get(k, "")) for k in keys))
    output.write_text(os.path.join(out, "convergence.csv"), "\n".join(lines))


def order_text(p):
    """How a fitted order p reads: 'order 1.02'; 'error stalls' below 0.2, where the error
    hardly falls with the mesh (against classic Terzaghi the model difference stays);
    'not converging' where it grows (p <= 0 is no order of convergence)."""
    if not math.isfinite(p):
        return "one run, no order"
    if p <= 0:
        return "not converging"
    return f"order {p:.2f}" if p >= STALLS else f"error stalls (slope {p:.2f})"


STALLS = 0.2


MARKERS = {"wide": ("s", "wider mesh (2 or 4 cells across)"),
           "ppc": ("^", "other points per cell"), "dt": ("D", "other dt_safety")}
PANELS = [("monitor", ("monitor_classic", "monitor_consistent"),
           "error at the monitor point (%)", "convergence-monitor.png"),
          ("l2", ("l2_classic", "l2_consistent"), "L2 error of p / q over the profile (-)",
           "convergence-l2.png")]
AXES_X = [("wall_seconds", "wall-clock time (s)"),
          ("cost", "cost: material points x steps (-)")]


def _refinement(ax, rows, orders, key, xkey):
    """The 1-cell-wide refinement series of each element, its order in the legend and the
    cells up the column written at its ends (the table has every run)."""
    for e in PPC:
        ser = sorted(refinement(rows, e), key=lambda r: r["cells"][1])
        if not ser:
            continue
        ax.plot([r[xkey] for r in ser], [r[key] for r in ser], "o-", color=COLORS[e],
                label=f"{e.upper()}, 1 x {ser[0]['cells'][1]} to 1 x {ser[-1]['cells'][1]} "
                      f"cells: {order_text(orders[e][key])}")
        for r in (ser[0], ser[-1]) if len(ser) > 1 else ser:
            ax.annotate(f"1x{r['cells'][1]}", (r[xkey], r[key]), fontsize=6,
                        color=COLORS[e], xytext=(4, 4), textcoords="offset points")


def _variants(ax, rows, key, xkey):
    """The other schemes, dashed, and the single runs off the series, hollow markers."""
    for e, variants in VARIANTS.items():
        for v, ls in zip(variants, ("--", ":", "-.")):
            ser = sorted((r for r in rows if r["variant"] == v and r["element"] == e
                          and r["stable"]), key=lambda r: r["cells"][1])
            if ser:
                ax.plot([r[xkey] for r in ser], [r[key] for r in ser],
                        ls + "x" if len(ser) > 1 else "x", color=COLORS[e],
                        label=f"{e.upper()}, {v}", lw=1, ms=6)
    for series, (mk, label) in MARKERS.items():
        pts = [r for r in rows if r["series"] == series and r["stable"]]
        for n, r in enumerate(pts):
            ax.plot(r[xkey], r[key], mk, color=COLORS[r["element"]], mfc="none", ms=7,
                    label=label if n == 0 else None)
            text = (f"{r['cells'][0]}x{r['cells'][1]}" if series == "wide" else
                    f"ppc {r['ppc']}" if series == "ppc" else f"dt x{r['dt_safety']:g}")
            ax.annotate(text, (r[xkey], r[key]), fontsize=6, xytext=(4, -8),
                        textcoords="offset points", color="0.3")


def drop_overlapping(fig):
    """Remove every annotation whose box overlaps one drawn before it, axes by axes (the
    series' ends come first, so they stay); return how many went."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    dropped = 0
    for ax in fig.axes:
        kept = []
        for text in list(ax.texts):
            box = text.get_window_extent(renderer).expanded(1.05, 1.1)
            if any(box.overlaps(k) for k in kept):
                text.remove()
                dropped += 1
            else:
                kept.append(box)
    return dropped


def draw(rows, orders, out, formats=("png",)):
    """convergence-monitor and convergence-l2 in ``out``, in each of ``formats``."""
    plt = output.pyplot()
    for kind, keys, ylabel, name in PANELS:
        fig, axes = plt.subplots(2, 2, figsize=(12, 9))
        for i, key in enumerate(keys):
            ref = "classic Terzaghi" if "classic" in key else "compressible-water Terzaghi"
            for j, (xkey, xlabel) in enumerate(AXES_X):
                ax = axes[i, j]
                _refinement(ax, rows, orders, key, xkey)
                _variants(ax, rows, key, xkey)
                ax.set_xscale("log")
                ax.set_yscale("log")
                ax.set_xlabel(xlabel)
                ax.set_ylabel(f"{ylabel}\nagainst {ref}")
                ax.grid(alpha=0.3, which="both")
        fig.suptitle("Consolidation work-precision (largest error over T_v = 0.5 and 1)")
        # One legend for the four panels, below them: the orders differ by reference, so
        # the lines of each reference's row name them.
        fig.tight_layout(rect=(0, 0.1, 1, 1))
        for i in range(2):
            handles, labels = axes[i, 0].get_legend_handles_labels()
            fig.legend(handles, labels, fontsize=7, ncol=2, frameon=False,
                       loc="lower left" if i == 0 else "lower right",
                       bbox_to_anchor=(0.0, 0.0) if i == 0 else (1.0, 0.0),
                       title=f"against {'classic' if i == 0 else 'compressible-water'} "
                             "Terzaghi", title_fontsize=7)
        drop_overlapping(fig)
        output.save_figure(fig, os.path.join(out, name), formats=formats)


def write_report(rows, orders, args, data_path):
    lines = ["# Convergence study: work against precision", "",
             f"Written by `scripts/convergence-study` (scene `{args.scene}`, "
             f"{args.ranks} rank(s) per run). Errors are the largest over T_v = 0.5 and 1; "
             "'monitor' in percent, 'L2' the volume-weighted RMS of p/q over all points. "
             f"Measured data for `-mpm_target_error`: `{os.path.relpath(data_path, ROOT)}`.",
             "", "![monitor](convergence-monitor.png)", "", "![L2](convergence-l2.png)", "",
             "| run | points | steps | cost | wall (s) | monitor, classic | monitor, "
             "compressible | L2, classic | L2, compressible | compressible at T_v 0.2 / 0.5 "
             "(monitor %, L2) | -mpm_target_error's measure (all of T_v 0.02 - 1) |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in sorted(rows, key=lambda r: r["cost"]):
        name = (f"{r['element'].upper()} {r['cells'][0]}x{r['cells'][1]} ppc {r['ppc']} "
                f"dt x{r['dt_safety']:g}" + (f", {r['variant']}" if r["variant"] else ""))
        if not r["stable"]:
            lines.append(f"| {name} | {r['n_points']} | {r['steps']} | | "
                         f"{r['wall_seconds']:.1f} | blew up | | | | | |")
            continue
        lines.append(f"| {name} | {r['n_points']} | {r['steps']} | {r['cost']:.3g} | "
                     f"{r['wall_seconds']:.1f} | {r['monitor_classic']:.2f} % | "
                     f"{r['monitor_consistent']:.2f} % | {r['l2_classic']:.4f} | "
                     f"{r['l2_consistent']:.4f} | {r['by_tv']['0.2'][0]:+.2f} / "
                     f"{r['by_tv']['0.5'][0]:+.2f} %, {r['by_tv']['0.2'][1]:.4f} / "
                     f"{r['by_tv']['0.5'][1]:.4f} | {r['measure']:.2f} % ({r['worst']}) |")
    lines += ["", "Observed orders (error ~ h^p over the 1-cell-wide refinement series):", "",
              "| element | monitor, classic | monitor, compressible | L2, classic | "
              "L2, compressible |", "|---|---|---|---|---|"]
    for e, o in orders.items():
        lines.append(f"| {e.upper()} | " + " | ".join(
            f"{o[k]:.2f}" if o[k] >= STALLS else order_text(o[k]) for k in ERRORS) + " |")
    text = "\n".join(lines)
    output.write_text(os.path.join(args.out, "convergence.md"), text)
    return text


if __name__ == "__main__":
    sys.exit(main())
