"""References for columns of horizontal layers: the natural frequencies of a layered rod and
the consolidation of a layered column, both from the modes of the 1D Sturm-Liouville problem

    (a X')' + lam b X = 0,   a, b > 0 constant in each layer,

with X and a X' continuous at the interfaces: the rod (a = E_c, b = rho, lam = omega^2) and
the column's excess pore pressure (a = k / gamma_w, b = m_v = 1 / E_c + n / K_l, lam the
decay rate). Layers are given from the surface down, as ``-mpm_layers``; heights y (m) are
measured up from the base, as the MPM's points are.

The modes come from the transfer matrix of each layer written in phase (Pruefer) form: with
w = sqrt(lam), X = r sin(theta) and a X' = w Z r cos(theta), Z = sqrt(a b), the phase grows
by exactly w d sqrt(b / a) across a layer of thickness d, and an interface maps
tan(theta) -> (Z_above / Z_below) tan(theta) within the same branch of width pi. The phase
at the top, Theta(w), is then continuous and strictly increasing in w (a composition of
increasing maps), and mode j is the one w where Theta reaches the j-th value the top's
condition allows. Each mode has its own equation with a bracket known in advance
(|Theta - theta_0 - w tau| < (interfaces) pi / 2, tau = sum d sqrt(b / a)), so no root can be
missed however close two are; bisection, vectorised over the modes, closes the brackets to
round-off.
"""

from __future__ import annotations

import math

import numpy as np

from .analytic import drained_ends

# Points per block, as in analytic: temporaries bounded whatever the number of points.
_CHUNK = 16384


def _per_layer(value, count: int) -> np.ndarray:
    """One value per layer, from the base up, of a scalar or a list from the surface down."""
    v = np.asarray(value, dtype=float)
    if v.ndim == 0:
        return np.full(count, float(v))
    if v.shape != (count,):
        raise ValueError(f"{v.size} values for {count} layers")
    return v[::-1].copy()


class _Modes:
    """Modes of (a X')' + lam b X = 0 on a stack of layers, computed as far as asked.

    ``thickness``, ``a``, ``b``: per layer, from the surface down; ``base``, ``top``: True
    where X = 0 (fixed, drained), False where a X' = 0 (free, impermeable)."""

    def __init__(self, thickness, a, b, base: bool, top: bool):
        self.d = np.asarray(thickness, dtype=float)[::-1].copy()     # from the base up
        self.a, self.b = _per_layer(a, self.d.size), _per_layer(b, self.d.size)
        if (self.d <= 0).any() or (self.a <= 0).any() or (self.b <= 0).any():
            raise ValueError("layers need positive thicknesses and coefficients")
        self.y0 = np.r_[0.0, np.cumsum(self.d)[:-1]]                # layer bottoms (m)
        self.H = float(self.d.sum())
        self.slow = np.sqrt(self.b / self.a)                         # phase per unit w, length
        self.Z = np.sqrt(self.a * self.b)
        self.tau = float((self.d * self.slow).sum())
        self.b_d = self.b * self.d
        self.base, self.top = base, top
        self.theta0 = 0.0 if base else math.pi / 2
        self.w = np.zeros(0)

    def targets(self, j):
        """The phase at the top of mode j (0, 1, ...): the values k pi (X = 0 at the top) or
        pi / 2 + k pi (a X' = 0) above theta_0, from theta_0 itself with both ends free (the
        constant mode, w = 0)."""
        first = self.theta0 + (math.pi / 2 if self.base != self.top else
                               (math.pi if self.base else 0.0))
        return first + math.pi * np.asarray(j, dtype=float)

    def march(self, w):
        """Phases at the bottom of each layer and amplitudes (modes x layers) for the
        frequencies w, and the phase at the top (modes)."""
        w = np.asarray(w, dtype=float)
        theta = np.full(w.shape, self.theta0)
        r = np.ones(w.shape)
        start, amp = np.empty(w.shape + self.d.shape), np.empty(w.shape + self.d.shape)
        for i in range(self.d.size):
            start[..., i], amp[..., i] = theta, r
            theta = theta + w * self.slow[i] * self.d[i]
            if i + 1 < self.d.size:
                ratio = self.Z[i + 1] / self.Z[i]
                m = np.floor(theta / math.pi + 0.5)
                phi = theta - m * math.pi                             # in [-pi/2, pi/2)
                r = r * np.sqrt(np.sin(phi) ** 2 + (np.cos(phi) / ratio) ** 2)
                theta = m * math.pi + np.arctan2(ratio * np.sin(phi), np.cos(phi))
        return start, amp, theta

    def frequencies(self, n: int):
        """The n smallest w (>= 0), to round-off."""
        if n > self.w.size:
            j = np.arange(self.w.size, n)
            target = self.targets(j)
            slack = (self.d.size - 1) * math.pi / 2
            lo = np.maximum((target - self.theta0 - slack) / self.tau, 0.0)
            hi = (target - self.theta0 + slack) / self.tau
            for _ in range(200):
                if (hi - lo <= 4e-16 * hi).all():
                    break
                mid = 0.5 * (lo + hi)
                below = self.march(mid)[2] < target
                lo, hi = np.where(below, mid, lo), np.where(below, hi, mid)
            self.w = np.r_[self.w, 0.5 * (lo + hi)]
        return self.w[:n]

    def shapes(self, y, w, start, amp):
        """X of the modes (rows) at heights y (m); heights outside [0, H] continue the end
        layers' sines, which is the odd (fixed) or even (free) continuation about the end."""
        layer = np.clip(np.searchsorted(self.y0, y, side="right") - 1, 0, self.d.size - 1)
        s = y - self.y0[layer]
        return amp[:, layer] * np.sin(start[:, layer] + np.outer(w, self.slow[layer] * s))


