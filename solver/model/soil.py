"""The soil: its two constituents and what follows from them, in SI units.

A :class:`Soil` is one saturated material: the skeleton (Young's modulus, Poisson's ratio,
grain density, porosity, hydraulic conductivity) and its pore fluid (density, bulk modulus,
viscosity). Everything the analyses derive from it (densities, moduli, wave speeds,
diffusivities, drag) is worked out here, once, so that the step, the time-step criteria,
the inertia regime and the references agree by construction. A layered deposit is a
sequence of these, one per layer; the fluid is the same in every layer.

A :class:`Ground` is such a sequence: horizontal layers, from the surface down, each a
:class:`Soil`, with the lookup of the layer at a height that the per-point material of the
eigen model needs.

This module is at the bottom of the package: it imports only :mod:`solver.common.errors`. The
coefficients it derives are written out here, not taken from :mod:`solver.references.analytic`: the
references check the model, so the model does not build on them (tests/test_analytic.py
holds the two equal).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..common.errors import InputError

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
                 ("k", self.k > 0, "> 0"), ("rho_l", self.rho_l >= 0, ">= 0"),
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

    @property
    def fluid(self) -> tuple:
        """The pore fluid's (rho_l, K_l, mu_l)."""
        return (self.rho_l, self.K_l, self.mu_l)

    @property
    def soils(self) -> tuple:
        """The layers (this one), as :attr:`Ground.soils`: code over layers takes either."""
        return (self,)

    @property
    def point_density(self) -> float:
        """The points' density (kg/m3) as :func:`points.place` takes it: one number."""
        return self.density

    @property
    def point_elasticity(self) -> np.ndarray:
        """The points' D (Pa) as :func:`assembly.stiffness_and_mass` takes it: one 3 x 3."""
        return self.elasticity()

    # -- densities and moduli -------------------------------------------------------------
    @property
    def density(self) -> float:
        """Saturated (mixture) density (1 - n) rho_s + n rho_l (kg/m3)."""
        return (1 - self.porosity) * self.rho_s + self.porosity * self.rho_l

    @property
    def constrained_modulus(self) -> float:
        """E_c (Pa), the skeleton's modulus in one-dimensional compression."""
        return constrained_modulus(self.E, self.nu)

    @property
    def shear_modulus(self) -> float:
        """G = E / 2(1 + nu) (Pa)."""
        return self.E / (2 * (1 + self.nu))

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
        return self.k * self.constrained_modulus / self.unit_weight_water

    @property
    def c2(self) -> float:
        """The diffusivity with compressible water, k / (gamma_w (1/E_c + n/K_l)) (m2/s)."""
        return self.k / (self.unit_weight_water * (1 / self.constrained_modulus
                                                   + self.porosity / self.K_l))

    @property
    def undrained_ratio(self) -> float:
        """The share of a sudden load the pore water takes, (K_l/n) / (K_l/n + E_c) (-)."""
        stiffness = self.K_l / self.porosity
        return stiffness / (stiffness + self.constrained_modulus)

    def wave_speeds(self, S: float = 1.0) -> dict:
        """Speeds c (drained), c1 (undrained) in m/s and the diffusivity c2 in m2/s, with the
        inertia scaled by S (the speeds fall as 1/sqrt(S); c2 has no inertia in it)."""
        E_c = self.constrained_modulus
        rho = self.density * S
        return {"c": np.sqrt(E_c / rho), "c1": np.sqrt((E_c + self.K_l / self.porosity) / rho),
                "c2": self.c2}


# The material options that take one value per layer, in Soil's order; the fluid's take one.
PER_LAYER = ("E", "nu", "rho_s", "porosity", "k")
FLUID = ("rho_l", "K_l", "mu_l")


def check_count(name: str, value, layers) -> None:
    """InputError when the option ``-mpm_<name>`` gives a list (``value`` a tuple) of
    another length than the layers ``layers`` (``-mpm_layers``; empty: one layer)."""
    count = len(layers) or 1
    if isinstance(value, tuple) and len(value) != count:
        hint = ("of -mpm_layers; give one value or one per layer" if layers else
                "(a list needs -mpm_layers, one thickness per layer)")
        raise InputError(f"-mpm_{name} {_text(value)}: {len(value)} values for "
                         f"{count} layer(s) {hint}")


