"""Finite strain for the materials of this room: Hencky's elasticity with the return
mapping in principal logarithmic strain (Simo 1992; de Souza Neto, Peric and Owen 2008,
chapter 14).

Each point carries its elastic left Cauchy-Green tensor b_e (plane strain: the in-plane
2 x 2 block and zz). A step's incremental deformation gradient f (the in-plane 2 x 2; f_zz
= 1) gives the trial

    b_e,tr = f b_e,n f^T,     eps_tr = ln(sqrt(eigenvalues of b_e,tr))   (principal),

the Kirchhoff stress is linear in the logarithmic elastic strain (tau = D eps, Hencky), so
the small-strain return of any material of constant elasticity (Elastic, Mohr-Coulomb,
Tresca, Drucker-Prager) applies unchanged in the principal frame of b_e,tr: the material
updates the zero stress by eps_tr along the principal axes and returns tau. The elastic
strain after the return is D^-1 tau, b_e = sum exp(2 eps_i) n_i n_i^T, and the Cauchy
stress sigma = tau / J, J = det F. A rigid rotation R leaves the eigenvalues of b_e,tr as
they were and turns its eigenvectors by R: the stress turns with the body and its
invariants stay exactly (objectivity without a stress rate).
"""

from __future__ import annotations

import numpy as np

from .model import isotropic


def _eigen(b) -> tuple:
    """(the in-plane eigenvalues (np, 2), the angle theta (np,) of the first's direction)
    of the symmetric 2 x 2 blocks b (np, 2, 2)."""
    c = 0.5 * (b[:, 0, 0] + b[:, 1, 1])
    r = np.hypot(0.5 * (b[:, 0, 0] - b[:, 1, 1]), b[:, 0, 1])
    theta = 0.5 * np.arctan2(2 * b[:, 0, 1], b[:, 0, 0] - b[:, 1, 1])
    return np.stack([c + r, c - r], axis=1), theta


def _rebuild(values, theta) -> np.ndarray:
    """Symmetric 2 x 2 blocks (np, 2, 2) of eigenvalues (np, 2) along theta and theta + 90."""
    c, s = np.cos(theta), np.sin(theta)
    out = np.empty((len(values), 2, 2))
    out[:, 0, 0] = values[:, 0] * c * c + values[:, 1] * s * s
    out[:, 1, 1] = values[:, 0] * s * s + values[:, 1] * c * c
    out[:, 0, 1] = out[:, 1, 0] = (values[:, 0] - values[:, 1]) * s * c
    return out


def det2(a) -> np.ndarray:
    """The determinants (np,) of the 2 x 2 blocks a (np, 2, 2), written out: LAPACK's per
    block (np.linalg.det) took a fifth of a large-deformation step."""
    return a[:, 0, 0] * a[:, 1, 1] - a[:, 0, 1] * a[:, 1, 0]


def congruence(f, b) -> np.ndarray:
    """f b f^T (np, 2, 2) of the 2 x 2 blocks f and the symmetric b, written out (NumPy's
    batched matmul of 2 x 2 blocks is slower than the six products)."""
    f00, f01, f10, f11 = f[:, 0, 0], f[:, 0, 1], f[:, 1, 0], f[:, 1, 1]
    b00, b01, b11 = b[:, 0, 0], b[:, 0, 1], b[:, 1, 1]
    g00, g01 = f00 * b00 + f01 * b01, f00 * b01 + f01 * b11
    g10, g11 = f10 * b00 + f11 * b01, f10 * b01 + f11 * b11
    out = np.empty_like(b)
    out[:, 0, 0] = g00 * f00 + g01 * f01
    out[:, 1, 1] = g10 * f10 + g11 * f11
    out[:, 0, 1] = out[:, 1, 0] = g00 * f10 + g01 * f11
    return out


class Hencky:
    """A material of this room (of constant elasticity E, nu) at finite strain. The points'
    state: ``b_e`` (np, 2, 2) and ``b_zz`` (np,), the material's own history, and the
    volume ratio J (np,)."""

    def __init__(self, material, cauchy: bool = False):
        self.material = material
        # The stress measure linear in the logarithmic strain: Kirchhoff's (Hencky), or
        # with ``cauchy`` Cauchy's itself (the law of a constant m_vl).
        self.cauchy = cauchy
        self.stiffness = isotropic(material.E, material.nu)[:3, :3]
        self.compliance = np.linalg.inv(self.stiffness)

    def initial_state(self, n: int) -> dict:
        """Unstrained points: b_e = I, J = 1, the material's history of zero stress."""
        return {"b_e": np.tile(np.eye(2), (n, 1, 1)), "b_zz": np.ones(n), "J": np.ones(n),
                **self.material.initial_state(np.zeros((n, 4)))}

    def update(self, f, state) -> tuple:
        """(the Cauchy stress (np, 4) (xx, yy, zz, xy; Pa), the new state) after the
        in-plane incremental deformation gradients ``f`` (np, 2, 2)."""
        b = congruence(f, state["b_e"])
        values, theta = _eigen(b)
        eps = np.zeros((len(b), 4))
        eps[:, :2] = 0.5 * np.log(values)
        eps[:, 2] = 0.5 * np.log(state["b_zz"])
        own = {k: v for k, v in state.items() if k not in ("b_e", "b_zz", "J")}
        if hasattr(self.material, "update_principal"):
            # The trial stress is principal already: the return alone, without the frame.
            tau = np.zeros((len(b), 4))
            tau[:, :3], own = self.material.update_principal(eps[:, :3] @ self.stiffness.T,
                                                             own)
        else:
            tau, own = self.material.update(np.zeros((len(b), 4)), eps, own)
        # The elastic strain after the return, and b_e from it.
        elastic = tau[:, :3] @ self.compliance.T
        J = state["J"] * det2(f)
        new = {"b_e": _rebuild(np.exp(2 * elastic[:, :2]), theta),
               "b_zz": np.exp(2 * elastic[:, 2]), "J": J, **own}
        c, s = np.cos(theta), np.sin(theta)
        a, d = tau[:, 0], tau[:, 1]
        sigma = np.empty((len(b), 4))
        sigma[:, 0] = a * c * c + d * s * s
        sigma[:, 1] = a * s * s + d * c * c
        sigma[:, 3] = (a - d) * s * c
        sigma[:, 2] = tau[:, 2]
        return (sigma if self.cauchy else sigma / J[:, None]), new
