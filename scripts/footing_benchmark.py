#!/usr/bin/env python3
"""The footing benchmark: a strip footing on layered clay at about 1e5 material points to
T_v = 1, by the implicit scheme on two ranks, against the FE at twice the resolution and
against the explicit step's time for the same case.

    .venv/bin/python scripts/footing-benchmark              # 224 x 112 cells, 100,352 points
    .venv/bin/python scripts/footing-benchmark --cells 32,16 --ranks 1   # a small check

The scene is cases/consolidation-strip-layered.opts (a 2 m footing on 0.5 m of silty sand
over 1.5 m of clay, a half model) on ``--cells`` Q4 cells with 2 x 2 points each. Three
measurements, each in its own process:

1. the implicit run (``-mpm_scheme implicit``, ``mpirun -n RANKS``, no FE reference, no
   figures), a run of the study harness (``solver.studies.study.execute``) made afresh: its
   wall time (the whole command) and its phases, steps, factorizations and solves, and the
   mean settlement under the load at T_v = 0.01, 0.1, 1;
2. the FE reference (solver/references/biot.py) of the same ground on Q9/Q4 cells as many
   as the run's, twice its nodal resolution, LU by MUMPS, at the same times: the run's
   settlement error against it; and the FE on half those cells against it (its own grid
   error, where the layer interface stays on a cell boundary);
3. the explicit step of the same scene (its own options: mass scaling auto), run for about
   ``--explicit-seconds`` of stepping; its time per step times the steps to T_v = 1 is its
   extrapolated time (the run itself would take hours to days).

Prints a table and writes footing-benchmark.json and .txt into output/studies/benchmark/
(``--publish``: docs/results/; ``--out FOLDER`` elsewhere).
"""

from __future__ import annotations

import argparse
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

from solver.studies import study  # noqa: E402

SCENE = os.path.join(ROOT, "cases", "consolidation-strip-layered.opts")
TV = (0.01, 0.1, 1.0)
QUIET = ["-mpm_figures", "0", "-mpm_fe_reference", "0", "-mpm_progress", "0"]


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cells", default="224,112", help="Q4 cells NX,NY (default 224,112)")
    ap.add_argument("--ranks", type=int, default=2, help="ranks of the implicit run")
    ap.add_argument("--explicit-seconds", type=float, default=60.0,
                    help="about this many seconds of explicit steps are timed (0: none)")
    study.add_destination(ap, "benchmark", "footing-benchmark.json and .txt")
    args = ap.parse_args(argv)
    args.out = study.destination(ap, args)
    return args


def _solver(name, args, folder, ranks: int) -> tuple:
    """(seconds, summary) of the scene with the options ``args`` on ``ranks`` ranks, run
    afresh into ``folder`` and timed whole (SystemExit when the solver failed)."""
    done = study.run_afresh(f"footing benchmark, {name}", ["-options_file", SCENE, *args],
                            folder, ranks, log=lambda m: print(m, flush=True))
    return done.seconds, done.result


def implicit_run(cells, ranks, folder) -> dict:
    args = ["-mpm_scheme", "implicit", "-mpm_cells", cells, "-mpm_Tv_end", "1",
            "-mpm_Tv_report", ",".join(map(str, TV)), *QUIET]
    seconds, s = _solver("implicit", args, folder, ranks)
    degree = s["consolidation_degree"]
    return {"seconds": seconds, "wall": s["wall"], "points": s["n_points"], "ranks": ranks,
            "implicit": s["implicit"], "Tv": degree["Tv"],
            "settlement_mean_m": degree["settlement_m"]}


def fe_reference(cells) -> dict:
    """The FE of the scene on Q9/Q4 cells ``cells`` (NX, NY) at TV, by MUMPS (serial)."""
    from petsc4py import PETSc

    from solver.consolidation import fe_reference as fe
    from solver.references import biot

    _, ground, body, loading = _scene(",".join(map(str, cells)))
    t = [ground.height ** 2 * tv / ground.c_v for tv in TV]
    t0 = time.perf_counter()
    db = PETSc.Options()
    db.setValue("biot_pc_factor_mat_solver_type", "mumps")
    try:
        r = biot.solve(PETSc.COMM_SELF, fe.body_of(ground.as_material(), body, loading), t,
                       [[0.0, body.height / 2]], cells=cells, steps=fe.STEPS)
    finally:
        db.delValue("biot_pc_factor_mat_solver_type")
    return {"cells": list(cells), "seconds": time.perf_counter() - t0, "steps": r.steps,
            "factorizations": r.factorizations, "settlement_mean_m": list(r.settlement)}


