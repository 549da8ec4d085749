"""The plan of a dynamic run: its options read once at the edge (:class:`Request`), checked
against each other (:func:`validate`) and resolved (:func:`plan_of`) into a
:class:`DynamicPlan`: the base motion (a record read here), the shaken body's supports, the
natural frequencies of the same column by our Jacobi solver (the default Rayleigh
frequencies f1 and 5 f1, and the marks on the transfer function), the Rayleigh
coefficients."""

from __future__ import annotations

import dataclasses
import os

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError
from ..io import checkpoint, output, provenance
from ..io import records as record_files
from ..io.restart import given_at_start
from ..materials import catalog
from ..model.motion import Motion, parse
from ..model.scene import Body, Loading
from ..model.soil import Ground
from ..modal.frequency import lowest
from ..references import layered
from ..stepping.onephase import Shaking, rayleigh
from . import histories

EIGEN_DOFS = 2000          # the dense Jacobi solve's largest problem here (about 30 s)
MAX_STEPS = 5e7


@dataclasses.dataclass
class DynamicPlan:
    """What a dynamic run does, resolved from the options: the body, ground and shaking,
    the sides (rollers, periodic, absorbing), the load (None: none), the motion, the
    phases, the end (s), the recorded depths (m), the natural frequencies (Hz; Jacobi's and
    the layered rod's), the Rayleigh damping (xi, F1, F2 or None), the outputs and the
    run's provenance."""

    body: Body
    ground: Ground
    shaking: Shaking
    sides: str
    loading: Loading | None
    motion: Motion
    phases: int
    t_end: float
    record_dt: float
    depths: tuple
    eigen_hz: np.ndarray
    eigen_solver: str
    analytic_hz: np.ndarray
    damping: tuple | None
    outputs: output.Outputs
    run: dict
    signature: str
    restart: str
    cadence: tuple          # (output_every, checkpoint_every, checkpoint_seconds, progress)
    psa: tuple = (histories.PERIODS, 0.05)     # the spectra's periods (s) and damping
    materials: tuple | None = None     # the hyperbolic soil of each layer (None: linear)
    twin: bool = False                 # step the linear twin after the run


@dataclasses.dataclass(frozen=True)
class Request:
    """The dynamic options, typed: read once at the edge (:meth:`from_options`)."""

    body: Body                 # its supports still the options' (plan_of sets the shaking's)
    ground: Ground
    phases: int
    motion: str                # -mpm_base_motion as given
    scale: float
    direction: str
    base: str
    rock: tuple                # (rho (kg/m3), Vs, Vp (m/s))
    sides: str                 # rollers | periodic | absorbing
    rayleigh: tuple
    t_end: float
    record_dt: float
    depths: tuple
    loading: Loading | None    # the sudden load, when given
    water: bool                # rho_l > 0
    jacobi: tuple              # (tolerance, sweeps)
    outputs: output.Outputs
    cadence: tuple             # (output_every, checkpoint_every, checkpoint_seconds, progress)
    psa: tuple                 # the spectra's periods (s) and damping ratio
    recipe: catalog.Recipe     # -mpm_material and its parameters
    small_strain_damping: float
    twin: bool
    restart: str
    overwrite: bool
    run: dict                  # {"id": None, "options": the options as read}
    signature: str
    provenance: dict

    @classmethod
    def from_options(cls, p) -> "Request":
        summary = p.summary or os.path.join(p.output, "summary.json")
        options = provenance.options(p)
        # The load acts when given (its default is consolidation's), by this command or by
        # the start of the run a restart continues.
        given = set(p.given) | set(given_at_start(p.restart))
        loading = Loading(load=p.load, extent=tuple(p.load_extent)) if "load" in given \
            else None
        return cls(body=Body.from_options(p), ground=Ground.from_options(p), phases=p.phases,
                   motion=p.base_motion, scale=p.base_motion_scale,
                   # Two phases under a load alone move vertically.
                   direction="y" if p.phases == 2 and parse(p.base_motion)[0] == "none"
                   else p.base_direction, base=p.base,
                   rock=(p.rock_rho, p.rock_Vs, p.rock_Vp), sides=p.bc_sides,
                   rayleigh=tuple(p.rayleigh), t_end=p.t_end, record_dt=p.record_dt,
                   depths=tuple(p.record_depths), loading=loading, water=p.rho_l > 0,
                   jacobi=(p.jacobi_tol, p.jacobi_max_sweeps),
                   outputs=output.Outputs(p.output, summary, p.figures, p.figure_format),
                   psa=(np.logspace(np.log10(p.psa_periods[0]), np.log10(p.psa_periods[1]),
                                    int(p.psa_periods[2])), p.psa_damping),
                   cadence=(p.output_every, p.checkpoint_every, p.checkpoint_seconds,
                            p.progress), recipe=catalog.Recipe.from_options(p),
                   small_strain_damping=p.small_strain_damping, twin=p.linear_twin,
                   restart=p.restart, overwrite=p.overwrite,
                   run={"id": None, "options": checkpoint.recorded(options),
                        "given": sorted(given)},
                   signature=checkpoint.signature(p), provenance=options)