@dataclass(frozen=True)
class Ground:
    """Horizontal layers of soil from the surface down: ``thickness`` (m) and one
    :class:`Soil` per layer in ``soils``; the column's height is their sum. Checked on
    construction (ValueError). Heights y are measured up from the base, as the points'."""

    thickness: tuple
    soils: tuple

    def __post_init__(self):
        if len(self.thickness) != len(self.soils) or not self.soils:
            raise ValueError(f"Ground: {len(self.thickness)} thicknesses for "
                             f"{len(self.soils)} soils")
        if not all(t > 0 and math.isfinite(t) for t in self.thickness):
            raise ValueError(f"Ground thickness = {self.thickness!r}: each must be > 0")
        if len({s.fluid for s in self.soils}) != 1:
            raise ValueError("Ground: the pore fluid must be the same in every layer")

    @classmethod
    def uniform(cls, soil: Soil, H: float) -> "Ground":
        """One layer of ``soil``, H (m) thick."""
        return cls((float(H),), (soil,))

    @classmethod
    def from_options(cls, p) -> "Ground":
        """The layers of the ``-mpm_`` options ``p`` (``-mpm_layers``, the per-layer material
        options), checked against the body (``-mpm_size``, ``-mpm_cells``): InputError naming
        the option."""
        values = {name: getattr(p, name) for name in PER_LAYER + FLUID}
        return cls.build(tuple(p.layers), values, p.size[1], p.size[1] / p.cells[1])

    @classmethod
    def build(cls, layers, values: dict, H: float, h_y: float) -> "Ground":
        """Layers ``layers`` thick (m, from the surface down, as ``-mpm_layers``; empty: one
        layer H high) of the materials ``values`` ({Soil field: a float for every layer, or
        a tuple with one per layer}) in a body H (m) high of cells h_y (m) high;
        InputError naming the option."""
        thickness = tuple(layers) or (H,)
        count = len(thickness)
        for name, value in values.items():
            check_count(name, value, layers)
        _check_thickness(thickness, H, h_y)
        soils = tuple(Soil(**{name: v[i] if isinstance(v, tuple) else v
                              for name, v in values.items()}) for i in range(count))
        return cls(tuple(float(t) for t in thickness), soils)

    @property
    def count(self) -> int:
        return len(self.soils)

    def as_material(self):
        """What the analyses take: the one Soil of a single layer (its code paths and
        numbers as before layers), else this Ground (material per point)."""
        return self.soils[0] if self.count == 1 else self

    @property
    def height(self) -> float:
        """H (m)."""
        return float(sum(self.thickness))

    @property
    def bottoms(self) -> np.ndarray:
        """The height (m) of each layer's base, in the layers' order (from the surface down)."""
        return self.height - np.cumsum(self.thickness)

    def layer_of(self, y) -> np.ndarray:
        """The index (from the surface down) of the layer holding each height y (m): the
        layer whose base is the highest at or below y (the interfaces lie on cell
        boundaries, where no point lies)."""
        below = np.asarray(y, dtype=float)[..., None] >= self.bottoms[:-1]
        return np.argmax(np.concatenate([below, np.ones(below.shape[:-1] + (1,), bool)],
                                        axis=-1), axis=-1)

    def at(self, name: str, y) -> np.ndarray:
        """A Soil property (a field or a derived one) at heights y (m): its layer's."""
        return self.per_layer(name)[self.layer_of(y)]

    def density_at(self, y) -> np.ndarray:
        """The saturated density (kg/m3) at heights y (m)."""
        return self.at("density", y)

    def elasticity_at(self, y) -> np.ndarray:
        """The skeleton's D (Pa) at heights y (m), (len(y), 3, 3)."""
        return np.stack([s.elasticity() for s in self.soils])[self.layer_of(y)]

    @property
    def point_density(self):
        """The points' density as :func:`points.place` takes it: a function of y."""
        return self.density_at

    @property
    def point_elasticity(self):
        """The points' D as :func:`assembly.stiffness_and_mass` takes it: a function of y."""
        return self.elasticity_at

    # -- the column as a whole: what sets its time scales ----------------------------------
    # A layered column has no one c_v; T_v = c_v t / H^2 takes the c_v of the uniform column
    # that diffuses across H in the same time as the layers in series (the transformed
    # thickness method: H / sqrt(c_v) = sum d_i / sqrt(c_v,i)), and the wave speeds likewise
    # the travel time. They scale time and the inertia regime; the step's stability limits
    # are the layers' own (timestep.criteria takes the layer that governs).
    def _across(self, values) -> float:
        """H / sum(d_i / v_i): the speed of the uniform column with the layers' travel time."""
        return self.height / float(np.sum(np.asarray(self.thickness) / np.asarray(values)))

    @property
    def density(self) -> float:
        """The column's weight per unit volume over g, sum rho_i d_i / H (kg/m3)."""
        return float(self.per_layer("density") @ np.asarray(self.thickness)) / self.height

    @property
    def c_v(self) -> float:
        """The equivalent Terzaghi coefficient (m2/s), incompressible water (see above)."""
        return self._across(np.sqrt(self.per_layer("c_v"))) ** 2

    @property
    def c2(self) -> float:
        """The equivalent diffusivity with compressible water (m2/s)."""
        return self._across(np.sqrt(self.per_layer("c2"))) ** 2

    def wave_speeds(self, S: float = 1.0) -> dict:
        """The equivalent speeds c, c1 (m/s; the layers' travel time) and diffusivity c2
        (m2/s), inertia scaled by S."""
        speeds = [s.wave_speeds(S) for s in self.soils]
        out = {key: self._across([v[key] for v in speeds]) for key in ("c", "c1")}
        return {**out, "c2": self.c2}

    def drag_rate(self, S: float = 1.0) -> float:
        """The slowest layer's decay rate of the relative velocity (1/s)."""
        return min(s.drag_rate(S) for s in self.soils)

    @property
    def K_l(self) -> float:
        """The pore fluid's bulk modulus (Pa), one for every layer."""
        return self.soils[0].K_l

    @property
    def rho_l(self) -> float:
        """The pore fluid's density (kg/m3)."""
        return self.soils[0].rho_l

    def per_layer(self, name: str) -> np.ndarray:
        """A Soil property (a field or a derived one, e.g. ``density``) per layer, from the
        surface down."""
        return np.array([getattr(s, name) for s in self.soils], dtype=float)


