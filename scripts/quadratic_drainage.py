#!/usr/bin/env python3
"""Quadratic cells drained through their sides and two ways: the corner pressure projection
(-mpm_pressure_projection corner, the default for Q8 and Q9) and point pressures (none),
the numbers of docs/method.md ("Quadratic cells drained through a side").

    scripts/quadratic-drainage [--blocks 8,16] [--columns 10,20,40] [--elements q8,q9]
                               [--projections corner,none] [--fe 32]

Two scenes, each point's largest |p/q - reference| (% of q) at T_v = 0.05 / 0.2 / 0.5:
- the 1.2 m block drained left and right (tests/test_drainage.py; E 8e6 Pa, nu 0.2, n 0.4,
  k 2e-4 m/s, q 15 kPa, mass scaling auto) on N x N cells, against the finite-element model
  (solver/references/biot.py) on FE x FE cells;
- the paper's column drained at the top and the base on 1 x N cells, the default scheme,
  against Terzaghi's series with compressible water (solver/references/analytic.py), and the
  largest spread of that error inside one cell (the ramp that point pressures repeat in
  every cell).
Point pressures on the block are left out (they never drain a mode in every cell). About
ten minutes on one core for the defaults; the runs go to a temporary folder.
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

REPORTS = (0.05, 0.2, 0.5)
COMMON = ["-mpm_analysis", "consolidation", "-mpm_ppc", "3", "-mpm_Tv_end", "0.5",
          "-mpm_Tv_report", ",".join(map(str, REPORTS)), "-mpm_progress", "0",
          "-mpm_figures", "0"]
BLOCK = ["-mpm_size", "1.2,1.2", "-mpm_E", "8e6", "-mpm_nu", "0.2", "-mpm_porosity", "0.4",
         "-mpm_k", "2e-4", "-mpm_load", "15e3", "-mpm_drained", "left,right",
         "-mpm_mass_scaling", "auto"]
# The paper's column (Table 2) with the default scheme.
COLUMN = ["-mpm_size", "0.1,1.0", "-mpm_E", "10e6", "-mpm_nu", "0", "-mpm_porosity", "0.3",
          "-mpm_rho_s", "2700", "-mpm_K_l", "120e6", "-mpm_k", "2.5e-4", "-mpm_load", "10e3",
          "-mpm_drained", "top,bottom"]


def run(folder, args):
    """The summary and the profile rows (T_v, t, x, y0, p/q, ...) of a run."""
    summary = study.run_afresh(os.path.basename(folder), [*COMMON, *args], folder).result
    import numpy as np

    return summary, np.loadtxt(os.path.join(folder, "profiles.csv"), delimiter=",",
                               skiprows=1)


def block_errors(summary, rows, fe_cells):
    """The largest |p/q - FE| at each report time."""
    import numpy as np
    from petsc4py import PETSc

    from solver.references import biot

    o = summary["provenance"]["options"]["mpm"]
    body = biot.Body(size=tuple(o["size"]), E=o["E"], nu=o["nu"], k=o["k"],
                     porosity=o["porosity"], K_l=o["K_l"], rho_l=o["rho_l"], load=o["load"],
                     drained=tuple(o["drained"]),
                     bcs={side: o[f"bc_{side}"] for side in ("left", "right", "bottom", "top")})
    out = []
    for tv in REPORTS:
        r = rows[np.isclose(rows[:, 0], tv)]
        fe = biot.solve(PETSc.COMM_SELF, body, [r[0, 1]], r[:, 2:4],
                        cells=(fe_cells, fe_cells)).pressure[0] / o["load"]
        out.append(np.abs(r[:, 4] - fe).max())
    return out


def column_errors(summary, rows):
    """The largest |p/q - series| at each report time, and the largest spread of the error
    inside one cell at T_v = 0.05."""
    import numpy as np

    from solver.model.soil import constrained_modulus
    from solver.references import analytic

    o = summary["provenance"]["options"]["mpm"]
    E_c, gw = constrained_modulus(o["E"], o["nu"]), o["rho_l"] * 9.81
    ratio = (analytic.consistent_coefficient(o["k"], E_c, gw, o["K_l"], o["porosity"])
             / analytic.consolidation_coefficient(o["k"], E_c, gw))
    p0 = analytic.undrained_pressure(1.0, E_c, o["K_l"], o["porosity"])
    H, ny = o["size"][1], o["cells"][1]
    out, spread = [], 0.0
    for tv in REPORTS:
        r = rows[np.isclose(rows[:, 0], tv)]
        err = r[:, 4] - analytic.column_pressure(r[:, 3], tv * ratio, H, ("top", "bottom"), p0)
        out.append(np.abs(err).max())
        if tv == REPORTS[0]:
            cell = np.floor(r[:, 3] / (H / ny)).astype(int)
            spread = max(np.ptp(err[cell == c]) for c in range(ny))
    return out, spread


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--blocks", default="8,16", help="cells per side of the block runs")
    ap.add_argument("--columns", default="10,20,40", help="cells up the column runs")
    ap.add_argument("--elements", default="q8,q9", help="cell types")
    ap.add_argument("--projections", default="corner,none", help="pressure projections")
    ap.add_argument("--fe", type=int, default=32, help="cells per side of the FE reference")
    args = ap.parse_args()
    elements, projections = args.elements.split(","), args.projections.split(",")

    def pct(values):
        return " / ".join(f"{100 * v:.2f}" for v in values)

    with tempfile.TemporaryDirectory() as tmp:
        print("Block drained left and right, % of q at T_v 0.05 / 0.2 / 0.5 against the FE "
              f"on {args.fe} x {args.fe} cells:")
        for e in elements:
            for n in filter(None, args.blocks.split(",")):
                folder = os.path.join(tmp, f"block-{e}-{n}")
                s, rows = run(folder, [*BLOCK, "-mpm_element", e, "-mpm_cells", f"{n},{n}"])
                print(f"  {e.upper()} {n} x {n} ({s['pressure_projection']}): "
                      f"{pct(block_errors(s, rows, args.fe))} (dt {s['dt']:.3g} s)",
                      flush=True)
        print("Column drained at the top and the base, % of q at T_v 0.05 / 0.2 / 0.5 "
              "against the series; the largest spread inside a cell at T_v 0.05:")
        for e in elements:
            for proj in projections:
                for n in filter(None, args.columns.split(",")):
                    folder = os.path.join(tmp, f"column-{e}-{proj}-{n}")
                    s, rows = run(folder, [*COLUMN, "-mpm_element", e, "-mpm_cells", f"1,{n}",
                                           "-mpm_pressure_projection", proj])
                    errs, spread = column_errors(s, rows)
                    print(f"  {e.upper()} 1 x {n} {proj}: {pct(errs)}; in a cell "
                          f"{100 * spread:.2f} (dt {s['dt']:.3g} s)", flush=True)


if __name__ == "__main__":
    main()
