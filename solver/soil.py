"""The soil: its two constituents and what follows from them, in SI units.

A :class:`Soil` is one saturated material: the skeleton (Young's modulus, Poisson's ratio,
grain density, porosity, hydraulic conductivity) and its pore fluid (density, bulk modulus,
viscosity). Everything the analyses derive from it (densities, moduli, wave speeds,
diffusivities, drag) is worked out here, once, so that the step, the time-step criteria,
the inertia regime and the references agree by construction. A layered deposit is a
sequence of these, one per layer; the fluid is the same in every layer.

This module is at the bottom of the package: it imports only :mod:`solver.analytic`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import analytic

G_REF = 9.81  # m/s2: the gravity in which the hydraulic conductivity k is defined


def elasticity(E: float, nu: float) -> np.ndarray:
    """Plane-strain elasticity matrix D (Pa) for stresses (xx, yy, xy) and engineering strains."""
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    G = E / (2 * (1 + nu))
    return np.array([[lam + 2 * G, lam, 0.0], [lam, lam + 2 * G, 0.0], [0.0, 0.0, G]])


def constrained_modulus(E: float, nu: float) -> float:
    """E_c = E (1 - nu) / ((1 + nu) (1 - 2 nu)) (Pa): the modulus of one-dimensional compression."""
    return E * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


@dataclass(frozen=True)
class Soil:
    """A saturated soil (SI units), checked on construction (ValueError naming the field).

    E (Pa), nu (-), rho_s (kg/m3, grains), porosity n (-), k (m/s, hydraulic conductivity
    defined with g = G_REF); the pore fluid's rho_l (kg/m3), K_l (Pa), mu_l (Pa s).
    """

    E: float = 10.0e6
    nu: float = 0.0
    rho_s: float = 2700.0
    porosity: float = 0.3
    k: float = 2.5e-4
    rho_l: float = 1000.0
    K_l: float = 120.0e6
    mu_l: float = 1.0e-3

    def __post_init__(self):
        rules = [("E", self.E > 0, "> 0"), ("nu", 0 <= self.nu < 0.5, "in [0, 0.5)"),
                 ("rho_s", self.rho_s > 0, "> 0"), ("porosity", 0 < self.porosity < 1,
                                                     "in (0, 1)"),
                 ("k", self.k > 0, "> 0"), ("rho_l", self.rho_l > 0, "> 0"),
                 ("K_l", self.K_l > 0, "> 0"), ("mu_l", self.mu_l > 0, "> 0")]
        for name, ok, rule in rules:
            value = getattr(self, name)
            if not (ok and math.isfinite(value)):
                raise ValueError(f"Soil {name} = {value!r}: must be {rule}")

    @classmethod
    def from_options(cls, p) -> "Soil":
        """The soil of the ``-mpm_`` options ``p`` (an eigen analysis reads only the
        skeleton and densities; the fluid's options keep their defaults there)."""
        return cls(E=p.E, nu=p.nu, rho_s=p.rho_s, porosity=p.porosity, k=p.k,
                   rho_l=p.rho_l, K_l=p.K_l, mu_l=p.mu_l)

    # -- densities and moduli -------------------------------------------------------------
    @property
    def density(self) -> float:
        """Saturated (mixture) density (1 - n) rho_s + n rho_l (kg/m3)."""
        return (1 - self.porosity) * self.rho_s + self.porosity * self.rho_l

    @property
    def constrained_modulus(self) -> float:
        """E_c (Pa), the skeleton's modulus in one-dimensional compression."""
        return constrained_modulus(self.E, self.nu)

    def elasticity(self) -> np.ndarray:
        """The skeleton's plane-strain D (Pa), 3 x 3."""
        return elasticity(self.E, self.nu)

    @property
    def unit_weight_water(self) -> float:
        """gamma_w = rho_l g (N/m3), with the g that defines k."""
        return self.rho_l * G_REF

    # -- flow -------------------------------------------------------------------------------
    @property
    def drag_coefficient(self) -> float:
        """n mu_l / kappa_l of eq. (12) (kg/m3/s), with the intrinsic permeability
        kappa_l = k mu_l / (rho_l g): the drag per unit volume and unit relative velocity."""
        kappa = self.k * self.mu_l / (self.rho_l * G_REF)
        return self.porosity * self.mu_l / kappa

    def drag_rate(self, S: float = 1.0) -> float:
        """Decay rate (1/s) of the relative velocity w = v_l - v_s under the drag alone, with
        both phases' inertia scaled by S (-mpm_mass_scaling; the drag is not)."""
        n = self.porosity
        return n * G_REF / self.k * (1 + n * self.rho_l / ((1 - n) * self.rho_s)) / S

    @property
    def c_v(self) -> float:
        """Terzaghi's consolidation coefficient k E_c / gamma_w (m2/s), incompressible water."""
        return analytic.consolidation_coefficient(self.k, self.constrained_modulus,
                                                  self.unit_weight_water)

    @property
    def c2(self) -> float:
        """The diffusivity with compressible water, k / (gamma_w (1/E_c + n/K_l)) (m2/s)."""
        return analytic.consistent_coefficient(self.k, self.constrained_modulus,
                                               self.unit_weight_water, self.K_l,
                                               self.porosity)

    @property
    def undrained_ratio(self) -> float:
        """The share of a sudden load the pore water takes, (K_l/n) / (K_l/n + E_c) (-)."""
        return analytic.undrained_pressure(1.0, self.constrained_modulus, self.K_l,
                                           self.porosity)

    def wave_speeds(self, S: float = 1.0) -> dict:
        """Speeds c (drained), c1 (undrained) in m/s and the diffusivity c2 in m2/s, with the
        inertia scaled by S (the speeds fall as 1/sqrt(S); c2 has no inertia in it)."""
        E_c = self.constrained_modulus
        rho = self.density * S
        return {"c": np.sqrt(E_c / rho), "c1": np.sqrt((E_c + self.K_l / self.porosity) / rho),
                "c2": self.c2}
