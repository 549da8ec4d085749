"""Closed-form references: the vibrating 1D soil column and Terzaghi's consolidation series."""

from __future__ import annotations

import math

import numpy as np
from scipy.special import erfc as _erfc


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


# Absolute accuracy (units of p0) of the Terzaghi references. The promise is 1e-10; measured
# against a 40-digit evaluation (mpmath) at 21 depths and T_v from 1e-6 to 3: at most 2e-16
# from the images (T_v < 0.007) and 1.3e-14 from the series (at T_v = 0.1; the sine
# recurrence's round-off). The margin absorbs the round-off of erfc (SciPy's, about 3e-16 absolute), of NumPy's exp and
# sin (a few ulp, their SIMD kernels differ between machines with and without AVX-512) and
# of the summation.
TOLERANCE = 1e-13
# Below this T_v the image form is cheaper than the Fourier series, which would need more
# than 20 terms (1e6 points, 2 busy cores: at 0.005 series 0.19 s, images 0.17 s; at 0.01
# 0.12 s and 0.22 s). Both meet TOLERANCE on either side: the switch only sets the cost.
_T_IMAGE = 0.007
# Points per block: the temporaries of one block stay in cache and bounded in memory
# whatever the number of points.
_CHUNK = 16384


def terzaghi(depth, Tv, H: float = 1.0, p0: float = 1.0, terms=None):
    """Terzaghi's excess pore pressure (units of p0) at ``depth`` (m) below the drained top.

    p = p0 sum_m (2 / M) sin(M z / H) exp(-M^2 Tv), M = (2m + 1) pi / 2, for a layer of
    thickness H (m) drained at the top and impermeable at the base; Tv is the time factor
    c t / H^2 (dimensionless). ``depth`` and ``Tv`` broadcast; scalars give a scalar.
    At Tv <= 0 the series is replaced by its limit p0 (0 at the drained surface).

    With ``terms=None`` the value is accurate to TOLERANCE x |p0| for every Tv > 0: the
    Fourier series with the few terms its tail bound asks for where Tv >= 0.007, the image
    (complementary error function) form below. An integer ``terms`` sums exactly that many
    series terms instead (the former default, 4000, is wrong below Tv ~ 1e-7). Either way
    the points go through in blocks of bounded size: memory O(points), never points x terms.
    """
    z = np.asarray(depth, dtype=float) / H
    T = np.asarray(Tv, dtype=float)
    shape = np.broadcast_shapes(z.shape, T.shape)
    # Flat views where the shapes allow (a copy of one operand where it broadcasts); one
    # Tv for all points stays one number.
    z = np.broadcast_to(z, shape).reshape(-1)
    T = T.reshape(-1) if T.size == 1 else np.broadcast_to(T, shape).reshape(-1)
    out = np.empty(z.size)
    for lo in range(0, z.size, _CHUNK):
        zb = z[lo:lo + _CHUNK]
        Tb = np.broadcast_to(T, zb.shape) if T.size == 1 else T[lo:lo + _CHUNK]
        out[lo:lo + _CHUNK] = _terzaghi_block(zb, Tb, terms)
    out = out.reshape(shape)
    if out.ndim and np.ndim(p0) == 0:
        out *= p0
        return out
    return p0 * out                           # a scalar for scalars, as numpy gives


def _terzaghi_block(z, T, terms):
    """Terzaghi's p / p0 on one block of points (1D arrays of z / H and Tv)."""
    live = T > 0
    if live.all():
        return _positive_time(z, T, terms)
    out = np.where(z > 0, 1.0, 0.0)           # the limit at Tv <= 0
    if live.any():
        out[live] = _positive_time(z[live], T[live], terms)
    return out


def _positive_time(z, T, terms):
    """p / p0 where every Tv > 0: points inside the layer as they are, others folded in."""
    inside = z.min() >= 0 and z.max() <= 1
    zf, sign = (z, None) if inside else _fold(z)
    if terms is not None:
        val = _series(zf, T, int(terms))
    else:
        val = np.empty_like(zf)
        short = T < _T_IMAGE
        for mask, form in ((short, _images), (~short, _series_to_tolerance)):
            if mask.all():
                val = form(zf, T)
            elif mask.any():
                val[mask] = form(zf[mask], T[mask])
    return val if sign is None else val * sign


def _fold(z):
    """z / H folded into [0, 1] with the sign the series takes there: the series is odd about
    the surface, even about the impermeable base and of period 4 layer thicknesses, so
    values outside the layer stay what the series gives."""
    zf = np.mod(z, 4.0)
    sign = np.where(zf > 2.0, -1.0, 1.0)
    zf = np.where(zf > 2.0, 4.0 - zf, zf)
    return np.where(zf > 1.0, 2.0 - zf, zf), sign


def _series(z, T, n):
    """The first ``n`` terms of the Fourier series, accumulated term by term (no z x n
    array). sin(M_m z) comes from the recurrence sin((2m + 3) a) = 2 cos(2a) sin((2m + 1) a)
    - sin((2m - 1) a), a = pi z / 2, with 2 cos(2a) = 2 - 4 sin(a)^2: one sine per point
    for the first _RESEED terms, then started afresh (its round-off grows like m^2 eps near
    z = 0). T is one number when the block shares it (the usual report), so that a term
    costs a few multiplications."""
    T = T[0] if T.min() == T.max() else T
    sin_m = np.sin(np.pi / 2 * z)
    two_cos = 2 - 4 * sin_m * sin_m
    prev = -sin_m
    acc = np.zeros_like(z)
    for m in range(n):
        M = (2 * m + 1) * np.pi / 2
        if m and m % _RESEED == 0:
            prev, sin_m = np.sin((M - np.pi) * z), np.sin(M * z)
        acc += (2 / M) * np.exp(-M * M * T) * sin_m
        prev, sin_m = sin_m, two_cos * sin_m - prev
    return acc