def rod_frequencies(thickness, E_c, rho, nmodes: int) -> np.ndarray:
    """Natural frequencies (Hz) of a column of horizontal layers fixed at the base and free
    at the top: thickness (m), constrained modulus E_c (Pa) and density rho (kg/m3) per
    layer from the surface down (a scalar: every layer). One layer gives
    analytic.rod_frequencies."""
    modes = _Modes(thickness, E_c, rho, base=True, top=False)
    return modes.frequencies(nmodes) / (2 * math.pi)


def rod_modes(thickness, E_c, rho, nmodes: int, y) -> np.ndarray:
    """Shapes (nmodes x heights, dimensionless, 1 at the top) of the rod's modes at heights
    ``y`` (m, up from the base)."""
    modes = _Modes(thickness, E_c, rho, base=True, top=False)
    w = modes.frequencies(nmodes)
    start, amp, _ = modes.march(w)
    X = modes.shapes(np.asarray(y, dtype=float).reshape(-1), w, start, amp)
    top = modes.shapes(np.array([modes.H]), w, start, amp)
    return (X / top).reshape((nmodes,) + np.shape(y))


def _g(x):
    """(sin x - x cos x) / x^2, by its series where the difference would cancel."""
    x = np.asarray(x, dtype=float)
    small = np.abs(x) < 0.05
    xs = np.where(small, 1.0, x)
    x2 = x * x
    series = x * (1 / 3 - x2 * (1 / 30 - x2 * (1 / 840 - x2 / 45360)))
    return np.where(small, series, (np.sin(xs) - xs * np.cos(xs)) / (xs * xs))


