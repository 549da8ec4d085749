#!/usr/bin/env python3
"""Benchmark of the solver: the ratios that can be compared across machines.

    .venv/bin/python scripts/benchmark            # 1e3 .. 1e6 points, Q4 and Q9, 1 and 2 ranks
    .venv/bin/python scripts/benchmark --quick    # up to 1e5 points
    .venv/bin/python scripts/benchmark --sizes 2e5,1e6 --elements q4 --ranks 1,2
    .venv/bin/python scripts/benchmark --paper    # also time scripts/reproduce-paper

The other benchmarks are commands of their own: scripts/footing-benchmark (the implicit
scheme's footing of 1e5 points), scripts/site-benchmark (the site response of
cases/dynamic-layers.opts on one core), scripts/series-benchmark (the point-field series'
outputs) and scripts/step-benchmark (one column, which this command runs for each size).

Prints and writes benchmark.json, benchmark.txt and benchmark.png into
output/studies/benchmark/ (``--publish``: docs/results/, the tracked copy
docs/performance.md shows; ``--out FOLDER`` elsewhere; ``--output PREFIX`` names the files
PREFIX.json, .txt, .png):
- the compilation of the step's kernels (numba): seconds and kernels compiled by a first
  run (an empty cache, ``NUMBA_CACHE_DIR`` pointed at a new folder) and by a second run of
  the same model (it loads them: nothing compiled);
- the explicit two-phase step (the step and the points' migration, as the run calls them)
  in ns per material point per step, for Q4 (2 x 2 points per cell) and Q9 (3 x 3) at about
  1e3, 1e4, 1e5, 2e5 and 1e6 points, on 1 and 2 ranks, with the 2-rank speedup and parallel
  efficiency; the best of ``--repeats`` timed runs, wall time and, beside it, the CPU time
  of the slowest rank (less disturbed by other jobs; the JSON has the medians); and the
  ratio of the previous NumPy step's CPU time to this one's (``--baseline``, default
  docs/results/benchmark-numpy.json: that step's figures);
- the time per step of the paper's smallest and largest consolidation scenes (M1-Q4 with
  40 points, M3-Q4 with 640 points), which is per-step overhead, not per-point work;
- the peak resident memory (ru_maxrss) at the largest size, per material point, in total and
  above a baseline taken right after the imports and the loading of the compiled kernels
  (per-process constants);
- the targets of the compiled step (docs/performance.md), met or missed, by CPU time;
- the Jacobi eigen solver (``scripts/eigen-study --benchmark``) and the whole-paper
  reproduction time (``scripts/reproduce-paper``, with ``--paper``) when those scripts exist.

Each size is the soil column of the paper (Table 2 soil, q = 10 kPa) with square cells,
about ten times as many up as across, chosen to give the point count, measured by
``mpirun -n R scripts/step-benchmark`` in its own process (its docstring says how the model
is built and stepped), so that its peak memory is its own. Timings on a shared machine are
noisy: the load average is recorded before and after, and the best of several repeats is the
figure that compares.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, str(REPO))
    from solver.studies.study import start

    start()

import step_benchmark  # noqa: E402  (scripts/step-benchmark: one column, timed)

from solver.studies import study  # noqa: E402

PAPER_SCENES = {"M1-Q4": (1, 10), "M3-Q4": (4, 40)}
# Targets of the compiled step (docs/performance.md), judged by CPU time (the wall time on a shared
# machine measures the other jobs too): ns per point per step on 1 core for Q4 (goal 60)
# and Q9 from 2e5 points up; 2-rank parallel efficiency at 1e6 points (wall time); us per
# step of the paper scenes; peak bytes per point at 1e6 points above the baseline.
TARGET_Q4_NS, GOAL_Q4_NS, TARGET_Q9_NS = 100.0, 60.0, 250.0
TARGET_EFFICIENCY = 0.85
TARGET_SCENE_US = {"M1-Q4": 10.0, "M3-Q4": 30.0}
TARGET_BYTES = 300.0
BASELINE = REPO / "docs" / "results" / "benchmark-numpy.json"

def cells_for(points: float, ppc: int):
    """Cells (NX, NY) of about ``points`` points, about ten times as many up as across
    (the column is then 0.1 m wide and about 1 m high, with square cells)."""
    cells = points / ppc ** 2
    nx = max(1, round(math.sqrt(cells / 10)))
    return nx, max(2, round(cells / nx))


def launch(cfg: dict, ranks: int, timeout: float, env_extra=None):
    """Run scripts/step-benchmark on the column ``cfg`` with ``ranks`` ranks, at most
    ``timeout`` s: (its figures, None), or (None, why not)."""
    env = dict(study.environment(), **(env_extra or {}))
    cmd = [sys.executable, str(REPO / "scripts" / "step_benchmark.py"),
           *step_benchmark.command(cfg)]
    if ranks > 1:
        mpirun = shutil.which("mpirun")
        if mpirun is None:
            return None, "mpirun not found"
        extra = ["--oversubscribe"] if ranks > (os.cpu_count() or 1) else []
        cmd = [mpirun, "-n", str(ranks), *extra, *cmd]
    try:
        res = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, env=env,
                             cwd=REPO)
    except subprocess.TimeoutExpired:
        return None, f"timed out after {timeout:.0f} s"
    for line in res.stdout.splitlines():
        if line.startswith(step_benchmark.TAG):
            return json.loads(line[len(step_benchmark.TAG):]), None
    tail = (res.stderr.strip().splitlines() or ["(no output)"])[-1]
    return None, f"exit {res.returncode}: {tail}"


def steps_for(points: int, budget: float) -> int:
    """Steps per timed repeat: about ``budget`` point-steps, at least 4, at most 2000."""
    return int(max(4, min(2000, budget // max(points, 1))))


def fmt_ns(v):
    return "-" if v is None else f"{v:,.0f}"


def load_baseline(path):
    """The results of an earlier run (``--baseline``), or None."""
    try:
        with open(path) as fh:
            return json.load(fh)
    except (OSError, ValueError):
        return None


def fmt_ratio(v):
    return "-" if v is None else f"{v:.1f}"


def ratio_step(baseline, row, ranks):
    """CPU time per point-step of the baseline's row of the same cell and about the same
    point count (within 5 %), over this row's; None without one."""
    now = row["by_ranks"].get(str(ranks), {}).get("cpu_ns_per_point_step")
    for old in baseline.get("step", []):
        if old["element"] == row["element"] and abs(old["points"] / row["points"] - 1) < 0.05:
            before = old["by_ranks"].get(str(ranks), {}).get("cpu_ns_per_point_step")
            if before and now:
                return before / now
    return None


