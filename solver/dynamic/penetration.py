"""A rigid strip footing pushed into the flowing body (:mod:`solver.dynamic.flowing`,
``-mpm_footing`` with ``-mpm_kinematics large``): its plan from the options, its
pressure-settlement curve as the steps go, and its report (``load_displacement.csv`` and
its figure, the summary's ``footing`` block, the printed lines).

The curve: a row every ``every`` steps, the settlement at its last step and the mean
contact pressure over its steps (a step's pressure carries the explicit step's ringing).
The plateau: the curve's mean pressure between settlements of 2.5 % and 5 % of the
footing's width B (twice x1 on a half model, x0 = 0), where Prandtl's (2 + pi) c_u is the
reference of a Tresca soil without weight; past that the footing is embedded and the
soil heaved beside it, and no closed form applies.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from petsc4py import PETSc

from ..common.errors import InputError
from ..io import output
from ..stepping.footing import Footing

WINDOW = (0.025, 0.05)       # the plateau's settlements, in footing widths
ROWS = 400                   # about so many rows in the curve
RAMP = 20.0                  # the ramp's duration in shear-wave crossings of x1 - x0


def plan_of(extent, rough, velocity, settlement, body, shear_wave, cohesion) -> dict:
    """The footing of ``extent`` (x0, x1) (m), ``rough`` or not, pushed at ``velocity``
    (m/s) to ``settlement`` (m) into the ``body`` (size (W, H) (m), cells (across, up),
    points per cell) of shear-wave speed ``shear_wave`` (m/s); ``cohesion``: c_u (Pa) of
    a weightless Tresca soil (Prandtl's the reference), else NaN. Returns its extent,
    interface, speed, ramp (s), end settlement, width B (m), the markers' inset and the
    reference (Pa, its name; NaN, '' where none applies). InputError where it does not
    fit."""
    (x0, x1), ((W, H), (cols, rows), ppc) = extent, body
    if not 0 <= x0 < x1 <= W:
        raise InputError(f"-mpm_footing {x0:g},{x1:g}: 0 <= x0 < x1 <= the body's width "
                         f"{W:g} m")
    if settlement >= H:
        raise InputError(f"-mpm_footing_settlement {settlement:g}: less than the body's "
                         f"height {H:g} m")
    tresca = not math.isnan(cohesion)
    return {"x": (x0, x1), "rough": rough, "velocity": velocity,
            "ramp": RAMP * (x1 - x0) / shear_wave, "settlement": settlement,
            "width": 2 * x1 if x0 == 0 else x1 - x0,
            "inset": (0.5 * W / cols / ppc, 0.5 * H / rows / ppc),
            "reference": ((2 + math.pi) * cohesion, "Prandtl (2 + pi) c_u") if tresca
            else (math.nan, "")}


def make(grid, size, footing) -> Footing:
    """The :class:`Footing` of the plan's ``footing`` on the body of ``size`` (m)."""
    f = footing
    return Footing(grid, *f["x"], size[1], f["rough"], f["velocity"], f["ramp"],
                   f["settlement"], inset=f["inset"])


def duration(grid, size, footing) -> float:
    """The run's end (s): when the footing reaches its settlement."""
    return make(grid, size, footing).duration()


class Curve:
    """The pressure-settlement curve as the steps go (every rank alike: the footing's force
    is the whole grid's)."""

    def __init__(self, footing: Footing, nsteps: int):
        self.footing = footing
        self.every = max(1, nsteps // ROWS)
        self.rows, self.total, self.count = [], 0.0, 0

    def sample(self, k: int, last: bool) -> None:
        self.total += self.footing.pressure
        self.count += 1
        if k % self.every == 0 or last:
            self.rows.append((self.footing.settlement(self.footing.t), self.total / self.count))
            self.total, self.count = 0.0, 0

    def state(self) -> dict:
        return {"footing": self.footing.state(), "curve": self.rows,
                "curve_sum": (self.total, self.count)}

    def restore(self, state) -> None:
        self.footing.restore(state["footing"])
        self.rows = [tuple(r) for r in state["curve"]]
        self.total, self.count = float(state["curve_sum"][0]), int(state["curve_sum"][1])

    def progress(self) -> str:
        p = self.rows[-1][1] if self.rows else 0.0
        return (f"settlement {1e3 * self.footing.settlement(self.footing.t):.4g} mm, "
                f"pressure {p / 1e3:.4g} kPa")


def block(plan, curve: Curve) -> dict:
    """The summary's ``footing`` block."""
    f = plan.footing
    rows = np.array(curve.rows).reshape(-1, 2)
    lo, hi = (w * f["width"] for w in WINDOW)
    inside = (rows[:, 0] >= lo) & (rows[:, 0] <= hi)
    plateau = float(rows[inside, 1].mean()) if inside.any() else math.nan
    ref, name = f["reference"]
    return {"extent_m": list(f["x"]), "width_m": f["width"],
            "interface": "rough" if f["rough"] else "smooth",
            "velocity_m_per_s": f["velocity"], "ramp_s": f["ramp"],
            "settlement_m": float(rows[-1, 0]) if len(rows) else 0.0,
            "pressure_final_pa": float(rows[-1, 1]) if len(rows) else math.nan,
            "plateau_window_m": [lo, hi], "plateau_pa": plateau,
            "reference_pa": ref, "reference": name,
            "plateau_error_pct": 100 * (plateau / ref - 1) if name else math.nan}


def write(plan, curve: Curve, files: dict, figures: bool = True) -> None:
    """load_displacement.csv and, where ``figures`` and the run's outputs ask, its figure
    (rank 0)."""
    f = plan.footing
    ref, name = f["reference"]
    outputs = plan.outputs if figures else dataclasses.replace(plan.outputs, figures=False)
    files.update(output.load_displacement(
        outputs, np.array(curve.rows).reshape(-1, 2), ref,
        name + " (small settlement)" if name else "", "mean contact pressure (kPa)",
        window=[w * f["width"] for w in WINDOW]))


def print_results(b: dict, comm) -> None:
    PETSc.Sys.Print(
        f"Footing: settlement {b['settlement_m']:.4g} m, pressure {b['pressure_final_pa']:.6g}"
        f" Pa at the end; at small settlement ({1e3 * b['plateau_window_m'][0]:.3g} to "
        f"{1e3 * b['plateau_window_m'][1]:.3g} mm) {b['plateau_pa']:.6g} Pa"
        + (f"; {b['reference']} = {b['reference_pa']:.6g} Pa: "
           f"{b['plateau_error_pct']:+.2f} %" if b["reference"] else ""), comm=comm)


def describe(plan) -> str:
    f = plan.footing
    return (f"a {'rough' if f['rough'] else 'smooth'} footing from {f['x'][0]:g} to "
            f"{f['x'][1]:g} m pushed {f['settlement']:g} m at {f['velocity']:g} m/s "
            f"(ramped over {f['ramp']:.3g} s)")

