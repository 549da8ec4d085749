#!/usr/bin/env python3
"""Stability and cost of the consolidation step against permeability: explicit against
implicit drag, with and without mass scaling, on M1-Q4 with k from 1e-2 to 1e-9 m/s.

For every k and configuration:
- the critical time steps (a run of a few steps; the discrete limit follows the drag
  treatment and the mass scaling), and the step the solver takes;
- the measured stability: --steps steps at 0.9 and 1.1 times the discrete limit
  (-mpm_allow_unstable), stable or blown up (the solver's own blow-up check, exit 3);
- the steps to reach T_v = 0.5 and the wall time: measured by running there when it takes at
  most --max-steps steps (with the errors at T_v = 0.1 and 0.5 against Terzaghi with
  compressible water), else estimated from the measured time per step of the probes.

    scripts/permeability-map [--cores 2] [--publish]

writes output/studies/permeability-map/permeability-map.{json,md,png} (--publish:
docs/results/); the runs go to output/permeability/ (a re-run reuses them).
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

from solver.io import output  # noqa: E402
from solver.studies import study  # noqa: E402

PERMEABILITY = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9)
CONFIGS = {"explicit drag": ["-mpm_drag", "explicit", "-mpm_mass_scaling", "none"],
           "implicit drag": ["-mpm_drag", "implicit", "-mpm_mass_scaling", "none"],
           "explicit drag, mass scaling auto": ["-mpm_drag", "explicit",
                                                "-mpm_mass_scaling", "auto"],
           "implicit drag, mass scaling auto": ["-mpm_drag", "implicit",
                                                "-mpm_mass_scaling", "auto"]}
STYLE = {"explicit drag": ("tab:orange", "o"), "implicit drag": ("tab:blue", "s"),
         "explicit drag, mass scaling auto": ("tab:red", "^"),
         "implicit drag, mass scaling auto": ("tab:green", "D")}
REPORT = "0.1,0.5"
TV_END = 0.5


CASE = "cases/consolidation-m1-q4.opts"


def base(k, config):
    """The run's options; `auto` is resolved once for the run to T_v = 0.5 (it depends on
    the earliest report time, which the short runs change) and given as a number."""
    opts = list(CONFIGS[config])
    if "auto" in opts:
        from solver.stepping import inertia
        from solver.model.soil import Soil

        p = study.read_scene(os.path.join(ROOT, CASE), ["-mpm_k", f"{k:g}", "-mpm_Tv_end",
                                                       str(TV_END), "-mpm_Tv_report", REPORT])
        S = inertia.auto_factor(Soil.from_options(p), p.size[1], min(p.Tv_report),
                                p.damping, p.fast_damping)
        opts[opts.index("auto")] = f"{S:.6g}"
    return ["-options_file", CASE, "-mpm_k", f"{k:g}", *opts, "-mpm_figures", "0",
            "-mpm_progress", "0"]


def folder(runs, k, config, what):
    """The folder of one run: RUNS/k<k>/<config>/<what>."""
    return os.path.join(runs, f"k{k:g}", config.replace(" ", "").replace(",", "-"), what)


def log(message: str) -> None:
    """A progress line, shown at once: the runs behind it take minutes."""
    print(message, flush=True)


def arguments():
    """The parser and the parsed command line."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cores", type=int, default=study.cores(), help="runs at once")
    ap.add_argument("--steps", type=int, default=4000, help="steps of each stability probe")
    ap.add_argument("--max-steps", type=int, default=300000,
                    help="run to T_v = 0.5 only when it takes at most this many steps")
    ap.add_argument("--runs", default=os.path.join(ROOT, "output", "permeability"),
                    help="folder of the individual runs (reused by a re-run)")
    study.add_destination(ap, "permeability-map", "permeability-map.md, .png and .json")
    return ap, ap.parse_args()


