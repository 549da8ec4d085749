"""Critical time steps of the explicit two-phase scheme (paper Table 1, and what it leaves out).

Table 1's four criteria use the smallest cell length L_min:
- ``cfl``        L_min / c,  c = sqrt(E_c / rho_m)                 (drained compression wave)
- ``undrained``  L_min / c1, c1 = sqrt((E_c + K_l / n) / rho_m)    (Jassim et al., 2013)
- ``diffusion``  L_min^2 / (2 c2), c2 = k / (gamma_w (1/E_c + n/K_l))
- ``oscillator`` L_min / c3, c3 = 2 pi f1 H, f1 the computed fundamental frequency
and two more that decide stability in practice:
- ``drag``       2 / lambda, lambda = (n g / k)(1 + n rho_l / ((1 - n) rho_s)): forward Euler
                 on the explicit drag, which damps the relative velocity at the rate lambda
- ``discrete``   2 / omega_max, omega_max^2 the largest eigenvalue of the undrained stiffness
                 against the lumped mixture mass of the actual grid, points and element
"""

from __future__ import annotations

import numpy as np
from slepc4py import SLEPc

from . import assembly
from .eigen import mixture_density
from .errors import NumericalError

G_REF = 9.81  # m/s2: the gravity in which the hydraulic conductivity k is defined


def unit_weight(p) -> float:
    """gamma_w = rho_l g (N/m3) of the liquid, with the g that defines k."""
    return p.rho_l * G_REF


def drag_rate(p) -> float:
    """Decay rate (1/s) of the relative velocity w = v_l - v_s under the drag alone."""
    n = p.porosity
    return n * G_REF / p.k * (1 + n * p.rho_l / ((1 - n) * p.rho_s))


def wave_speeds(p) -> dict:
    """Speeds c (drained), c1 (undrained) in m/s and the diffusivity c2 in m2/s."""
    E_c = assembly.constrained_modulus(p.E, p.nu)
    rho = mixture_density(p)
    return {"c": np.sqrt(E_c / rho), "c1": np.sqrt((E_c + p.K_l / p.porosity) / rho),
            "c2": p.k / (unit_weight(p) * (1 / E_c + p.porosity / p.K_l))}


def impermeable(drained) -> dict:
    """Liquid components held at zero on the impermeable sides: the normal one, as bcs."""
    normal = {"left": "x", "right": "x", "bottom": "y", "top": "y"}
    return {side: comp for side, comp in normal.items() if side not in drained}


def discrete_limit(grid, points, p, bcs, lumping) -> float:
    """The exact stability limit (s) of the explicit step on this grid, points and element.

    Linearised, the step is symplectic Euler on M u'' + C u' + K u = 0 with unknowns
    (u_s, u_l) per node: masses diag(M_s, M_l) lumped as in the step; drag C = n Q [[1, -1],
    [-1, 1]]; stiffness sum V [B^T D B on u_s + (K_l / n) b b^T], b = ((1 - n) div_s, n div_l),
    the discrete energy behind the step's effective stress and pore pressure (eqs. 8-9, 13-14).
    An amplification factor crosses -1 first, where det(4 M - 2 dt C - dt^2 K) = 0: with
    s = 1 / dt, the largest root of 4 s^2 M - 2 s C - K (real, since M, C, K are symmetric
    and semi-definite) gives dt_crit = 1 / s. Without drag this is 2 / omega_max; without
    stiffness, 2 / lambda of the drag. SLEPc's PEP solves it, in parallel.
    """
    n = p.porosity
    x, volume = points.get("x", "volume")
    it = assembly.interpolation(grid, x)
    npnt, nen = it.N.shape
    B = assembly.strain_matrix(it.dNdx)
    div = B[:, 0, :] + B[:, 1, :]
    solid = (4 * np.arange(nen)[:, None] + np.array([0, 1])).ravel()
    liquid = solid + 2
    Ke = np.zeros((npnt, 4 * nen, 4 * nen))
    Ke[:, solid[:, None], solid[None, :]] = np.einsum(
        "pki,kl,plj->pij", B, assembly.elasticity(p.E, p.nu), B) * volume[:, None, None]
    b = np.zeros((npnt, 4 * nen))
    b[:, solid] = (1 - n) * div
    b[:, liquid] = n * div
    Ke += (p.K_l / n) * volume[:, None, None] * b[:, :, None] * b[:, None, :]

    w = assembly.lumping_weights(it.N, lumping)
    kappa = p.k * p.mu_l / (p.rho_l * G_REF)
    q = n * (n * p.mu_l / kappa) * w * volume[:, None]          # n Q per (point, node)
    Ce = np.zeros_like(Ke)
    r = np.arange(npnt)[:, None]
    for c in range(2):
        i, j = solid[c::2], liquid[c::2]
        Ce[r, i, i] = q
        Ce[r, j, j] = q
        Ce[r, i, j] = -q
        Ce[r, j, i] = -q
    masses = np.stack([(1 - n) * p.rho_s * volume, n * p.rho_l * volume], axis=1)
    Me = np.zeros_like(Ke)
    for c in range(2):
        Me[r, solid[c::2], solid[c::2]] = w * masses[:, :1]
        Me[r, liquid[c::2], liquid[c::2]] = w * masses[:, 1:]

    da = grid.da.duplicate(dof=4)
    dofs = (4 * it.nodes[:, :, None] + np.arange(4)).reshape(npnt, -1)
    K, C, M = (assembly.assemble(da, e, dofs) for e in (Ke, Ce, Me))
    fixed = np.hstack([grid.constrained_mask(bcs).reshape(-1, 2),
                       grid.constrained_mask(impermeable(p.drained)).reshape(-1, 2)]).ravel()
    free = assembly.free_dofs(M, fixed, grid.comm)
    Kf, Cf, Mf = (A.createSubMatrix(free, free) for A in (K, C, M))
    Kf.scale(-1.0)
    Cf.scale(-2.0)
    Mf.scale(4.0)
    pep = SLEPc.PEP().create(grid.comm)
    pep.setOperators([Kf, Cf, Mf])
    pep.setProblemType(SLEPc.PEP.ProblemType.GENERAL)
    pep.setWhichEigenpairs(SLEPc.PEP.Which.LARGEST_REAL)
    pep.setDimensions(nev=1)
    pep.setTolerances(tol=1e-12, max_it=2000)
    pep.solve()
    if pep.getConverged() < 1:
        raise NumericalError("SLEPc PEP did not converge on the discrete stability limit")
    s_max = max(pep.getEigenpair(k).real for k in range(pep.getConverged()))
    for obj in (pep, K, C, M, Kf, Cf, Mf, free, da):
        obj.destroy()
    return 1.0 / s_max


def criteria(p, f1: float, dt_discrete: float, grid) -> dict:
    """All critical time steps (s) of the scene, keyed as in the summary."""
    L = min(grid.h)
    s = wave_speeds(p)
    c3 = 2 * np.pi * f1 * p.size[1]
    return {"cfl": L / s["c"], "undrained": L / s["c1"], "diffusion": L * L / (2 * s["c2"]),
            "oscillator": L / c3, "drag": 2 / drag_rate(p), "discrete": dt_discrete}


# Criteria that bound stability; the oscillator criterion is Table 1's but, built on the
# lowest frequency, it does not.
STABILITY = ("cfl", "undrained", "diffusion", "oscillator", "drag", "discrete")
