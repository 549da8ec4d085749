"""A material from its name and parameters, checked against each other (one line, InputError,
naming the option): what every analysis that takes ``-mpm_material`` builds."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

from ..common.errors import InputError
from .cam_clay import CamClay
from .drucker_prager import DruckerPrager
from .hyperbolic import Hyperbolic
from .model import Elastic
from .mohr_coulomb import MohrCoulomb, tresca

NAMES = ("elastic", "tresca", "mohr-coulomb", "drucker-prager", "mcc", "hyperbolic")


def make(name: str, E: float, nu: float, cohesion: float = 0.0, phi: float = 0.0,
         psi: float = math.nan, mcc: dict | None = None, tension: float = math.nan,
         hyperbolic: tuple = (math.nan, 25)):
    """The material ``name`` (NAMES) of Young's modulus E (Pa) and Poisson's ratio nu, with
    cohesion (Pa), friction and dilation angles phi, psi (degrees; psi NaN: phi), the Cam
    Clay parameters ``mcc`` ({M, lam, kappa, e0, ocr}), a tension cutoff (Pa; NaN: none)
    and the hyperbolic soil's (reference strain, surfaces). InputError for a combination
    that means nothing."""
    psi = phi if math.isnan(psi) else psi
    if not math.isnan(tension) and name not in ("tresca", "mohr-coulomb"):
        raise InputError(f"-mpm_tension_cutoff: only tresca and mohr-coulomb take one (not "
                         f"{name})")
    cut = math.inf if math.isnan(tension) else tension
    if name == "elastic":
        return Elastic(E, nu)
    if name == "tresca":
        if phi or psi:
            raise InputError(f"-mpm_friction_angle {phi:g}: tresca has none (an undrained "
                             "strength on total stress; take mohr-coulomb for friction)")
        if cohesion <= 0:
            raise InputError("-mpm_cohesion: tresca needs the undrained strength c_u > 0")
        return dataclasses.replace(tresca(E, nu, cohesion), tension=cut)
    if name in ("mohr-coulomb", "drucker-prager"):
        if psi > phi:
            raise InputError(f"-mpm_dilation_angle {psi:g}: above the friction angle {phi:g} "
                             "(dilation cannot exceed friction)")
        if cohesion <= 0 and phi <= 0:
            raise InputError(f"-mpm_material {name}: no strength (give -mpm_cohesion or "
                             "-mpm_friction_angle)")
        if name == "drucker-prager":
            return DruckerPrager(E, nu, cohesion, phi, psi)
        return MohrCoulomb(E, nu, cohesion, phi, psi, cut)
    if name == "hyperbolic":
        gamma_r, surfaces = hyperbolic
        if not gamma_r > 0:
            raise InputError("-mpm_material hyperbolic: needs the reference shear strain "
                             "(-mpm_reference_strain)")
        return Hyperbolic(E, nu, gamma_r, surfaces)
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
    (NAMES), cohesion (Pa), phi and psi (degrees; psi NaN: phi), each one value or a tuple
    with one per layer; the Cam Clay parameters ``mcc`` ({M, lam, kappa, e0, ocr})."""

    name: object = "elastic"
    cohesion: object = 0.0
    phi: object = 0.0
    psi: object = math.nan
    mcc: dict = field(default_factory=dict)
    tension: object = math.nan
    reference_strain: object = math.nan
    surfaces: int = 25

    @classmethod
    def from_options(cls, p) -> "Recipe":
        """The ``-mpm_material`` options of ``p``."""
        return cls(p.material, p.cohesion, p.friction_angle, p.dilation_angle,
                   {"M": p.mcc_M, "lam": p.mcc_lambda, "kappa": p.mcc_kappa,
                    "e0": p.void_ratio, "ocr": p.mcc_ocr}, p.tension_cutoff,
                   p.reference_strain, p.surfaces)

    @property
    def names(self) -> tuple:
        """The material's name per layer given (one: every layer's)."""
        return self.name if isinstance(self.name, tuple) else (self.name,)

    @property
    def elastic(self) -> bool:
        return all(n == "elastic" for n in self.names)

    @property
    def layered(self) -> bool:
        return any(isinstance(v, tuple) for v in (self.name, self.cohesion, self.phi,
                                                  self.psi, self.tension,
                                                  self.reference_strain))

    def layer(self, i: int) -> "Recipe":
        """Layer i's recipe (from the surface down)."""
        def pick(v):
            return v[i] if isinstance(v, tuple) else v
        return Recipe(pick(self.name), pick(self.cohesion), pick(self.phi), pick(self.psi),
                      self.mcc, pick(self.tension), pick(self.reference_strain),
                      self.surfaces)

    def make(self, E: float, nu: float):
        """The material of Young's modulus E (Pa) and Poisson's ratio nu (:func:`make`); one
        material only (InputError for a list: the analyses of one material take one)."""
        if self.layered or isinstance(E, tuple) or isinstance(nu, tuple):
            raise InputError("-mpm_material, -mpm_E, -mpm_nu: one material here, one value "
                             "each (per layer only in the consolidation analysis)")
        return make(self.name, E, nu, self.cohesion, self.phi, self.psi, self.mcc,
                    self.tension, (self.reference_strain, self.surfaces))

    def per_layer(self, soils) -> tuple:
        """One material per layer of ``soils`` (each layer's E and nu); InputError for
        lists of another length than the layers."""
        for option, v in (("material", self.name), ("cohesion", self.cohesion),
                          ("friction_angle", self.phi), ("dilation_angle", self.psi),
                          ("tension_cutoff", self.tension),
                          ("reference_strain", self.reference_strain)):
            if isinstance(v, tuple) and len(v) != len(soils):
                raise InputError(f"-mpm_{option}: {len(v)} values for {len(soils)} "
                                 "layer(s); give one value or one per layer")
        out = []
        for i, s in enumerate(soils):
            r = self.layer(i)
            out.append(make(r.name, s.E, s.nu, r.cohesion, r.phi, r.psi, r.mcc, r.tension,
                            (r.reference_strain, r.surfaces)))
        return tuple(out)
