"""Closed-form references: the vibrating 1D soil column and Terzaghi's consolidation series."""

from __future__ import annotations

import numpy as np


def rod_frequencies(E_c: float, rho: float, H: float, nmodes: int) -> np.ndarray:
    """Natural frequencies (Hz) of a rod fixed at the base and free at the top.

    f_k = (2k - 1) c / (4 H) with c = sqrt(E_c / rho); E_c in Pa, rho in kg/m3, H in m.
    """
    c = np.sqrt(E_c / rho)
    k = np.arange(1, nmodes + 1)
    return (2 * k - 1) * c / (4 * H)


def rod_mode(y, H: float, k: int):
    """Shape of the k-th rod mode, sin((2k - 1) pi y / (2 H)), y measured up from the base."""
    return np.sin((2 * k - 1) * np.pi * np.asarray(y) / (2 * H))


def terzaghi(depth, Tv, H: float = 1.0, p0: float = 1.0, terms: int = 4000):
    """Terzaghi's excess pore pressure (units of p0) at ``depth`` below the drained top.

    p = p0 sum_m (2 / M) sin(M z / H) exp(-M^2 Tv), M = (2m + 1) pi / 2, for a layer of
    thickness H drained at the top and impermeable at the base. ``depth`` and ``Tv`` broadcast.
    At Tv = 0 the series is replaced by its limit p0 (0 at the drained surface).
    """
    z = np.asarray(depth, dtype=float) / H
    T = np.asarray(Tv, dtype=float)
    z, T = np.broadcast_arrays(z, T)
    M = (2 * np.arange(terms) + 1) * np.pi / 2
    zz = z[..., None]
    TT = T[..., None]
    series = np.sum(2 / M * np.sin(M * zz) * np.exp(-M * M * TT), axis=-1)
    series = np.where(T > 0, series, np.where(z > 0, 1.0, 0.0))
    return p0 * series


def consolidation_coefficient(k: float, E_c: float, gamma_w: float) -> float:
    """Terzaghi's c_v = k E_c / gamma_w (m2/s): incompressible water."""
    return k * E_c / gamma_w


def consistent_coefficient(k: float, E_c: float, gamma_w: float, K_l: float, n: float) -> float:
    """Diffusivity with compressible water, c2 = k / (gamma_w (1/E_c + n/K_l)) (m2/s)."""
    return k / (gamma_w * (1 / E_c + n / K_l))


def undrained_pressure(q: float, E_c: float, K_l: float, n: float) -> float:
    """Initial excess pore pressure under a sudden load q with compressible water (Pa)."""
    return q * (K_l / n) / (K_l / n + E_c)
