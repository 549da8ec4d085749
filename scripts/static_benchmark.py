#!/usr/bin/env python3
"""The static benchmark: the Tresca footing of cases/footing-tresca.opts (Q9 cells, 3 x 3
points) refined to at least 25,000 material points and pushed to failure on 2 ranks, timed
whole against its target (at most 60 s), with its Newton iterations and bearing capacity;
then the same at 100,000 points.

    .venv/bin/python scripts/static-benchmark                 # 25k and 100k points
    .venv/bin/python scripts/static-benchmark --sizes 25000 --publish

Each run is ``python -m solver -options_file cases/footing-tresca.opts -mpm_cells NX,NY
-mpm_figures 0`` on ``--ranks`` ranks (``solver.studies.study.run_afresh``: made afresh into a
temporary folder, timed whole). Prints a table and writes static-benchmark.json and .txt
into output/studies/benchmark/ (``--publish``: docs/results/; ``--out FOLDER`` elsewhere).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import tempfile

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

from solver.studies import study  # noqa: E402

SCENE = "cases/footing-tresca.opts"
TARGET_S = 60.0            # for 25,000 points on 2 ranks
POINTS_PER_CELL = 9        # the scene's Q9 cells with 3 x 3 points


def cells_for(points: int) -> tuple:
    """The scene's grid (twice as wide as deep, as it is) with at least ``points`` points,
    the footing's edge (x = 0.5 m of 4 m) on a cell boundary: NX a multiple of 8."""
    ny = 4 * math.ceil(math.sqrt(points / POINTS_PER_CELL / 2) / 4)
    return 2 * ny, ny


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="25000,100000", help="material points, comma-separated")
    ap.add_argument("--ranks", type=int, default=2, help="ranks per run")
    study.add_destination(ap, "benchmark", "static-benchmark.json and .txt")
    args = ap.parse_args(argv)
    args.out = study.destination(ap, args)
    return args


def measure(sizes, ranks) -> dict:
    rows = []
    with tempfile.TemporaryDirectory(prefix="static-benchmark-") as tmp:
        for size in sizes:
            nx, ny = cells_for(size)
            done = study.run_afresh(f"static benchmark, {size} points",
                                    ["-options_file", SCENE, "-mpm_cells", f"{nx},{ny}",
                                     "-mpm_figures", "0"], os.path.join(tmp, str(size)),
                                    ranks, log=lambda m: print(m, flush=True))
            s = done.result          # the summary, head and block flattened
            rows.append({"points": s["n_points"], "cells": [nx, ny], "ranks": ranks,
                         "seconds": done.seconds, "steps": len(s["newton_iterations"]),
                         "newton_iterations": sum(s["newton_iterations"]),
                         "bearing_capacity_pa": s["bearing_capacity_pa"],
                         "error_pct": s["error_pct"]})
    first = rows[0]
    return {"scene": SCENE, "target_s": TARGET_S, "runs": rows,
            "met": first["points"] >= 25000 and first["seconds"] <= TARGET_S,
            "load_average": study.load_average()}


def text(r) -> str:
    lines = [f"Static benchmark: {r['scene']} pushed to failure; target: 25,000 points on 2 "
             f"ranks in at most {r['target_s']:g} s: " + ("met" if r["met"] else "NOT met")]
    for row in r["runs"]:
        lines.append(f"  {row['points']:>7d} points (Q9 {row['cells'][0]} x {row['cells'][1]}), "
                     f"{row['ranks']} ranks: {row['seconds']:.1f} s, {row['steps']} steps, "
                     f"{row['newton_iterations']} Newton iterations, bearing capacity "
                     f"{row['bearing_capacity_pa']:.6g} Pa ({row['error_pct']:+.2f} % of Prandtl)")
    lines.append(f"  load average {', '.join(f'{x:.2f}' for x in r['load_average'])}")
    return "\n".join(lines)


def main(argv=None) -> int:
    args = arguments(argv)
    result = measure([int(x) for x in args.sizes.split(",")], args.ranks)
    report = text(result)
    print(report)
    json_path, _ = study.write_results(os.path.join(args.out, "static-benchmark"), result,
                                       report.splitlines())
    print(f"Wrote {json_path} and .txt")
    return 0 if result["met"] else 1


if __name__ == "__main__":
    sys.exit(main())
