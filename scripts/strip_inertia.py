#!/usr/bin/env python3
"""The inertia of a strip footing's consolidation against the finite-element reference
(solver/references/biot.py): what ``-mpm_mass_scaling auto`` picks, what the run prints about the
inertia error, and what is measured.

    scripts/strip-inertia [--scene strip] [--cells 16x8] [--element q4] [--ppc 2]
                          [--reports 0.01,0.05,0.1] [--S auto,none,0.277] [--ranks 1]
                          [--bound] [-- extra -mpm_ options]

For every grid, element and mass scaling: the run of cases/consolidation-<scene>.opts to the
last report time, and beside it the FE (Q9/Q4 on 64 x 32 cells, TR-BDF2) of the same body:
at each report time the settlement under the load (the mean over the loaded part of the
top) against the FE's (%), the RMS and the largest |p - p_FE| over every point (% of q);
the swing, the largest peak-to-peak change of the settlement's error within one (scaled)
period of the slowest wave after the first physical one and the first report (%); the S
chosen, the run's estimated wave error at the earliest report (% of q) and its wall time.
``--bound`` adds, for each run, a run with S / 100 and the same report times (the
inertia-free answer of the same discretisation): the measured inertia error at each
report, max |dp| over the points (% of q) and |ds| / s (%), beside the estimate.

A 16 x 8 Q4 strip to T_v = 0.1 takes about 10 s on one core; the layered one (64 x 32
cells, 8,192 points) about 10 minutes.
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

FE_CELLS = (64, 32)   # within 0.05 % of 128 x 64 in the settlement at T_v = 0.01
REFERENCE = 100.0     # --bound: the inertia-free run has S / REFERENCE


def run(scene, folder, extra=(), ranks=1) -> dict:
    """The summary of cases/consolidation-``scene``.opts with the options ``extra``, run on
    ``ranks`` ranks into ``folder``."""
    return study.run_afresh(os.path.basename(folder),
                            ["-options_file", f"cases/consolidation-{scene}.opts",
                             "-mpm_figures", "0", "-mpm_progress", "0", *extra],
                            folder, ranks).result


def fe_body(o):
    """The biot.Body of a run's options ``o`` (the summary's provenance): a step load on
    the loaded part of the top, layers as the run's."""
    from solver.references import biot

    def value(name):
        v = o[name]
        return tuple(v) if isinstance(v, list) else v

    return biot.Body(size=tuple(o["size"]), E=value("E"), nu=value("nu"), k=value("k"),
                     porosity=value("porosity"), K_l=o["K_l"], rho_l=o["rho_l"],
                     load=o["load"], loaded=tuple(o["load_extent"]) or (0.0, o["size"][0]),
                     drained=tuple(s for s in o["drained"] if s != "none"),
                     layers=tuple(o["layers"]) if o["layers"] else None,
                     bcs={s: o[f"bc_{s}"] for s in biot.SIDES})


def series(folder):
    """(settlement.csv rows (t s, T_v, s m, mean p Pa), {T_v: profiles.csv rows})."""
    import numpy as np

    rows = np.loadtxt(os.path.join(folder, "settlement.csv"), delimiter=",", skiprows=1,
                      ndmin=2)
    prof = np.loadtxt(os.path.join(folder, "profiles.csv"), delimiter=",", skiprows=1)
    return rows, {float(tv): prof[np.isclose(prof[:, 0], tv)] for tv in np.unique(prof[:, 0])}


def compare(s, folder, reports) -> dict:
    """The run of summary ``s`` in ``folder`` against the FE: per report T_v the settlement
    error (%), p RMS and max (% of q); the swing (%) after the first wave period."""
    import numpy as np
    from petsc4py import PETSc

    from solver.references import biot

    o = s["provenance"]["options"]["mpm"]
    rows, prof = series(folder)
    t_rep = [prof[tv][0, 1] for tv in reports]
    # The FE's settlement on a geometric grid of times, interpolated in sqrt(t) (smooth).
    grid = np.geomspace(rows[0, 0], rows[-1, 0], 120)
    times = np.concatenate([grid, t_rep])
    xy = prof[reports[0]][:, 2:4]
    fe = biot.solve(PETSc.COMM_SELF, fe_body(o), times, xy, cells=FE_CELLS)
    out = {"S": s["mass_scaling"], "estimate_pct": 100 * s["regime"]["wave_error"],
           "wall_s": study.wall_seconds(s), "steps": s["steps"], "reports": {}}
    for k, tv in enumerate(reports):
        i = len(grid) + k
        mine = np.interp(t_rep[k], rows[:, 0], rows[:, 2])
        dp = (prof[tv][:, 4] - fe.pressure[i] / o["load"]) * 100
        out["reports"][tv] = {"settlement_mm": 1e3 * mine, "fe_mm": 1e3 * fe.settlement[i],
                              "error_pct": 100 * (mine / fe.settlement[i] - 1),
                              "p_rms_pct": float(np.sqrt(np.mean(dp ** 2))),
                              "p_max_pct": float(np.abs(dp).max())}
    error = rows[:, 2] / np.interp(np.sqrt(rows[:, 0]), np.sqrt(grid),
                                   fe.settlement[:len(grid)]) - 1
    out["swing_pct"] = 100 * swing(rows[:, 0], error, s["regime"])
    return out


