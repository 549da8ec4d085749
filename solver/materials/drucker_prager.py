"""Drucker-Prager plasticity matched to Mohr-Coulomb in plane strain.

    f = sqrt(J2) + eta I1 / 3 - xi c,    g = sqrt(J2) + eta_g I1 / 3     (tension positive)

with the plane-strain match (de Souza Neto, Peric and Owen 2008, section 8.3.3)

    eta = 3 tan(phi) / sqrt(9 + 12 tan^2 phi),    xi = 3 / sqrt(9 + 12 tan^2 phi)

(eta_g the same with psi): under associated flow the cone then gives Mohr-Coulomb's
collapse loads in plane strain, which is what a plane-strain model is asked (the outer or
inner triaxial matches would give the triaxial strengths instead). The return is exact:
radial in the deviatoric plane onto the cone, dgamma = f_tr / (G + K eta eta_g), or onto the
apex I1 / 3 = xi c / eta where the cone's return would cross it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .model import XY, Frictional


def match(angle: float) -> tuple:
    """(eta, xi) of a friction (or dilation) angle in degrees, the plane-strain match."""
    t = math.tan(math.radians(angle))
    r = math.sqrt(9 + 12 * t * t)
    return 3 * t / r, 3 / r


@dataclass(frozen=True)
class DruckerPrager(Frictional):
    """E (Pa), nu (-), cohesion c (Pa), friction and dilation angles phi, psi (degrees)."""

    def update(self, stress, d_strain, state):
        trial = self.predictor(stress, d_strain)
        G = self.E / (2 * (1 + self.nu))
        K = self.E / (3 * (1 - 2 * self.nu))
        eta, xi = match(self.phi)
        eta_g, _ = match(self.psi)
        mean = trial[:, :3].mean(axis=1)
        dev = trial.copy()
        dev[:, :3] -= mean[:, None]
        J2 = 0.5 * np.sum(dev[:, :3] ** 2, axis=1) + dev[:, XY] ** 2
        rj = np.sqrt(J2)
        f = rj + eta * mean - xi * self.cohesion
        yielding = f > 1e-12 * (np.abs(trial).max(axis=1) + self.cohesion)
        dgamma = np.where(yielding, f / (G + K * eta * eta_g), 0.0)
        cone = yielding & (rj - G * dgamma >= 0)
        apex = yielding & ~cone
        out = trial.copy()
        scale = np.where(cone, 1 - G * dgamma / np.where(rj > 0, rj, 1.0), 1.0)
        new_mean = mean - K * eta_g * dgamma
        if apex.any():
            if eta <= 0:
                raise ArithmeticError("Drucker-Prager: a frictionless return left its cone")
            new_mean[apex] = xi * self.cohesion / eta
            scale[apex] = 0.0
            dgamma[apex] = rj[apex] / G
        out[yielding] = dev[yielding] * scale[yielding, None]
        out[yielding, :3] += new_mean[yielding, None]
        return out, {"plastic": yielding, "eps_p": state["eps_p"] + dgamma}
