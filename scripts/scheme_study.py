#!/usr/bin/env python3
"""Work against precision of the two time schemes: the explicit v-w step and the implicit
quasi-static scheme, on 1 and 2 ranks, each scene under refinement.

    .venv/bin/python scripts/scheme-study              # everything (about 15 min on 2 cores)
    .venv/bin/python scripts/scheme-study --quick      # the coarsest two grids of each scene
    .venv/bin/python scripts/scheme-study --publish    # into docs/results/

Scenes (each run as the solver runs it, ``-mpm_scheme explicit`` or ``implicit``, the scene
file's other options as they are):
- the paper's column, cases/consolidation-m1-q4.opts on the meshes M1 (1 x 10), M2 (2 x 20)
  and M3 (4 x 40), to T_v = 1: the error is the largest profile L2 error against Terzaghi with
  compressible water over the report times (% of q);
- the strip footing (cases/consolidation-strip.opts, 8 x 4 to 32 x 16 cells) and the layered
  strip (cases/consolidation-strip-layered.opts, 16 x 8 to 64 x 32), to T_v = 0.1, reported
  at 0.01 and 0.1: the error is the largest RMS pore-pressure error over every point against
  the scene's FE reference (% of q).
The time is the run's wall time less its FE reference's solve. Writes scheme-study.json, .md
(the table) and .png (error against time) into output/studies/scheme-study/ (``--publish``:
docs/results/).

The crossover: the explicit step's time grows with the regime number Pi_S (consolidation
time over the slowest wave's period, with the run's mass scaling: its wave periods, hence
steps, per consolidation time), the implicit scheme's does not. For each explicit run,
Pi* = Pi_S t_implicit / t_explicit is the regime number below which the explicit step would
be the cheaper on that grid; it is the cheaper at equal error only where it is also as
accurate.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

from solver.studies import study  # noqa: E402

SCENES = {
    "column": ("consolidation-m1-q4", ["1,10", "2,20", "4,40"], []),
    "strip": ("consolidation-strip", ["8,4", "16,8", "32,16"],
              ["-mpm_Tv_end", "0.1", "-mpm_Tv_report", "0.01,0.1"]),
    "layered strip": ("consolidation-strip-layered", ["16,8", "32,16", "64,32"],
                      ["-mpm_Tv_end", "0.1", "-mpm_Tv_report", "0.01,0.1"]),
}
SCHEMES = ("explicit", "implicit")


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="the coarsest two grids of each")
    ap.add_argument("--ranks", default="1,2", help="rank counts (default 1,2)")
    ap.add_argument("--fresh", action="store_true", help="run again what is stored")
    study.add_destination(ap, "scheme-study", "scheme-study.json, .md, .png")
    return ap, ap.parse_args(argv)


def runs_of(args, folder) -> list:
    runs = []
    for name, (scene, grids, extra) in SCENES.items():
        for cells in grids[:2] if args.quick else grids:
            for scheme in SCHEMES:
                for ranks in (int(r) for r in args.ranks.split(",")):
                    tag = f"{scene}-{cells.replace(',', 'x')}-{scheme}-n{ranks}"
                    runs.append(study.Run(
                        f"{name} {cells} {scheme} {ranks}",
                        ["-options_file", os.path.join(ROOT, "cases", f"{scene}.opts"),
                         "-mpm_cells", cells, "-mpm_scheme", scheme, "-mpm_figures", "0",
                         "-mpm_progress", "0", *extra],
                        os.path.join(folder, "runs", tag), ranks))
    return runs


def measure(run) -> dict:
    """The row of one run: its error (% of q), time (s) and regime."""
    s = run.result
    fe = s.get("fe_reference") or {}
    if fe.get("available"):
        error = max(fe["error_rms_pct_of_q"])
    else:
        error = 100 * max(s["profile_l2"]["consistent"])
    name, cells, scheme, ranks = run.name.rsplit(" ", 3)
    seconds = study.wall_seconds(s) - (fe.get("wall_seconds") or 0.0)
    return {"scene": name, "cells": cells, "scheme": scheme, "ranks": int(ranks),
            "points": s["n_points"], "error_pct_of_q": error, "seconds": seconds,
            "Pi": s["regime"].get("Pi"), "Pi_S": s["regime"].get("Pi_S"), "steps": s["steps"]}


def crossovers(rows) -> list:
    """Pi* per scene, grid and rank count (module docstring)."""
    out = []
    for r in rows:
        if r["scheme"] != "explicit":
            continue
        twin = [i for i in rows if i["scheme"] == "implicit" and
                (i["scene"], i["cells"], i["ranks"]) == (r["scene"], r["cells"], r["ranks"])]
        if twin and r["Pi_S"]:
            out.append({**{k: r[k] for k in ("scene", "cells", "ranks", "Pi_S")},
                        "Pi_star": r["Pi_S"] * twin[0]["seconds"] / r["seconds"],
                        "speedup": r["seconds"] / twin[0]["seconds"]})
    return out


def table(rows, cross) -> str:
    lines = ["| scene | cells | points | ranks | explicit: error (% of q), time (s) | "
             "implicit: error (% of q), time (s) | time ratio | Pi_S | Pi* |",
             "|---|---|---|---|---|---|---|---|---|"]
    for c in cross:
        pair = {r["scheme"]: r for r in rows
                if (r["scene"], r["cells"], r["ranks"]) == (c["scene"], c["cells"], c["ranks"])}
        e, i = pair["explicit"], pair["implicit"]
        lines.append(f"| {c['scene']} | {c['cells'].replace(',', ' x ')} | {e['points']:,} | "
                     f"{c['ranks']} | {e['error_pct_of_q']:.3g}, {e['seconds']:.3g} | "
                     f"{i['error_pct_of_q']:.3g}, {i['seconds']:.3g} | {c['speedup']:.3g} | "
                     f"{c['Pi_S']:.3g} | {c['Pi_star']:.3g} |")
    return "\n".join(lines) + "\n"


def plot(rows, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7.5, 5))
    colours = dict(zip(SCENES, ("C0", "C1", "C2")))
    for scene in SCENES:
        for scheme, marker in (("explicit", "o"), ("implicit", "s")):
            for ranks, style in ((1, "-"), (2, "--")):
                pts = sorted((r["seconds"], r["error_pct_of_q"]) for r in rows
                             if (r["scene"], r["scheme"], r["ranks"]) == (scene, scheme, ranks))
                if pts:
                    ax.plot(*zip(*pts), style, marker=marker, color=colours[scene],
                            mfc="white" if scheme == "explicit" else colours[scene],
                            label=f"{scene}, {scheme}, {ranks} rank(s)")
    ax.set(xscale="log", yscale="log", xlabel="wall time (s, the FE reference's solve left "
           "out)", ylabel="error (% of q)",
           title="Explicit (open) and implicit (filled) under refinement")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap, args = arguments(argv)
    folder = study.destination(ap, args)
    work = os.path.join(study.STUDIES, "scheme-study")
    runs = study.execute_all(runs_of(args, work), cores=study.cores(), fresh=args.fresh)
    failed = [r for r in runs if r.result is None or r.code != 0]
    if failed:
        print(f"scheme-study: {len(failed)} run(s) failed, first {failed[0].name}: "
              f"{failed[0].stderr[-400:]}", file=sys.stderr)
        return 1
    rows = [measure(r) for r in runs]
    cross = crossovers(rows)
    text = table(rows, cross)
    print(text)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, "scheme-study.json"), "w") as fh:
        json.dump({"rows": rows, "crossovers": cross}, fh, indent=1)
    with open(os.path.join(folder, "scheme-study.md"), "w") as fh:
        fh.write("# Explicit or implicit: work against precision (scripts/scheme-study)\n\n"
                 + text)
    plot(rows, os.path.join(folder, "scheme-study.png"))
    print(f"Results in {folder}: scheme-study.json, scheme-study.md, scheme-study.png")
    return 0


if __name__ == "__main__":
    sys.exit(main())