def validate(req: Request) -> None:
    """InputError for options that contradict each other."""
    W, H = req.body.size
    moving = parse(req.motion)[0] != "none"
    if req.phases == 2 and moving and req.base != "rigid":
        raise InputError(f"-mpm_base {req.base}: two phases (-mpm_phases 2) are shaken on "
                         "a rigid base (-mpm_base rigid; the motion is the base's own)")
    if req.phases == 2 and req.sides != "rollers":
        raise InputError(f"-mpm_bc_sides {req.sides}: two phases take rollers")
    if req.phases == 2 and not req.water:
        raise InputError("-mpm_rho_l 0: two phases need pore water (rho_l > 0)")
    if not moving and req.loading is None:
        raise InputError("-mpm_base_motion none: nothing moves the body (give a base "
                         "motion or -mpm_load)")
    if req.loading is not None and req.direction == "x" and req.sides == "rollers":
        raise InputError("-mpm_load: with -mpm_base_direction x the sides are held "
                         "vertically and carry it; give -mpm_base_direction y"
                         + (", or -mpm_bc_sides periodic" if req.phases == 1 else ""))
    extent = req.loading.extent if req.loading is not None else ()
    if extent and not 0 <= extent[0] < extent[1] <= W:
        raise InputError(f"-mpm_load_extent {extent[0]:g},{extent[1]:g}: outside the top "
                         f"(0 <= x0 < x1 <= {W:g} m)")
    if req.sides == "absorbing" and moving:
        raise InputError("-mpm_bc_sides absorbing: dashpots for waves leaving a body whose "
                         "far field is at rest (a sudden load, no base motion); "
                         "a shaken body takes periodic sides")
    if req.sides == "periodic" and extent and req.loading.partial(W):
        raise InputError(f"-mpm_bc_sides periodic: a load on part of the top "
                         f"(-mpm_load_extent {extent[0]:g},{extent[1]:g}) is not the same on "
                         "every column; use rollers")
    deep = [d for d in req.depths if d > H]
    if deep:
        raise InputError(f"-mpm_record_depths {deep[0]:g}: below the base ({H:g} m deep)")
    if req.rayleigh and req.phases == 2:
        raise InputError("-mpm_rayleigh: for one phase (the v-w step's drag damps the "
                         "two-phase waves)")
    names = set(req.recipe.names)
    if names - {"elastic", "hyperbolic"} or len(names) > 1:
        raise InputError(f"-mpm_material {','.join(req.recipe.names)}: the shaken body takes "
                         "elastic or hyperbolic, one for every layer (-mpm_reference_strain "
                         "per layer)")
    hyperbolic = names == {"hyperbolic"}
    if hyperbolic and req.phases == 2:
        raise InputError("-mpm_material hyperbolic: one phase (-mpm_phases 1: a total-stress "
                         "analysis)")
    if req.small_strain_damping and not hyperbolic:
        raise InputError("-mpm_small_strain_damping: the hyperbolic soil's (a linear soil's "
                         "damping is -mpm_rayleigh)")
    if req.small_strain_damping and req.rayleigh:
        raise InputError("-mpm_small_strain_damping with -mpm_rayleigh: give one (both are "
                         "Rayleigh damping)")
    if req.t_end / req.record_dt > 1e6:
        raise InputError(f"-mpm_record_dt {req.record_dt:g}: more than 1e6 samples to "
                         f"-mpm_t_end {req.t_end:g} s")


