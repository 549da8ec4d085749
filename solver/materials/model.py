"""What every material offers, the linear elastic law, and the algorithmic tangent.

A material is a frozen dataclass with

    update(stress, d_strain, state) -> (stress, state)

over np points: ``stress`` (np, 4) (xx, yy, zz, xy; Pa, tension positive), ``d_strain``
(np, 4) (xx, yy, zz, 2 xy; -), ``state`` a dict of (np,) or (np, k) arrays (history
variables: plastic strains, the preconsolidation pressure), returned anew; and
``initial_state(stress)``, the history of points starting from ``stress``. The update is
exact for the step given (a return mapping of the elastic predictor), so its derivative is
the tangent that keeps Newton quadratic; :func:`tangent` takes it by central differences
of the update itself (four more updates per point), which any model gets without writing
its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# The components' order: stress (xx, yy, zz, xy), strain (xx, yy, zz, 2 xy).
XX, YY, ZZ, XY = range(4)


def isotropic(E: float, nu: float) -> np.ndarray:
    """The 4 x 4 elasticity matrix (Pa) of (E, nu) on (xx, yy, zz, 2 xy)."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    G = E / (2 * (1 + nu))
    D = np.full((4, 4), 0.0)
    D[:3, :3] = lam
    D[[0, 1, 2], [0, 1, 2]] += 2 * G
    D[3, 3] = G
    return D


@dataclass(frozen=True)
class Elastic:
    """Linear isotropic elasticity: E (Pa), nu (-)."""

    E: float
    nu: float

    def initial_state(self, stress) -> dict:
        return {"plastic": np.zeros(len(stress), dtype=bool)}

    def predictor(self, stress, d_strain) -> np.ndarray:
        """The elastic trial stress (np, 4) (Pa) of the increments: what every return
        starts from."""
        return stress + d_strain @ isotropic(self.E, self.nu).T

    def update(self, stress, d_strain, state):
        return self.predictor(stress, d_strain), dict(state)

    def plane(self) -> np.ndarray:
        """The in-plane 3 x 3 stiffness (Pa) on (xx, yy, 2 xy): what the linear analyses
        (eigen, dynamic, consolidation) assemble their stiffness from."""
        return isotropic(self.E, self.nu)[np.ix_([XX, YY, XY], [XX, YY, XY])]


@dataclass(frozen=True)
class Frictional(Elastic):
    """What Mohr-Coulomb and Drucker-Prager share: elasticity (E, nu), cohesion c (Pa),
    friction and dilation angles phi, psi (degrees), and the history of a point: whether
    it yielded in the step and its accumulated plastic multiplier ``eps_p``."""

    cohesion: float = 0.0
    phi: float = 0.0
    psi: float = 0.0

    def initial_state(self, stress) -> dict:
        return {"plastic": np.zeros(len(stress), dtype=bool),
                "eps_p": np.zeros(len(stress))}


def tangent(material, stress, d_strain, state, h: float = 1e-7) -> np.ndarray:
    """d sigma_new / d (d_strain), (np, 4, 4) (Pa): central differences of the update,
    steps of h times the larger of the increment's size and 1e-6 (a step well inside the
    smooth part of the return, and resolved against round-off)."""
    size = np.maximum(np.max(np.abs(d_strain), axis=1, keepdims=True), 1e-6)
    out = np.empty((len(stress), 4, 4))
    for j in range(4):
        step = np.zeros_like(d_strain)
        step[:, j] = h * size[:, 0]
        up, _ = material.update(stress, d_strain + step, state)
        down, _ = material.update(stress, d_strain - step, state)
        out[:, :, j] = (up - down) / (2 * step[:, j:j + 1])
    return out


def invariants(stress) -> tuple:
    """(p, q) (Pa) of (np, 4) stresses: p = -tr / 3 (compression positive) and
    q = sqrt(3 J2)."""
    p = -(stress[:, XX] + stress[:, YY] + stress[:, ZZ]) / 3
    s = stress[:, :3] + p[:, None]
    J2 = 0.5 * np.sum(s * s, axis=1) + stress[:, XY] ** 2
    return p, np.sqrt(3 * J2)


def principal(stress) -> tuple:
    """The principal stresses (np, 3), descending (tension positive), and what puts them
    back: the in-plane angle theta (rad) of the larger in-plane one and where each sorted
    value came from (np, 3) (0: the larger in-plane, 1: the smaller, 2: zz)."""
    c = 0.5 * (stress[:, XX] + stress[:, YY])
    r = np.hypot(0.5 * (stress[:, XX] - stress[:, YY]), stress[:, XY])
    theta = 0.5 * np.arctan2(2 * stress[:, XY], stress[:, XX] - stress[:, YY])
    values = np.stack([c + r, c - r, stress[:, ZZ]], axis=1)
    order = np.argsort(-values, axis=1, kind="stable")
    return np.take_along_axis(values, order, axis=1), theta, order


def from_principal(sorted_values, theta, order) -> np.ndarray:
    """The (np, 4) stress of principal values in :func:`principal`'s order and frame."""
    values = np.empty_like(sorted_values)
    np.put_along_axis(values, order, sorted_values, axis=1)
    a, b = values[:, 0], values[:, 1]
    c, s = np.cos(theta), np.sin(theta)
    out = np.empty((len(values), 4))
    out[:, XX] = a * c * c + b * s * s
    out[:, YY] = a * s * s + b * c * c
    out[:, XY] = (a - b) * s * c
    out[:, ZZ] = values[:, 2]
    return out
