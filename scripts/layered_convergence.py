#!/usr/bin/env python3
"""Convergence of layered consolidation under refinement, Q4, Q8 and Q9 cells: a 1 m column
of two 0.5 m layers from the surface down, stiff and permeable over soft and tight (E 40
and 10 MPa, k 2.5e-3 and 2.5e-4 m/s: contrasts 4 and 10), against the layered column's
series (solver.references.layered) with compressible water.

    scripts/layered-convergence [--elements q4,q8,q9] [--cells 1x10,1x20]

The scene: nu 0, n 0.3, rho_s 2700, rho_l 1000 kg/m3, K_l 120 MPa, q = 10 kPa on the
drained top, rollers on the sides, fixed impermeable base, no gravity, the solver's default
scheme with -mpm_mass_scaling auto (k ten times the paper's, so the column reaches T_v =
0.5 in 0.66 s, not 6.6 s; auto then scales the inertia down, S = 0.09, to keep its error
within 0.2 % of q), reports at T_v = 0.05, 0.2, 0.5. Grids 1 x NY with NY even, so the interface
lies on a cell boundary; Q4 with 2 x 2 points per cell, Q8 and Q9 with 3 x 3.

For each element and grid, reads the run's profiles.csv and compares every point's p/q
(at its initial height) at each report time (at t_s, the time of the step that reports;
the solver's own errors take the nominal time of T_v, within half a step of it) with
LayeredColumn built here from the summary's layers alone: E_c = E (1 - nu) / ((1 + nu)
(1 - 2 nu)), gamma_w = 9.81 rho_l, K_l, n and k per layer, q = 10 kPa, drained where the
summary's reference says. Prints a table: element, cells, points, max |p/q - ref| (% of
q) at each report time, the volume-weighted L2 error over all points and report times (%
of q), its observed order between successive grids (log of the error ratio over log of
the cell-height ratio) and the run's wall time (the summary's, without Python's start).
The default study (Q4 on 1 x 10 to 1 x 80 cells, Q8 and Q9 on 1 x 4 to 1 x 40) takes
about 3.5 minutes on one core, Q8 on 1 x 40 cells 70 s of it.
"""

import argparse
import csv
import json
import math
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

from solver.studies import study as harness  # noqa: E402  (study() below is one grid's)

Q = 10e3            # the load (Pa)
G_REF = 9.81        # the gravity in which k is defined (m/s2)
TV_REPORT = "0.05,0.2,0.5"
SCENE = ["-mpm_analysis", "consolidation", "-mpm_size", "0.1,1.0",
         "-mpm_layers", "0.5,0.5", "-mpm_E", "40e6,10e6", "-mpm_nu", "0",
         "-mpm_k", "2.5e-3,2.5e-4", "-mpm_porosity", "0.3", "-mpm_rho_s", "2700",
         "-mpm_rho_l", "1000", "-mpm_K_l", "120e6", "-mpm_mu_l", "1e-3",
         "-mpm_gravity", "0", "-mpm_load", str(Q), "-mpm_drained", "top",
         "-mpm_bc_left", "x", "-mpm_bc_right", "x", "-mpm_bc_bottom", "xy",
         "-mpm_bc_top", "none", "-mpm_mass_scaling", "auto",
         "-mpm_Tv_end", TV_REPORT.split(",")[-1], "-mpm_Tv_report", TV_REPORT]
ELEMENTS = ("q4", "q8", "q9")
CELLS = {"q4": "1x10,1x20,1x40,1x80", "q8": "1x4,1x10,1x20,1x40", "q9": "1x4,1x10,1x20,1x40"}
PPC = {"q4": 2, "q8": 3, "q9": 3}


def options(element, cells, folder):
    """The solver's options of the scene on ``cells`` ("NXxNY") ``element`` cells, its
    output in ``folder``."""
    nx, ny = cells.split("x")
    return [*SCENE, "-mpm_element", element, "-mpm_cells", f"{nx},{ny}",
            "-mpm_ppc", str(PPC[element]), "-mpm_figures", "0", "-mpm_progress", "0",
            "-mpm_output", folder]


def read(folder):
    """(summary, profile rows as dicts of floats) of the run in ``folder``."""
    with open(os.path.join(folder, "summary.json")) as fh:
        summary = harness.results(json.load(fh))
    with open(os.path.join(folder, "profiles.csv")) as fh:
        rows = [{k: float(v) for k, v in r.items()} for r in csv.DictReader(fh)]
    return summary, rows


def run(element, cells, folder):
    """(summary, profile rows) of the scene on ``cells`` ``element`` cells, a solver run of
    the study harness with its output in ``folder``."""
    # options() names the folder last (-mpm_output): the harness names it itself.
    harness.run_afresh(f"{element} {cells}", options(element, cells, folder)[:-2], folder)
    return read(folder)


