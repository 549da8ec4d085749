#!/usr/bin/env python3
"""Early-time oscillation of the pore pressure and what each remedy does to it.

Runs the M1-Q4 consolidation scene to T_v = 0.1 with no damping, local damping 0.1 and 0.5
(the default), PIC velocity transfer and a load ramp, then plots p/q at the monitor point
against T_v beside both Terzaghi references. Writes damping.png into
output/studies/damping-figure/ (with --publish into docs/results/, the tracked copy the docs
show) and prints p/q at T_v = 0.02 for each variant.

    .venv/bin/python scripts/damping-figure [-n RANKS] [--publish | --out FOLDER]
"""

import argparse
import csv
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

VARIANTS = [
    ("no damping", ["-mpm_damping", "0"]),
    ("local damping 0.1", ["-mpm_damping", "0.1"]),
    ("local damping 0.5 (the paper's scenes)", ["-mpm_damping", "0.5"]),
    ("PIC transfer, no damping", ["-mpm_damping", "0", "-mpm_flip", "0"]),
    ("load ramp 20 ms, no damping", ["-mpm_damping", "0", "-mpm_load_ramp", "0.02"]),
]

def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-n", type=int, default=1, help="MPI ranks per run (default 1)")
    study.add_destination(ap, "damping-figure", "damping.png")
    args = ap.parse_args()
    target = os.path.join(study.destination(ap, args), "damping.png")
    curves = []
    with tempfile.TemporaryDirectory() as tmp:
        for k, (label, extra) in enumerate(VARIANTS):
            out = os.path.join(tmp, str(k))
            s = study.run_afresh(label, ["-options_file", "cases/consolidation-m1-q4.opts",
                                         "-mpm_Tv_end", "0.1", "-mpm_Tv_report", "0.02,0.1",
                                         "-mpm_figures", "0", "-mpm_progress", "0", *extra],
                                 out, args.n).result
            with open(os.path.join(out, "monitor.csv")) as fh:
                rows = np.array([[float(v) for v in r] for r in list(csv.reader(fh))[1:]])
            curves.append((label, rows, s))
            print(f"{label:32s} p/q(T_v = 0.02) = {s['monitor']['p_over_q'][0]:.3f}  "
                  f"(Terzaghi {s['monitor']['terzaghi'][0]:.3f}, compressible water "
                  f"{s['monitor']['consistent'][0]:.3f})")

    from solver.io import output
    from solver.references import analytic

    plt = output.pyplot()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    for label, rows, _ in curves:
        ax.plot(rows[:, 1], rows[:, 2], lw=0.9, label=label)
    s = curves[0][2]
    depth = 1.0 - s["monitor"]["height"]
    Tv = np.linspace(1e-4, 0.1, 300)
    ax.plot(Tv, analytic.terzaghi(depth, Tv), "k-", lw=1.5, label="Terzaghi")
    ax.plot(Tv, analytic.terzaghi(depth, Tv * s["c2"] / s["c_v"], 1.0,
                                  s["p0_consistent_over_q"]), "k:", lw=1.5,
            label="Terzaghi, compressible water")
    ax.set_xlabel("T_v")
    ax.set_ylabel("p / q at the monitor point (y = 0.475 m)")
    ax.set_title("M1-Q4: undrained wave after the sudden load, and its remedies")
    ax.set_ylim(0, 2.2)
    ax.legend(fontsize=7, ncol=2)
    ax.grid(alpha=0.3)
    output.save_figure(fig, target)
    print("wrote", target)

if __name__ == "__main__":
    main()
