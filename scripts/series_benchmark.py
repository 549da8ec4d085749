#!/usr/bin/env python3
"""The cost of one output of the point-field series (points.xdmf + points_<step>.h5) against
the number of outputs before it.

    .venv/bin/python scripts/series-benchmark [--outputs 10000] [--points 40] [--whole]

Writes --outputs times of a body of --points points with the seven fields a consolidation
run writes (output.XdmfSeries, as the run does) into a temporary folder, and prints the
wall time and the bytes written to the index per block of a tenth of the outputs: flat when
each output appends its entry to the index. --whole rewrites the index whole after every
output instead, as the solver did before (its time per output grows with the
outputs). Writes nothing that stays; times depend on the disk and on what else runs.
"""

import argparse
import os
import sys
import tempfile
import time

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

from solver.io import output  # noqa: E402

FIELDS = {"displacement": 3, "velocity_solid": 3, "velocity_liquid": 3, "pore_pressure": 1,
          "effective_stress_xx": 1, "effective_stress_yy": 1, "effective_stress_xy": 1}


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--outputs", type=int, default=10000, help="outputs to write (default "
                    "10000)")
    ap.add_argument("--points", type=int, default=40, help="points of the body (default 40, "
                    "M1-Q4's)")
    ap.add_argument("--whole", action="store_true", help="rewrite the index whole after "
                    "every output (the former way) instead of appending to it")
    return ap.parse_args(argv)


def main(argv=None):
    args = arguments(argv)
    rng = np.random.default_rng(1)
    xy = rng.random((args.points, 2))
    fields = {k: rng.random((args.points, c)).squeeze() for k, c in FIELDS.items()}
    block = max(1, args.outputs // 10)
    print(f"{args.outputs} outputs of {args.points} points, index "
          f"{'rewritten whole' if args.whole else 'appended'}; per block of {block}:")
    print(f"{'outputs':>13s}{'ms per output':>15s}{'index bytes per output':>24s}")
    with tempfile.TemporaryDirectory(prefix="series-benchmark-") as folder:
        path = os.path.join(folder, "points.xdmf")
        series = output.XdmfSeries(path, run_id="benchmark")
        t0, written = time.perf_counter(), 0
        for k in range(args.outputs):
            if args.whole:
                series._appending = False        # the former way: the whole index each time
            before = os.path.getsize(path) if k else 0
            series.write(k, 1e-3 * k, xy, fields)
            # Bytes written: the whole file when rewritten, else what it grew by and the
            # closing tags written again.
            after = os.path.getsize(path)
            written += after if (args.whole or k == 0) else \
                after - before + len(output._XDMF_TAIL)
            if (k + 1) % block == 0:
                now = time.perf_counter()
                print(f"{k + 2 - block:>6d}-{k + 1:<6d}{1e3 * (now - t0) / block:15.3f}"
                      f"{written / block:24.0f}")
                t0, written = now, 0


if __name__ == "__main__":
    main()
