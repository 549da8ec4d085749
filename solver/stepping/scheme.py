"""The explicit step's scheme: its discretisation choices, resolved to values once.

The options ``-mpm_kinematics``, ``-mpm_lumping``, ``-mpm_liquid_basis`` and
``-mpm_pressure_projection`` may say ``auto``: the most accurate measured choice for the
cell type (docs/studies.md, "Quadratic cells"); ``-mpm_flip`` ``auto``: pure FLIP, but
where the lumping and projection need a little PIC to stay stable (:func:`auto_flip`);
``-mpm_mass_scaling`` may say ``auto``: the largest factor whose inertia error stays within
tolerance (:mod:`solver.stepping.inertia`). A
:class:`Scheme` holds them resolved, with the drag treatment, the damping terms and the
FLIP fraction: what the step, the stability analysis and the summary read.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

from ..common.errors import InputError
from . import inertia

AUTO_KEYS = ("lumping", "kinematics", "pressure_projection", "liquid_basis")


def default_lumping(element: str) -> str:
    """Row sums (w = N), but for Q8, whose corner row sums are negative, the blended basis
    N_hat for the solid's transfer both ways (weights and interpolation). HRZ weights are
    positive too, but they spread momentum with other functions than the N that brings it
    back: the step then grows on the laterally drained block (8 x 8 cells, an impermeable
    top that moves) at every time step; with N_hat it runs at pure FLIP and is within
    1.25 % of q of the FE from T_dr 0.2 on (docs/studies.md)."""
    return "blended" if element == "q8" else "rowsum"


def auto_scheme(element: str, lateral: bool = False) -> dict:
    """What ``auto`` means for each discretisation choice of the step on a cell type, on a
    body drained through a side (``lateral``) or not. The pressure projection: corner on
    quadratic cells; on Q4 the nodal one, but corner on a body drained through a side, where
    its compact Darcy stencil (kernels._compact) brings the laterally drained block within
    1.4 % of q of the FE from T_dr 0.2 (nodal 4.2 %); on the columns the nodal projection
    converges and the compact stencil's cap fades it as cells shrink (docs/studies.md)."""
    return {"lumping": default_lumping(element),
            "kinematics": "small",
            "pressure_projection": "nodal" if element == "q4" and not lateral else "corner",
            "liquid_basis": "blended" if element == "q8" else "element"}


def auto_flip(lumping: str, pressure_projection: str) -> float:
    """What ``-mpm_flip auto`` means: pure FLIP (1), but 0.99 for HRZ lumping with the
    corner projection. HRZ weighs the solid's transfer with other functions than the N it
    interpolates with, and pure FLIP then feeds a slow mode (growth about 5e-4 per step)
    wherever an impermeable side moves (a loaded top); 1 % PIC damps it on narrow bodies,
    not on wide ones (the stability analysis refuses those: timestep._check_below)."""
    return 0.99 if lumping == "hrz" and pressure_projection == "corner" else 1.0


