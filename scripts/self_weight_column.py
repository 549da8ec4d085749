#!/usr/bin/env python3
"""The self-weight column of large deformation: an elastic column (nu = 0, one cell wide,
rollers on its sides, a fixed floor) under its own weight, its foot shortened by 30 %, on
the hat functions of standard MPM, uGIMP and quadratic B-splines (solver/model/lattice.py,
solver/stepping/flow.py), against the exact Cauchy stress -rho0 g (l0 - Y) at each point's
material height Y.

    scripts/self-weight-column [--cells 4,8,16,32] [--ppc 2,4] [--kinds linear,gimp,bspline]

Prints, per grid function and points per cell direction, the RMS and the largest stress
error over the points (in rho0 g l0) on each grid, and the observed order of the RMS
between successive grids. Serial; about three minutes with the defaults.
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

from solver.materials.model import Elastic  # noqa: E402
from solver.model import lattice  # noqa: E402
from solver.stepping.flow import Flow  # noqa: E402


def column(kind, cells, ppc=4, l0=1.0, rho=1000.0, g=10.0, lam=0.7):
    """The column of height l0 (m) and density rho (kg/m3) on ``cells`` cells of grid
    functions ``kind`` with ppc x ppc points each, E = rho g l0 lam / -ln(lam) (Hencky in
    uniaxial strain: the foot shortens to lam), gravity g (m/s2) ramped over 10 periods of
    the column and relaxed to rest over 30 (local damping 0.1, 10 % PIC). Returns the RMS
    and the largest error of sigma_yy over the points in units of rho g l0, and the largest
    vertical strain 1 - J."""
    E = rho * g * l0 * lam / -np.log(lam)
    h = l0 / cells
    grid = lattice.Lattice(kind, (1, cells + 1), (h, h), (0.5 * h / ppc, 0.5 * h / ppc))
    x, volume = lattice.fill((h, l0), (1, cells), ppc)
    flow = Flow(grid, x, volume, rho,
                Elastic(E, 0.0), g=0.0, walls={"left": "x", "right": "x", "bottom": "xy"},
                damping=0.1, flip=0.9)
    period = 4 * l0 / np.sqrt(E / rho)
    dt = 0.25 * h * lam / np.sqrt(E / (rho * lam))      # the wave at the stiffened foot
    for k in range(int(30 * period / dt)):
        flow.g = g * min(1.0, k * dt / (10 * period))
        flow.step(dt)
    err = (flow.sigma[:, 1] + rho * g * (l0 - flow.x0[:, 1])) / (rho * g * l0)
    return float(np.sqrt(np.mean(err ** 2))), float(np.max(np.abs(err))), 1 - flow.J.min()


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0].replace("\n", " "))
    ap.add_argument("--cells", default="4,8,16,32",
                    help="cells over the column's height, one grid per value")
    ap.add_argument("--ppc", default="2,4", help="points per cell direction, each value")
    ap.add_argument("--kinds", default="linear,gimp,bspline",
                    help="grid functions: linear (standard MPM), gimp (uGIMP), bspline "
                    "(quadratic)")
    return ap.parse_args(argv)


def main(argv=None):
    args = arguments(argv)
    cells = [int(c) for c in args.cells.split(",")]
    for kind in args.kinds.split(","):
        for ppc in (int(p) for p in args.ppc.split(",")):
            rows = [column(kind, n, ppc) for n in cells]
            PETSc.Sys.Print(f"{kind}, {ppc} x {ppc} points per cell: RMS / largest error of "
                            f"sigma_yy (in rho0 g l0), the foot's strain")
            for i, (n, (rms, worst, strain)) in enumerate(zip(cells, rows)):
                order = "" if i == 0 else f"   order {np.log2(rows[i - 1][0] / rms):+.2f}"
                PETSc.Sys.Print(f"  {n:4d} cells  {100 * rms:7.2f} %  {100 * worst:7.2f} %  "
                                f"{100 * strain:5.1f} %{order}")


if __name__ == "__main__":
    main()