def _text(value) -> str:
    return ",".join(f"{v:g}" for v in value) if isinstance(value, tuple) else f"{value:g}"


def _check_thickness(thickness, H: float, h_y: float) -> None:
    """InputError unless the layers fill the height H (m), relative 1e-9, each at least a cell
    (h_y, m) high, their interfaces on cell boundaries."""
    given = f"-mpm_layers {_text(tuple(thickness))}"
    total = math.fsum(thickness)
    if abs(total - H) > 1e-9 * H:
        raise InputError(f"{given}: the thicknesses sum to {total:g} m, not the body's "
                         f"height {H:g} m (-mpm_size)")
    thin = [i for i, t in enumerate(thickness) if t < h_y * (1 - 1e-9)]
    if thin:
        raise InputError(f"{given}: layer {thin[0] + 1} ({thickness[thin[0]]:g} m) is thinner "
                         f"than a cell (h_y = {h_y:g} m, -mpm_cells)")
    for depth in np.cumsum(thickness)[:-1]:
        cells = depth / h_y
        if abs(cells - round(cells)) > 1e-9 * max(cells, 1.0):
            raise InputError(f"{given}: the interface at depth {depth:g} m is not on a cell "
                             f"boundary (cells {h_y:g} m high, -mpm_cells); interfaces "
                             "inside a cell are not supported")