def swing(t, error, regime) -> float:
    """The largest peak-to-peak change of ``error`` at times ``t`` (s) within one scaled
    period of the slowest wave, after its first physical period and the first report (auto
    lets the wave die out by then, not before)."""
    import numpy as np

    window = regime["wave_period_scaled_s"]
    later = t >= max(regime["wave_period_s"], regime["first_report_s"])
    t, e = t[later], error[later]
    worst = 0.0
    for j in range(len(t)):
        inside = e[j:np.searchsorted(t, t[j] + window, side="right")]
        worst = max(worst, float(inside.max() - inside.min()))
    return worst


def inertia_error(folder, reference) -> dict:
    """Per report T_v: max |dp| over the points (% of q) and |ds| / s (%) between the runs
    in ``folder`` and ``reference`` (the same report times)."""
    import numpy as np

    (a, pa), (b, pb) = series(folder), series(reference)
    out = {}
    for tv in pa:
        sa = np.interp(pa[tv][0, 1], a[:, 0], a[:, 2])
        sb = np.interp(pb[tv][0, 1], b[:, 0], b[:, 2])
        out[tv] = (float(np.abs(pa[tv][:, 4] - pb[tv][:, 4]).max() * 100),
                   100 * abs(sa / sb - 1))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--scene", default="strip", help="cases/consolidation-SCENE.opts")
    ap.add_argument("--cells", default="16x8", help="grids NXxNY, comma-separated")
    ap.add_argument("--element", default="q4", help="cell types, comma-separated")
    ap.add_argument("--ppc", type=int, default=0, help="points per cell (0: 2 for Q4, 3 else)")
    ap.add_argument("--reports", default="0.01,0.05,0.1", help="report times T_v")
    ap.add_argument("--S", default="auto", help="mass scalings, comma-separated")
    ap.add_argument("--ranks", type=int, default=1, help="ranks per run")
    ap.add_argument("--bound", action="store_true", help="measure the inertia error too")
    ap.add_argument("extra", nargs="*", help="further -mpm_ options (after --)")
    args = ap.parse_args()
    reports = [float(x) for x in args.reports.split(",")]
    common = ["-mpm_Tv_end", str(max(reports)), "-mpm_Tv_report", args.reports, *args.extra]
    print(f"{'cells':>7s} {'el':>3s} {'S':>9s} {'est. %q':>8s} {'T_v':>6s} {'s mm':>8s} "
          f"{'FE mm':>8s} {'err %':>7s} {'p RMS':>6s} {'p max':>6s} {'swing':>6s}"
          + (f" {'dp max':>7s} {'ds %':>6s}" if args.bound else "") + f" {'wall s':>7s}")
    with tempfile.TemporaryDirectory() as tmp:
        for cells in args.cells.split(","):
            for element in args.element.split(","):
                ppc = args.ppc or (2 if element == "q4" else 3)
                for S in args.S.split(","):
                    name = f"{cells}-{element}-{S}"
                    opts = [*common, "-mpm_cells", cells.replace("x", ","), "-mpm_element",
                            element, "-mpm_ppc", str(ppc), "-mpm_mass_scaling", S]
                    folder = os.path.join(tmp, name)
                    s = run(args.scene, folder, opts, args.ranks)
                    c = compare(s, folder, reports)
                    measured = {}
                    if args.bound:
                        ref = os.path.join(tmp, name + "-ref")
                        run(args.scene, ref, opts + ["-mpm_mass_scaling",
                                                     f"{s['mass_scaling'] / REFERENCE:.6g}"],
                            args.ranks)
                        measured = inertia_error(folder, ref)
                    for tv in reports:
                        r = c["reports"][tv]
                        first = tv == reports[0]
                        print(f"{cells:>7s} {element:>3s} {c['S']:9.3g} "
                              + (f"{c['estimate_pct']:8.2g}" if first else " " * 8)
                              + f" {tv:6.3g} {r['settlement_mm']:8.4f} {r['fe_mm']:8.4f} "
                              f"{r['error_pct']:+7.2f} {r['p_rms_pct']:6.2f} "
                              f"{r['p_max_pct']:6.2f} "
                              + (f"{c['swing_pct']:6.2f}" if first else " " * 6)
                              + (f" {measured[tv][0]:7.3f} {measured[tv][1]:6.3f}"
                                 if args.bound else "")
                              + (f" {c['wall_s']:7.1f}" if first else ""), flush=True)


if __name__ == "__main__":
    main()
