#!/usr/bin/env python3
"""The strip footing's ends of consolidation under refinement (cases/consolidation-strip.opts):
for each grid, the static undrained and final settlements under the load
(solver/references/static.py, KSP), the run's settlement at T_v = 2 against the final one,
and that of the same strip on a clay (k = 1e-9 m/s, no mass scaling: the wave damped out
long before drainage begins) at T_v = 1e-6 against the undrained one.

    scripts/strip-refinement [--cells 8x4,16x8,32x16] [--ranks 1]

Prints a table: cells, points, static undrained and final settlement (mm), their change
from the previous grid (%), the clay's settlement at T_v = 1e-6 and the run's at T_v = 2
(mm) with their errors against the same grid's static ends (%), and the run's wall time.
32 x 16 cells take about 40 s on one core.
"""

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

from solver.studies import study  # noqa: E402

SCENE = os.path.join(ROOT, "cases", "consolidation-strip.opts")


CLAY = ["-mpm_k", "1e-9", "-mpm_mass_scaling", "none", "-mpm_Tv_end", "1e-6",
        "-mpm_Tv_report", "1e-6"]


def run(cells, ranks, folder, extra=()) -> dict:
    """The summary of the scene on ``cells`` ("NXxNY") on ``ranks`` ranks, with the options
    ``extra``."""
    nx, ny = cells.split("x")
    return study.run_afresh(os.path.basename(folder),
                            ["-options_file", SCENE, "-mpm_cells", f"{nx},{ny}",
                             "-mpm_figures", "0", "-mpm_progress", "0", *extra],
                            folder, ranks).result


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", default="8x4,16x8,32x16", help="grids NXxNY, comma-separated")
    ap.add_argument("--ranks", type=int, default=1, help="ranks per run")
    args = ap.parse_args()
    print(f"{'cells':>8s}{'points':>8s}{'undrained':>11s}{'change':>9s}{'final':>9s}"
          f"{'change':>9s}{'clay 1e-6':>11s}{'error':>9s}{'run T_v=2':>11s}{'error':>9s}"
          f"{'wall s':>8s}")
    before = None
    with tempfile.TemporaryDirectory() as tmp:
        for cells in args.cells.split(","):
            s = run(cells, args.ranks, os.path.join(tmp, cells))
            clay = run(cells, args.ranks, os.path.join(tmp, cells + "-clay"), CLAY)
            c = clay["static_references"]
            e = s["static_references"]
            ends = (1e3 * e["undrained_m"], 1e3 * e["final_m"])
            change = ["" if before is None else f"{100 * (a / b - 1):+8.2f}%"
                      for a, b in zip(ends, before or ends)]
            print(f"{cells:>8s}{s['n_points']:8d}{ends[0]:11.5f}{change[0]:>9s}{ends[1]:9.5f}"
                  f"{change[1]:>9s}{1e3 * c['settlement_last_m']:11.5f}"
                  f"{100 * (c['settlement_last_m'] / c['undrained_m'] - 1):+8.2f}%"
                  f"{1e3 * e['settlement_last_m']:11.5f}"
                  f"{e['error_final_pct']:+8.2f}%{study.wall_seconds(s):8.1f}")
            before = ends


if __name__ == "__main__":
    main()
