#!/usr/bin/env python3
"""Convergence of the finite-element Biot reference (solver/references/biot.py) on the block
drained through its sides, the scene of tests/test_biot.py: W = H = 1.2 m, E 8e6 Pa, nu 0.2,
n 0.4, k 2e-4 m/s, K_l 1.2e8 Pa, rho_l 1000 kg/m3, q 15 kPa on the whole top, drained left
and right, rollers on the sides, fixed base; p on a 9 x 9 lattice of points and the mean
settlement at T = c_v t / H^2 = 0.05, 0.2, 0.5 (classic c_v = k E_c / gamma_w).

    scripts/biot-convergence [--element q9] [--cells 8,16,32,64] [--steps 8,16,32,64]

Prints, for refinement in space (cells per side, at 16 steps per doubling of time) and in
time (steps per doubling, on 16 x 16 cells), max |dp| / q and |ds| / s_inf between
successive levels at each T, and the observed order log2 of the ratio of successive
differences. Serial, a few tens of seconds (64 x 64 cells about a minute).
"""

import argparse
import os
import sys

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402
from petsc4py import PETSc  # noqa: E402

from solver.model.soil import G_REF, constrained_modulus  # noqa: E402
from solver.references import analytic, biot  # noqa: E402

TV = np.array([0.05, 0.2, 0.5])
Q = 15e3


def run(element, cells, steps):
    """p / q (T, points) and settlement / s_inf (T,) of the block."""
    body = biot.Body(size=(1.2, 1.2), E=8e6, nu=0.2, k=2e-4, porosity=0.4, K_l=1.2e8,
                     rho_l=1000.0, load=Q, drained=("left", "right"))
    c_v = analytic.consolidation_coefficient(2e-4, constrained_modulus(8e6, 0.2),
                                             1000.0 * G_REF)
    g = np.linspace(0.0, 1.2, 9)
    X, Y = np.meshgrid(g, g)
    r = biot.solve(PETSc.COMM_SELF, body, TV * 1.2**2 / c_v,
                   np.stack([X.ravel(), Y.ravel()], -1), cells=(cells, cells),
                   element=element, steps=steps)
    return r.pressure / Q, r.settlement / r.drained


def table(label, levels, runs):
    PETSc.Sys.Print(f"\n{label}: max |dp| / q and |ds| / s_inf between levels, "
                    f"at T = {', '.join(f'{t:g}' for t in TV)}")
    prev = None
    for (a, b), (ra, rb) in zip(zip(levels[:-1], levels[1:]), zip(runs[:-1], runs[1:])):
        dp = np.abs(ra[0] - rb[0]).max(axis=1)
        ds = np.abs(ra[1] - rb[1])
        order = "" if prev is None else "  order p " + " ".join(
            f"{v:.2f}" for v in np.log2(prev[0] / dp)) + ", s " + " ".join(
            f"{v:.2f}" for v in np.log2(prev[1] / ds))
        PETSc.Sys.Print(f"  {a:>3} -> {b:<3} dp " + " ".join(f"{v:.2e}" for v in dp)
                        + "  ds " + " ".join(f"{v:.2e}" for v in ds) + order)
        prev = (dp, ds)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--element", default="q9", choices=biot.ELEMENTS,
                    help="Taylor-Hood cells: q9 (Q9/Q4, the default) or q8 (Q8/Q4)")
    ap.add_argument("--cells", default="8,16,32,64", help="cells per side, comma-separated")
    ap.add_argument("--steps", default="8,16,32,64", help="steps per doubling of time")
    args = ap.parse_args()
    cells = [int(c) for c in args.cells.split(",")]
    steps = [int(s) for s in args.steps.split(",")]
    table(f"space ({args.element}, cells per side, 16 steps per doubling)", cells,
          [run(args.element, c, 16) for c in cells])
    table(f"time (steps per doubling, {args.element} 16 x 16)", steps,
          [run(args.element, 16, s) for s in steps])


if __name__ == "__main__":
    main()
