"""Measured work-precision data, and the cheapest discretization that meets an accuracy target.

``scripts/convergence-study`` runs one scene over elements, meshes, points per cell and time
step fractions and stores, for every run, its cost (material points x steps, wall time) and
its errors. ``-mpm_target_error`` reads those data and picks the cheapest run whose measured
error meets the target. The data hold only for the scene they were measured on: the physical
parameters, the boundary conditions and the scheme options are stored with them and must
match the run's (another soil needs its own study, ``scripts/convergence-study
-options_file <scene>``).

The error measure (percent) is the largest error, against the compressible-water Terzaghi
solution, of everything the run reports at its report times (T_v = 0.02, 0.2, 0.5 and 1 in
the study): p at the monitor point (% of its reference), the L2 norm of the whole profile
(% of q) and the degree of consolidation U from the settlement and from the pore pressure
(% of the reference U). The compressible-water reference gives the numerical error alone,
which refinement drives down (against classic Terzaghi the compressible water leaves a floor
of a few percent, the model error of the paper's comparison).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os

from ..common.errors import InputError

DEFAULT = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "work_precision.json")
# What the measure judges: the summary's entries (their T_v, their errors in %).
JUDGED = {"monitor p": ("monitor", "error_consistent_pct", 1.0),
          "profile L2": ("profile_l2", "consistent", 100.0),
          "U_s": ("consolidation_degree", "error_settlement_consistent_pct", 1.0),
          "U_p": ("consolidation_degree", "error_pressure_consistent_pct", 1.0)}

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


def errors(summary) -> dict:
    """{quantity: (largest |error| (%), its T_v)} of a finished run's ``summary`` (its
    ``consolidation`` block) over its report times, for each quantity of JUDGED that it
    reports (U is none without a surface load)."""
    out = {}
    for name, (entry, key, scale) in JUDGED.items():
        table = summary.get(entry) or {}
        worst = [(abs(scale * e), tv) for tv, e in zip(table.get("Tv", []), table.get(key, []))
                 if e is not None and math.isfinite(e)]
        if worst:
            out[name] = max(worst)
    return out


def measure(summary) -> float:
    """The error measure (%) of a finished run's ``summary`` (its ``consolidation`` block;
    NaN when it reported nothing)."""
    return max((e for e, _ in errors(summary).values()), default=math.nan)


def worst(errs) -> str:
    """The quantity and T_v of the largest of :func:`errors`."""
    name, (e, tv) = max(errs.items(), key=lambda kv: kv[1][0])
    return f"{name} at T_v = {tv:g}"


def verdict(summary, target: float, measured_tv) -> tuple:
    """(met, the line that says so) of a finished run against ``target`` (%): met only when
    every judged error at every report time is within it. ``measured_tv``: the T_v the
    data measured (a report time outside them is said)."""
    errs = errors(summary)
    if not errs:
        return False, "not checked: the run reported nothing"
    largest = max(e for e, _ in errs.values())
    met = largest <= target
    line = (f"{'met' if met else 'NOT met'}: largest error {largest:.2f} % ({worst(errs)}); "
            + ", ".join(f"{name} {e:.2f} %" for name, (e, _) in errs.items()))
    extra = sorted({tv for _, tv in errs.values()} - set(measured_tv))
    if extra:
        line += (" (T_v = " + ", ".join(f"{t:g}" for t in extra) + " not in the "
                 "work-precision data)")
    return met, line


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


def pick(scene: dict, given: dict, target: float, path: str = "", scheme: dict = None):
    """The cheapest measured run (fewest material points x steps) with error <= ``target``
    (%), the lines that explain the choice and the T_v the data measured, for the run of
    :func:`scene_signature` ``scene`` that gives the options ``given`` ({name: value} of
    PICKED's that its command line or scene sets) and the scheme options ``scheme`` ({name:
    value or 'auto'} of SCHEME_KEYS; missing: auto): runs measured with another scheme are
    left out. InputError when the data do not fit the scene or no measured run meets the
    target."""
    path = path or DEFAULT
    data = load(path)
    bad = _mismatch(data["scene"], scene)
    if bad:
        key, want, have = bad
        raise InputError(f"-mpm_target_error: the work-precision data ({path}) were measured "
                         f"with -mpm_{key} {want}, this run has {have}; run "
                         "scripts/convergence-study for this scene and pass its file with "
                         "-mpm_work_precision")
    if data.get("judged") != list(JUDGED):
        raise InputError(f"-mpm_target_error: the work-precision data ({path}) judge the "
                         "monitor point only; run scripts/convergence-study again to measure "
                         "the profile and U too")
    measured = [r for r in data["runs"] if math.isfinite(r.get("measure", math.nan))]
    runs = [r for r in measured if _same_scheme(r, scheme or {})]
    meets = sorted((r for r in runs if r["measure"] <= target), key=lambda r: r["cost"])
    if not meets:
        best = min(runs, key=lambda r: r["measure"])
        raise InputError(f"-mpm_target_error {target:g}: no measured discretization reaches "
                         f"it; the most accurate is {_describe(best)} with "
                         f"{best['measure']:.2f} % (refine further with "
                         "scripts/convergence-study)")
    choice = meets[0]
    tvs = ", ".join(f"{t:g}" for t in data["Tv"])
    lines = [f"Target error {target:g} % (the largest error against compressible-water "
             f"Terzaghi of p at the monitor point, the profile's L2 (% of q), U from the "
             f"settlement and U from the pore pressure, at T_v = {tvs}; from "
             f"{os.path.basename(path)}, {len(runs)} measured runs):",
             f"  picked {_describe(choice)}: measured {choice['measure']:.2f} % "
             f"({choice['worst']}), {choice['steps']} steps of {choice['n_points']} points "
             f"({choice['cost']:.3g} point-steps), the cheapest of {len(meets)} that meet "
             "it; its time on this machine is measured from its first steps"]
    if len(runs) < len(measured):
        lines.append(f"  {len(measured) - len(runs)} measured runs left out: their scheme "
                     "(kinematics, pressure projection, liquid basis, lumping) is not what "
                     "these options give their cell type")
    cheaper = [r for r in runs if r["cost"] < choice["cost"]]
    if cheaper:
        near = min(cheaper, key=lambda r: r["measure"])
        lines.append(f"  cheaper runs miss it: the best of them, {_describe(near)}, "
                     f"measured {near['measure']:.2f} % at {near['cost']:.3g} point-steps")
    overridden = [k for k in PICKED if k in given and given[k] != _value(choice, k)]
    if overridden:
        lines.append("  this overrides " + ", ".join(
            f"-mpm_{k} {_text(given[k])}" for k in overridden))
    return choice, lines, tuple(data["Tv"])


SCHEME_KEYS = ("lumping", "kinematics", "pressure_projection", "liquid_basis")


def _same_scheme(run, choices: dict) -> bool:
    """Whether ``run`` was measured with the scheme that the scheme options ``choices``
    ({name: value or 'auto'}) resolve to on its cell type (data measured before a default
    changed are not; a run that did not record its scheme is taken as it is)."""
    from ..stepping.scheme import AUTO_KEYS, Scheme

    scheme = Scheme.resolve(run["element"], choices)
    return all(run.get(k, getattr(scheme, k)) == getattr(scheme, k) for k in AUTO_KEYS)


def _value(run, key):
    v = run[key]
    return tuple(v) if isinstance(v, list) else v


def _text(v) -> str:
    return ",".join(map(str, v)) if isinstance(v, tuple) else str(v)


def apply(p, choice):
    """A copy of the run's parameters ``p`` (frozen) with the picked discretization."""
    return dataclasses.replace(p, **{key: _value(choice, key) for key in PICKED})


