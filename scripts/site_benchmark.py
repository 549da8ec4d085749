#!/usr/bin/env python3
"""The site-response benchmark (``scripts/benchmark --dynamic``): the dry 30 m deposit of
three layers of cases/dynamic-layers.opts (1 x 300 Q4 cells, 20 s of a recorded-like motion,
Rayleigh damping 5 % at f1 and 5 f1) on one core, against the target of issue 30: at most
30 s for the whole command.

    .venv/bin/python scripts/benchmark --dynamic              # 3 timed runs, the best counts
    .venv/bin/python scripts/benchmark --dynamic --repeats 1 --publish

Each run is ``python -m solver -options_file cases/dynamic-layers.opts -mpm_figures 0
-mpm_progress 0`` in its own process, timed whole (start-up, the Jacobi eigen analysis of
the column, the steps, the outputs). Beside it, once each: the same deposit without
damping (``-mpm_rayleigh`` off: no LU solve a step), and the step that the damping's
stiffness part would allow if it were explicit (the solver takes it by Crank-Nicolson),
with the time that step would take, extrapolated from the undamped run's time per step.
Prints a table and writes site-benchmark.json and .txt into output/studies/benchmark/
(``--publish``: docs/results/; ``--out FOLDER`` elsewhere).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, str(REPO))
    from solver.studies.study import start

    start()

SCENE = REPO / "cases" / "dynamic-layers.opts"
TARGET_S = 30.0
QUIET = ["-mpm_figures", "0", "-mpm_progress", "0"]


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed runs (the best counts)")
    ap.add_argument("--publish", action="store_true", help="write into docs/results/")
    ap.add_argument("--out", default=None, help="folder for the results")
    return ap.parse_args(argv)


def run(extra, folder) -> tuple:
    """(seconds, summary) of the scene with ``extra`` options, timed whole."""
    cmd = [sys.executable, "-m", "solver", "-options_file", str(SCENE), *QUIET, *extra,
           "-mpm_output", str(folder)]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=3600)
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"site benchmark: the solver failed ({proc.returncode}):\n"
                         f"{proc.stderr[-2000:]}")
    return seconds, json.loads((folder / "summary.json").read_text())


def explicit_damping_step(summary) -> float:
    """The step (s) the Rayleigh damping's stiffness part would allow taken explicitly, by
    the solver's own bound: 0.9 (2 / w_max)(sqrt(1 + xi^2) - xi), xi = a0 / 2 w_max +
    a1 w_max / 2 at the grid's fastest mode (w_max, the Gershgorin bound, from the
    summary)."""
    ray = summary["dynamic"]["rayleigh"]
    w = summary["w_max"]
    xi = ray["a0"] / (2 * w) + ray["a1"] * w / 2
    return 0.9 * 2 / w * (math.sqrt(1 + xi * xi) - xi)


def measure(repeats: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="site-benchmark-") as tmp:
        tmp = Path(tmp)
        times, summary = [], None
        for k in range(repeats):
            seconds, summary = run([], tmp / f"damped-{k}")
            times.append(seconds)
        undamped_s, undamped = run(["-mpm_rayleigh", "0"], tmp / "undamped")
    steps = summary["steps"]
    per_step = undamped["wall_seconds"] / undamped["steps"]
    dt_explicit = explicit_damping_step(summary)
    return {"scene": "cases/dynamic-layers.opts", "cells": [1, 300], "t_end_s": 20.0,
            "seconds": times, "best_s": min(times), "target_s": TARGET_S,
            "met": min(times) <= TARGET_S, "steps": steps, "dt_s": summary["dt"],
            "undamped_s": undamped_s, "explicit_damping_dt_s": dt_explicit,
            "explicit_damping_estimate_s": per_step * 20.0 / dt_explicit,
            "load_average": os.getloadavg(), "dynamic": summary["dynamic"]}


def text(r) -> str:
    return "\n".join([
        f"Site-response benchmark: {r['scene']}, Q4 {r['cells'][0]} x {r['cells'][1]}, "
        f"{r['t_end_s']:g} s of motion, one core",
        f"  whole command, best of {len(r['seconds'])}: {r['best_s']:.1f} s (runs "
        + ", ".join(f"{s:.1f}" for s in r["seconds"]) + f"); target {r['target_s']:g} s: "
        + ("met" if r["met"] else "NOT met"),
        f"  {r['steps']} steps of {r['dt_s']:.4g} s, Rayleigh damping's stiffness part by "
        "Crank-Nicolson",
        f"  without damping: {r['undamped_s']:.1f} s",
        f"  the damping taken explicitly would need steps of {r['explicit_damping_dt_s']:.3g}"
        f" s: about {r['explicit_damping_estimate_s']:.0f} s of stepping",
        f"  load average {', '.join(f'{x:.2f}' for x in r['load_average'])}"])


def main(argv=None) -> int:
    args = arguments(argv)
    result = measure(args.repeats)
    report = text(result)
    print(report)
    folder = Path(args.out) if args.out else \
        REPO / ("docs/results" if args.publish else "output/studies/benchmark")
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "site-benchmark.json").write_text(json.dumps(result, indent=1) + "\n")
    (folder / "site-benchmark.txt").write_text(report + "\n")
    print(f"Wrote {folder / 'site-benchmark.json'} and .txt")
    return 0 if result["met"] else 1


if __name__ == "__main__":
    sys.exit(main())