def ratio_scene(baseline, name, ranks, cpu_us):
    """The baseline's CPU time per step of scene ``name`` on ``ranks`` ranks over
    ``cpu_us`` (us per step); None without one."""
    for old in baseline.get("scenes", []):
        if old["scene"] == name:
            before = old["by_ranks"].get(str(ranks), {}).get("cpu_us_per_step")
            return before / cpu_us if before else None
    return None
def measure_compile(args, say):
    """Compile time of a first run (an empty numba cache) and of a second (the cache the
    first wrote), both on the Q4 and Q9 paper columns, 1 rank: seconds in MPMCompile and
    the numbers of kernel variants compiled and loaded."""
    import tempfile

    say("\nCompilation of the step's kernels (numba; 1 rank, an empty cache, then the same "
        "cache again):")
    out = {}
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache:
        for element in ("q4", "q9"):
            ppc = 2 if element == "q4" else 3
            cfg = {"element": element, "cells": [1, 10], "size": [0.1, 1.0], "ppc": ppc,
                   "steps": 4, "warmup": 2, "repeats": 1}
            for run in ("first", "second"):
                res, err = launch(cfg, 1, args.timeout, {"NUMBA_CACHE_DIR": cache})
                if res is None:
                    say(f"  {element}, {run} run: failed ({err})")
                    continue
                c = res["compile"]
                out[f"{element}_{run}"] = c
                say(f"  {element.upper()}, {run} run: {c['seconds']:6.2f} s, "
                    f"{c['compiled']} kernels compiled, {c['loaded']} loaded from the cache")
    return out


