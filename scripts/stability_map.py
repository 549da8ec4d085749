#!/usr/bin/env python3
"""Where the explicit two-phase step blows up, measured, beside every critical time step.

    .venv/bin/python scripts/stability-map [--cores 2] [--steps 4000] [--bisect 5] [--publish]

For each scene (M1-Q4, M1-Q8, M1-Q9, M2-Q4, M3-Q4, M1-Q4 with a ten times less permeable
soil, where the drag decides, and M2-Q4 without the pressure projection), first one short
run gives all the critical time steps (Table 1's four, the drag limit and the discrete limit
of the step). Then runs of --steps steps sweep dt / dt_discrete over --ratios, with the
default local damping (0.5) and without it, each run marked stable (exit 0) or blown up
(exit 3, the solver's own blow-up check; -mpm_allow_unstable lets it run above the limits);
bisection between the largest stable and the smallest unstable ratio then pins the measured
limit to 2^-bisect of the gap.
Writes stability-map.png, stability-map.md and stability-map.json into
output/studies/stability-map/ (with --publish into docs/results/, the tracked copy the docs
show); the runs themselves go to output/stability/ (a re-run reuses them).
"""

import argparse
import os
import sys
from concurrent.futures import ThreadPoolExecutor

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

from solver.io import output  # noqa: E402
from solver.studies import study  # noqa: E402

SCENES = {"m1-q4": [], "m1-q8": [], "m1-q9": [], "m2-q4": [], "m3-q4": [],
          "m1-q4-tight": ["-mpm_k", "2.5e-5"],
          "m2-q4-unprojected": ["-mpm_pressure_projection", "none"]}
TITLES = {"m1-q4-tight": " (k = 2.5e-5 m/s)", "m2-q4-unprojected": " (no pressure projection)"}
CRITERIA = [("cfl", "CFL", "tab:gray"), ("undrained", "dt_crit,1 undrained", "tab:blue"),
            ("oscillator", "dt_crit,3 oscillator", "tab:purple"),
            ("diffusion", "dt_crit,2 diffusion", "tab:brown"),
            ("drag", "drag 2/lambda", "tab:orange"), ("discrete", "discrete", "k")]
PAPER_DT = {"m1": 1e-4, "m2": 1e-4, "m3": 5e-5}
DAMPING = (0.5, 0.0)


def base_args(scene):
    """The solver options of ``scene`` (a key of SCENES)."""
    case = "-".join(scene.split("-")[:2])
    return ["-options_file", f"cases/consolidation-{case}.opts", *SCENES[scene],
            "-mpm_figures", "0"]


def limits_run(scene, runs_dir):
    """A run of a few steps whose summary holds every critical time step."""
    return study.Run(f"{scene} limits", base_args(scene) + ["-mpm_Tv_end", "1e-4",
                                                            "-mpm_Tv_report", "1e-4"],
                     os.path.join(runs_dir, scene, "limits"))


def probe(scene, ratio, damping, limits, cv, steps, runs_dir):
    """A run of ``steps`` steps at ``ratio`` times the discrete limit (``limits`` in s),
    local damping ``damping``, past the solver's refusal; ``cv`` (m2/s) converts to T_v."""
    dt = ratio * limits["discrete"]
    tv = steps * dt * cv            # H = 1 m
    return study.Run(f"{scene} damping {damping:g} dt/dt_discrete {ratio:.4f}",
                     base_args(scene) + ["-mpm_dt", repr(dt), "-mpm_allow_unstable",
                                         "-mpm_stability_analysis", "0",
                                         "-mpm_damping", repr(damping),
                                         "-mpm_Tv_end", repr(tv), "-mpm_Tv_report", repr(tv)],
                     os.path.join(runs_dir, scene, f"d{damping:g}-r{ratio:.4f}"))


def verdict(run):
    """True for a stable run, False for a blown-up one (exit 3); any other end stops the
    study."""
    if run.code == 0 and run.result and study.stable(run.result):
        return True
    if run.code == 3 and run.result and not study.stable(run.result):
        return False
    raise SystemExit(f"error: {run.name}: exit {run.code}: {run.stderr[-300:]}")


def log(message: str) -> None:
    """A progress line, shown at once: the runs behind it take minutes."""
    print(message, flush=True)


