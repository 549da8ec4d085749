"""Measured work-precision data, and the cheapest discretization that meets an accuracy target.

``scripts/convergence-study`` runs one scene over elements, meshes, points per cell and time
step fractions and stores, for every run, its cost (material points x steps, wall time) and
its errors. ``-mpm_target_error`` reads those data and picks the cheapest run whose measured
error meets the target. The data hold only for the scene they were measured on: the physical
parameters, the boundary conditions and the scheme options are stored with them and must
match the run's (another soil needs its own study, ``scripts/convergence-study
-options_file <scene>``).

The error measure (percent) is the largest |error| at the monitor point against the
compressible-water Terzaghi solution at T_v = 0.5 and 1: the numerical error alone, which
refinement drives to zero (against classic Terzaghi the compressible water leaves a floor of
a few percent, the model error of the paper's comparison).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os

from .errors import InputError

DEFAULT = os.path.join(os.path.dirname(__file__), "data", "work_precision.json")
MEASURE_TV = (0.5, 1.0)

# What the measured error depends on besides the discretization: it must match.
SCENE_KEYS = ("E", "nu", "rho_s", "rho_l", "porosity", "K_l", "mu_l", "k", "size", "gravity",
              "drained", "bc_left", "bc_right", "bc_bottom", "bc_top", "damping", "flip",
              "lumping", "kinematics", "pressure_projection", "liquid_basis", "load_ramp",
              "points", "drag", "mass_scaling", "bulk_viscosity", "fast_damping")
# What the target picks.
PICKED = ("element", "cells", "ppc", "dt_safety")


def scene_signature(p) -> dict:
    sig = {k: getattr(p, k) for k in SCENE_KEYS}
    return {k: list(v) if isinstance(v, tuple) else v for k, v in sig.items()}


def measure(summary) -> float:
    """The error measure (%) of a finished run's summary: the largest |error| against the
    compressible-water reference at T_v = 0.5 and 1 (NaN when the run did not reach both)."""
    mon = summary.get("monitor") or {}
    errs = {round(tv, 9): e for tv, e in zip(mon.get("Tv", []),
                                             mon.get("error_consistent_pct", []))}
    if not all(round(tv, 9) in errs for tv in MEASURE_TV):
        return math.nan
    return max(abs(errs[round(tv, 9)]) for tv in MEASURE_TV)


def load(path: str) -> dict:
    try:
        with open(path) as fh:
            data = json.load(fh)
    except OSError as exc:
        raise InputError(f"-mpm_work_precision {path}: cannot be read ({exc.strerror})") \
            from None
    except ValueError:
        raise InputError(f"-mpm_work_precision {path}: not a JSON work-precision file") \
            from None
    if not isinstance(data, dict) or "runs" not in data or "scene" not in data:
        raise InputError(f"-mpm_work_precision {path}: not a work-precision file "
                         "(written by scripts/convergence-study)")
    return data


def _mismatch(scene: dict, sig: dict):
    for key, want in scene.items():
        have = sig.get(key)
        if isinstance(want, (int, float)) and isinstance(have, (int, float)):
            same = math.isclose(want, have, rel_tol=1e-9, abs_tol=1e-300)
        else:
            same = want == have
        if not same:
            return key, want, have
    return None


def _describe(run) -> str:
    return (f"{run['element'].upper()}, {run['cells'][0]} x {run['cells'][1]} cells, "
            f"{run['ppc']} x {run['ppc']} points per cell, dt_safety {run['dt_safety']:g}")


def pick(p, target: float, path: str = ""):
    """The cheapest measured run (fewest material points x steps) with error <= ``target``
    (%), and the lines that explain the choice. InputError when the data do not fit the
    scene or no measured run meets the target."""
    path = path or DEFAULT
    data = load(path)
    bad = _mismatch(data["scene"], scene_signature(p))
    if bad:
        key, want, have = bad
        raise InputError(f"-mpm_target_error: the work-precision data ({path}) were measured "
                         f"with -mpm_{key} {want}, this run has {have}; run "
                         "scripts/convergence-study for this scene and pass its file with "
                         "-mpm_work_precision")
    runs = [r for r in data["runs"] if math.isfinite(r.get("measure", math.nan))]
    meets = sorted((r for r in runs if r["measure"] <= target), key=lambda r: r["cost"])
    if not meets:
        best = min(runs, key=lambda r: r["measure"])
        raise InputError(f"-mpm_target_error {target:g}: no measured discretization reaches "
                         f"it; the most accurate is {_describe(best)} with "
                         f"{best['measure']:.2f} % (refine further with "
                         "scripts/convergence-study)")
    choice = meets[0]
    lines = [f"Target error {target:g} % (largest |error| against compressible-water "
             f"Terzaghi at T_v = 0.5 and 1, from {os.path.basename(path)}, "
             f"{len(runs)} measured runs):",
             f"  picked {_describe(choice)}: measured {choice['measure']:.2f} % at "
             f"{choice['cost']:.3g} point-steps ({choice['wall_seconds']:.0f} s on "
             f"{choice['ranks']} rank(s)), the cheapest of {len(meets)} that meet it"]
    cheaper = [r for r in runs if r["cost"] < choice["cost"]]
    if cheaper:
        near = min(cheaper, key=lambda r: r["measure"])
        lines.append(f"  cheaper runs miss it: the best of them, {_describe(near)}, "
                     f"measured {near['measure']:.2f} % at {near['cost']:.3g} point-steps")
    given = [k for k in PICKED if k in p.given and getattr(p, k) != _value(choice, k)]
    if given:
        lines.append("  this overrides " + ", ".join(
            f"-mpm_{k} {_text(getattr(p, k))}" for k in given))
    return choice, lines


def _value(run, key):
    v = run[key]
    return tuple(v) if isinstance(v, list) else v


def _text(v) -> str:
    return ",".join(map(str, v)) if isinstance(v, tuple) else str(v)


def apply(p, choice):
    """A copy of the run's parameters ``p`` (frozen) with the picked discretization."""
    return dataclasses.replace(p, **{key: _value(choice, key) for key in PICKED})
