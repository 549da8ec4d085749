#!/usr/bin/env python3
"""Damping without bias: which damping takes the undrained wave out and leaves consolidation
alone, on columns whose regime number Pi (consolidation time over wave period) runs from 6
to 435.

Every scene is the paper's column on 1 x 40 Q4 cells, 1 point per cell, implicit drag,
with E and k varied to set Pi; every variant runs to T_v = 1 and is compared with Terzaghi's
solution with compressible water at the monitor point (error in % of q) at T_v = 0.05, 0.1,
0.5 and 1. Variants: no damping, local damping 0.5, bulk viscosity b1 = 0.5, fast-part
damping zeta = 0.5 and 1, a load ramp over one wave period (no damping), and
-mpm_mass_scaling auto (with local damping 0.5).

    scripts/damping-study [-j JOBS] [--publish]

writes output/studies/damping-study/damping-study.{json,png} (--publish: docs/results/);
the runs go to output/damping/ (a re-run reuses them).
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

from solver.stepping import inertia  # noqa: E402
from solver.io import output  # noqa: E402
from solver.model.soil import Soil  # noqa: E402
from solver.studies import study  # noqa: E402

# (E in Pa, k in m/s): Pi = 6, 25, 59, 183, 435 on the paper's column.
SCENES = [(1e8, 2.5e-3), (1e8, 6e-4), (1e8, 2.5e-4), (1e7, 6e-4), (1e7, 2.5e-4)]
REPORT = (0.05, 0.1, 0.5, 1.0)
VARIANTS = {
    "none": ["-mpm_damping", "0"],
    "local 0.5": ["-mpm_damping", "0.5"],
    "bulk viscosity 0.5": ["-mpm_damping", "0", "-mpm_bulk_viscosity", "0.5"],
    "fast-part 0.5": ["-mpm_damping", "0", "-mpm_fast_damping", "0.5"],
    "fast-part 1": ["-mpm_damping", "0", "-mpm_fast_damping", "1"],
    "load ramp T_w": ["-mpm_damping", "0", "-mpm_load_ramp", "RAMP"],
    "mass scaling auto": ["-mpm_damping", "0.5", "-mpm_mass_scaling", "auto"],
}
CASE = os.path.join(ROOT, "cases", "consolidation-stiff.opts")


def scene_args(E, k):
    return ["-options_file", CASE, "-mpm_E", f"{E:g}", "-mpm_k", f"{k:g}", "-mpm_ppc", "1",
            "-mpm_mass_scaling", "none", "-mpm_Tv_end", "1",
            "-mpm_Tv_report", ",".join(map(str, REPORT)), "-mpm_figures", "0",
            "-mpm_progress", "0"]


def job(E, k, label, runs):
    """The run of one variant on one scene; RAMP becomes the scene's wave period 4H/c1."""
    extra = VARIANTS[label]
    if "RAMP" in extra:
        p = study.read_scene(CASE, scene_args(E, k)[2:])
        T_w = inertia.regime(Soil.from_options(p), p.size[1], min(p.Tv_report), p.damping,
                             p.fast_damping)["wave_period_s"]
        extra = [f"{T_w:.6g}" if a == "RAMP" else a for a in extra]
    return study.Run(f"E = {E:g} k = {k:g} {label}", scene_args(E, k) + extra,
                     os.path.join(runs, f"{E:g}-{k:g}-{label.replace(' ', '_')}"))


def row(E, k, label, run):
    if run.result is None or run.code != 0:
        return {"E": E, "k": k, "variant": label, "failed": run.stderr[-300:]}
    s, m = run.result, run.result["monitor"]
    return {"E": E, "k": k, "variant": label, "Pi": s["regime"]["Pi"],
            "S": s["mass_scaling"], "steps": s["steps"], "wall_s": study.wall_seconds(s),
            "error_pct": [100 * (a - b) for a, b in zip(m["p_over_q"], m["consistent"])]}


def figure(rows, path):
    plt = output.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharey=True)
    for label in VARIANTS:
        mine = sorted((r for r in rows if r["variant"] == label and "Pi" in r),
                      key=lambda r: r["Pi"])
        Pi = [r["Pi"] for r in mine]
        early = [max(abs(r["error_pct"][0]), 1e-3) for r in mine]
        late = [max(max(abs(e) for e in r["error_pct"][1:]), 1e-3) for r in mine]
        axes[0].loglog(Pi, early, "o-", label=label)
        axes[1].loglog(Pi, late, "o-", label=label)
    axes[0].set_title("T_v = 0.05 (the wave's tail)")
    axes[1].set_title("largest over T_v = 0.1, 0.5, 1 (the settlement)")
    for ax in axes:
        ax.set_xlabel("Pi = (H^2/c2) / (4H/c1)")
        ax.axhline(1.0, color="k", lw=0.6, ls=":")
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("|p - p_Terzaghi| at the monitor point (% of q)")
    axes[1].legend(fontsize=7)
    fig.suptitle("Damping of the undrained wave, 1 x 40 Q4 cells (1 point each), "
                 "implicit drag")
    output.save_figure(fig, path)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("-j", type=int, default=study.cores(), help="runs at once (1 rank each)")
    ap.add_argument("--runs", default=os.path.join(ROOT, "output", "damping"),
                    help="folder of the individual runs (reused by a re-run)")
    study.add_destination(ap, "damping-study", "damping-study.json and .png")
    args = ap.parse_args()
    dest = study.destination(ap, args)
    os.makedirs(dest, exist_ok=True)
    keys = [(E, k, label) for E, k in SCENES for label in VARIANTS]
    runs = study.execute_all([job(*key, args.runs) for key in keys], args.j,
                             lambda m: print(m, flush=True))
    rows = [row(*key, run) for key, run in zip(keys, runs)]
    for r in rows:
        errs = " ".join(f"{e:+7.2f}" for e in r.get("error_pct", []))
        print(f"E = {r['E']:.0e} k = {r['k']:.1e} Pi = {r.get('Pi', float('nan')):6.1f} "
              f"{r['variant']:20s} {errs or r.get('failed')}")
    output.write_json(os.path.join(dest, "damping-study.json"),
                      {"report_Tv": REPORT, "runs": rows})
    figure(rows, os.path.join(dest, "damping-study.png"))
    print("wrote", dest)


if __name__ == "__main__":
    main()
