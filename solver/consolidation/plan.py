"""What a consolidation run does, as typed values: the :class:`Plan` its set-up returns.

After the set-up nothing reads the options: the time loop, the reporting and the output
take the plan (or the few of its values they need). A plan is the soil, the body and its
loading (:mod:`solver.model.soil`, :mod:`solver.model.scene`), the step's scheme
(:mod:`solver.stepping.scheme`), the schedule (time step, steps, report and
isochrone times), the references the results are compared with, where the results go, and
the run's identity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..io.output import Outputs
from ..model.scene import Body, Loading
from ..model.soil import Soil
from ..references import analytic, layered
from ..run.loop import Cadence
from ..stepping.scheme import Scheme
from ..stepping.timestep import Limits


@dataclass(frozen=True)
class Schedule:
    """The time stepping: ``dt`` (s), ``nsteps``, the end ``Tv_end`` and the report times
    ``Tv_report`` (T_v), and the steps at which the reports and the isochrones fall
    ({step: T_v}); the cadence of the field output, checkpoints (steps; 0: none) and
    progress lines (s; 0: none). The explicit step's steps are equal, step k ends at k dt;
    the implicit scheme's are graded, step k ends at ``times[k - 1]`` (s), and its monitor
    and settlement are sampled every step (``sample_every``)."""

    dt: float
    nsteps: int
    report_steps: dict
    iso_steps: dict
    Tv_end: float
    Tv_report: tuple
    output_every: int = 0
    checkpoint_every: int = 0
    checkpoint_seconds: float = 0.0
    progress: float = 10.0
    times: tuple = ()
    sample_every: int = 10

    def time(self, k: int) -> float:
        """The time (s) at the end of step k (0: the start)."""
        if not self.times:
            return k * self.dt
        return self.times[k - 1] if k > 0 else 0.0

    @property
    def t_end(self) -> float:
        """The time (s) of the last step."""
        return self.time(self.nsteps)

    def cadence(self) -> Cadence:
        """The loop's cadence: samples every ``sample_every`` steps and at the isochrones,
        fields at the reports (and every ``output_every``), the state checked at the
        isochrones too."""
        iso = frozenset(self.iso_steps)
        return Cadence(self.nsteps, sample_every=self.sample_every,
                       output_every=self.output_every,
                       checkpoint_every=self.checkpoint_every,
                       checkpoint_seconds=self.checkpoint_seconds,
                       progress_seconds=self.progress, sample_steps=iso,
                       output_steps=frozenset(self.report_steps), check_steps=iso)


FORMS = ("classic", "consistent")     # incompressible water (c_v), compressible (c2)


@dataclass(frozen=True)
class References:
    """The scene's own analytic references, and the scales of every comparison.

    ``c_v`` (m2/s) Terzaghi's coefficient, ``c2`` (m2/s) the compressible-water
    diffusivity, ``p0`` (-) the share B of a sudden load the water takes; ``q`` (Pa) the
    pressure p is normalised by; ``H`` (m) the column height (T_v = c_v t / H^2 whatever
    the drainage). The reference is a uniform column drained at its ends ``drained``
    (a subset of top, bottom; empty: undrained) from an initial excess over hydrostatic
    linear in height: (p_top, p_base) / q in each form (``initial``: classic, consistent).
    ``hydrostatic`` (Pa/m) is rho_l g: the excess at height y is p - rho_l g (H - y), with
    or without a reference (the water table at the surface). ``why`` says why the scene
    has no reference ('' when it has one); ``why_degree`` why it has no degree of
    consolidation (U) although it has a reference. ``fe`` is the finite-element solution
    of a scene without one (:class:`solver.consolidation.fe_reference.FEReference`, or None:
    ``fe_why`` says why not).
    """

    c_v: float
    c2: float
    p0: float
    q: float
    H: float
    drained: tuple = ("top",)
    initial: tuple = ((1.0, 1.0), (1.0, 1.0))
    hydrostatic: float = 0.0
    why: str = ""
    why_degree: str = ""
    static: tuple = ()      # (undrained, final) settlement (m) by static solves, or ()
    layered: tuple = ()     # a layered column's references (classic, consistent), or ()
    fe: object = None       # fe_reference.FEReference of a scene without a closed form
    fe_why: str = ""

    @classmethod
    def of(cls, soil: Soil, loading: Loading, body: Body) -> "References":
        """The references of ``body`` of ``soil`` (a soil.Soil, or a soil.Ground of
        layers) under ``loading``."""
        H, q = body.height, loading.scale(soil, body.height)
        why = no_reference(body, loading)
        if len(soil.soils) > 1:
            return cls._of_layers(soil, loading, body, q, why)
        scales = (soil.c_v, soil.c2, soil.undrained_ratio, q, H)
        g, E_c, n = loading.gravity, soil.constrained_modulus, soil.porosity
        if why:
            return cls(*scales, drained=(), why=why, why_degree=why,
                       hydrostatic=soil.rho_l * g)
        initial = tuple(
            tuple(v / q for v in analytic.undrained_excess(
                loading.load, H, n, E_c, K_l, soil.rho_s, soil.rho_l, g))
            for K_l in (None, soil.K_l))
        if not loading.self_weight:     # a load alone: the paper's closed forms
            initial = ((1.0, 1.0), (soil.undrained_ratio,) * 2)
        drained = tuple(s for s in ("top", "bottom") if s in body.drained)
        why_degree = "" if drained else ("no drained side: the mean pore pressure and the "
                                         "settlement do not change, U is undefined")
        return cls(*scales, drained=drained, initial=initial,
                   hydrostatic=soil.rho_l * g, why_degree=why_degree)

    @classmethod
    def _of_layers(cls, ground, loading: Loading, body: Body, q: float, why: str):
        """A layered column's references: the mode solutions of :class:`layered.
        LayeredColumn` with incompressible and compressible water; T_v with the ground's
        equivalent c_v (soil.Ground.c_v)."""
        H, g = body.height, loading.gravity
        drained = tuple(s for s in ("top", "bottom") if s in body.drained)
        columns = () if why else tuple(
            layered.LayeredColumn(
                ground.thickness, ground.per_layer("constrained_modulus"),
                ground.per_layer("k"), ground.per_layer("porosity"),
                ground.soils[0].unit_weight_water, K_l, q=loading.load, drained=drained,
                rho_s=ground.per_layer("rho_s"), rho_l=ground.rho_l,
                g=g if loading.self_weight else 0.0)
            for K_l in (None, ground.K_l))
        p0 = float(columns[1].mean_excess(0.0)) / q if columns else math.nan
        initial = tuple(tuple(float(v) / q for v in c.initial(np.array([H, 0.0])))
                        for c in columns) or ((1.0, 1.0), (1.0, 1.0))
        why_degree = why or ("" if drained else "no drained side: the mean pore pressure "
                             "and the settlement do not change, U is undefined")
        return cls(ground.c_v, ground.c2, p0, q, H, drained=drained if not why else (),
                   initial=initial, hydrostatic=ground.rho_l * g,
                   why=why, why_degree=why_degree, layered=columns)

    @property
    def available(self) -> bool:
        return not self.why

    @property
    def terzaghi(self) -> bool:
        """Whether the reference is Terzaghi's (drained at the top, a uniform initial
        excess): the paper's comparison, by its closed forms."""
        return (self.drained == ("top",) and all(a == b for a, b in self.initial)
                and not self.layered)

    def describe(self) -> str:
        """The reference in words, for the run's banner."""
        if not self.available:
            return f"No analytic reference for this scene: {self.why}"
        if self.layered:
            ends = {("top",): "at the top", ("bottom",): "at the base",
                    ("top", "bottom"): "at the top and the base", (): "nowhere"}[self.drained]
            return (f"Reference: the layered column drained {ends} ({len(self.layered[0].B)} "
                    "layers; a series of its exact modes, summed to 1e-10 of the initial "
                    "excess: solver.references.layered), classic and with compressible water; T_v "
                    "with the layers' equivalent c_v")
        if self.terzaghi:
            return ("Reference: Terzaghi's one-way consolidation (drained at the top), "
                    "classic and with compressible water")
        ends = {("top",): "at the top", ("bottom",): "at the base",
                ("top", "bottom"): "at the top and the base (two-way)",
                (): "nowhere (undrained)"}[self.drained]
        (ct, cb), (st, sb) = self.initial
        return (f"Reference: a uniform column drained {ends}, initial excess over "
                f"hydrostatic p/q = {ct:.4g} at the top and {cb:.4g} at the base (classic; "
                f"{st:.4g} and {sb:.4g} with compressible water)")

    def summary(self) -> dict:
        """What the run's summary says of the reference."""
        entry = {"description": self.describe(), "available": self.available}
        if self.available:
            entry.update(drained=list(self.drained), initial_excess_over_q={
                form: list(values) for form, values in zip(FORMS, self.initial)})
        return entry

    def pressure(self, y, Tv, form: str):
        """The reference excess pore pressure p / q at heights y (m) and time factor Tv
        in ``form`` (classic or consistent)."""
        if self.layered:
            column = self.layered[FORMS.index(form)]
            return column.pressure(y, self.time(np.asarray(Tv, dtype=float))) / self.q
        top, base = self.initial[FORMS.index(form)]
        T = Tv * self.c2 / self.c_v if form == "consistent" else Tv
        if self.terzaghi:
            return analytic.terzaghi(self.H - np.asarray(y), T, self.H, top)
        return analytic.column_pressure(y, T, self.H, self.drained, top, base)

    def degree(self, Tv, form: str):
        """The reference degree of consolidation U at time factors Tv in ``form``."""
        if self.layered:
            return self.layered[FORMS.index(form)].degree(self.time(np.asarray(Tv,
                                                                              dtype=float)))
        T = Tv * self.ratio if form == "consistent" else Tv
        if self.terzaghi:
            return analytic.degree_of_consolidation(T)
        top, base = self.initial[FORMS.index(form)]
        return analytic.column_degree(T, self.drained, top, base)

    def degree_pressure(self, Tv, form: str):
        """The reference U from the mean excess pore pressure, 1 - mean u / mean u0, at time
        factors Tv in ``form``: U itself in a uniform column (m_v the same everywhere),
        another curve in layers (the layers' m_v weigh the settlement, not the mean)."""
        if not self.layered:
            return self.degree(Tv, form)
        column = self.layered[FORMS.index(form)]
        t = self.time(np.asarray(Tv, dtype=float))
        return 1 - column.mean_excess(t) / column.mean_excess(0.0)

    def excess(self, p, y):
        """The excess over hydrostatic (Pa) of pore pressures p (Pa) at heights y (m)."""
        if self.hydrostatic == 0:
            return p
        return p - self.hydrostatic * (self.H - np.asarray(y))

    def time_factor(self, t: float) -> float:
        """T_v = c_v t / H^2 at time t (s)."""
        return self.c_v * t / (self.H * self.H)

    def time(self, Tv: float) -> float:
        """The time (s) of the time factor Tv."""
        return Tv * self.H * self.H / self.c_v

    @property
    def ratio(self) -> float:
        """c2 / c_v: the compressible-water reference's time factor per T_v."""
        return self.c2 / self.c_v


@dataclass(frozen=True)
class Plan:
    """A consolidation run, set up: everything the steps and the reporting read.

    ``monitor_height`` (m) is the height of the monitor points, ``monitor_x`` (m) the x of
    a monitor point (NaN: the monitor is the mean of the row of points at that height, a
    one-dimensional column's); ``probes`` where a scene without a closed form is watched
    (:class:`solver.consolidation.fe_reference.Probes`: the monitor, the axis under the load
    (:func:`axis`), the column of points under it, the trough's x; None for a column);
    ``run`` the run's id and the options a restart takes up; ``signature`` the options that
    a checkpoint must match; ``scene`` the scene's signature for the work-precision data;
    ``provenance`` the options as the provenance records them; ``restart`` the checkpoint
    continued ('' for a fresh run) and ``resumed_id`` its run id; ``goal`` the target
    error's pick or None and ``target_error`` (%) the target; ``method`` the time scheme
    (explicit, implicit) and ``stabilize`` the implicit scheme's pressure projection.
    """

    soil: Soil
    body: Body
    loading: Loading
    scheme: Scheme
    schedule: Schedule
    refs: References
    limits: Limits
    outputs: Outputs
    monitor_height: float
    run: dict
    signature: str
    scene: dict
    provenance: dict
    restart: str = ""
    resumed_id: str | None = None
    goal: dict | None = None
    target_error: float = math.nan
    monitor_x: float = math.nan
    probes: object = None
    method: str = "explicit"     # the time scheme: explicit or implicit
    stabilize: bool = True       # the implicit scheme's pressure projection
    materials: tuple | None = None   # one yielding material per layer; None: linear elastic
    material: str = "elastic"        # -mpm_material


def axis(body: Body, loading: Loading) -> float:
    """The x (m) of the axis under the load: the side a load on part of the top starts
    from, where that side is on rollers (a half model's axis of symmetry), else the
    middle of the loaded part (of the top, for a load over all of it)."""
    W = body.size[0]
    x0, x1 = loading.extent if loading.partial(W) else (0.0, W)
    supports = body.supports
    if loading.partial(W) and x0 <= 0 and "x" in supports["left"]:
        return 0.0
    if loading.partial(W) and x1 >= W and "x" in supports["right"]:
        return W
    return (x0 + x1) / 2


def no_reference(body: Body, loading: Loading) -> str:
    """Why the scene is not a one-dimensional column with an analytic reference ('' when
    it is one)."""
    bcs = body.supports
    if loading.partial(body.size[0]):
        return ("a load over part of the top (-mpm_load_extent "
                + ",".join(f"{x:g}" for x in loading.extent) + "), the consolidation is "
                "two-dimensional")
    if set(body.drained) & {"left", "right"}:
        return ("drained through a side (-mpm_drained " + ",".join(body.drained) + "), the "
                "consolidation is two-dimensional")
    if bcs["left"] != "x" or bcs["right"] != "x" or "y" not in bcs["bottom"]:
        return ("the supports (-mpm_bc_*) are not those of a one-dimensional column "
                "(rollers on both sides, the base fixed vertically)")
    return ""
