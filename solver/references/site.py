"""Site response of a layered shear column: the exact one-dimensional references of the
dynamic analysis.

Vertically propagating shear waves through horizontal layers (thickness h, shear-wave speed
Vs, density rho, hysteretic damping ratio xi each) on a rigid base or on an elastic
half-space (the rock: Vs_r, rho_r, xi_r). SI units. In each layer the displacement is
u = A e^{i(w t + k z)} + B e^{i(w t - k z)}, z down from the layer's top, the complex
modulus G* = G (1 + 2 i xi), V* = sqrt(G* / rho), k* = w / V* (Kramer 1996, section 7.2);
A travels up, B down. The free surface gives A_1 = B_1; continuity of displacement and
shear stress at each interface gives, with the impedance ratio a_m = rho_m V*_m /
(rho_{m+1} V*_{m+1}),

    A_{m+1} = (A_m (1 + a_m) e^{i k_m h_m} + B_m (1 - a_m) e^{-i k_m h_m}) / 2
    B_{m+1} = (A_m (1 - a_m) e^{i k_m h_m} + B_m (1 + a_m) e^{-i k_m h_m}) / 2.

With A_1 = B_1 = 1 the surface moves 2; the rock's outcrop (its free surface with the same
incident wave) 2 A_{N+1}; the base of the soil (a "within" motion) A_{N+1} + B_{N+1}. So

    outcrop transfer function  H_o(f) = A_1 / A_{N+1}         (a compliant base)
    within transfer function   H_w(f) = 2 / (A_{N+1} + B_{N+1})  (a rigid base)

:func:`transfer` evaluates either at frequencies f (Hz); :func:`response` turns an input
acceleration history into the surface's by FFT (zero-padded, so that the response has died
before it wraps around: damping or a compliant base make it decay). Everything here is the
closed form, independent of the MPM that it checks.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..common.errors import InputError


@dataclass(frozen=True)
class Column:
    """Layers from the surface down: ``thickness`` (m), ``Vs`` (m/s), ``rho`` (kg/m3) and
    ``damping`` (ratio) each a tuple of one value per layer; the rock under them ``rock``
    = (Vs_r (m/s), rho_r (kg/m3), xi_r), or None for a rigid base; ``viscosity`` a1 (s),
    the soil's stiffness-proportional (Kelvin-Voigt) damping, G* = G (1 + 2 i xi + i w a1):
    the damping ratio a1 w / 2 of Rayleigh's stiffness term."""

    thickness: tuple
    Vs: tuple
    rho: tuple
    damping: tuple = None
    rock: tuple = None
    viscosity: float = 0.0

    def __post_init__(self):
        n = len(self.thickness)
        damping = self.damping if self.damping is not None else (0.0,) * n
        object.__setattr__(self, "damping", tuple(damping))
        for name in ("Vs", "rho", "damping"):
            if len(getattr(self, name)) != n:
                raise InputError(f"site column: {n} layers but {len(getattr(self, name))} "
                                 f"values of {name}")
        values = list(self.thickness) + list(self.Vs) + list(self.rho)
        if self.rock is not None:
            values += list(self.rock[:2])
        if n == 0 or not all(v > 0 and math.isfinite(v) for v in values):
            raise InputError("site column: thicknesses, speeds and densities must be > 0")

    @property
    def height(self) -> float:
        """H (m)."""
        return float(sum(self.thickness))

    def travel_time(self) -> float:
        """The shear wave's travel time through the layers (s)."""
        return float(sum(h / v for h, v in zip(self.thickness, self.Vs)))


def _complex_speed(Vs, xi):
    return np.asarray(Vs, dtype=float) * np.sqrt(1 + 2j * np.asarray(xi, dtype=float))


def _amplitudes(column: Column, f) -> tuple:
    """(A_{N+1}, B_{N+1}) for A_1 = B_1 = 1 at frequencies f (Hz), one array each."""
    w = 2 * np.pi * np.asarray(f, dtype=float)
    A = np.ones_like(w, dtype=complex)
    B = np.ones_like(w, dtype=complex)
    # Layers down, frequencies across: the viscous term makes V* depend on w.
    V = _complex_speed(np.asarray(column.Vs)[:, None],
                       np.asarray(column.damping)[:, None] + w[None, :] * column.viscosity / 2)
    rho = np.asarray(column.rho, dtype=float)
    if column.rock is not None:
        Vr = _complex_speed(column.rock[0], column.rock[2] if len(column.rock) > 2 else 0.0)
        below = np.vstack([rho[1:, None] * V[1:], column.rock[1] * Vr + 0 * w])
    else:       # the base: continuity of u alone counts
        below = np.vstack([rho[1:, None] * V[1:], np.full_like(w, np.inf)])
    for m, h in enumerate(column.thickness):
        phase = np.exp(1j * w / V[m] * h)
        a = rho[m] * V[m] / below[m]
        A, B = (A * (1 + a) * phase + B * (1 - a) / phase) / 2, \
            (A * (1 - a) * phase + B * (1 + a) / phase) / 2
    return A, B


def transfer(column: Column, f, base: str = "outcrop") -> np.ndarray:
    """The surface's motion over the input's at frequencies f (Hz), complex: ``outcrop``
    (the rock's outcrop motion, a compliant base) or ``within`` (the motion at the base of
    the soil; the only one a rigid base has)."""
    if base not in ("outcrop", "within"):
        raise InputError(f"site transfer: base {base!r}: outcrop or within")
    if base == "outcrop" and column.rock is None:
        raise InputError("site transfer: a rigid base has no outcrop motion (use within)")
    A, B = _amplitudes(column, f)
    return 1 / A if base == "outcrop" else 2 / (A + B)


def response(column: Column, dt: float, a_in, base: str = "outcrop", pad: int = 4):
    """The surface acceleration (m/s2) for the input acceleration history ``a_in`` (m/s2,
    samples dt s apart, from t = 0), by FFT of the input zero-padded to ``pad`` times its
    length (rounded up to a power of two) and multiplied by :func:`transfer`."""
    a_in = np.asarray(a_in, dtype=float)
    n = 1 << max(1, math.ceil(math.log2(pad * max(len(a_in), 2))))
    spectrum = np.fft.rfft(a_in, n)
    f = np.fft.rfftfreq(n, dt)
    tf = transfer(column, f, base)
    return np.fft.irfft(spectrum * tf, n)[:len(a_in)]


def layer_frequencies(H: float, Vs: float, count: int = 3) -> np.ndarray:
    """The resonances (2 n - 1) Vs / (4 H) (Hz), n = 1 .. count, of a uniform layer of
    height H (m) on a rigid base."""
    return (2 * np.arange(1, count + 1) - 1) * Vs / (4 * H)


def peaks(f, tf, count: int = 3) -> np.ndarray:
    """The frequencies (Hz) of the first ``count`` local maxima of |tf| over the grid f,
    each refined by a parabola through its three samples."""
    mag = np.abs(np.asarray(tf))
    i = np.flatnonzero((mag[1:-1] > mag[:-2]) & (mag[1:-1] >= mag[2:])) + 1
    out = []
    for k in i[:count]:
        y0, y1, y2 = mag[k - 1], mag[k], mag[k + 1]
        shift = 0.5 * (y0 - y2) / (y0 - 2 * y1 + y2) if y0 - 2 * y1 + y2 else 0.0
        out.append(f[k] + shift * (f[k + 1] - f[k]))
    return np.array(out)