class LayeredColumn:
    """Consolidation of a column of horizontal layers: thickness (m), constrained modulus
    E_c (Pa), hydraulic conductivity k (m/s), porosity n per layer from the surface down (a
    scalar: every layer); gamma_w = rho_l G_REF (N/m3), in which k is defined; K_l (Pa) the
    pore fluid's bulk modulus (None: incompressible, the classic form); a uniform load q
    (Pa) and, with g > 0 (m/s2), the layers' own weight (rho_s per layer, rho_l, kg/m3), all
    applied at t = 0; drained through the ends in ``drained`` ("top", "bottom", both or
    none), held there at the hydrostatic pressure of a water table at the surface.

    The excess pore pressure u over hydrostatic obeys m_v u_t = ((k / gamma_w) u_y)_y,
    m_v = 1 / E_c + n / K_l, with u and the flux (k / gamma_w) u_y continuous at the
    interfaces, from the undrained state u0 = B sigma_v - rho_l g z in each layer
    (analytic.undrained_excess: B = (K_l / n) / (K_l / n + E_c) of the layer, sigma_v the
    total vertical stress at depth z). It is the mode expansion
    u = sum_j c_j X_j(y) exp(-w_j^2 t), c_j = int m_v u0 X_j / int m_v X_j^2 (closed forms
    per layer), summed to ``tol`` x max|u0| at every point: the modes left out are bounded
    by |c_j X_j| <= |u0|_m (Z_max / Z_min)^(interfaces) / sqrt(sum m_v d / 4) once every
    counted layer holds two radians of the mode, and w_j >= its bracket's lower end.
    """

    def __init__(self, thickness, E_c, k, n, gamma_w: float, K_l=None, q: float = 0.0,
                 drained=("top",), rho_s=0.0, rho_l: float = 0.0, g: float = 0.0,
                 tol: float = 1e-10):
        base, top = drained_ends(drained)
        d = np.asarray(thickness, dtype=float)
        count = d.size
        self.E_c, n = _per_layer(E_c, count), _per_layer(n, count)      # from the base up
        self.m_v = 1 / self.E_c + (0.0 if K_l is None else n / K_l)
        self.modes = _Modes(d, _per_layer(k, count)[::-1] / gamma_w, self.m_v[::-1],
                            base, top)
        B = np.ones(count) if K_l is None else (K_l / n) / (K_l / n + self.E_c)
        gamma_m = ((1 - n) * _per_layer(rho_s, count) + n * rho_l) * g
        md = self.modes
        # Total vertical stress and depth at each layer's bottom; the excess is linear in y
        # within a layer: u0 = alpha + beta (y - y_bottom).
        depth = md.H - md.y0
        sigma = q + np.cumsum((gamma_m * md.d)[::-1])[::-1]
        self.alpha = B * sigma - rho_l * g * depth
        self.beta = -(B * gamma_m - rho_l * g)
        self.B, self.tol, self.drained = B, tol, (base, top)
        # The settlement with no excess left: the hydrostatic state's effective stress.
        self.s_eff = float(((sigma - gamma_m * md.d / 2 - rho_l * g * (depth - md.d / 2))
                            * md.d / self.E_c).sum())
        self.s0 = self.s_eff - self._integral(1.0 / self.E_c)
        ub = self._integral(self.m_v) / float((self.m_v * md.d).sum())
        self.s_inf = self.s_eff - (ub * float((md.d / self.E_c).sum())
                                   if not (base or top) else 0.0)
        h = md.d / 2
        norm2 = (self.m_v * md.d * ((self.alpha + self.beta * h) ** 2
                                    + (self.beta * h) ** 2 / 3)).sum()
        self.scale = float(np.abs(np.r_[self.alpha, self.alpha + self.beta * md.d]).max())
        ratio = np.maximum(md.Z[1:] / md.Z[:-1], md.Z[:-1] / md.Z[1:])
        self._bound = math.sqrt(norm2) * float(np.prod(ratio))
        self._c = self._settle = self._mean = np.zeros(0)

    def _integral(self, weight):
        """int weight u0 dy (weight per layer, from the base up)."""
        d = self.modes.d
        return float((weight * d * (self.alpha + self.beta * d / 2)).sum())

    @property
    def undrained(self) -> np.ndarray:
        """The undrained share B of a load in each layer, from the surface down."""
        return self.B[::-1].copy()

    def _count(self, t: float) -> int:
        """Modes whose tail is below tol x max|u0| at time t > 0 (the class docstring's
        bound, with w_j >= L_j = (target_j - theta_0 - slack) / tau, L_j + 1 = L_j + pi /
        tau, so the tail from n sums below exp(-L_n^2 t) / (1 - exp(-2 pi L_n t / tau)))."""
        md = self.modes
        slack = (md.d.size - 1) * math.pi / 2
        n, step = 0, 64
        while True:
            j = np.arange(n, n + step)
            L = np.maximum((md.targets(j) - md.theta0 - slack) / md.tau, 0.0)
            held = (np.outer(L, md.slow * md.d) >= 2) * (md.b_d / 4)
            room = held.sum(axis=1)
            with np.errstate(divide="ignore", over="ignore", invalid="ignore"):
                tail = (self._bound / np.sqrt(room) * np.exp(-L * L * t)
                        / -np.expm1(-2 * math.pi * L * t / md.tau))
            ok = (room > 0) & (L > 0) & (tail <= self.tol * self.scale)
            if ok.any():
                return int(j[np.argmax(ok)])
            n, step = n + step, 2 * step

    def _ensure(self, n: int):
        """Frequencies, phases, amplitudes, coefficients c_j and int X_j / E_c of n modes."""
        if n <= self._c.size:
            return
        md = self.modes
        w = md.frequencies(n)
        start, amp, _ = md.march(w)
        x = np.outer(w, md.slow * md.d / 2)                 # half the phase across a layer
        mid = start + x
        h = md.d / 2
        sinc = np.sinc(x / math.pi)
        proj = (self.m_v * amp * ((self.alpha + self.beta * h) * md.d * np.sin(mid) * sinc
                                  + 2 * self.beta * h * h * np.cos(mid) * _g(x))).sum(axis=1)
        norm = (self.m_v * amp ** 2 * h * (1 - np.cos(2 * mid) * np.sinc(2 * x / math.pi))
                ).sum(axis=1)
        self.w, self.start, self.amp = w, start, amp
        self._c = proj / norm
        self._settle = (amp * md.d * np.sin(mid) * sinc / self.E_c).sum(axis=1)
        self._mean = (amp * md.d * np.sin(mid) * sinc).sum(axis=1) / md.H

    def _at(self, t: float):
        """(w, c_j exp(-w^2 t)) of the modes time t needs."""
        n = self._count(t) if self.scale > 0 else 1
        self._ensure(n)
        w = self.w[:n]
        return w, self._c[:n] * np.exp(-w * w * t)

    def initial(self, y) -> np.ndarray:
        """The undrained excess pore pressure u0 (Pa) at heights ``y`` (m), 0 at a drained
        end."""
        md = self.modes
        y = np.asarray(y, dtype=float)
        layer = np.clip(np.searchsorted(md.y0, y, side="right") - 1, 0, md.d.size - 1)
        u = self.alpha[layer] + self.beta[layer] * (y - md.y0[layer])
        base, top = self.drained
        return np.where((base & (y == 0)) | (top & (y == md.H)), 0.0, u)

    def pressure(self, y, t) -> np.ndarray:
        """Excess pore pressure over hydrostatic (Pa) at heights ``y`` (m, up from the base)
        and times ``t`` (s; shape t.shape + y.shape); at t <= 0 the undrained state."""
        md = self.modes
        y = np.asarray(y, dtype=float).reshape(-1)
        times = np.asarray(t, dtype=float)
        out = np.empty((times.size, y.size))
        for row, ti in zip(out, times.reshape(-1)):
            if ti <= 0:
                row[:] = self.initial(y)
                continue
            w, e = self._at(float(ti))
            for lo in range(0, y.size, _CHUNK):
                yb = y[lo:lo + _CHUNK]
                layer = np.clip(np.searchsorted(md.y0, yb, side="right") - 1, 0,
                                md.d.size - 1)
                phase = md.slow[layer] * (yb - md.y0[layer])
                acc = np.zeros(yb.size)
                for j in range(w.size):
                    acc += e[j] * self.amp[j, layer] * np.sin(self.start[j, layer]
                                                              + w[j] * phase)
                row[lo:lo + _CHUNK] = acc
        return out.reshape(times.shape + np.shape(np.asarray(y)))

    def _over_time(self, t, initial: float, weights: str, offset: float = 0.0,
                   sign: float = 1.0) -> np.ndarray:
        """offset + sign sum_j c_j exp(-w_j^2 t) W_j at times ``t`` (s), W the per-mode
        integrals named ``weights`` ('_settle', '_mean'); ``initial`` at t <= 0."""
        times = np.asarray(t, dtype=float)
        out = np.empty(times.size)
        for i, ti in enumerate(times.reshape(-1)):
            if ti <= 0:
                out[i] = initial
                continue
            w, e = self._at(float(ti))
            out[i] = offset + sign * float(e @ getattr(self, weights)[:w.size])
        return out.reshape(times.shape)[()]

    def settlement(self, t) -> np.ndarray:
        """Settlement (m, downwards) at times ``t`` (s): int (sigma_v - rho_l g z - u) / E_c
        dy; s0 at t <= 0."""
        return self._over_time(t, self.s0, "_settle", self.s_eff, -1.0)

    def mean_excess(self, t) -> np.ndarray:
        """The mean excess pore pressure over the height (Pa) at times ``t`` (s); the
        undrained one at t <= 0."""
        return self._over_time(t, self._integral(1.0) / self.modes.H, "_mean")

    def degree(self, t) -> np.ndarray:
        """U = (s - s0) / (s_inf - s0) (dimensionless) at times ``t`` (s); undefined (raises
        ValueError) without a drained end, as analytic.column_degree."""
        if not any(self.drained):
            raise ValueError("U is undefined for a column without a drained end")
        return (self.settlement(t) - self.s0) / (self.s_inf - self.s0)