_RESEED = 16


def _series_terms(T: float) -> int:
    """Fourier terms that reach TOLERANCE at every Tv >= T: the first n whose tail bound is
    below it. The terms fall at least geometrically, by exp(-2 pi M_n T) from the n-th on
    (consecutive M differ by pi), so sum_{m >= n} <= (2 / M_n) exp(-M_n^2 T) / (1 - q)."""
    n = 0
    while True:
        M = (2 * n + 1) * np.pi / 2
        q = np.exp(-2 * np.pi * M * T)
        if 2 / M * np.exp(-M * M * T) <= TOLERANCE * (1 - q):
            return max(n, 1)
        n += 1


def _series_to_tolerance(z, T):
    return _series(z, T, _series_terms(float(T.min())))


def _image_pairs(T: float) -> int:
    """Pairs of images that reach TOLERANCE at every Tv <= T. Pair n has arguments at least
    n / sqrt(T) and erfc falls by exp(-(2n + 1) / T) from one pair to the next, so the pairs
    from K on add at most 2 x 2 erfc(K / sqrt(T)) for T <= 1."""
    K = 1
    while 4 * math.erfc(K / math.sqrt(T)) > TOLERANCE:
        K += 1
    return K


def _images(z, T):
    """p / p0 from the images of the drained surface in the impermeable base (Carslaw and
    Jaeger): 1 - sum_n (-1)^n [erfc((2n + z) / s) + erfc((2n + 2 - z) / s)], s = 2 sqrt(Tv)."""
    s = 2 * np.sqrt(T)
    acc = 1.0 - _erfc(z / s)
    acc -= _erfc((2 - z) / s)
    for n in range(1, _image_pairs(float(T.max()))):
        acc -= (-1) ** n * (_erfc((2 * n + z) / s) + _erfc((2 * n + 2 - z) / s))
    return acc


def consolidation_coefficient(k: float, E_c: float, gamma_w: float) -> float:
    """Terzaghi's c_v = k E_c / gamma_w (m2/s): incompressible water."""
    return k * E_c / gamma_w


def consistent_coefficient(k: float, E_c: float, gamma_w: float, K_l: float, n: float) -> float:
    """Diffusivity with compressible water, c2 = k / (gamma_w (1/E_c + n/K_l)) (m2/s)."""
    return k / (gamma_w * (1 / E_c + n / K_l))


def undrained_pressure(q: float, E_c: float, K_l: float, n: float) -> float:
    """Initial excess pore pressure under a sudden load q with compressible water (Pa)."""
    return q * (K_l / n) / (K_l / n + E_c)


def degree_of_consolidation(Tv, terms=None):
    """Terzaghi's average degree of consolidation U (dimensionless, 0 to 1) at the time
    factor ``Tv`` (dimensionless) of a layer drained at the top and impermeable at the base
    under a uniform initial excess pore pressure: the depth average of 1 - p / p0 of
    :func:`terzaghi`,

        U = 1 - sum_m (2 / M^2) exp(-M^2 Tv),  M = (2m + 1) pi / 2,

    which is also the settlement ratio (s - s0) / (s_inf - s0). With compressible water the
    same U holds in the diffusivity c2 (evaluate at Tv c2 / c_v), U measured from the
    undrained p0 and s0. ``Tv`` broadcasts; a scalar gives a scalar; Tv <= 0 gives 0.

    With ``terms=None`` U is accurate to TOLERANCE for every Tv > 0, in O(terms) work per
    value: the series with the terms :func:`_series_terms` asks for where Tv >= 0.007 (its
    terms (2 / M^2) exp(-M^2 Tv) are below the pressure series' (2 / M) exp(-M^2 Tv), M > 1,
    so the same tail bound holds), the image form below (:func:`_mean_images`). An integer
    ``terms`` sums exactly that many series terms.
    """
    T = np.asarray(Tv, dtype=float)
    flat = T.reshape(-1)
    out = np.zeros(flat.size)
    if terms is not None:
        live = flat > 0
        if live.any():
            out[live] = 1.0 - _mean_series(flat[live], int(terms))
    else:
        short = (flat > 0) & (flat < _T_IMAGE)
        long = flat >= _T_IMAGE
        if short.any():
            out[short] = _mean_images(flat[short])
        if long.any():
            out[long] = 1.0 - _mean_series(flat[long], _series_terms(float(flat[long].min())))
    return out.reshape(T.shape)[()]


def _mean_series(T, n):
    """Depth average of p / p0: the first ``n`` terms of sum_m (2 / M^2) exp(-M^2 T), term by
    term over the array T (no T x n array)."""
    acc = np.zeros_like(T)
    for m in range(n):
        M = (2 * m + 1) * np.pi / 2
        acc += (2 / (M * M)) * np.exp(-M * M * T)
    return acc


def _mean_images(T):
    """U from the images (the depth integral of :func:`_images`):
    U = 2 sqrt(Tv / pi) + 4 sqrt(Tv) sum_{m >= 1} (-1)^m ierfc(m / sqrt(Tv)), with
    ierfc(x) = exp(-x^2) / sqrt(pi) - x erfc(x). The terms alternate and fall, and
    4 sqrt(Tv) ierfc(x) <= 4 erfc(x) where it matters (x >= 1, Tv <= 1), so the pairs of
    :func:`_image_pairs` bound the tail as they do for the pressure."""
    s = np.sqrt(T)
    U = 2 * s / math.sqrt(math.pi)
    for m in range(1, _image_pairs(float(T.max()))):
        x = m / s
        U += 4 * s * (-1) ** m * (np.exp(-x * x) / math.sqrt(math.pi) - x * _erfc(x))
    return U