def critical_steps(keys, args):
    """The short run of each (k, configuration) of ``keys``, and the row each starts: the
    critical time steps (s), the governing one, the step taken (s), the mass-scaling
    factor, Pi and the steps to T_v = 0.5 at that step."""
    log("Critical time steps:")
    # T_v = 1e-12 is a step or a few, whatever k: the summary then holds every limit.
    lim = {key: study.Run(f"k = {key[0]:g} {key[1]} limits",
                          base(*key) + ["-mpm_Tv_end", "1e-12", "-mpm_Tv_report", "1e-12"],
                          folder(args.runs, *key, "limits")) for key in keys}
    study.execute_all(list(lim.values()), args.cores, log)
    info = {}
    for key, run in lim.items():
        s = run.result
        if s is None:
            raise SystemExit(f"error: {run.name}: exit {run.code}: {run.stderr[-300:]}")
        info[key] = {"k": key[0], "config": key[1], "limits_s": s["dt_critical"],
                     "governing": s["dt_governing"], "dt_s": s["dt"],
                     "mass_scaling": s["mass_scaling"], "Pi": s["regime"]["Pi"],
                     "steps_to_0.5": TV_END / s["c_v"] / s["dt"]}    # H = 1 m
    return lim, info


def probe(key, ratio, disc, cv, args):
    """A run of --steps steps at ``ratio`` times the discrete limit ``disc`` (s), past the
    solver's refusal; ``cv``: the consolidation coefficient (m2/s)."""
    dt = ratio * disc
    tv = args.steps * dt * cv            # H = 1 m
    return study.Run(f"k = {key[0]:g} {key[1]} dt = {ratio} x discrete",
                     base(*key) + ["-mpm_dt", repr(dt), "-mpm_allow_unstable",
                                   "-mpm_stability_analysis", "0", "-mpm_Tv_end", repr(tv),
                                   "-mpm_Tv_report", repr(tv)],
                     folder(args.runs, *key, f"r{ratio}"))


def probe_stability(keys, lim, info, args) -> None:
    """Into each row: stable or not at 0.9 and 1.1 times the discrete limit, and the wall
    seconds per step at 0.9."""
    log("Stability probes:")
    probes = {(key, ratio): probe(key, ratio, info[key]["limits_s"]["discrete"],
                                  lim[key].result["c_v"], args)
              for key in keys for ratio in (0.9, 1.1)}
    study.execute_all(list(probes.values()), args.cores, log)
    for (key, ratio), run in probes.items():
        if run.result is None or run.code not in (0, 3):
            raise SystemExit(f"error: {run.name}: exit {run.code}: {run.stderr[-300:]}")
        info[key][f"stable_at_{ratio}"] = bool(run.code == 0 and study.stable(run.result))
        if ratio == 0.9 and run.result["steps"]:
            info[key]["seconds_per_step"] = study.wall_seconds(run.result) / run.result["steps"]


def run_to_end(keys, info, args) -> None:
    """Into each row: the steps and wall seconds to T_v = 0.5 and the errors (% of q) at
    the report times, measured where it takes at most --max-steps steps, else estimated
    from the probes' time per step."""
    log("Runs to T_v = 0.5:")
    full = {key: study.Run(f"k = {key[0]:g} {key[1]} to T_v = 0.5",
                           base(*key) + ["-mpm_Tv_end", str(TV_END), "-mpm_Tv_report", REPORT],
                           folder(args.runs, *key, "full"))
            for key in keys if info[key]["steps_to_0.5"] <= args.max_steps}
    study.execute_all(list(full.values()), args.cores, log)
    for key in keys:
        r = info[key]
        run = full.get(key)
        if run is not None and run.result and "monitor" in run.result:
            m = run.result["monitor"]
            r.update(measured=True, steps=run.result["steps"],
                     wall_s=study.wall_seconds(run.result),
                     error_pct=[100 * (a - b) for a, b in zip(m["p_over_q"], m["consistent"])])
        else:
            r.update(measured=False, steps=r["steps_to_0.5"],
                     wall_s=r["steps_to_0.5"] * r.get("seconds_per_step", float("nan")))