def fe_half(cells):
    """The FE on half the cells each way (its own grid error beside the run's), or None
    where a layer interface would fall inside a cell."""
    from solver.common.errors import InputError

    try:
        return fe_reference(tuple(c // 2 for c in cells))
    except InputError:
        return None


def _scene(cells):
    """(options, ground, body, loading) of the scene on ``cells`` ('NX,NY'), read as the
    solver reads it."""
    from solver.model.scene import Body, Loading
    from solver.model.soil import Ground

    p = study.read_scene(SCENE, ["-mpm_cells", cells])
    return p, Ground.from_options(p), Body.from_options(p), Loading.from_options(p)


def mass_scaling(cells) -> float:
    """The factor S the scene's explicit run picks (-mpm_mass_scaling auto)."""
    from petsc4py import PETSc

    from solver.stepping import inertia
    from solver.stepping.scheme import Scheme

    p, ground, body, loading = _scene(cells)
    soil = ground.as_material()
    period = inertia.slowest_period(PETSc.COMM_SELF, body, soil, loading)
    swings = inertia.load_swings(PETSc.COMM_SELF, body, soil, loading)
    return Scheme.from_options(p, soil, min(p.Tv_report), period, swings).mass_scaling


def explicit_estimate(cells, budget, folder) -> dict:
    """The explicit step's seconds per step on one rank and its steps to T_v = 1."""
    probe = os.path.join(folder, "probe")
    S = mass_scaling(cells)

    def run(tv):
        # The scene's mass scaling as its full run picks it (auto depends on the first
        # report, which these short runs move).
        args = ["-mpm_scheme", "explicit", "-mpm_cells", cells, "-mpm_Tv_end", f"{tv:.6g}",
                "-mpm_Tv_report", f"{tv:.6g}", "-mpm_mass_scaling", repr(S), *QUIET]
        return _solver(f"explicit to T_v = {tv:.3g}", args, probe, 1)[1]

    # A short run learns dt and the time per step; a second steps for about ``budget`` s.
    tv = 1e-6
    for _ in range(3):
        s = run(tv)
        per_step = s["wall"]["stepping_s"] / max(s["steps"], 1)
        if s["wall"]["stepping_s"] > budget / 2:
            break
        tv = min(1.0, tv * budget / per_step / max(s["steps"], 1))
    steps_total = s["steps"] / tv
    return {"dt_s": s["dt"], "steps_timed": s["steps"], "stepping_s": s["wall"]["stepping_s"],
            "seconds_per_step": per_step, "steps_to_Tv1": steps_total,
            "extrapolated_s": per_step * steps_total,
            "mass_scaling": S}


def main(argv=None) -> int:
    args = arguments(argv)
    cells = tuple(int(c) for c in args.cells.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        run = implicit_run(args.cells, args.ranks, os.path.join(tmp, "implicit"))
        fe = fe_reference(cells)
        half = fe_half(cells)
        explicit = explicit_estimate(args.cells, args.explicit_seconds, tmp) \
            if args.explicit_seconds > 0 else None
    errors = [100 * (a / b - 1) for a, b in zip(run["settlement_mean_m"],
                                                fe["settlement_mean_m"])]
    lines = [f"Footing benchmark: cases/consolidation-strip-layered.opts on {cells[0]} x "
             f"{cells[1]} Q4 cells, {run['points']:,} material points, to T_v = 1",
             f"Implicit scheme on {run['ranks']} rank(s): {run['seconds']:.1f} s in all "
             f"(set-up {run['wall']['setup_s']:.1f} s, steps {run['wall']['stepping_s']:.1f} "
             f"s); {run['implicit']['steps']} steps, {run['implicit']['factorizations']} "
             f"factorizations ({run['implicit']['factor_seconds']:.1f} s), "
             f"{run['implicit']['solves']} solves ({run['implicit']['solve_seconds']:.1f} s)",
             f"FE reference: Q9/Q4 on {cells[0]} x {cells[1]} cells (twice the nodal "
             f"resolution), {fe['steps']} steps, {fe['seconds']:.1f} s",
             f"{'T_v':>6s}{'run (mm)':>11s}{'FE (mm)':>11s}{'error':>9s}"]
    lines += [f"{tv:6.3g}{1e3 * a:11.4f}{1e3 * b:11.4f}{e:+8.3f}%" for tv, a, b, e in zip(
        TV, run["settlement_mean_m"], fe["settlement_mean_m"], errors)]
    if half:
        own = [100 * (a / b - 1) for a, b in zip(half["settlement_mean_m"],
                                                 fe["settlement_mean_m"])]
        lines.append(f"The FE on {half['cells'][0]} x {half['cells'][1]} cells against it: "
                     + ", ".join(f"{e:+.3f} %" for e in own) + f" ({half['seconds']:.1f} s)")
    if explicit:
        lines.append("Explicit step (one rank, the scene's mass scaling, "
                     f"S = {explicit['mass_scaling']:.3g}, dt = {explicit['dt_s']:.3g} s, "
                     f"{explicit['steps_to_Tv1']:.4g} steps to T_v = 1; "
                     f"{explicit['steps_timed']} steps took {explicit['stepping_s']:.1f}"
                     f" s, so about {explicit['extrapolated_s']:.3g} s "
                     f"({explicit['extrapolated_s'] / 3600:.3g} h) in all")
    print("\n".join(lines))
    result = {"cells": list(cells), "implicit": run, "fe": fe, "fe_half": half,
              "errors_pct": errors,
              "explicit": explicit, "Tv": list(TV)}
    study.write_results(os.path.join(args.out, "footing-benchmark"), result, lines)
    print(f"Results in {args.out}: footing-benchmark.json, footing-benchmark.txt")
    return 0 if all(math.isfinite(e) for e in errors) else 1


if __name__ == "__main__":
    sys.exit(main())
