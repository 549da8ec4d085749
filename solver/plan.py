"""What a consolidation run does, as typed values: the :class:`Plan` its set-up returns.

After the set-up nothing reads the options: the time loop, the reporting and the output
take the plan (or the few of its values they need). A plan is the soil, the body and its
loading (:mod:`solver.soil`, :mod:`solver.scene`), the step's scheme
(:mod:`solver.scheme`), the schedule (time step, steps, report and isochrone times), the
references the results are compared with, where the results go, and the run's identity.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from .scene import Body, Loading
from .scheme import Scheme
from .soil import Soil


@dataclass(frozen=True)
class Schedule:
    """The time stepping: ``dt`` (s), ``nsteps``, the end ``Tv_end`` and the report times
    ``Tv_report`` (T_v), and the steps at which the reports and the isochrones fall
    ({step: T_v}); the cadence of the field output, checkpoints (steps; 0: none) and
    progress lines (s; 0: none)."""

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

    @property
    def t_end(self) -> float:
        """The time (s) of the last step."""
        return self.nsteps * self.dt


@dataclass(frozen=True)
class References:
    """Scales of the analytic references: Terzaghi's c_v (m2/s), the compressible-water
    diffusivity c2 (m2/s) and share p0 / q of the load the water takes at once (-); ``q``
    (Pa) the pressure p is normalised by; H (m) the drainage length of the column."""

    c_v: float
    c2: float
    p0: float
    q: float
    H: float

    @classmethod
    def of(cls, soil: Soil, loading: Loading, H: float) -> "References":
        return cls(soil.c_v, soil.c2, soil.undrained_ratio, loading.scale(soil, H), H)

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
class Outputs:
    """Where the results go: the ``folder``, the summary file, figures (on/off and their
    formats)."""

    folder: str
    summary: str
    figures: bool = True
    formats: str = "png"


@dataclass(frozen=True)
class Limits:
    """The critical time steps (s) by criterion, the one that governs dt, those dt
    exceeds, f1 (Hz) and the inertia regime (:func:`solver.inertia.regime`)."""

    steps: dict
    governing: str
    exceeded: tuple
    f1: float = math.nan
    regime: dict = field(default_factory=dict)
    warning: str = ""


@dataclass(frozen=True)
class Plan:
    """A consolidation run, set up: everything the steps and the reporting read.

    ``monitor_height`` (m) is the height of the monitor points; ``run`` the run's id and
    the options a restart takes up; ``signature`` the options that a checkpoint must
    match; ``scene`` the scene's signature for the work-precision data; ``provenance`` the
    options as the provenance records them; ``restart`` the checkpoint continued ('' for a
    fresh run) and ``resumed_id`` its run id; ``goal`` the target error's pick or None and
    ``target_error`` (%) the target.
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
