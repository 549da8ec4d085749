"""Base motions (issue 30): analytic wavelets and the resampling of a record onto a run's
time steps. Accelerations in m/s2, times in s."""

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


def resample(t_rec, a_rec, t) -> tuple:
    """(the record (t_rec, a_rec) linearly interpolated at the times t, whether t reaches
    past the record's end): a record shorter than the run is padded with zeros."""
    t = np.asarray(t, dtype=float)
    a = np.interp(t, t_rec, a_rec, left=0.0, right=0.0)
    return a, bool(t.size and t[-1] > t_rec[-1] * (1 + 1e-12))


def ricker_velocity(t, f0: float, amp: float) -> np.ndarray:
    """The velocity (m/s) of :func:`ricker` from rest at t = 0: amp (tau e^-x + t0 e^-x0),
    tau = t - t0, t0 = 1.5 / f0, x = (pi f0 tau)^2, x0 its value at t = 0."""
    t0 = 1.5 / f0
    tau = np.asarray(t, dtype=float) - t0
    return amp * (tau * np.exp(-(np.pi * f0 * tau) ** 2) + t0 * np.exp(-(1.5 * np.pi) ** 2))
