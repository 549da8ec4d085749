"""Spectra of acceleration histories: Fourier amplitudes, Konno-Ohmachi smoothing
and the pseudo-spectral acceleration of a damped oscillator. Accelerations in m/s2, times in
s, frequencies in Hz."""

from __future__ import annotations

import numpy as np


def fourier_amplitude(a, dt: float, n: int | None = None) -> tuple:
    """(f (Hz), |A(f)| (m/s)): the amplitude of the discrete Fourier transform of ``a``
    times dt (the continuous transform's scale), zero-padded to ``n`` samples."""
    n = n or len(a)
    return np.fft.rfftfreq(n, dt), np.abs(np.fft.rfft(np.asarray(a, dtype=float), n)) * dt


def konno_ohmachi(f, amplitude, fc=None, b: float = 40.0) -> np.ndarray:
    """The Konno-Ohmachi (1998) smoothing of ``amplitude`` over the frequencies f at the
    centre frequencies fc (default: f itself): the weights (sin(b log10(f/fc)) /
    (b log10(f/fc)))^4, symmetric in log frequency, bandwidth b (40, the usual)."""
    f = np.asarray(f, dtype=float)
    amplitude = np.asarray(amplitude, dtype=float)
    fc = f if fc is None else np.asarray(fc, dtype=float)
    out = np.zeros(len(fc))
    positive = f > 0
    fp, ap = f[positive], amplitude[positive]
    for i, c in enumerate(fc):          # one row of weights at a time: memory stays O(n)
        if c <= 0:
            out[i] = amplitude[0] if len(amplitude) else 0.0
            continue
        x = b * np.log10(fp / c)
        with np.errstate(invalid="ignore", divide="ignore"):
            w = (np.sin(x) / x) ** 4
        w[np.abs(x) < 1e-12] = 1.0
        w[np.abs(x) > np.pi * 3] = 0.0       # beyond the third side lobe: < 1e-6
        out[i] = np.sum(w * ap) / np.sum(w)
    return out


def pseudo_acceleration(a, dt: float, periods, damping: float = 0.05) -> np.ndarray:
    """The pseudo-spectral acceleration w^2 max|u| (m/s2) of a linear oscillator of each
    period T (s) and damping ratio ``damping`` under the ground acceleration ``a`` (from
    rest), by the exact integration of a ground motion linear between samples (Nigam and
    Jennings 1969): no time-step error, stable for any T / dt."""
    a = np.asarray(a, dtype=float)
    w = 2 * np.pi / np.asarray(periods, dtype=float)
    A, B = _nigam_jennings(w, damping, dt)          # (2, 2, nT) each
    u, v, peak = np.zeros_like(w), np.zeros_like(w), np.zeros_like(w)
    for k in range(len(a) - 1):                      # over time; the periods at once
        p0, p1 = -a[k], -a[k + 1]
        u, v = (A[0, 0] * u + A[0, 1] * v + B[0, 0] * p0 + B[0, 1] * p1,
                A[1, 0] * u + A[1, 1] * v + B[1, 0] * p0 + B[1, 1] * p1)
        np.maximum(peak, np.abs(u), out=peak)
    return w * w * peak


def _nigam_jennings(w, z: float, dt: float) -> tuple:
    """The 2 x 2 matrices (A, B) (each entry an array over the circular frequencies w) of
    u'' + 2 z w u' + w^2 u = p(t), p linear over a step dt: (u, v)_{k+1} = A (u, v)_k +
    B (p_k, p_{k+1})."""
    wd = w * np.sqrt(1 - z * z)
    e, s, c = np.exp(-z * w * dt), np.sin(wd * dt), np.cos(wd * dt)
    zr = z / np.sqrt(1 - z * z)
    A = np.array([[e * (zr * s + c), e * s / wd],
                  [-w / np.sqrt(1 - z * z) * e * s, e * (c - zr * s)]])
    w2, w3 = w * w, w ** 3
    t1 = (2 * z * z - 1) / (w2 * dt)
    t2 = 2 * z / (w3 * dt)
    B = np.array([
        [e * ((t1 + z / w) * s / wd + (t2 + 1 / w2) * c) - t2,
         -e * (t1 * s / wd + t2 * c) - 1 / w2 + t2],
        [e * ((t1 + z / w) * (c - zr * s) - (t2 + 1 / w2) * (wd * s + z * w * c)) + 1 / (w2 * dt),
         -e * (t1 * (c - zr * s) - t2 * (wd * s + z * w * c)) - 1 / (w2 * dt)]])
    return A, B
