"""Closed-form references: the vibrating 1D soil column, Terzaghi's consolidation series and
Xie and Leo's large-strain consolidation."""

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


# -- A uniform column drained on any set of its ends, under a linear initial excess ---------
#
# The excess pore pressure u over hydrostatic (water table at the surface) of a uniform column
# of height H obeys u_t = c u_yy, u = 0 at a drained end and u_y = 0 at an impermeable one,
# from an initial excess linear in height (a load: uniform; self-weight: zero at the surface,
# largest at the base; both: their sum). In xi = y / H and the time factor Tv = c t / H^2 (H
# the column height whatever the drainage; the drainage path enters the eigenvalues) it is
# sum_j a_j X_j(xi) exp(-M_j^2 Tv) with
#   drained base only   X = sin(M xi),  M = (j + 1/2) pi
#   drained top only    X = cos(M xi),  M = (j + 1/2) pi
#   drained both ends   X = sin(M xi),  M = (j + 1) pi
#   no drained end      X = cos(M xi),  M = j pi
# and, below _T_IMAGE, the image form: the initial excess continued oddly about a drained end
# and evenly about an impermeable one is piecewise linear on the line, and heat flow smooths
# each jump J at x_k by J erfc / 2 and each kink (slope change D) by D s ierfc(|x - x_k| / s) / 2,
# s = 2 sqrt(Tv).

def drained_ends(drained):
    """(base drained, top drained) from the drained sides ("top", "bottom")."""
    sides = set(drained)
    if sides - {"top", "bottom"}:
        raise ValueError(f"a 1D column drains through its top and bottom only, not "
                         f"{sorted(sides - {'top', 'bottom'})}: lateral drainage is 2D")
    return "bottom" in sides, "top" in sides


def _column_modes(base, top, j):
    """Wavenumbers M_j and the exact sin M_j, cos M_j of the column's modes j (int array)."""
    half = base != top
    M = (j + (0.5 if half else (1.0 if base else 0.0))) * np.pi
    sign = np.where(j % 2 == 0, 1.0, -1.0)
    if half:
        return M, sign, np.zeros_like(M)
    return M, np.zeros_like(M), -sign if base else sign


def _column_coefficients(base, top, j, f0, f1):
    """a_j of f0 + f1 xi in the modes j: (1 / |X|^2) integral_0^1 (f0 + f1 xi) X dxi."""
    M, s, c = _column_modes(base, top, j)
    Ms = np.where(M > 0, M, 1.0)
    if base:                                    # X = sin(M xi)
        return 2 * (f0 * (1 - c) / Ms + f1 * (s / Ms ** 2 - c / Ms))
    a = 2 * (f0 * s / Ms + f1 * (c / Ms ** 2 + s / Ms - 1 / Ms ** 2))
    return np.where(M > 0, a, f0 + f1 / 2)      # X = cos(M xi); the mean for M = 0


def _column_terms(base, top, T):
    """Modes whose tail is below TOLERANCE x (|f0| + |f1|) at every time factor >= T:
    |a_j| <= 4 (|f0| + |f1|) / M_j (the closed forms above, M_j >= pi / 2), and M_j^2 grows
    by at least 2 pi M_n from mode n on, so the tail from n is below
    4 (|f0| + |f1|) exp(-M_n^2 T) / (M_n (1 - q)), q = exp(-2 pi M_n T)."""
    n = 1
    while True:
        M = float(_column_modes(base, top, np.array([n]))[0][0])
        q = math.exp(-2 * math.pi * M * T)
        if 4 / M * math.exp(-M * M * T) <= TOLERANCE * (1 - q):
            return n
        n += 1


def _column_fold(x, base, top):
    """x = y / H folded into [0, 1] and the sign of the continued excess there: odd about a
    drained end, even about an impermeable one."""
    s0, s1 = (-1.0 if base else 1.0), (-1.0 if top else 1.0)
    n2 = np.floor(x / 2)
    r = x - 2 * n2
    sign = np.where(np.mod(n2, 2) == 0, 1.0, s0 * s1)
    far = r > 1
    return np.where(far, 2 - r, r), np.where(far, sign * s1, sign)