def targets(result):
    """(text, met) for each target that the measured rows cover."""
    marks = []
    for row in result["step"]:
        one = row["by_ranks"].get("1", {}).get("cpu_ns_per_point_step")
        if one is not None and row["points"] >= 1.5e5:
            limit = TARGET_Q4_NS if row["element"] == "q4" else TARGET_Q9_NS
            goal = f" (goal {GOAL_Q4_NS:.0f})" if row["element"] == "q4" else ""
            marks.append((f"{row['element'].upper()} {row['points']:,} points, 1 core: "
                          f"{one:,.0f} ns/point/step <= {limit:.0f}{goal}", one <= limit))
        if row.get("efficiency") is not None and row["points"] >= 5e5:
            marks.append((f"{row['element'].upper()} {row['points']:,} points: 2-rank "
                          f"efficiency {row['efficiency']:.2f} >= {TARGET_EFFICIENCY}",
                          row["efficiency"] >= TARGET_EFFICIENCY))
    for row in result["scenes"]:
        us = row["by_ranks"].get("1", {}).get("cpu_us_per_step")
        if us is not None and row["scene"] in TARGET_SCENE_US:
            limit = TARGET_SCENE_US[row["scene"]]
            marks.append((f"{row['scene']} ({row['points']} points), 1 rank: {us:.1f} "
                          f"us/step <= {limit:.0f}", us <= limit))
    for m in result["memory"] or []:
        if m["element"] == "q4" and m["points"] >= 5e5 and m["ranks"] == 1:
            marks.append((f"Q4 {m['points']:,} points, 1 rank: "
                          f"{m['bytes_per_point_above_baseline']:.0f} bytes/point above the "
                          f"baseline ({m['bytes_per_point']:.0f} in total) <= "
                          f"{TARGET_BYTES:.0f}",
                          m["bytes_per_point_above_baseline"] <= TARGET_BYTES))
    return marks