class Pace:
    """The run's own step cost on this machine, measured over its first steps, and the
    stepping time it predicts (what the data's wall times, taken elsewhere, cannot say).

    The clock starts after WARM_UP steps (the first ones load the compiled kernels) and
    stops after 0.5 s or 1 % of the steps, whichever comes first (at least 50 steps): before
    the first report time of the default scenes (T_v = 0.02 of 1, 2 %), whose outputs are
    a few per run and would be extrapolated as if every step wrote them."""

    WARM_UP, MIN_STEPS, MIN_SECONDS, SHARE = 10, 50, 0.5, 0.01

    def __init__(self, first: int, last: int, t0: float):
        self.first, self.last, self.t0 = first, last, t0     # steps, perf_counter (s)
        self.start = None            # (step, perf_counter) where the clock started
        self.predicted = None

    def tick(self, k: int, now: float):
        """After step ``k`` at ``now`` (perf_counter): the line of the prediction (s) of the
        whole stepping, once (kept in ``predicted``); None otherwise."""
        if self.predicted is not None:
            return None
        if self.start is None:
            if k - self.first + 1 >= min(self.WARM_UP, self.last - self.first):
                self.start = (k, now)
            return None
        done, elapsed = k - self.start[0], now - self.start[1]
        if k < self.last and (done < self.MIN_STEPS or elapsed < self.MIN_SECONDS
                              and done < self.SHARE * (self.last - self.first)):
            return None
        per_step = elapsed / max(done, 1)
        self.predicted = (self.start[1] - self.t0) + per_step * (self.last - self.start[0])
        return (f"Target error: {1e6 * per_step:.3g} us per step on this machine (steps "
                f"{self.start[0] + 1}-{k}): about {self.predicted:.3g} s for the "
                f"{self.last - self.first + 1} steps")
