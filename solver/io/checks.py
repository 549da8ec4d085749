"""The checks of the ``-mpm_`` options' values (:data:`solver.io.options.SPEC`): each takes a
parsed value and returns the problem in words, or None."""

from __future__ import annotations

import math

LIMIT = 1e30   # larger magnitudes overflow the products the solver forms


def parse_float(text):
    value = float(text)
    if not math.isfinite(value):
        raise ValueError("not a finite number")
    if abs(value) > LIMIT:
        raise ValueError(f"outside the range this solver handles (|x| <= {LIMIT:g})")
    return value


def positive(v):
    return None if v > 0 else "must be > 0"


def nonnegative(v):
    return None if v >= 0 else "must be >= 0"


def all_positive(vs):
    return None if all(v > 0 for v in vs) else "every entry must be > 0"


def all_at_least_one(vs):
    return None if all(v >= 1 for v in vs) else "every entry must be >= 1"


def all_nonnegative(vs):
    return None if all(v >= 0 for v in vs) else "every entry must be >= 0"


def rayleigh(vs):
    """-mpm_rayleigh: XI in [0, 1), then none or two frequencies F1 < F2 (Hz)."""
    if len(vs) not in (1, 3):
        return "give XI or XI,F1,F2"
    if not 0 <= vs[0] < 1:
        return "XI must lie in [0, 1)"
    if len(vs) == 3 and not 0 < vs[1] < vs[2]:
        return "needs 0 < F1 < F2"
    return None


def motion(v):
    """-mpm_base_motion: its form (a file is read when the run starts)."""
    from ..model.motion import parse

    try:
        parse(v)
    except ValueError as exc:
        return str(exc)
    return None


def poisson(v):
    return None if 0 <= v < 0.5 else "must lie in [0, 0.5)"


def open_unit(v):
    return None if 0 < v < 1 else "must lie in (0, 1)"


def at_least_one(v):
    return None if v >= 1 else "must be >= 1"


def scaling(v):
    """-mpm_mass_scaling: none, auto or a finite number S > 0."""
    if v in ("none", "auto"):
        return None
    try:
        S = parse_float(v)
    except ValueError:
        return "choose none, auto or a number S > 0"
    return None if S > 0 else "must be none, auto or > 0"


def fraction(v):
    """-mpm_flip: auto or a number in [0, 1]."""
    if v == "auto":
        return None
    try:
        f = parse_float(v)
    except ValueError:
        return "choose auto or a number in [0, 1]"
    return None if 0 <= f <= 1 else "must be auto or lie in [0, 1]"


def figure_formats(v):
    from .output import figure_formats

    try:
        figure_formats(v)
    except ValueError as exc:
        return str(exc)
    return None


def tolerance(v):
    return None if 0 < v < 1 else "must lie in (0, 1)"


def angle(v):
    """An angle in degrees in [0, 90), or NaN (not given)."""
    return None if v != v or 0 <= v < 90 else "must lie in [0, 90)"


def psa_periods(vs):
    """T_MIN,T_MAX,N: 0 < T_MIN < T_MAX and N a whole number of at least 2."""
    t0, t1, n = vs
    if not 0 < t0 < t1:
        return "give T_MIN,T_MAX,N with 0 < T_MIN < T_MAX (s)"
    if n != int(n) or n < 2:
        return "N, the number of periods, must be a whole number of at least 2"
    return None
