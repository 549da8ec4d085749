"""Base motions: analytic wavelets, the form of ``-mpm_base_motion`` and a motion
as functions of time (a record linear between its samples, zero after its end).
Accelerations in m/s2, times in s."""

from __future__ import annotations

import numpy as np


def ricker(t, f0: float, amp: float) -> np.ndarray:
    """A Ricker wavelet of centre frequency f0 (Hz) and peak acceleration ``amp`` (m/s2),
    centred at 1.5 / f0 s: amp (1 - 2 x) e^-x, x = (pi f0 (t - 1.5 / f0))^2."""
    x = (np.pi * f0 * (np.asarray(t, dtype=float) - 1.5 / f0)) ** 2
    return amp * (1 - 2 * x) * np.exp(-x)


def sine(t, f: float, amp: float, cycles: float) -> np.ndarray:
    """``cycles`` cycles of amp sin(2 pi f t) from t = 0 (Hz, m/s2), then rest."""
    t = np.asarray(t, dtype=float)
    return np.where((t >= 0) & (t <= cycles / f), amp * np.sin(2 * np.pi * f * t), 0.0)


def ricker_velocity(t, f0: float, amp: float) -> np.ndarray:
    """The velocity (m/s) of :func:`ricker` from rest at t = 0: amp (tau e^-x + t0 e^-x0),
    tau = t - t0, t0 = 1.5 / f0, x = (pi f0 tau)^2, x0 its value at t = 0."""
    t0 = 1.5 / f0
    tau = np.asarray(t, dtype=float) - t0
    return amp * (tau * np.exp(-(np.pi * f0 * tau) ** 2) + t0 * np.exp(-(1.5 * np.pi) ** 2))


def parse(text: str) -> tuple:
    """The form of ``-mpm_base_motion``: ("none",), ("ricker", F0, AMP), ("sine", F, AMP,
    CYCLES) or ("file", path); ValueError (its message one line) for a malformed one. A
    file is only named here: it is read where the run starts."""
    text = text.strip()
    if text in ("", "none"):
        return ("none",)
    kind, _, args = text.partition(":")
    counts = {"ricker": ("F0,AMP", 2), "sine": ("F,AMP,CYCLES", 3)}
    if kind not in counts:
        return ("file", text)
    form, count = counts[kind]
    try:
        values = tuple(float(v) for v in args.split(","))
    except ValueError:
        raise ValueError(f"{kind}:{form} takes numbers") from None
    if len(values) != count or not all(np.isfinite(values)):
        raise ValueError(f"give {kind}:{form}")
    if values[0] <= 0 or (kind == "sine" and values[2] <= 0):
        raise ValueError(f"{kind}:{form}: the frequency{' and cycles' * (kind == 'sine')} "
                         "must be > 0")
    return (kind,) + values


class Motion:
    """A base motion as functions of time (s): :meth:`acceleration` (m/s2) and
    :meth:`velocity` (m/s, from rest at t = 0), vectorised. ``form`` is :func:`parse`'s;
    a record (``table``: its times and accelerations) is linear between its samples, zero
    before its first and after its last, and its velocity the exact integral of that.
    ``scale`` multiplies it."""

    def __init__(self, form: tuple, scale: float = 1.0, table=None):
        self.form, self.scale = form, float(scale)
        if form[0] == "file":
            self.t, self.a = (np.asarray(x, dtype=float) for x in table)
            steps = np.diff(self.t)
            self.v = np.r_[0.0, np.cumsum(steps * (self.a[1:] + self.a[:-1]) / 2)]

    @property
    def end(self) -> float:
        """The end of a record (s); inf for an analytic motion."""
        return float(self.t[-1]) if self.form[0] == "file" else np.inf

    def acceleration(self, t):
        t = np.asarray(t, dtype=float)
        kind = self.form[0]
        if kind == "ricker":
            return self.scale * ricker(t, *self.form[1:])
        if kind == "sine":
            return self.scale * sine(t, *self.form[1:])
        if kind == "file":
            return self.scale * np.interp(t, self.t, self.a, left=0.0, right=0.0)
        return np.zeros_like(t)

    def velocity(self, t):
        t = np.asarray(t, dtype=float)
        kind = self.form[0]
        if kind == "ricker":
            return self.scale * ricker_velocity(t, *self.form[1:])
        if kind == "sine":
            f, amp, cycles = self.form[1:]
            w = 2 * np.pi * f
            return self.scale * amp / w * (1 - np.cos(w * np.clip(t, 0.0, cycles / f)))
        if kind == "file":
            k = np.clip(np.searchsorted(self.t, t, side="right") - 1, 0, len(self.t) - 2)
            tau = np.clip(t, self.t[0], self.t[-1]) - self.t[k]
            slope = (self.a[k + 1] - self.a[k]) / (self.t[k + 1] - self.t[k])
            return self.scale * np.where(t < self.t[0], 0.0,
                                         self.v[k] + self.a[k] * tau + slope * tau * tau / 2)
        return np.zeros_like(t)
