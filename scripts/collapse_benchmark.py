#!/usr/bin/env python3
"""The large-deformation benchmark: cases/collapse-bui.opts at its published resolution
(2.5 mm cells, 2 x 2 points, 12,800 points) run to rest on 2 ranks, against its target: at
most 60 s for the whole command; beside it the small-strain explicit two-phase step on the
same number of points and ranks.

    .venv/bin/python scripts/collapse-benchmark                  # 1 timed run
    .venv/bin/python scripts/collapse-benchmark --repeats 3 --publish

Each run is ``mpirun -n 2 python -m solver -options_file cases/collapse-bui.opts
-mpm_figures 0 -mpm_progress 0``, made afresh into a temporary folder (a timed run never
reuses a stored result) and timed whole: start-up, the steps to rest, the outputs. Its
point updates per second are the points times the steps over its stepping phase's wall
time. Beside it, ``scripts/step-benchmark`` on a Q4 column of the same number of points
(2 x 2 per cell) on the same ranks: the explicit two-phase step of the consolidation and
dynamic analyses (its best of 3 runs of 100 steps). Prints a table and writes
collapse-benchmark.json and .txt into output/studies/benchmark/ (``--publish``:
docs/results/; ``--out FOLDER`` elsewhere).
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import tempfile

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import benchmark  # noqa: E402  (scripts/benchmark: launch scripts/step-benchmark)

from solver.studies import study  # noqa: E402

SCENE = "cases/collapse-bui.opts"
TARGET_S = 60.0
RANKS = 2
QUIET = ["-mpm_figures", "0", "-mpm_progress", "0"]


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0].replace("\n", " "))
    ap.add_argument("--repeats", type=int, default=1, help="timed runs (the best counts)")
    study.add_destination(ap, "benchmark", "collapse-benchmark.json and .txt")
    args = ap.parse_args(argv)
    args.out = study.destination(ap, args)
    return args


def measure(repeats: int) -> dict:
    if shutil.which("mpirun") is None:
        raise SystemExit("collapse-benchmark: mpirun not found (the benchmark runs on 2 ranks)")
    with tempfile.TemporaryDirectory(prefix="collapse-benchmark-") as tmp:
        runs = [study.run_afresh(f"collapse, run {k + 1}", ["-options_file", SCENE, *QUIET],
                                 os.path.join(tmp, f"run-{k}"), ranks=RANKS,
                                 log=lambda m: print(m, flush=True))
                for k in range(repeats)]
    best = min(runs, key=lambda r: r.seconds)
    s = best.result
    points, steps = s["points"], s["steps"]
    stepping = s["wall"]["stepping_s"]
    step, why = benchmark.launch({"element": "q4", "cells": [40, 80], "size": [0.1, 0.2],
                                  "ppc": 2, "steps": 100, "warmup": 10, "repeats": 3},
                                 RANKS, timeout=600)
    small = None if step is None else {
        "points": step["points"], "ranks": step["ranks"],
        "ns_per_point_step": min(step["times_s"]) / step["steps"] / step["points"] * 1e9}
    return {"scene": SCENE, "ranks": RANKS, "points": points, "steps": steps,
            "t_final_s": s["t_final_s"], "seconds": [r.seconds for r in runs],
            "best_s": best.seconds, "target_s": TARGET_S, "met": best.seconds <= TARGET_S,
            "stepping_s": stepping,
            "ns_per_point_step": stepping / (points * steps) * 1e9,
            "point_updates_per_s": points * steps / stepping,
            "small_strain_step": small, "small_strain_why_not": why,
            "toe_m": s["toe_m"], "experiment": s.get("experiment"),
            "load_average": study.load_average()}


def text(r) -> str:
    small = r["small_strain_step"]
    e = r["experiment"] or {}
    return "\n".join([
        f"Collapse benchmark: {r['scene']}, {r['points']:,} points, {r['ranks']} ranks, to "
        f"rest at t = {r['t_final_s']:.3g} s in {r['steps']:,} steps",
        f"  whole command, best of {len(r['seconds'])}: {r['best_s']:.1f} s (runs "
        + ", ".join(f"{s:.1f}" for s in r["seconds"]) + f"); target {r['target_s']:g} s: "
        + ("met" if r["met"] else "NOT met"),
        f"  stepping {r['stepping_s']:.1f} s: {r['point_updates_per_s'] / 1e6:.2f} million "
        f"point updates per second ({r['ns_per_point_step']:.0f} ns per point and step, "
        f"{r['ranks']} ranks)",
        (f"  the small-strain explicit two-phase step, Q4 40 x 80 cells, {small['points']:,} "
         f"points, {small['ranks']} ranks: {small['ns_per_point_step']:.0f} ns per point "
         f"and step ({1e3 / small['ns_per_point_step']:.2f} million updates per second)"
         if small else f"  the small-strain step: not measured ({r['small_strain_why_not']})"),
        f"  toe {r['toe_m']:.4g} m, surface RMS {1e3 * e.get('surface_rms_m', float('nan')):.2f}"
        " mm against the experiment",
        f"  load average {', '.join(f'{x:.2f}' for x in r['load_average'])}"])


def main(argv=None) -> int:
    args = arguments(argv)
    result = measure(args.repeats)
    report = text(result)
    print(report)
    json_path, _ = study.write_results(os.path.join(args.out, "collapse-benchmark"), result,
                                       report.splitlines())
    print(f"Wrote {json_path} and .txt")
    return 0 if result["met"] else 1


if __name__ == "__main__":
    sys.exit(main())
