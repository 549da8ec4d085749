"""Q4's compact Darcy stencil (``kernels._compact``) as the explicit step's stability
analysis sees it: its cap, and its operator on the corner pressures, which the linearised
step (``timestep``) carries as a state of its own, Z = P - A U, Z' = Z + E(dt)(A U + Z).
"""

from __future__ import annotations

import numpy as np

from ..common.linalg import reciprocal


def applies(element: str, projection: str, liquid_basis: str, layers: int) -> bool:
    """Whether the explicit step's Darcy flux takes the compact stencil: Q4 cells with the
    corner projection (its pressures share their nodes with the liquid), the element's
    basis and one soil (in layers the nodes' harmonic flux made it grow: docs/method.md)."""
    return (element == "q4" and projection == "corner" and liquid_basis == "element"
            and layers == 1)


def cap(h) -> float:
    """The cap (m2) on dt (K_l / n)(k / gamma_w) of Q4's compact Darcy stencil
    (kernels._compact) on cells of sizes h (m): h_min^2 / 4 = 1 / lambda, lambda <= 4 /
    h_min^2 the largest eigenvalue of its operator M^-1 (K - G^T M^-1 G) (3.75-3.99 /
    h_min^2 on square and stretched cells, 1 to 4 points: tests/test_compact_darcy.py),
    half the forward-Euler limit of the stencil alone."""
    return min(h) ** 2 / 4


def operator(corner, Nl, V, n, soil, drag, cap, Dx, Dy) -> dict:
    """What the compact Darcy stencil's step on the corner pressures is made of: per step
    P += E(dt) P with E(dt) = M^-1 sum V grad N4 . c dq (kernels._compact), dq = -(k /
    gamma_w) grad p - N_l F, F = sum N_l V (-grad p) / sum N_l V gamma_w / k (the nodes'
    quasi-static flux), and c = dt (K_l / n) min(1, cap / (dt (K_l / n)(k / gamma_w))).
    Returned as the matrices of the operator (E is linear in P; dt enters through c), with
    A (P of U) and the forces of the pressure state Z = P - A U."""
    L, Lx, Ly, held = corner["L"], corner["Lx"], corner["Ly"], corner["held"]
    n = np.broadcast_to(np.ravel(n), V.shape)
    kg = n / drag                                              # k / gamma_w per point
    Minv = np.where(held, 0.0, reciprocal(L.T @ V))
    Sdrag = Nl.T @ (V / kg)                                    # sum N_l V gamma_w / k
    ops = []
    for D in (Lx, Ly):
        F = reciprocal(Sdrag)[:, None] * (Nl.T @ (V[:, None] * -D))    # nodes x P
        dq = -kg[:, None] * D - Nl @ F                             # points x P
        ops.append((D, dq))
    # The pressure state Z = P - A U that the stencil adds: its forces on the mixture
    # (B^T N4 Z V) and the liquid (-N_l^T V grad N4 Z).
    pz = L * V[:, None]
    return {"Minv": Minv, "ops": ops, "V": V, "Kn": soil.K_l / n, "kg": kg, "cap": cap,
            "A": corner["A"],
            "fm": np.vstack([Dx.T @ pz, Dy.T @ pz]),
            "fl": -np.vstack([Nl.T @ (V[:, None] * Lx), Nl.T @ (V[:, None] * Ly)])}


def step(compact, dt):
    """E(dt) (corner nodes x corner nodes) of :func:`operator`."""
    kdp = dt * compact["Kn"]
    c = kdp * np.minimum(1.0, compact["cap"] / (kdp * compact["kg"]))
    E = sum(D.T @ ((compact["V"] * c)[:, None] * dq) for D, dq in compact["ops"])
    return compact["Minv"][:, None] * E