def arguments():
    """The parsed command line, with the destination resolved (``out``)."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cores", type=int, default=study.cores(),
                    help="runs at once, one rank each (default: the cores of this machine, "
                         "%(default)s)")
    ap.add_argument("--steps", type=int, default=4000,
                    help="steps of each stability probe (default %(default)s)")
    ap.add_argument("--ratios", default="0.25,0.5,0.75,0.9,1.1,1.25,1.5,2",
                    help="comma-separated dt / dt_discrete of the sweep (default %(default)s)")
    ap.add_argument("--bisect", type=int, default=5,
                    help="bisections between the largest stable and smallest unstable ratio "
                         "(default %(default)s)")
    ap.add_argument("--scenes", default=",".join(SCENES),
                    help="comma-separated scenes (default: all, %(default)s)")
    study.add_destination(ap, "stability-map", "stability-map.md, .png and .json")
    ap.add_argument("--runs", default=os.path.join(ROOT, "output", "stability"),
                    help="folder of the individual runs, reused by a re-run (default "
                         "output/stability)")
    args = ap.parse_args()
    args.out = study.destination(ap, args)
    return args


def critical_steps(scenes, args):
    """Per scene, the critical time steps (s) and the consolidation coefficient c_v
    (m2/s), from one short run each."""
    log("Critical time steps of each scene:")
    lim_runs = study.execute_all([limits_run(s, args.runs) for s in scenes], args.cores, log)
    limits = {s: r.result["dt_critical"] for s, r in zip(scenes, lim_runs)}
    cv = {s: r.result["c_v"] for s, r in zip(scenes, lim_runs)}
    return limits, cv


def sweep(scenes, ratios, limits, cv, args) -> dict:
    """Per (scene, damping), the (ratio, stable) of a probe at each of ``ratios`` times
    the discrete limit."""
    log("Sweep:")
    runs = {(s, d, r): probe(s, r, d, limits[s], cv[s], args.steps, args.runs)
            for s in scenes for d in DAMPING for r in ratios}
    study.execute_all(list(runs.values()), args.cores, log)
    return {(s, d): [(r, verdict(runs[(s, d, r)])) for r in ratios]
            for s in scenes for d in DAMPING}


def bisect(key, pts, limits, cv, args):
    """Halve --bisect times the gap between the largest stable and the smallest unstable
    ratio dt / dt_discrete of ``key`` = (scene, damping), adding each probe's (ratio,
    stable) to ``pts``. Returns key, stable ratio, unstable ratio; left as the sweep found
    them when it has no stable or no unstable run (None) or they are inverted."""
    s, d = key
    lo = max([r for r, ok in pts if ok], default=None)
    hi = min([r for r, ok in pts if not ok], default=None)
    if lo is None or hi is None or lo > hi:
        return key, lo, hi
    for _ in range(args.bisect):
        mid = 0.5 * (lo + hi)
        ok = verdict(study.execute(probe(s, mid, d, limits[s], cv[s], args.steps,
                                         args.runs), log))
        pts.append((mid, ok))
        lo, hi = (mid, hi) if ok else (lo, mid)
    return key, lo, hi


def bisect_all(points, limits, cv, args) -> dict:
    """The (stable, unstable) ratios of every (scene, damping), bisected side by side."""
    log("Bisection:")
    with ThreadPoolExecutor(max_workers=max(1, args.cores)) as pool:
        return {k: (lo, hi) for k, lo, hi in pool.map(
            lambda key: bisect(key, points[key], limits, cv, args), list(points))}


def scene_result(limits, points, found) -> dict:
    """One scene's results: its limits (s), every run's dt (s) and verdict, and the measured
    bracket (s) per damping, flagged when a stable run lies above an unstable one."""
    result = {"limits_s": limits, "runs": {}, "measured_s": {}}
    disc = limits["discrete"]
    for d in DAMPING:
        lo, hi = found[d]
        # A stable run above a blown-up one would make the limit ill-defined: flag it.
        pts = sorted(points[d])
        inverted = any(ok and any(not ok2 for r2, ok2 in pts if r2 < r) for r, ok in pts)
        result["runs"][f"{d:g}"] = [{"ratio": r, "dt_s": r * disc, "stable": ok}
                                    for r, ok in pts]
        result["measured_s"][f"{d:g}"] = {
            "stable_s": None if lo is None else lo * disc,
            "unstable_s": None if hi is None else hi * disc, "consistent": not inverted}
    return result


def main():
    args = arguments()
    os.chdir(ROOT)
    scenes = args.scenes.split(",")
    ratios = [float(r) for r in args.ratios.split(",")]
    limits, cv = critical_steps(scenes, args)
    points = sweep(scenes, ratios, limits, cv, args)
    found = bisect_all(points, limits, cv, args)
    result = {s: scene_result(limits[s], {d: points[(s, d)] for d in DAMPING},
                              {d: found[(s, d)] for d in DAMPING}) for s in scenes}
    output.write_json(os.path.join(args.out, "stability-map.json"),
                      {"steps_per_run": args.steps, "scenes": result})
    table = write_table(result, args)
    draw(result, args)
    print(table)
    return 0


def write_table(result, args):
    """stability-map.md in --out (time steps in s); returns its text."""
    rows = ["| scene | undrained (Table 1) | drag | discrete | measured, damping 0.5 | "
            "measured, no damping | paper's dt |", "|---|---|---|---|---|---|---|"]
    for s, r in result.items():
        L = r["limits_s"]
        cells = []
        for d in ("0.5", "0"):
            m = r["measured_s"][d]
            if m["stable_s"] is None or m["unstable_s"] is None:
                cells.append("outside the sweep")
                continue
            a, b = m["stable_s"], m["unstable_s"]
            cells.append(f"{a:.3g} - {b:.3g} ({a / L['discrete']:.3f} - "
                         f"{b / L['discrete']:.3f} x discrete)"
                         + ("" if m["consistent"] else " (not monotone)"))
        paper = PAPER_DT.get(s[:2])
        fate = ""
        if paper is not None and "tight" not in s:
            m = r["measured_s"]["0.5"]
            if m["stable_s"] is not None and m["unstable_s"] is not None:
                fate = " stable" if paper <= m["stable_s"] else (
                    " blows up" if paper >= m["unstable_s"] else " at the limit")
        rows.append(f"| {s.upper()} | {L['undrained']:.3g} | {L['drag']:.3g} | "
                    f"{L['discrete']:.3g} | {cells[0]} | {cells[1]} | "
                    f"{'' if paper is None or 'tight' in s else f'{paper:.0e}' + fate} |")
    text = "\n".join(["# Stability map", "",
                      f"Written by `scripts/stability-map` ({args.steps} steps per run; "
                      "'measured': the largest stable and the smallest unstable dt found, "
                      f"after {args.bisect} bisections). All time steps in s.", "",
                      *rows, "", "![stability map](stability-map.png)"])
    output.write_text(os.path.join(args.out, "stability-map.md"), text)
    return text


def draw(result, args):
    """stability-map.png in --out: per scene, the runs (stable or not) on a dt axis (s)
    beside every critical time step and the paper's dt."""
    plt = output.pyplot()
    n = len(result)
    fig, axes = plt.subplots(n, 1, figsize=(10, 1.3 * n + 1.2), sharex=True, squeeze=False)
    for ax, (s, r) in zip(axes[:, 0], result.items()):
        L = r["limits_s"]
        for key, label, col in CRITERIA:
            if key in L:
                ax.axvline(L[key], color=col, lw=1.5 if key == "discrete" else 1,
                           ls="-" if key in ("discrete", "drag") else "--",
                           label=label if ax is axes[0, 0] else None)
        paper = PAPER_DT.get(s[:2])
        if paper and "tight" not in s:
            ax.axvline(paper, color="tab:red", ls=":", lw=1.5,
                       label="paper's dt" if ax is axes[0, 0] else None)
        for y, d in ((1, "0.5"), (0, "0")):
            pts = r["runs"][d]
            ok = [p["dt_s"] for p in pts if p["stable"]]
            bad = [p["dt_s"] for p in pts if not p["stable"]]
            ax.plot(ok, [y] * len(ok), "o", color="tab:green", ms=5,
                    label="stable" if ax is axes[0, 0] and y == 1 else None)
            ax.plot(bad, [y] * len(bad), "x", color="tab:red", ms=6,
                    label="blew up" if ax is axes[0, 0] and y == 1 else None)
        ax.set_yticks([0, 1])
        ax.set_yticklabels(["no damping", "damping 0.5"], fontsize=8)
        ax.set_ylim(-0.6, 1.6)
        ax.set_xscale("log")
        ax.set_title(s[:5].upper() + TITLES.get(s, ""), fontsize=9, loc="left")
        ax.grid(alpha=0.3, axis="x")
    axes[-1, 0].set_xlabel("time step dt (s)")
    fig.legend(loc="upper center", ncol=5, fontsize=8, bbox_to_anchor=(0.5, 1.0))
    fig.tight_layout(rect=(0, 0, 1, 0.93))
    output.save_figure(fig, os.path.join(args.out, "stability-map.png"))


if __name__ == "__main__":
    sys.exit(main())