def _column_singularities(base, top, f0, f1, T):
    """Integers x_k near [0, 1] at which the continued initial excess jumps (J_k) or kinks
    (slope change D_k), enough of them that the images left out sum below TOLERANCE x
    (|f0| + |f1|) for time factors up to T (|J| <= 2 (|f0| + |f1|), |D| <= 2 |f1|, and s
    ierfc(w) <= erfc(w) <= erfc(m / s) beyond m). The continuation is linear between
    integers, so two samples on each side give its limits and slopes there."""
    s = 2 * math.sqrt(T)
    m = 1
    while 8 * math.erfc(m / s) > TOLERANCE:
        m += 1
    k = np.arange(-m, m + 2, dtype=float)

    def F(x):
        xi, sign = _column_fold(x, base, top)
        return sign * (f0 + f1 * xi)
    jump = (2 * F(k + 0.25) - F(k + 0.5)) - (2 * F(k - 0.25) - F(k - 0.5))
    kink = 4 * (F(k + 0.5) - F(k + 0.25)) - 4 * (F(k - 0.25) - F(k - 0.5))
    return k, jump, kink


def _ierfc(w):
    return np.exp(-w * w) / math.sqrt(math.pi) - w * _erfc(w)


def _i2erfc(w):
    return 0.25 * ((1 + 2 * w * w) * _erfc(w) - 2 * w * np.exp(-w * w) / math.sqrt(math.pi))


def _column_images(xi, T, base, top, f0, f1):
    """The excess at xi in [0, 1] and time factors T > 0 (below _T_IMAGE) from the images:
    f(xi) - sum_{x_k <= 0} J_k erfc((xi - x_k) / s) / 2 + sum_{x_k >= 1} J_k erfc((x_k - xi)
    / s) / 2 + sum_k D_k s ierfc(|xi - x_k| / s) / 2."""
    s = 2 * np.sqrt(T)
    acc = f0 + f1 * xi
    for x, J, D in zip(*_column_singularities(base, top, f0, f1, float(T.max()))):
        w = np.abs(xi - x) / s
        acc = acc + (J / 2) * _erfc(w) * (-1.0 if x <= 0 else 1.0) + (D / 2) * s * _ierfc(w)
    return acc


def _column_series(xi, T, base, top, f0, f1):
    """The excess at xi and time factors T from the modes _column_terms asks for."""
    T = T[0] if T.min() == T.max() else T
    j = np.arange(_column_terms(base, top, float(np.min(T))))
    M = _column_modes(base, top, j)[0]
    a = _column_coefficients(base, top, j, f0, f1)
    trig = np.sin if base else np.cos
    acc = np.zeros_like(xi)
    for Mj, aj in zip(M, a):
        acc += aj * np.exp(-Mj * Mj * T) * trig(Mj * xi)
    return acc