def arguments(argv=None):
    """The parser and the parsed command line."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0],
                                 formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="sizes up to 1e5 points only")
    ap.add_argument("--sizes",
                    help="comma-separated point counts (default 1e3,1e4,1e5,2e5,1e6)")
    ap.add_argument("--elements", default="q4,q9", help="cells to time (default q4,q9)")
    ap.add_argument("--ranks", default="1,2", help="rank counts (default 1,2)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per case (best counts)")
    ap.add_argument("--budget", type=float, default=4e6,
                    help="point-steps per timed run (sets the steps per run, 4 to 2000)")
    ap.add_argument("--no-scenes", action="store_true", help="skip the paper-scene overhead")
    ap.add_argument("--no-compile", action="store_true",
                    help="skip the first-run compilation measurement")
    ap.add_argument("--baseline", default=str(BASELINE),
                    help="JSON of an earlier run to compare with (default: the NumPy step's)")
    ap.add_argument("--no-jacobi", action="store_true", help="skip scripts/eigen-study")
    ap.add_argument("--paper", action="store_true", help="time scripts/reproduce-paper")
    ap.add_argument("--paper-args", default="", help="arguments for scripts/reproduce-paper")
    ap.add_argument("--timeout", type=float, default=3600.0, help="seconds per measurement")
    study.add_destination(ap, "benchmark", "benchmark.json, .txt and .png")
    ap.add_argument("--output", default=None,
                    help="prefix of the .json/.txt/.png results, in place of --out and "
                         "--publish ('' to write none)")
    return ap, ap.parse_args(argv)


def plan(args):
    """The point counts, cell types and rank counts to measure."""
    sizes = [float(s) for s in args.sizes.split(",")] if args.sizes else \
        ([1e3, 1e4, 1e5] if args.quick else [1e3, 1e4, 1e5, 2e5, 1e6])
    elements = [e.strip() for e in args.elements.split(",") if e.strip()]
    ranks = [int(r) for r in args.ranks.split(",")]
    return sizes, elements, ranks


def start(args, say):
    """The results to fill (machine, command) and the baseline to compare with (or None),
    both announced."""
    machine = study.machine()
    say(f"Machine: {machine['nproc']} cores, {machine['cpu']}; load average "
        f"{machine['load_before']} at the start ({machine['date']})")
    result = {"machine": machine, "command": " ".join([Path(sys.argv[0]).name, *sys.argv[1:]]),
              "step": [], "scenes": [], "memory": None}
    baseline = load_baseline(args.baseline)
    if baseline:
        say(f"Compared with: {args.baseline} ({baseline['machine'].get('date', '?')}, "
            f"load {baseline['machine'].get('load_before')}), CPU-time ratios 'x before'")
    return result, baseline


def step_figures(res: dict, steps: int, npts: int) -> dict:
    """scripts/step-benchmark's figures ``res`` per point and step (ns), and the time of a
    report time in steps."""
    t = sorted(res["times_s"])
    return {"ns_per_point_step": t[0] / steps / npts * 1e9,
            "ns_per_point_step_median": t[len(t) // 2] / steps / npts * 1e9,
            "cpu_ns_per_point_step": min(res["cpu_s"]) / steps / npts * 1e9,
            "times_s": res["times_s"], "cpu_s": res["cpu_s"], "dt": res["dt"],
            "finite": res["finite"], "peak_rss_bytes": res["peak_rss_bytes"],
            "base_rss_bytes": res["base_rss_bytes"], "setup_s": res["setup_s"],
            "import_rss_bytes": res.get("import_rss_bytes"), "report_s": res["report_s"],
            "report_steps": res["report_s"][-1] / (t[0] / steps)}


def two_rank_columns(row: dict) -> str:
    """Speedup, efficiency and ns x core on 2 ranks, into ``row`` and as table columns
    (empty without both a 1-rank and a 2-rank figure)."""
    one, two = row["by_ranks"].get("1", {}), row["by_ranks"].get("2", {})
    if "ns_per_point_step" not in one or "ns_per_point_step" not in two:
        return ""
    sp = one["ns_per_point_step"] / two["ns_per_point_step"]
    row.update(speedup=sp, efficiency=sp / 2,
               ns_per_point_step_core_2ranks=2 * two["ns_per_point_step"])
    return f"{sp:9.2f}{sp / 2:8.2f}{2 * two['ns_per_point_step']:9,.0f}"


def measure_step_row(element: str, size: float, ranks, args, baseline, say) -> dict:
    """The explicit step of the column of cell ``element`` with about ``size`` points on
    each rank count: its row of results, and its line of the table."""
    ppc = 2 if element == "q4" else 3
    nx, ny = cells_for(size, ppc)
    npts = nx * ny * ppc * ppc
    steps = steps_for(npts, args.budget)
    cfg = {"element": element, "cells": [nx, ny], "size": [0.1, 0.1 * ny / nx],
           "ppc": ppc, "steps": steps, "warmup": max(2, min(20, steps // 10)),
           "repeats": args.repeats}
    row = {"element": element, "points": npts, "cells": [nx, ny], "steps": steps,
           "by_ranks": {}}
    cells = []
    for r in ranks:
        res, err = launch(cfg, r, args.timeout)
        if res is None:
            row["by_ranks"][str(r)] = {"error": err}
            cells.append(f"{'failed':>22}")
            say(f"  ({element}, {npts} points, {r} ranks: {err})")
            continue
        m = row["by_ranks"][str(r)] = step_figures(res, steps, npts)
        cells.append(f"{fmt_ns(m['ns_per_point_step']):>12} "
                     f"({fmt_ns(m['cpu_ns_per_point_step']):>7})")
    extra = two_rank_columns(row)
    if baseline:
        extra += "".join(f"{fmt_ratio(ratio_step(baseline, row, r)):>15}" for r in ranks)
    say(f"{element:<5}{npts:>10,}{steps:>7}" + "".join(cells) + extra)
    return row


def measure_steps(args, sizes, elements, ranks, baseline, say) -> list:
    """The explicit step, ns per point per step, for every cell type and size: the rows."""
    say("\nExplicit two-phase step (the step and the points' migration), ns per material "
        f"point per step: wall time, best of {args.repeats} (CPU time of the slowest rank, "
        "best)")
    say(f"{'cell':<5}{'points':>10}{'steps':>7}" + "".join(f"{f'{r} rank(s)':>22}" for r in ranks)
        + (f"{'speedup':>9}{'effic.':>8}{'ns*core':>9}" if 2 in ranks and 1 in ranks else "")
        + ("".join(f"{f'x before ({r})':>15}" for r in ranks) if baseline else ""))
    return [measure_step_row(element, size, ranks, args, baseline, say)
            for element in elements for size in sizes]


def say_report_times(rows, say) -> None:
    """The cost of a report time, in steps, of the rows from 5e5 points up."""
    say("\nA report time (profile gathered, monitor, both references' L2 errors), in steps "
        "of the same run (first and second report):")
    for row in rows:
        for r, res in row["by_ranks"].items():
            if "report_s" in res and row["points"] >= 5e5:
                first, later = res["report_s"]
                say(f"  {row['element'].upper()} {row['points']:,} points, {r} rank(s): "
                    f"{first * 1e3:.0f} ms, then {later * 1e3:.0f} ms = "
                    f"{res['report_steps']:.2f} steps")


def scene_cell(row: dict, cfg: dict, r: int, args, baseline) -> str:
    """Time paper scene ``row`` on ``r`` ranks: its figures (us per step) into ``row``, and
    its part of the table line."""
    res, err = launch(cfg, r, args.timeout)
    if res is None:
        row["by_ranks"][str(r)] = {"error": err}
        return f"{r} rank(s): failed ({err})"
    steps = cfg["steps"]
    t = sorted(res["times_s"])
    best, med = t[0] / steps * 1e6, t[len(t) // 2] / steps * 1e6
    cpu = min(res["cpu_s"]) / steps * 1e6
    row["by_ranks"][str(r)] = {"us_per_step": best, "us_per_step_median": med,
                               "cpu_us_per_step": cpu, "times_s": res["times_s"],
                               "cpu_s": res["cpu_s"]}
    before = ratio_scene(baseline, row["scene"], r, cpu) if baseline else None
    return (f"{r} rank(s): {best:7.1f} ({cpu:7.1f})"
            + (f", x {fmt_ratio(before)} before" if baseline else ""))


def measure_scenes(args, ranks, baseline, say) -> list:
    """The paper's scenes, time per step (per-step overhead, not per-point work): the rows."""
    say("\nPaper scenes (Q4, 2 x 2 points per cell), microseconds per step: wall, "
        f"best of {args.repeats} (CPU)")
    rows = []
    for name, (nx, ny) in PAPER_SCENES.items():
        cfg = {"element": "q4", "cells": [nx, ny], "size": [0.1, 1.0], "ppc": 2,
               "steps": 2000, "warmup": 200, "repeats": args.repeats}
        row = {"scene": name, "points": nx * ny * 4, "by_ranks": {}}
        cells = [scene_cell(row, cfg, r, args, baseline) for r in ranks]
        say(f"  {name} ({row['points']} points): " + ";  ".join(cells))
        rows.append(row)
    return rows