def write(rows, args, dest) -> None:
    """permeability-map.json, .md and .png in ``dest``; the table printed."""
    os.makedirs(dest, exist_ok=True)
    output.write_json(os.path.join(dest, "permeability-map.json"),
                      {"scene": "consolidation-m1-q4", "steps_per_probe": args.steps,
                       "max_steps": args.max_steps, "rows": rows})
    text = table(rows, args)
    output.write_text(os.path.join(dest, "permeability-map.md"), text)
    draw(rows, os.path.join(dest, "permeability-map.png"))
    print(text)


def main():
    ap, args = arguments()
    dest = study.destination(ap, args)
    os.chdir(ROOT)
    keys = [(k, c) for k in PERMEABILITY for c in CONFIGS]
    lim, info = critical_steps(keys, args)
    probe_stability(keys, lim, info, args)
    run_to_end(keys, info, args)
    write([info[key] for key in keys], args, dest)


def table(rows, args):
    """The Markdown report: one row per (k, configuration); time steps in s."""
    out = ["# Permeability map (M1-Q4)", "",
           f"Written by `scripts/permeability-map`. Probes: {args.steps} steps at 0.9 and 1.1 "
           "times the discrete limit (S: stable, X: blew up). Steps and wall time to T_v = "
           f"0.5 on 1 rank: measured where at most {args.max_steps} steps, else estimated (~) "
           "from the probes' time per step. Errors: p at the monitor point against Terzaghi "
           "with compressible water, % of q.", "",
           "| k (m/s) | drag, scaling | Pi | S | governing | dt (s) | 0.9 / 1.1 x discrete | "
           "steps to T_v = 0.5 | wall (s) | error T_v = 0.1, 0.5 |",
           "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        probe = ("S" if r["stable_at_0.9"] else "X") + " / " + \
            ("S" if r["stable_at_1.1"] else "X")
        est = "" if r["measured"] else "~"
        err = ", ".join(f"{e:+.2f}" for e in r["error_pct"]) if r["measured"] else ""
        out.append(f"| {r['k']:.0e} | {r['config']} | {r['Pi']:.3g} | {r['mass_scaling']:.3g}"
                   f" | {r['governing']} | {r['dt_s']:.3g} | {probe} | {est}{r['steps']:.3g} "
                   f"| {est}{r['wall_s']:.3g} | {err} |")
    out += ["", "![permeability map](permeability-map.png)"]
    return "\n".join(out)


def draw(rows, path):
    """Steps and wall time (s) to T_v = 0.5 against k (m/s), one line per configuration."""
    plt = output.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.3))
    for config, (col, mk) in STYLE.items():
        mine = sorted((r for r in rows if r["config"] == config), key=lambda r: r["k"])
        k = [r["k"] for r in mine]
        for ax, key in zip(axes, ("steps", "wall_s")):
            ax.loglog(k, [r[key] for r in mine], "-", color=col, lw=1, label=config)
            for r in mine:
                ax.loglog(r["k"], r[key], mk, color=col, ms=6,
                          mfc=col if r["measured"] else "none")
    axes[0].axhline(1e8, color="k", ls=":", lw=0.8)
    axes[0].text(1.5e-9, 1.3e8, "refused (1e8 steps)", fontsize=7)
    axes[0].set_ylabel("steps to T_v = 0.5")
    axes[1].set_ylabel("wall time to T_v = 0.5 (s, 1 rank)")
    for ax in axes:
        ax.set_xlabel("hydraulic conductivity k (m/s)")
        ax.grid(alpha=0.3, which="both")
    axes[1].axhline(3600, color="k", ls=":", lw=0.8)
    axes[1].text(1.5e-9, 4500, "1 hour", fontsize=7)
    axes[0].legend(fontsize=7)
    fig.suptitle("M1-Q4 consolidation against permeability (filled: measured, open: "
                 "estimated from the time per step)")
    output.save_figure(fig, path)


if __name__ == "__main__":
    main()