def column_pressure(y, Tv, H: float = 1.0, drained=("top",), p_top: float = 1.0,
                    p_base=None):
    """Excess pore pressure over hydrostatic (Pa, or the units of p_top) at heights ``y`` (m,
    up from the base, as the MPM's points are) of a uniform column of height H (m) drained
    at the sides in ``drained`` (a subset of "top", "bottom"; empty: no drainage),
    impermeable at the others, from an undrained initial excess linear in height: p_top at
    the surface, p_base at the base (None: p_top, a uniform load). :func:`undrained_excess`
    gives them for a load, self-weight or both, with or without compressible water.

    ``Tv`` = c t / H^2 (dimensionless) with H the column height whatever the drainage (the
    MPM's T_v; the drainage path enters the modes) and c the diffusivity of the form:
    c_v = k E_c / gamma_w (classic) or c2 (compressible water: evaluate at T_v c2 / c_v).
    Drained at the top only with p_base None this is :func:`terzaghi` at depth H - y;
    drained at both ends, Terzaghi on H / 2 at 4 Tv from the nearer end.

    Accurate to TOLERANCE x (|p_top| + |p_base - p_top|) at every Tv > 0: the mode series
    with the terms its tail bound asks for where Tv >= 0.007, the image form below; at
    Tv <= 0 the initial excess (0 at a drained end). ``y`` and ``Tv`` broadcast; points go
    through in blocks of bounded size (memory O(points)); heights outside [0, H] take the
    continued solution (odd about a drained end, even about an impermeable one).
    """
    base, top = drained_ends(drained)
    f0 = float(p_top if p_base is None else p_base)
    f1 = float(p_top) - f0
    x = np.asarray(y, dtype=float) / H
    T = np.asarray(Tv, dtype=float)
    shape = np.broadcast_shapes(x.shape, T.shape)
    x = np.broadcast_to(x, shape).reshape(-1)
    T = T.reshape(-1) if T.size == 1 else np.broadcast_to(T, shape).reshape(-1)
    out = np.empty(x.size)
    for lo in range(0, x.size, _CHUNK):
        xi, sign = _column_fold(x[lo:lo + _CHUNK], base, top)
        Tb = np.broadcast_to(T, xi.shape) if T.size == 1 else T[lo:lo + _CHUNK]
        out[lo:lo + _CHUNK] = sign * _column_block(xi, Tb, base, top, f0, f1)
    return out.reshape(shape)[()]


def _column_block(xi, T, base, top, f0, f1):
    """The excess on one block of folded heights xi in [0, 1] and time factors T."""
    out = f0 + f1 * xi
    out[(base & (xi == 0)) | (top & (xi == 1))] = 0.0    # the limit at Tv <= 0
    for mask, form in ((T >= _T_IMAGE, _column_series),
                       ((T > 0) & (T < _T_IMAGE), _column_images)):
        if mask.all():
            return form(xi, T, base, top, f0, f1)
        if mask.any():
            out[mask] = form(xi[mask], T[mask], base, top, f0, f1)
    return out


def column_mean(Tv, drained=("top",), p_top: float = 1.0, p_base=None):
    """Depth average of :func:`column_pressure` (its units) at the time factors ``Tv``
    (broadcast; a scalar gives a scalar), to TOLERANCE x (|p_top| + |p_base - p_top|): the
    mode series (integral_0^1 sin(M xi) = (1 - cos M) / M, of cos(M xi) = sin M / M) where
    Tv >= 0.007, the depth integral of the image form below (erfc integrates to s ierfc,
    s ierfc to s^2 i2erfc, i2erfc(w) = ((1 + 2 w^2) erfc(w) - 2 w exp(-w^2) / sqrt(pi)) / 4)."""
    base, top = drained_ends(drained)
    f0 = float(p_top if p_base is None else p_base)
    f1 = float(p_top) - f0
    T = np.asarray(Tv, dtype=float)
    flat = T.reshape(-1)
    out = np.full(flat.size, f0 + f1 / 2)
    short, long = (flat > 0) & (flat < _T_IMAGE), flat >= _T_IMAGE
    if long.any():
        Tl = flat[long]
        j = np.arange(_column_terms(base, top, float(Tl.min())))
        M, sM, cM = _column_modes(base, top, j)
        Ms = np.where(M > 0, M, 1.0)
        mean = (1 - cM) / Ms if base else np.where(M > 0, sM / Ms, 1.0)
        a = _column_coefficients(base, top, j, f0, f1) * mean
        out[long] = sum(aj * np.exp(-Mj * Mj * Tl) for Mj, aj in zip(M, a))
    if short.any():
        Ts = flat[short]
        s = 2 * np.sqrt(Ts)
        acc = np.full(Ts.size, f0 + f1 / 2)
        for x, J, D in zip(*_column_singularities(base, top, f0, f1, float(Ts.max()))):
            near, far = (-x / s, (1 - x) / s) if x <= 0 else ((x - 1) / s, x / s)
            sign = -1.0 if x <= 0 else 1.0
            acc += sign * (J / 2) * s * (_ierfc(near) - _ierfc(far))
            acc += (D / 2) * s * s * (_i2erfc(near) - _i2erfc(far))
        out[short] = acc
    return out.reshape(T.shape)[()]