def largest_rows(rows) -> list:
    """The row of the most points of each cell type."""
    largest = {}
    for row in rows:
        if row["points"] > largest.get(row["element"], {"points": -1})["points"]:
            largest[row["element"]] = row
    return list(largest.values())


def memory_entry(row: dict, r: str, m: dict) -> dict:
    """Peak memory of ``row`` on ``r`` ranks: bytes per point in total and above the
    baseline, and the compiled kernels' share of the baseline (MiB; None if unknown)."""
    kern = (m["base_rss_bytes"] - m["import_rss_bytes"]) / 2 ** 20 \
        if m.get("import_rss_bytes") else None
    return {"element": row["element"], "points": row["points"], "ranks": int(r),
            "bytes_per_point": m["peak_rss_bytes"] / row["points"],
            "bytes_per_point_above_baseline":
                (m["peak_rss_bytes"] - m["base_rss_bytes"]) / row["points"],
            "peak_rss_bytes": m["peak_rss_bytes"], "base_rss_bytes": m["base_rss_bytes"],
            "compiled_kernels_mib": kern}


def measure_memory(step_rows, say):
    """Peak resident memory at the largest size of each cell type: the entries, or None
    when no size was measured."""
    big = largest_rows(step_rows)
    if not big:
        return None
    say("\nPeak resident memory (ru_maxrss, summed over ranks) at the largest size, "
        "bytes per material point: total / above the baseline (after the imports and the "
        "loading of the compiled kernels)")
    mem = []
    for row in big:
        for r, m in row["by_ranks"].items():
            if "peak_rss_bytes" not in m:
                continue
            e = memory_entry(row, r, m)
            mem.append(e)
            kern = e["compiled_kernels_mib"]
            say(f"  {row['element']}, {row['points']:,} points, {r} rank(s): "
                f"{e['bytes_per_point']:7.0f} / {e['bytes_per_point_above_baseline']:7.0f}"
                + (f"  (the compiled kernels: {kern:.0f} MiB of the baseline)"
                   if kern is not None else ""))
    return mem