def motion_of(req: Request) -> tuple:
    """(the base motion of ``-mpm_base_motion`` times its scale, the notes): a record file
    is read here (InputError: missing, unreadable, times not increasing)."""
    form = parse(req.motion)
    table = record_files.read(form[1]) if form[0] == "file" else None
    motion = Motion(form, req.scale, table)
    notes = []
    if motion.end < req.t_end:
        notes.append(f"-mpm_base_motion {form[1]}: the record ends at {motion.end:.6g} s, "
                     f"before -mpm_t_end {req.t_end:g} s; zero acceleration after it")
    return motion, notes


def plan_of(req: Request, comm) -> DynamicPlan:
    """The plan of the request (printed as it goes): the motion read, the shaken body's
    supports, the natural frequencies, the Rayleigh coefficients."""
    validate(req)
    motion, notes = motion_of(req)
    for note in notes:
        PETSc.Sys.Print(f"Note: {note}", comm=comm)
    rho, Vs, Vp = req.rock
    shaking = Shaking(req.direction, "rigid" if req.phases == 2 else req.base, rho,
                      Vs if req.direction == "x" else Vp)
    body = dataclasses.replace(req.body, bcs=shaking.supports(req.sides))
    if req.loading is not None:
        req.loading.check_extent(body)
    eig, solver = np.zeros(0), "none"
    soils = req.ground.soils
    if req.phases == 1:
        signals.stage("set-up: the natural frequencies")
        eigen_body = dataclasses.replace(body, bcs=Shaking(req.direction, "rigid").supports())
        eig, solver = lowest(comm, eigen_body, req.ground, 3, "jacobi", *req.jacobi,
                             "eigen_", EIGEN_DOFS)
        modulus = [s.shear_modulus if req.direction == "x" else s.constrained_modulus
                   for s in soils]
    else:         # the waves of a saturated column: undrained, the phases locked by drag
        modulus = [s.shear_modulus if req.direction == "x" else
                   s.constrained_modulus + s.K_l / s.porosity for s in soils]
    analytic = layered.rod_frequencies(req.ground.thickness, modulus,
                                       [s.density for s in soils], 3)
    damping = None
    given = req.rayleigh or ((req.small_strain_damping,) if req.small_strain_damping else ())
    if given:
        xi = given[0]
        f1, f2 = given[1:] if len(given) == 3 else (eig[0], 5 * eig[0])
        damping = (xi, f1, f2)
        shaking = dataclasses.replace(shaking, **dict(zip(("a0", "a1"), rayleigh(xi, f1,
                                                                                   f2))))
    return DynamicPlan(body=body, ground=req.ground, shaking=shaking, sides=req.sides,
                       loading=req.loading, motion=motion, phases=req.phases,
                       t_end=req.t_end, record_dt=req.record_dt, depths=req.depths,
                       eigen_hz=eig, eigen_solver=solver, analytic_hz=analytic,
                       damping=damping, outputs=req.outputs, run=dict(req.run),
                       signature=req.signature, restart=req.restart, cadence=req.cadence,
                       psa=req.psa, materials=req.recipe.per_layer(soils)
                       if "hyperbolic" in req.recipe.names else None,
                       twin=req.twin and "hyperbolic" in req.recipe.names)