def column(summary):
    """The layered column of the run's summary (layers from the surface down), built from
    its inputs alone: compressible water, the load Q, drained where the reference says."""
    from solver.references.layered import LayeredColumn

    layers = summary["layers"]
    E = np.array([s["E"] for s in layers])
    nu = np.array([s["nu"] for s in layers])
    rho_l, K_l = layers[0]["rho_l"], layers[0]["K_l"]
    return LayeredColumn([s["thickness_m"] for s in layers],
                         E * (1 - nu) / ((1 + nu) * (1 - 2 * nu)),
                         [s["k"] for s in layers], [s["porosity"] for s in layers],
                         rho_l * G_REF, K_l, q=Q,
                         drained=tuple(summary["reference"]["drained"]))


def errors(summary, rows):
    """(report times, max |p/q - ref| at each (% of q), the volume-weighted L2 error at each
    (% of q), the L2 error over every point and all those times together (% of q)) of the
    run's profiles ``rows`` against the layered column of its ``summary``."""
    ref = column(summary)
    reports = summary["monitor"]["Tv"]
    worst, l2, sq, vol = [], [], 0.0, 0.0
    for Tv in reports:
        at = [r for r in rows if math.isclose(r["Tv"], Tv, rel_tol=1e-9)]
        if not at:
            raise ValueError(f"no profile at T_v = {Tv}")
        y = np.array([r["y0_m"] for r in at])
        p = np.array([r["p_over_q_compression_positive"] for r in at])
        V = np.array([r["volume_m3"] for r in at])
        e = p - ref.pressure(y, at[0]["t_s"]) / Q
        worst.append(100 * float(np.abs(e).max()))
        l2.append(100 * math.sqrt(float(V @ e ** 2) / float(V.sum())))
        sq += float(V @ e ** 2)
        vol += float(V.sum())
    return reports, worst, l2, 100 * math.sqrt(sq / vol)


def study(element, cells, folder):
    """One row of the table: the run on ``cells`` ("1xNY") ``element`` cells and its
    errors, as a dict."""
    summary, rows = run(element, cells, folder)
    reports, worst, l2_each, l2 = errors(summary, rows)
    return {"element": element, "cells": cells, "ny": int(cells.split("x")[1]),
            "points": summary["n_points"], "Tv": reports, "max_pct": worst,
            "l2_each_pct": l2_each, "l2_pct": l2, "wall_s": harness.wall_seconds(summary)}


def order(coarse, fine):
    """The observed order of the L2 error between two rows (cell heights 1 / NY)."""
    return math.log(coarse["l2_pct"] / fine["l2_pct"]) / math.log(fine["ny"] / coarse["ny"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--elements", default=",".join(ELEMENTS),
                    help="cells to study, comma-separated: q4, q8, q9")
    ap.add_argument("--cells", default="",
                    help="grids NXxNY (NY even), comma-separated, for every element studied "
                         f"(default: {CELLS['q4']} for q4, {CELLS['q9']} for q8 and q9)")
    args = ap.parse_args()
    elements = [e.strip() for e in args.elements.split(",")]
    bad = [e for e in elements if e not in ELEMENTS]
    if bad:
        ap.error(f"--elements: unknown {', '.join(bad)} (q4, q8, q9)")
    grids = {e: (args.cells or CELLS[e]).split(",") for e in elements}
    for cells in sum(grids.values(), []):
        nx, _, ny = cells.partition("x")
        if not (nx.isdigit() and ny.isdigit() and int(nx) > 0 and int(ny) > 0
                and int(ny) % 2 == 0):
            ap.error(f"--cells: {cells}: give NXxNY with NY even (the interface at "
                     "mid-height on a cell boundary)")
    reports = TV_REPORT.split(",")
    print("max |p/q - ref| at each T_v and the L2 error over all points and times, % of q;"
          " order: of the L2 error")
    print(f"{'element':>8s}{'cells':>7s}{'points':>8s}"
          + "".join(f"{'T_v=' + t:>10s}" for t in reports)
          + f"{'L2':>9s}{'order':>7s}{'wall s':>8s}", flush=True)
    start = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        for element in elements:
            before = None
            for cells in grids[element]:
                r = study(element, cells, os.path.join(tmp, f"{element}-{cells}"))
                rate = "" if before is None else f"{order(before, r):7.2f}"
                print(f"{element:>8s}{cells:>7s}{r['points']:8d}"
                      + "".join(f"{w:9.3f}%" for w in r["max_pct"])
                      + f"{r['l2_pct']:8.3f}%{rate:>7s}{r['wall_s']:8.1f}", flush=True)
                before = r
    print(f"study: {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()