def judge_targets(result, say) -> list:
    """The targets the results cover, met or missed (by CPU time; the efficiency by wall
    time), announced and as entries."""
    marks = targets(result)
    if marks:
        say("\nTargets (CPU time; efficiency by wall time):")
        for text, ok in marks:
            say(f"  [{'met' if ok else 'MISSED'}] {text}")
    return [{"target": t, "met": ok} for t, ok in marks]


def measure_jacobi(args, say) -> dict:
    """scripts/eigen-study --benchmark, unless --no-jacobi."""
    say("\nJacobi eigen solver (scripts/eigen-study --benchmark):")
    if args.no_jacobi:
        say("  skipped (--no-jacobi)")
        return {"status": "skipped (--no-jacobi)"}
    jacobi = study.run_script("eigen-study", ["--benchmark"], args.timeout)
    if jacobi["status"] == "missing":
        say("  scripts/eigen-study is missing: no Jacobi figures")
    else:
        say(f"  {jacobi['status']}, {jacobi.get('wall_seconds', 0):.1f} s")
        for text in jacobi.get("stdout", "").rstrip().splitlines():
            say("  | " + text)
    return jacobi


def measure_paper(args, say) -> dict:
    """The wall time of scripts/reproduce-paper, with --paper (at least 6 hours allowed)."""
    say("\nWhole-paper reproduction (scripts/reproduce-paper):")
    if not args.paper:
        say("  skipped (give --paper to time it)")
        return {"status": "skipped (no --paper)"}
    paper = study.run_script("reproduce-paper", args.paper_args.split(),
                         max(args.timeout, 6 * 3600))
    if paper["status"] == "missing":
        say("  scripts/reproduce-paper is missing: skipped")
    else:
        say(f"  {paper['status']}: {paper.get('wall_seconds', 0):.0f} s wall")
    return paper


def write_results(result, lines, prefix: str) -> None:
    """PREFIX.json (the results), .txt (the report) and .png (the chart)."""
    study.write_results(prefix, result, lines)
    _plot(result, prefix + ".png")
    print(f"\nWrote {prefix}.json, .txt, .png")


def main(argv=None) -> int:
    ap, args = arguments(argv)
    if args.output is None:
        args.output = os.path.join(study.destination(ap, args), "benchmark")
    sizes, elements, ranks = plan(args)
    say = study.Transcript()
    result, baseline = start(args, say)
    if not args.no_compile:
        result["compile"] = measure_compile(args, say)
    result["step"] = measure_steps(args, sizes, elements, ranks, baseline, say)
    say_report_times(result["step"], say)
    if not args.no_scenes:
        result["scenes"] = measure_scenes(args, ranks, baseline, say)
    result["memory"] = measure_memory(result["step"], say)
    result["targets"] = judge_targets(result, say)
    result["jacobi"] = measure_jacobi(args, say)
    result["paper"] = measure_paper(args, say)
    result["machine"]["load_after"] = study.load_average()
    say(f"\nLoad average at the end: {result['machine']['load_after']}")
    if args.output:
        write_results(result, say.lines, str(Path(args.output)))
    return 0


def _plot(result, path):
    """ns per point per step against the point count, one line per cell and rank count."""
    from solver.io import output

    plt = output.pyplot()
    fig, ax = plt.subplots(figsize=(6, 4))
    series = {}
    for row in result["step"]:
        for r, m in row["by_ranks"].items():
            if "ns_per_point_step" in m:
                series.setdefault((row["element"], r), []).append(
                    (row["points"], m["ns_per_point_step"] * int(r)))
    for (element, r), pts in sorted(series.items()):
        pts.sort()
        ax.loglog([a for a, _ in pts], [b for _, b in pts], "o-" if r == "1" else "s--",
                  label=f"{element.upper()}, {r} rank(s)")
    ax.axhline(TARGET_Q4_NS, color="k", lw=0.8, ls=":", label="target: Q4 100 ns, 1 core")
    ax.axhline(TARGET_Q9_NS, color="k", lw=0.8, ls="--", label="target: Q9 250 ns, 1 core")
    ax.set_xlabel("material points")
    ax.set_ylabel("ns per point per step x ranks (core time)")
    ax.set_title("Explicit two-phase step")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=7)
    fig.tight_layout()
    output.save_figure(fig, path, dpi=110)


if __name__ == "__main__":
    sys.exit(main())
