"""Spectra of acceleration histories: Fourier amplitudes, Konno-Ohmachi smoothing
and the pseudo-spectral acceleration of a damped oscillator. Accelerations in m/s2, times in
s, frequencies in Hz."""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm
from scipy.signal import lfilter


def fourier_amplitude(a, dt: float, n: int | None = None) -> tuple:
    """(f (Hz), |A(f)| (m/s)): the amplitude of the discrete Fourier transform of ``a``
    times dt (the continuous transform's scale), zero-padded to ``n`` samples."""
    n = n or len(a)
    return np.fft.rfftfreq(n, dt), np.abs(np.fft.rfft(np.asarray(a, dtype=float), n)) * dt


def konno_ohmachi(f, amplitude, fc=None, b: float = 40.0) -> np.ndarray:
    """The Konno-Ohmachi (1998) smoothing of ``amplitude`` over the frequencies f at the
    centre frequencies fc (default: f itself): the mean weighted by (sin x / x)^4,
    x = b log10(f / fc), symmetric in log frequency, bandwidth b (40, the usual).
    ``amplitude``: one spectrum (n,) or k of them (k, n), smoothed with the same weights.

    The window is taken whole: its weights fall only as x^-4, and the many frequencies of
    a long record's spectrum far from a centre still weigh (cut at the third side lobe,
    |x| = 3 pi, where the weights reach 7e-5, the smoothing of cases/motions/three-layers.csv
    moved by up to 0.09 % to 50 Hz, 1.5 % near its 100 Hz). The n x m weights are made in
    blocks of centres (2^20 weights a block), O(n m) time: 0.01 s for the 1000 lines to 50 Hz of a
    4000-sample record, 0.1 s for the 4096 of its four times padded transform."""
    f = np.asarray(f, dtype=float)
    amplitude = np.asarray(amplitude, dtype=float)
    fc = f if fc is None else np.asarray(fc, dtype=float)
    positive = f > 0
    lf, ap = np.log10(f[positive]), amplitude[..., positive]
    out = np.zeros(amplitude.shape[:-1] + (len(fc),))
    lc = np.log10(np.where(fc > 0, fc, 1.0))
    rows = max(1, (1 << 20) // max(len(lf), 1))
    for s in range(0, len(fc), rows):       # a block of centres at a time
        x = b * (lf[None, :] - lc[s:s + rows, None])
        with np.errstate(invalid="ignore", divide="ignore"):
            w = np.sin(x) / x
        w[x == 0] = 1.0
        w *= w
        w *= w
        out[..., s:s + rows] = (ap @ w.T) / np.sum(w, axis=1)
    # At a centre of 0 Hz (the transform's first line) the amplitude as it is.
    out[..., fc <= 0] = amplitude[..., :1] if amplitude.shape[-1] else 0.0
    return out


def pseudo_acceleration(a, dt: float, periods, damping: float = 0.05) -> np.ndarray:
    """The pseudo-spectral acceleration w^2 max|u| (m/s2) of a linear oscillator of each
    period T (s) and damping ratio ``damping`` under the ground acceleration ``a`` (from
    rest), by the exact integration of a ground motion linear between samples: no
    time-step error, stable for any T / dt (:class:`Oscillators`)."""
    return Oscillators(periods, dt, damping).feed(a).psa


class Oscillators:
    """Linear oscillators u'' + 2 z w u' + w^2 u = -a(t) of the periods T (s) (w = 2 pi / T)
    and damping ratio z, at rest at the first sample, under the ground acceleration a (m/s2)
    sampled every dt (s) and linear between samples, fed in pieces (:meth:`feed`); ``psa``:
    the pseudo-spectral accelerations w^2 max|u| (m/s2) of what was fed.

    The exact step (:func:`_discrete`) is the state recursion x_(k+1) = A x_k + B (p_k,
    p_(k+1)), x = (u, v), p = -a; by Cayley-Hamilton u alone obeys u_k = tr A u_(k-1) -
    det A u_(k-2) + b (p_k, p_(k-1), p_(k-2)), a second-order filter (SciPy's ``lfilter``,
    over time in C), so that what a piece leaves to the next (:meth:`state`) is the last
    two displacements and ground accelerations and the peaks: five numbers a period."""

    def __init__(self, periods, dt: float, damping: float = 0.05):
        self.w = 2 * np.pi / np.asarray(periods, dtype=float)
        A, B = _discrete(self.w, damping, dt)
        one = np.ones_like(self.w)
        self.den = np.column_stack([one, -(A[:, 0, 0] + A[:, 1, 1]),
                                    A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]])
        self.num = np.column_stack([
            B[:, 0, 1], B[:, 0, 0] - A[:, 1, 1] * B[:, 0, 1] + A[:, 0, 1] * B[:, 1, 1],
            A[:, 0, 1] * B[:, 1, 0] - A[:, 1, 1] * B[:, 0, 0]])
        self.first = B[:, 0, :]                  # u_1 from rest: B_u (p_0, p_1)
        self.u = np.zeros((len(self.w), 2))      # (u_(m-1), u_m): the last two fed
        self.p = np.zeros(2)                     # (p_(m-1), p_m)
        self.peak = np.zeros(len(self.w))
        self.count = 0                           # samples fed

    @property
    def psa(self) -> np.ndarray:
        return self.w * self.w * self.peak

    def feed(self, a) -> "Oscillators":
        """Go on with the next samples ``a`` (m/s2) of the ground acceleration."""
        p = -np.asarray(a, dtype=float).ravel()
        if len(p) and self.count == 0:           # u_0 = 0: at rest
            self.p[1], self.count, p = p[0], 1, p[1:]
        if len(p) and self.count == 1:
            u1 = self.first[:, 0] * self.p[1] + self.first[:, 1] * p[0]
            self.u = np.column_stack([np.zeros_like(u1), u1])
            self.p = np.array([self.p[1], p[0]])
            np.maximum(self.peak, np.abs(u1), out=self.peak)
            self.count, p = 2, p[1:]
        if not len(p):
            return self
        b, d, u, q = self.num, self.den, self.u, self.p
        # lfilter's state (transposed direct form II) after the last two samples fed.
        zi = np.column_stack([b[:, 1] * q[1] + b[:, 2] * q[0] - d[:, 1] * u[:, 1]
                              - d[:, 2] * u[:, 0], b[:, 2] * q[1] - d[:, 2] * u[:, 1]])
        for i in range(len(self.w)):             # over the periods; time runs in C
            y, _ = lfilter(b[i], d[i], p, zi=zi[i])
            self.peak[i] = max(self.peak[i], float(np.max(np.abs(y))))
            self.u[i] = (y[-2], y[-1]) if len(y) > 1 else (u[i, 1], y[-1])
        self.p = np.concatenate([self.p, p])[-2:]
        self.count += len(p)
        return self

    def state(self) -> dict:
        """What the next piece needs (JSON values): the last two u (m) and p (m/s2) of each
        oscillator, the peaks (m) and the count of samples fed."""
        return {"u": self.u.tolist(), "p": self.p.tolist(), "peak": self.peak.tolist(),
                "count": self.count}

    def restore(self, d: dict) -> "Oscillators":
        self.u = np.array(d["u"], dtype=float).reshape(len(self.w), 2)
        self.p = np.array(d["p"], dtype=float)
        self.peak = np.array(d["peak"], dtype=float)
        self.count = int(d["count"])
        return self


def _discrete(w, z: float, dt: float) -> tuple:
    """(A, B), each (len(w), 2, 2): the exact step of u'' + 2 z w u' + w^2 u = p(t), p
    linear over a step dt: (u, v)_(k+1) = A (u, v)_k + B (p_k, p_(k+1)). By the exponential
    of the system augmented by p and its slope (Van Loan 1978): the matrices of Nigam and
    Jennings (1969), without the cancellation of their closed form at small w dt (1e-4 of B
    at T = 10 s, dt = 1e-4 s; 0.3 at dt = 1e-5 s)."""
    M = np.zeros((len(w), 4, 4))
    M[:, 0, 1] = 1.0
    M[:, 1, 0], M[:, 1, 1], M[:, 1, 2] = -w * w, -2 * z * w, 1.0
    M[:, 2, 3] = 1.0                     # p' = its slope over the step, (p_(k+1) - p_k) / dt
    E = expm(M * dt)
    slope = E[:, :2, 3] / dt
    return E[:, :2, :2], np.stack([E[:, :2, 2] - slope, slope], axis=2)