def column_degree(Tv, drained=("top",), p_top: float = 1.0, p_base=None):
    """Average degree of consolidation U = 1 - mean(p) / mean(p0) (dimensionless) of
    :func:`column_pressure`; for a uniform column it is also the settlement ratio
    (s - s0) / (s_inf - s0), since s = (q H + gamma' H^2 / 2 - H mean(p)) / E_c
    (:func:`column_settlement`). Undefined without drainage (the mean excess, and with it
    the settlement, does not change) or where the initial excess averages to zero: both
    raise ValueError."""
    if not set(drained) & {"top", "bottom"}:
        raise ValueError("U is undefined for a column without a drained end: its mean "
                         "excess pore pressure and its settlement do not change")
    mean0 = (p_top + (p_top if p_base is None else p_base)) / 2
    if mean0 == 0:
        raise ValueError("U is undefined for an initial excess pore pressure of mean zero")
    return 1.0 - column_mean(Tv, drained, p_top, p_base) / mean0


def column_settlement(mean_excess, H: float, E_c: float, q: float = 0.0,
                      gamma_b: float = 0.0):
    """Settlement (m, downwards) of a uniform column of height H (m) and constrained modulus
    E_c (Pa) under a load q (Pa) and its buoyant weight gamma_b = (1 - n)(rho_s - rho_l) g
    (N/m3), at a depth-average excess pore pressure ``mean_excess`` (Pa): the integral of
    the effective stress over E_c, (q H + gamma_b H^2 / 2 - H mean_excess) / E_c. The
    undrained settlement s0 at the initial mean, the final s_inf at 0 (any drained end)."""
    return (q * H + gamma_b * H * H / 2 - H * np.asarray(mean_excess)) / E_c


def undrained_excess(q: float, H: float, n: float, E_c: float, K_l=None, rho_s: float = 0.0,
                     rho_l: float = 0.0, g: float = 0.0):
    """(p_top, p_base): the excess pore pressure over hydrostatic (Pa) at the surface and at
    the base of a uniform column of height H (m) just after a load q (Pa) and gravity g
    (m/s2; 0: none) are applied to a fresh deposit, before water moves; K_l None: classic
    (incompressible water, B = 1), else the compressible-water share
    B = (K_l / n) / (K_l / n + E_c).

    Without relative flow the mixture strains as one body of modulus E_c + K_l / n under the
    total vertical stress sigma_v = q + gamma_m z (gamma_m = ((1 - n) rho_s + n rho_l) g, the
    mixture's weight, as the MPM's body force), so the pore pressure is B sigma_v and its
    excess over the hydrostatic rho_l g z is B q + (B gamma_m - rho_l g) z: with B = 1,
    q + gamma' z, gamma' = gamma_m - rho_l g = (1 - n)(rho_s - rho_l) g the buoyant weight."""
    B = 1.0 if K_l is None else undrained_pressure(1.0, E_c, K_l, n)
    gamma_m = ((1 - n) * rho_s + n * rho_l) * g
    return B * q, B * q + (B * gamma_m - rho_l * g) * H


