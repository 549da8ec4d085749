"""A material from its name and parameters, checked against each other (one line, InputError,
naming the option): what every analysis that takes ``-mpm_material`` builds."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from ..common.errors import InputError
from .cam_clay import CamClay
from .drucker_prager import DruckerPrager
from .model import Elastic
from .mohr_coulomb import MohrCoulomb, tresca

NAMES = ("elastic", "tresca", "mohr-coulomb", "drucker-prager", "mcc")


def make(name: str, E: float, nu: float, cohesion: float = 0.0, phi: float = 0.0,
         psi: float = math.nan, mcc: dict | None = None):
    """The material ``name`` (NAMES) of Young's modulus E (Pa) and Poisson's ratio nu, with
    cohesion (Pa), friction and dilation angles phi, psi (degrees; psi NaN: phi) and the
    Cam Clay parameters ``mcc`` ({M, lam, kappa, e0, ocr}). InputError for a combination
    that means nothing."""
    psi = phi if math.isnan(psi) else psi
    if name == "elastic":
        return Elastic(E, nu)
    if name == "tresca":
        if phi or psi:
            raise InputError(f"-mpm_friction_angle {phi:g}: tresca has none (an undrained "
                             "strength on total stress; take mohr-coulomb for friction)")
        if cohesion <= 0:
            raise InputError("-mpm_cohesion: tresca needs the undrained strength c_u > 0")
        return tresca(E, nu, cohesion)
    if name in ("mohr-coulomb", "drucker-prager"):
        if psi > phi:
            raise InputError(f"-mpm_dilation_angle {psi:g}: above the friction angle {phi:g} "
                             "(dilation cannot exceed friction)")
        if cohesion <= 0 and phi <= 0:
            raise InputError(f"-mpm_material {name}: no strength (give -mpm_cohesion or "
                             "-mpm_friction_angle)")
        cls = MohrCoulomb if name == "mohr-coulomb" else DruckerPrager
        return cls(E, nu, cohesion, phi, psi)
    if name == "mcc":
        mcc = mcc or {}
        if math.isnan(mcc.get("e0", math.nan)):
            raise InputError("-mpm_material mcc: needs the initial void ratio "
                             "(-mpm_void_ratio)")
        if mcc["kappa"] >= mcc["lam"]:
            raise InputError(f"-mpm_mcc_kappa {mcc['kappa']:g}: must be below -mpm_mcc_lambda "
                             f"{mcc['lam']:g} (swelling is stiffer than compression)")
        return CamClay(mcc["M"], mcc["lam"], mcc["kappa"], mcc["e0"], nu, mcc.get("ocr", 1.0))
    raise InputError(f"-mpm_material {name}: choose one of {', '.join(NAMES)}")


@dataclass(frozen=True)
class Recipe:
    """A material named and parametrised once, made for each layer's elasticity: ``name``
    (NAMES), cohesion (Pa), phi and psi (degrees; psi NaN: phi), the Cam Clay parameters
    ``mcc`` ({M, lam, kappa, e0, ocr})."""

    name: str = "elastic"
    cohesion: float = 0.0
    phi: float = 0.0
    psi: float = math.nan
    mcc: dict = field(default_factory=dict)

    @classmethod
    def from_options(cls, p) -> "Recipe":
        """The ``-mpm_material`` options of ``p``."""
        return cls(p.material, p.cohesion, p.friction_angle, p.dilation_angle,
                   {"M": p.mcc_M, "lam": p.mcc_lambda, "kappa": p.mcc_kappa,
                    "e0": p.void_ratio, "ocr": p.mcc_ocr})

    @property
    def elastic(self) -> bool:
        return self.name == "elastic"

    def make(self, E: float, nu: float):
        """The material of Young's modulus E (Pa) and Poisson's ratio nu (:func:`make`)."""
        return make(self.name, E, nu, self.cohesion, self.phi, self.psi, self.mcc)
