"""Compression waves in a saturated column: the references of a sudden load.

The one-dimensional v-w equations of the explicit step (paper eqs. 6-15, incompressible
grains) for plane waves e^{i(w t - kappa x)}: solid and liquid velocities V, W, effective
stress rate E_c div v_s, pore pressure rate -(K_l / n)[(1 - n) div v_s + n div v_l], drag
b (v_l - v_s) with b = n rho_l g / k per unit volume. With s = kappa^2 / w^2 (a squared
slowness) they read s A x = B(w) x, x = (V, W):

    A = [[E_c + (1 - n) K_l / n, K_l], [(1 - n) K_l / n, K_l]]     (mixture; liquid)
    B = [[(1 - n) rho_s, n rho_l], [i b / w, rho_l - i b / w]]

Two waves: the fast one and Biot's slow one. At low frequency (w << b / rho_l: the drag
locks the phases) the fast wave is undrained, c_u = sqrt((E_c + K_l / n) / rho) with the
mixture's density rho; at high frequency the phases decouple and both speeds follow from
B(inf). A step load sends a front at the high-frequency speed whose height decays by drag
within a few b / rho_l of time, behind it the undrained wave at c_u carrying the pressure
jump B q = q (K_l / n) / (E_c + K_l / n), and once the waves have died (by drag) the column
consolidates as Terzaghi's with compressible water. SI units."""

from __future__ import annotations

import math

import numpy as np

from ..model.soil import G_REF


def matrices(E_c, K_l, n, rho_s, rho_l, k, f):
    """(A, B) of the plane-wave problem s A x = B x at frequency f (Hz; inf: the drag
    vanishes beside the inertia)."""
    b = n * rho_l * G_REF / k
    A = np.array([[E_c + (1 - n) * K_l / n, K_l], [(1 - n) * K_l / n, K_l]],
                 dtype=complex)
    drag = 0.0 if math.isinf(f) else 1j * b / (2 * math.pi * f)
    B = np.array([[(1 - n) * rho_s, n * rho_l], [drag, rho_l - drag]], dtype=complex)
    return A, B


def phase_speeds(E_c, K_l, n, rho_s, rho_l, k, f) -> np.ndarray:
    """The phase speeds w / Re(kappa) (m/s) of the fast and the slow wave at frequency f
    (Hz; inf allowed), fast first."""
    A, B = matrices(E_c, K_l, n, rho_s, rho_l, k, f)
    s = np.linalg.eigvals(np.linalg.solve(A, B))
    c = 1 / np.real(np.sqrt(s))
    return np.sort(c)[::-1]


def undrained_speed(E_c, K_l, n, rho_s, rho_l) -> float:
    """c_u = sqrt((E_c + K_l / n) / rho) (m/s): the fast wave when drag locks the phases."""
    rho = (1 - n) * rho_s + n * rho_l
    return math.sqrt((E_c + K_l / n) / rho)


def decay_time(E_c, K_l, n, rho_s, rho_l, k, f) -> float:
    """The time (s) over which the fast wave of frequency f (Hz) loses a factor e of its
    amplitude by drag: 1 / (Im(kappa) c)."""
    A, B = matrices(E_c, K_l, n, rho_s, rho_l, k, f)
    kappa = 2 * math.pi * f * np.sqrt(np.linalg.eigvals(np.linalg.solve(A, B)))
    fast = np.argmin(np.abs(kappa.real))           # the smaller wavenumber: the fast wave
    c = 2 * math.pi * f / abs(kappa[fast].real)
    return float(1 / (abs(kappa[fast].imag) * c))