def large_strain_column(a, t, H0: float, q: float, m_vl: float, k0: float,
                        gamma_w: float = 9.81e3, drained=("top",)) -> tuple:
    """Xie and Leo's (2004) large-strain consolidation of a weightless homogeneous clay
    column under a sudden load q (Pa): (the excess pore pressure u (Pa) at the material
    heights ``a`` (m, the heights before the load, up from the base) at time t (s), the
    settlement (m) at t). ``a`` and ``t`` broadcast for u; the settlement follows t.

    The clay's volume ratio zeta = (1 + e) / (1 + e0) = exp(-m_vl sigma') (m_vl (1/Pa)
    constant, sigma' the Cauchy effective stress) and its permeability k = k0 zeta^2 (m/s;
    the Gibson form with A = 2). In the material coordinate a the relative discharge is
    -(k / gamma_w) (1 / zeta) du/da, and with u = q - sigma' Gibson's equation becomes the
    linear diffusion d zeta / dt = c_v0 d^2 zeta / da^2, c_v0 = k0 / (gamma_w m_vl) (m2/s):
    zeta runs from 1 (the undrained start) to exp(-m_vl q) as Terzaghi's excess does, so
    zeta = zeta_inf + (1 - zeta_inf) P, P = :func:`column_pressure` / q at T_v = c_v0 t /
    H0^2, u = q + ln(zeta) / m_vl, and the settlement is the integral of 1 - zeta,
    H0 (1 - exp(-m_vl q)) U(T_v). Small strain gives m_vl q H0 at the end.
    """
    zeta_inf = math.exp(-m_vl * q)
    Tv = np.asarray(t, dtype=float) * k0 / (gamma_w * m_vl) / (H0 * H0)
    P = column_pressure(a, Tv, H0, drained, 1.0)
    u = q + np.log(zeta_inf + (1.0 - zeta_inf) * P) / m_vl
    settlement = H0 * (1.0 - zeta_inf) * column_degree(Tv, drained)
    return u, settlement


def large_strain_final(a, H0: float, q: float, gamma_b: float, M: float,
                       stress: str = "kirchhoff") -> tuple:
    """The drained end of a column of height H0 (m) on rollers (no lateral strain) under a
    load q (Pa) and its buoyant weight gamma_b (N/m3 of its initial volume: (1 - n0)
    (rho_s - rho_l) g), its skeleton Hencky-elastic of constrained modulus M (Pa): (the
    vertical effective stress, compression positive (Pa), and the volume ratio J at the
    material heights ``a`` (m, before the load, up from the base); the settlement (m)).

    Equilibrium alone gives the stress, whatever the law: the weight of the solids above
    and the load, s = q + gamma_b (H0 - a) (the area stays 1). The law gives J: ``cauchy``,
    s = -M ln J, J = exp(-s / M); ``kirchhoff``, J s = -M ln J, J = exp(-W(s / M)) = W / z
    (Lambert's W, z = s / M). The settlement is the integral of 1 - J over a: with
    dz = gamma_b da / M, the integral of exp(-z) is closed, and that of W(z) / z is
    W + W^2 / 2."""
    from scipy.special import lambertw

    a = np.asarray(a, dtype=float)
    s = q + gamma_b * (H0 - a)
    z0, z1 = q / M, (q + gamma_b * H0) / M

    def W(z):
        return np.real(lambertw(z))

    if stress == "cauchy":
        J = np.exp(-s / M)
        kept = H0 * math.exp(-z0) if gamma_b == 0 else M / gamma_b * (math.exp(-z0)
                                                                         - math.exp(-z1))
    else:
        J = np.exp(-W(s / M))
        w0, w1 = float(W(z0)), float(W(z1))
        kept = H0 * math.exp(-w0) if gamma_b == 0 else \
            M / gamma_b * ((w1 + w1 * w1 / 2) - (w0 + w0 * w0 / 2))
    return s, J, H0 - kept


def masing_damping(x):
    """The damping ratio (-) of a cycle at strain amplitude x = gamma_a / gamma_r of a soil
    whose backbone is the hyperbola tau = G gamma / (1 + gamma / gamma_r) and whose loops
    follow Masing's rules: the loop's area over 4 pi times tau_a gamma_a / 2,

        xi = (4 / pi) (1 + 1 / x) (1 - ln(1 + x) / x) - 2 / pi      (0.1448 at x = 1)

    (the area of the loop of branches 2 F(d / 2) about each tip, in closed form)."""
    x = np.asarray(x, dtype=float)
    return (4 / np.pi) * (1 + 1 / x) * (1 - np.log1p(x) / x) - 2 / np.pi


def hyperbolic_modulus_ratio(x):
    """G_secant / G_max (-) of the hyperbolic backbone at x = gamma / gamma_r: 1 / (1 + x)."""
    return 1.0 / (1.0 + np.asarray(x, dtype=float))