@dataclass(frozen=True)
class Scheme:
    """The step's choices, resolved (no ``auto``).

    ``lumping`` rowsum | hrz | blended (the solid's transfer in N_hat); ``kinematics`` small | large; ``pressure_projection``
    none | nodal | corner; ``liquid_basis`` element | blended; ``drag`` implicit | explicit;
    ``mass_scaling`` the factor S (-) on both phases' inertia; ``damping`` the local
    damping coefficient (-), ``bulk_viscosity`` b1 (-), ``fast_damping`` zeta (-),
    ``flip`` the FLIP fraction (-); ``mass_scaling_choice`` the option as given (for
    messages).
    """

    lumping: str = "rowsum"
    kinematics: str = "small"
    pressure_projection: str = "nodal"
    liquid_basis: str = "element"
    drag: str = "implicit"
    mass_scaling: float = 1.0
    damping: float = 0.0
    bulk_viscosity: float = 0.0
    fast_damping: float = 0.0
    flip: float = 1.0
    mass_scaling_choice: str = "none"
    wave_period: float = math.nan
    # The undrained modes the load excites (waves.Swings; None: the closed-form estimate).
    swings: object = field(default=None, compare=False, repr=False)

    @classmethod
    def resolve(cls, element: str, choices: dict, S: float = 1.0, lateral: bool = False,
                **terms) -> "Scheme":
        """The scheme of a cell type from ``choices`` ({AUTO_KEYS name: value or 'auto'},
        missing: auto) on a body drained through a side or not (``lateral``), the factor S
        and the remaining fields (``terms``; a ``flip`` of 'auto' is :func:`auto_flip`'s)."""
        auto = auto_scheme(element, lateral)
        picked = {k: auto[k] if choices.get(k, "auto") == "auto" else choices[k]
                  for k in AUTO_KEYS}
        if picked["lumping"] == "blended" and picked["liquid_basis"] != "blended":
            if choices.get("lumping", "auto") == "auto":
                picked["lumping"] = "hrz"       # the blend is the liquid's; Q8 keeps HRZ
            else:
                raise InputError(f"-mpm_lumping blended: the solid's transfer in the blended "
                                 f"basis needs the liquid's in it too (-mpm_liquid_basis "
                                 f"blended, not {picked['liquid_basis']})")
        if terms.get("flip") == "auto":
            terms["flip"] = auto_flip(picked["lumping"], picked["pressure_projection"])
        if "flip" in terms:
            terms["flip"] = float(terms["flip"])
        return cls(**picked, mass_scaling=float(S), **terms)

    @classmethod
    def from_options(cls, p, soil, first_report_tv: float,
                     wave_period: float = math.nan, swings=None) -> "Scheme":
        """The scheme of the ``-mpm_`` options ``p`` for ``soil`` whose slowest wave has
        the period ``wave_period`` (s; NaN: a column's 4H/c1); ``auto`` mass scaling is
        judged at the earliest report time ``first_report_tv`` (T_v)."""
        S = inertia.scaling(p.mass_scaling, soil, p.size[1], first_report_tv, p.damping,
                            p.fast_damping, wave_period, swings)
        return cls.resolve(p.element, {k: getattr(p, k) for k in AUTO_KEYS}, S,
                           lateral=bool({"left", "right"} & set(p.drained)), drag=p.drag,
                           damping=p.damping, bulk_viscosity=p.bulk_viscosity,
                           fast_damping=p.fast_damping, flip=p.flip,
                           mass_scaling_choice=str(p.mass_scaling), wave_period=wave_period,
                           swings=swings)

    def with_mass_scaling(self, S: float) -> "Scheme":
        """The same scheme with the factor S (a restart keeps the one its run began with)."""
        return replace(self, mass_scaling=float(S))

    def summary(self) -> dict:
        """The choices as the run's summary records them."""
        return {"lumping": self.lumping, "kinematics": self.kinematics,
                "pressure_projection": self.pressure_projection,
                "liquid_basis": self.liquid_basis, "drag": self.drag,
                "mass_scaling": self.mass_scaling}


def lateral_drainage_notes(element: str, drained, projection: str) -> list:
    """A note for quadratic cells drained through a side with their pore pressures per
    point or projected onto every node: water flowing across the body then excites a
    pressure mode inside each cell that the discrete gradient does not see and that never
    drains (the 1.2 m block drained left and right, 8 x 8 cells: Q9 10-15 % of q off, Q8
    7-25 %; the nodal projection leaves Q9 +-3 % and blows Q8 up). The corner projection,
    the default, drains it (docs/method.md)."""
    lateral = [side for side in ("left", "right") if side in drained]
    if element == "q4" or not lateral or projection not in ("none", "nodal"):
        return []
    return [f"-mpm_pressure_projection {projection}: quadratic cells drained through a side "
            f"(-mpm_drained {','.join(drained)}) keep a pressure mode in every cell that "
            "never drains (10-15 % of q off; docs/method.md); the corner projection (the "
            "default) drains it"]
