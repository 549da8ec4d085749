"""The ``-mpm_`` options: read once from the PETSc options database, checked, returned as data.

Every parameter of a run is a PETSc option with the prefix ``-mpm_``, so a scene file passed
with ``-options_file`` sets them and the command line overrides any of them. Each option is
declared once in :data:`SPEC` with its type, default, range check, the analyses that use it
and a help line; the README's option table is generated from the same list
(``python -m solver -help`` prints it with the values in effect).

Every ``-mpm_`` value is fetched from the database by name (``getString``), which marks it
used: ``-options_left`` then lists only options nobody read, such as a misspelt
``-eps_tpye``. The result of :func:`read` is frozen; a changed set of parameters is a new
value (``dataclasses.replace``), so what the run uses is what was read and checked, plus
changes that are visible where they are made. :func:`from_mapping` gives the same value
from ``{name: value}`` without the database (a study's or a test's scenes), through the
same parsing and checks.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import math
from dataclasses import dataclass

from ..common.errors import InputError
from . import checks
from .scenefile import PREFIX, pairs as file_pairs

EIGEN, CONSOLIDATION, DYNAMIC, SOILTEST, STATIC = ("eigen", "consolidation", "dynamic",
                                                   "soiltest", "static")
ANALYSES = (EIGEN, CONSOLIDATION, DYNAMIC, SOILTEST, STATIC)
BOTH = (EIGEN, CONSOLIDATION, STATIC)      # the analyses of a body on supports
MATERIAL = (CONSOLIDATION, SOILTEST, STATIC)   # the analyses that take -mpm_material
MOVING = (CONSOLIDATION, DYNAMIC)       # the analyses that step in time
BC_CHOICES = ("none", "x", "y", "xy")


@dataclass(frozen=True)
class Option:
    name: str            # without the prefix
    kind: str            # "str", "int", "float", "bool", "ints", "floats", "strs",
    #                      "float_or_floats" (one value: a float; several: a tuple, per layer),
    #                      "str_or_strs" (the same for names)
    default: object
    help: str
    used_by: tuple = ANALYSES
    check: object = None  # callable(value) -> error text or None
    choices: tuple = ()
    length: int = 0      # fixed list length, 0 for any


SPEC = [
    Option("analysis", "str", EIGEN, "what to compute: eigen (frequencies and modes), "
           "consolidation, dynamic (the body shaken at its base or loaded suddenly, in time), "
           "soiltest (one material point through a laboratory test), static (a footing pushed, "
           "or a load raised, in load steps)",
           choices=ANALYSES),
    Option("element", "str", "q4", "background cell: q4 (bilinear), q8 (serendipity), "
           "q9 (Lagrange)", choices=("q4", "q8", "q9")),
    Option("cells", "ints", (1, 10), "cells across and up, NX,NY", length=2,
           check=checks.all_at_least_one),
    Option("size", "floats", (0.1, 1.0), "body width and height W,H (m); the grid covers it",
           length=2, check=checks.all_positive),
    Option("ppc", "int", 2, "material points per cell per direction", check=checks.at_least_one),
    Option("points", "str", "uniform", "point placement: uniform (sub-cell centres, MPM) or "
           "gauss (Gauss points: the plain FE model)", choices=("uniform", "gauss")),
    Option("layers", "floats", (), "thicknesses of horizontal soil layers from the surface "
           "down, t1,t2,... (m), summing to the height H, each at least a cell high, the "
           "interfaces on cell boundaries; default: one layer. Options 'per layer' take one "
           "value (every layer) or one per layer, in this order",
           check=checks.all_positive),
    Option("E", "float_or_floats", 10.0e6, "Young's modulus of the soil skeleton (Pa), per "
           "layer", check=checks.positive),
    Option("nu", "float_or_floats", 0.0, "Poisson's ratio, per layer", check=checks.poisson),
    Option("rho_s", "float_or_floats", 2700.0, "solid grain density (kg/m3), per layer",
           check=checks.positive),
    Option("rho_l", "float", 1000.0, "liquid density (kg/m3), one for every layer (0: "
           "a dry soil, dynamic one-phase only)",
           check=checks.nonnegative),
    Option("porosity", "float_or_floats", 0.3, "porosity n, per layer", check=checks.open_unit),
    Option("bc_left", "str", "x", "fixed displacement components on x = 0", BOTH, choices=BC_CHOICES),
    Option("bc_right", "str", "x", "fixed displacement components on x = W", BOTH, choices=BC_CHOICES),
    Option("bc_bottom", "str", "xy", "fixed displacement components on y = 0", BOTH, choices=BC_CHOICES),
    Option("bc_top", "str", "none", "fixed displacement components on y = H", BOTH, choices=BC_CHOICES),
    Option("nmodes", "int", 5, "eigenpairs to report", BOTH, check=checks.at_least_one),
    Option("eigen_solver", "strs", ("jacobi", "slepc"), "eigen solvers to run, one or both",
           BOTH, choices=("jacobi", "slepc")),
    Option("jacobi_tol", "float", 1e-15, "Jacobi convergence tolerance xi, eq. (4)",
           check=checks.tolerance),
    Option("jacobi_max_sweeps", "int", 50, "Jacobi sweeps before giving up (exit code 3)",
           check=checks.at_least_one),
    # -- two-phase consolidation --------------------------------------------------------
    Option("K_l", "float", 120.0e6, "liquid bulk modulus (Pa)", MOVING, checks.positive),
    Option("mu_l", "float", 1.0e-3, "liquid dynamic viscosity (Pa s)", MOVING, checks.positive),
    Option("k", "float_or_floats", 2.5e-4, "hydraulic conductivity (m/s), defined with g = "
           "9.81 m/s2, per layer", MOVING, checks.positive),
    Option("gravity", "float", 0.0, "body force, acting downwards (m/s2); static: the body "
           "starts at rest under it (K0), its weight buoyant under the water table at the "
           "surface (dry with -mpm_rho_l 0)", (CONSOLIDATION, STATIC), checks.nonnegative),
    Option("initial_state", "str", "deposited", "the state before the load, with gravity: "
           "deposited (a fresh deposit, pore pressure and effective stress 0: it consolidates "
           "under its own weight) or geostatic (hydrostatic pore pressure and K0 effective "
           "stress, at rest under gravity: a load drives the excess it drives without "
           "gravity)", (CONSOLIDATION,), choices=("deposited", "geostatic")),
    Option("K0", "float_or_floats", float("nan"), "earth pressure coefficient at rest "
           "sigma'_h / sigma'_v of the geostatic state, per layer (default: each layer's "
           "nu / (1 - nu))", (CONSOLIDATION, STATIC), checks.nonnegative),
    Option("load", "float", 10.0e3, "surface load q on the top, downwards (Pa); dynamic: "
           "applied suddenly at t = 0, and only when given; static: raised in -mpm_load_steps "
           "(in place of a footing), only when given", MOVING + (STATIC,), checks.nonnegative),
    Option("load_extent", "floats", (), "the loaded part x0,x1 of the top (m), e.g. a strip "
           "footing on a half model with rollers on its axis x = 0 (default: the whole top)",
           MOVING + (STATIC,), length=2),
    Option("load_ramp", "float", 0.0, "time over which the load rises linearly to q (s)",
           (CONSOLIDATION,), checks.nonnegative),
    Option("drained", "strs", ("top",), "drained sides (p = 0); the others are impermeable "
           "(no flow relative to the skeleton); left and right with q4 cells only; none: "
           "no drained side (undrained loading)",
           MOVING, choices=("left", "right", "bottom", "top", "none")),
    Option("scheme", "str", "auto", "time scheme: explicit (the dynamic v-w step of the "
           "paper), implicit (quasi-static u-p Biot on the material points: TR-BDF2 on steps "
           "graded from the load, LU by MUMPS; options -mpm_ksp_*, -mpm_pc_*, -mpm_mat_mumps_*) "
           "or auto (implicit, unless the explicit step is estimated both within 0.2 % of q of "
           "the quasi-static answer at the first report and cheaper, or an option of the "
           "explicit step is given; it prints why)", (CONSOLIDATION,),
           choices=("auto", "explicit", "implicit")),
    Option("implicit_steps", "int", 8, "implicit scheme: time steps per doubling of time "
           "(report times are step ends)", (CONSOLIDATION,), checks.at_least_one),
    Option("pressure_stabilization", "str", "auto", "implicit scheme: ppp (Dohrmann and "
           "Bochev's polynomial pressure projection, which keeps the undrained start free of "
           "oscillations), none, auto (ppp on Q4 cells; none on Q8 and Q9, the inf-sup stable "
           "Taylor-Hood pairs)", (CONSOLIDATION,), choices=("auto", "ppp", "none")),
    Option("dt", "float", float("nan"), "time step (s); default: dt_safety times the "
           "smallest critical time step", (CONSOLIDATION,), checks.positive),
    Option("dt_safety", "float", 0.5, "fraction of the smallest critical time step used",
           (CONSOLIDATION,), lambda v: None if 0 < v <= 1 else "must lie in (0, 1]"),
    Option("stability_analysis", "bool", True, "compute the discrete stability limit of the "
           "step (a dense analysis; 0: Table 1's criteria and the drag limit only)",
           (CONSOLIDATION,)),
    Option("target_error", "float", float("nan"), "accuracy target (%): pick the cheapest "
           "element, cells, points per cell and dt_safety that the measured work-precision "
           "data say meet it: the largest error against compressible-water Terzaghi of all the "
           "run reports (p at the monitor point, the profile's L2 in % of q, U from the "
           "settlement and from the pore pressure) at T_v = 0.02, 0.2, 0.5 and 1; the run "
           "checks its own errors (met or NOT met) and predicts its time from its first "
           "steps", (CONSOLIDATION,), checks.positive),
    Option("work_precision", "str", "", "work-precision data for -mpm_target_error (default: "
           "the data measured on the paper's column, shipped with the solver)",
           (CONSOLIDATION,)),
    Option("allow_unstable", "bool", False, "run even with dt more than twice a stability "
           "limit (for studies of blow-up)", (CONSOLIDATION,)),
    Option("Tv_end", "float", 1.0, "end of the run as Terzaghi time factor T_v",
           (CONSOLIDATION,), checks.positive),
    Option("Tv_report", "floats", (0.02, 0.5, 1.0), "T_v at which pore pressures are reported",
           (CONSOLIDATION,), checks.all_positive),
    Option("monitor_height", "float", float("nan"), "height of the monitor point (m); "
           "default: the highest material point below mid-height", (CONSOLIDATION,)),
    Option("monitor", "floats", (), "the monitor point x,y (m): the material point nearest "
           "it (default: a column's monitor is the mean of the row of points at "
           "-mpm_monitor_height; a scene without a closed form's the point at that height "
           "nearest its axis under the load: the rollers' side a load on part of the top "
           "starts from, else the load's middle)", (CONSOLIDATION,), length=2),
    Option("fe_reference", "bool", True, "solve a scene without a closed form again by "
           "finite elements (solver/references/biot.py: the same body, quasi-static) and report "
           "the settlement under the load and the monitor's pore pressure against it, with "
           "errors (0: not)", (CONSOLIDATION,)),
    Option("fe_cells", "ints", (), "the FE reference's Q9/Q4 cells NX,NY (default: square "
           "cells, 32 across the shorter side or fewer to keep about 2048, the layer "
           "interfaces on cell boundaries)", (CONSOLIDATION,), length=2,
           check=checks.all_at_least_one),
    Option("output_every", "int", 0, "write point fields every N steps and at the report "
           "times (0: at the report times only)", MOVING, checks.nonnegative),
    Option("damping", "float", 0.0, "local (Cundall) damping coefficient of the nodal "
           "accelerations, 0 for none (it opposes the settlement too: docs/studies.md)",
           (CONSOLIDATION,),
           lambda v: None if 0 <= v < 1 else "must lie in [0, 1)"),
    Option("bulk_viscosity", "float", 0.0, "linear bulk viscosity b1: a viscous stress "
           "b1 rho c1 h div(v_s) on the mixture (rho, c1 with the scaled inertia, h the "
           "smaller cell size), which damps the wave near the cell scale; 0 for none",
           (CONSOLIDATION,), lambda v: None if 0 <= v <= 1 else "must lie in [0, 1]"),
    Option("fast_damping", "float", 0.5, "damping ratio zeta of the fast part of the "
           "mixture's motion: point velocities lose 2 zeta w1 (v_m - v_slow) per second, "
           "v_slow their mixture velocity low-passed over 1/w1 (w1 = 2 pi / T_w, T_w the "
           "scaled wave period 4H/c1); both phases alike, so Darcy flow is untouched; takes "
           "the wave out without slowing the settlement (docs/studies.md); 0 for none", (CONSOLIDATION,), lambda v: None if 0 <= v <= 5 else "must lie in [0, 5]"),
    Option("flip", "str", "auto", "FLIP fraction of the point velocity update, in [0, 1] "
           "(0: PIC), or auto (1; 0.99 for hrz lumping with the corner pressure projection, "
           "whose pure FLIP transfer feeds a slow growing mode)", (CONSOLIDATION,), checks.fraction),
    Option("lumping", "str", "auto", "lumped masses and the solid's transfer: rowsum, hrz, "
           "blended (the liquid's blended basis N_hat both ways), auto (blended for q8)",
           (CONSOLIDATION,), choices=("auto", "rowsum", "hrz", "blended")),
    Option("kinematics", "str", "auto", "where shape functions are evaluated: small (at the "
           "points' initial positions: small strains, as the constant volumes and porosity "
           "assume), large (at their current positions: moving-point MPM), auto (small)",
           (CONSOLIDATION,), choices=("auto", "small", "large")),
    Option("pressure_projection", "str", "auto", "pore-pressure increments: none (kept per "
           "point), nodal (projected onto the nodal field and interpolated back), corner "
           "(onto the bilinear field of the cells' corner nodes: below the quadratic cells' "
           "velocities; on q4 with the compact Darcy stencil), auto (corner; nodal for q4 "
           "undrained at its sides)",
           (CONSOLIDATION,), choices=("auto", "none", "nodal", "corner")),
    Option("liquid_basis", "str", "auto", "basis of the liquid equation (its masses, drag, "
           "force, velocity transfers and relative motion): element (N), blended (N/2 + "
           "N_Q4/2, positive lumped weights), auto (blended for q8)", (CONSOLIDATION,),
           choices=("auto", "element", "blended")),
    Option("drag", "str", "implicit", "drag of the liquid equation (eq. 14): implicit "
           "(backward Euler on the relative velocity, node by node: no drag limit on dt), "
           "explicit (forward, the paper's scheme: dt < 2/lambda)", (CONSOLIDATION,),
           choices=("implicit", "explicit")),
    Option("mass_scaling", "str", "none", "factor S on both phases' inertia (not on drag or "
           "weight): none (S = 1), auto (the largest S whose inertia error at the earliest "
           "report time stays within 0.2 % of q, docs/method.md), or a number S > 0; the "
           "wave limits grow as sqrt(S)", (CONSOLIDATION,), checks.scaling),
    Option("checkpoint_every", "int", 0, "write OUTPUT/checkpoint.npz every N steps (0: never)",
           MOVING + (STATIC,), checks.nonnegative),
    Option("checkpoint_seconds", "float", 0.0, "also write it every S seconds of wall time",
           MOVING, checks.nonnegative),
    Option("restart", "str", "", "continue the run stored in this checkpoint file, with its "
           "options (-mpm_restart CK alone); options beside it may change only the output, "
           "the end and report times and the cadence of fields, checkpoints and progress",
           MOVING + (STATIC,)),
    Option("overwrite", "bool", False, "let -mpm_restart write into an -mpm_output that "
           "holds another run's results (its summary, field series or checkpoint); the "
           "field series starts again from the checkpoint's own times", MOVING + (STATIC,)),
    Option("progress", "float", 10.0, "seconds between progress lines (0: none)",
           MOVING, checks.nonnegative),
    # -- dynamics: the body shaken at its base (or loaded suddenly) -----------------------
    Option("phases", "int", 1, "1: the solid alone with the mixture's density (dry or total "
           "stress; a dry soil sets -mpm_rho_l 0); 2: saturated, the v-w step (pore pressure; "
           "shaken on a rigid base, or loaded)", (DYNAMIC,),
           lambda v: None if v in (1, 2) else "choose 1 or 2"),
    Option("base_motion", "str", "none", "the input motion: none, ricker:F0,AMP (Hz, peak "
           "m/s2, centred at 1.5/F0 s), sine:F,AMP,CYCLES, or a record file: CSV t (s), a "
           "(m/s2), or a PEER .AT2 (g); interpolated onto the steps, zero after its end",
           (DYNAMIC,), checks.motion),
    Option("base_motion_scale", "float", 1.0, "factor on the input motion", (DYNAMIC,),
           checks.positive),
    Option("base_direction", "str", "x", "direction of the base motion: x (vertically "
           "propagating shear waves) or y (compression waves)", (DYNAMIC,), choices=("x", "y")),
    Option("base", "str", "compliant", "rigid (the motion is the base's own, a within "
           "motion) or compliant (elastic rock under the soil: a Lysmer dashpot driven by the "
           "rock-outcrop motion)", (DYNAMIC,), choices=("rigid", "compliant")),
    Option("rock_Vs", "float", 760.0, "shear-wave speed of the rock under a compliant base "
           "(m/s)", (DYNAMIC,), checks.positive),
    Option("rock_Vp", "float", 1520.0, "compression-wave speed of the rock (m/s)",
           (DYNAMIC,), checks.positive),
    Option("rock_rho", "float", 2200.0, "density of the rock (kg/m3)", (DYNAMIC,), checks.positive),
    Option("bc_sides", "str", "rollers", "the sides: rollers (held across the shaking "
           "direction), periodic (left and right nodes tied: a body of any width moves as "
           "a column; not with a load on part of the top) or absorbing (Lysmer dashpots "
           "rho Vp, rho Vs: waves from a sudden load leave; not with a base motion)",
           (DYNAMIC,), choices=("rollers", "periodic", "absorbing")),
    Option("rayleigh", "floats", (), "Rayleigh damping XI[,F1,F2]: ratio XI at F1 and F2 "
           "(Hz; default f1 and 5 f1 of the Jacobi eigen analysis of the same column); "
           "none when not given", (DYNAMIC,), checks.rayleigh),
    Option("t_end", "float", 10.0, "end of the run (s)", (DYNAMIC,), checks.positive),
    Option("record_depths", "floats", (), "depths below the surface of the recorded "
           "histories (m); the surface and the base always", (DYNAMIC,), checks.all_nonnegative),
    Option("record_dt", "float", 0.005, "time between recorded samples (s; the time step "
           "is a divisor of it)", (DYNAMIC,), checks.positive),
    # -- materials, soil tests and the static analysis ------------------------------------
    Option("material", "str_or_strs", "elastic", "the soil's model: elastic, tresca (undrained "
           "strength -mpm_cohesion, total stress), mohr-coulomb, drucker-prager (matched to "
           "Mohr-Coulomb in plane strain), mcc (Modified Cam Clay); consolidation: per layer",
           MATERIAL, choices=("elastic", "tresca", "mohr-coulomb", "drucker-prager", "mcc")),
    Option("cohesion", "float_or_floats", 0.0, "cohesion c (Pa); tresca: the undrained "
           "strength c_u; consolidation: per layer", MATERIAL, checks.nonnegative),
    Option("friction_angle", "float_or_floats", 0.0, "friction angle phi (degrees); consolidation: "
           "per layer", MATERIAL, checks.angle),
    Option("dilation_angle", "float_or_floats", math.nan, "dilation angle psi (degrees; default: "
           "phi, associated flow); consolidation: per layer", MATERIAL, checks.angle),
    Option("tension_cutoff", "float_or_floats", math.nan, "tresca, mohr-coulomb: the largest "
           "principal stress, tension positive (Pa; default: none); consolidation: per layer",
           MATERIAL, checks.nonnegative),
    Option("mcc_M", "float", 1.0, "mcc: critical state slope in p'-q", MATERIAL, checks.positive),
    Option("mcc_lambda", "float", 0.2, "mcc: compression slope, e-ln p'", MATERIAL, checks.positive),
    Option("mcc_kappa", "float", 0.04, "mcc: swelling slope in e-ln p'", MATERIAL, checks.positive),
    Option("void_ratio", "float", float("nan"), "mcc: void ratio e0", MATERIAL, checks.positive),
    Option("mcc_ocr", "float", 1.0, "mcc: overconsolidation ratio p_c / p'_0", MATERIAL, lambda v:
           None if v >= 1 else "must be at least 1"),
    Option("soiltest", "str", "triaxial-drained", "the soil test", (SOILTEST,), choices=(
        "triaxial-drained", "triaxial-undrained", "plane-strain", "simple-shear", "oedometer")),
    Option("confining", "float", 100e3, "the soil test's initial isotropic effective stress, "
           "drained its cell pressure (Pa)", (SOILTEST,), checks.nonnegative),
    Option("strain_end", "float", 0.1, "the soil test's axial (simple shear: shear) strain "
           "at the end, compression positive", (SOILTEST,), checks.positive),
    Option("strain_steps", "int", 500, "soil test steps", (SOILTEST,), checks.at_least_one),
    Option("footing", "floats", (), "the rigid strip footing x0,x1 on the top (m; a half "
           "model: 0,B/2 with rollers on x = 0)", (STATIC,), length=2),
    Option("footing_interface", "str", "smooth", "smooth (the footing holds the vertical "
           "displacement) or rough (both)", (STATIC,), choices=("smooth", "rough")),
    Option("footing_settlement", "float", 0.01, "the footing's settlement at the end (m)", (STATIC,), checks.positive),
    Option("surcharge", "float", 0.0, "a pressure q0 on the top beside the footing or load "
           "(Pa), from the start", (STATIC,), checks.nonnegative),
    Option("load_steps", "int", 20, "equal settlement steps (each halved where Newton does "
           "not converge)", (STATIC,), checks.at_least_one),
    Option("bbar", "bool", True, "B-bar: each point's volume change its cell's", (STATIC,)),
    Option("output", "str", "output", "folder for figures, fields and the summary"),
    Option("summary", "str", "", "JSON summary file (default: OUTPUT/summary.json)"),
    Option("figures", "bool", True, "write figures (in -mpm_figure_format)"),
    Option("figure_format", "str", "png", "formats of the figures, comma-separated: png, pdf, "
           "svg (e.g. png,pdf)", check=checks.figure_formats),
    Option("debug", "bool", False, "show the Python traceback of a failure"),
]

_BY_NAME = {o.name: o for o in SPEC}
# PETSc's own options of the implicit scheme's linear solver (KSP prefix mpm_): PETSc reads
# them (-mpm_ksp_type, -mpm_pc_factor_mat_solver_type, -mpm_mat_mumps_icntl_14, ...).
LINEAR_SOLVER = ("ksp_", "pc_", "mat_", "snes_")
# The options that only the explicit step reads, and those only the implicit scheme reads.
EXPLICIT_ONLY = ("dt", "dt_safety", "stability_analysis", "target_error", "work_precision",
                 "allow_unstable", "damping", "bulk_viscosity", "fast_damping", "flip",
                 "lumping", "kinematics", "pressure_projection", "liquid_basis", "drag",
                 "mass_scaling")
IMPLICIT_ONLY = ("implicit_steps", "pressure_stabilization")
# Why a value that is not per layer is one: the pore fluid is the same in every layer.
_FLUID = ("one value: the pore water is one fluid, the same in every layer (per layer: "
          + ", ".join(f"-{PREFIX}{o.name}" for o in SPEC if o.kind == "float_or_floats")
          + ")")
ONE_VALUE = {"rho_l": _FLUID, "K_l": _FLUID, "mu_l": _FLUID}
# Besides the options, what :func:`read` found out about where they came from.
EXTRA_FIELDS = ("given", "from_file", "notes")


def params_class(spec):
    """A frozen dataclass with a field per option of ``spec`` and :data:`EXTRA_FIELDS`
    (assigning a field raises ``dataclasses.FrozenInstanceError``)."""
    fields = [(o.name, object) for o in spec] + [(f, object) for f in EXTRA_FIELDS]
    cls = dataclasses.make_dataclass("Params", fields, frozen=True)
    cls.__module__ = __name__
    return cls


Params = params_class(SPEC)    # module level, so that the default parameters pickle


def _parse_int(text):
    value = float(text)
    if not math.isfinite(value) or value != int(value):
        raise ValueError("not an integer")
    if abs(value) > 2**31 - 1:
        raise ValueError("outside the 32-bit integer range")
    return int(value)


def _parse(opt: Option, text: str):
    scalar = {"int": _parse_int, "ints": _parse_int,
              "float": checks.parse_float, "floats": checks.parse_float}.get(opt.kind, str.strip)
    if opt.kind in ("ints", "floats", "strs", "float_or_floats", "str_or_strs"):
        parts = [p.strip() for p in text.split(",")]
        if any(p == "" for p in parts):
            raise ValueError("malformed list (empty entry)")
        if opt.kind in ("float_or_floats", "str_or_strs"):  # one value stays a scalar
            values = tuple(checks.parse_float(p) if opt.kind == "float_or_floats" else p
                           for p in parts)
            return values[0] if len(values) == 1 else values
        value = tuple(scalar(p) for p in parts)
        if opt.length and len(value) != opt.length:
            raise ValueError(f"needs {opt.length} comma-separated values")
        if opt.kind == "strs" and len(set(value)) != len(value):
            raise ValueError("repeated entry")
        return value
    return scalar(text)


def _check_value(opt: Option, value):
    values = value if isinstance(value, tuple) else (value,)
    if opt.choices:
        bad = [v for v in values if v not in opt.choices]
        if bad:
            return f"unknown value '{bad[0]}' (choose from {', '.join(opt.choices)})"
    if opt.kind == "float_or_floats" and isinstance(value, tuple) and opt.check:
        return next((f"layer {i + 1}: {problem}" for i, v in enumerate(value)
                     if (problem := opt.check(v))), None)
    return opt.check(value) if opt.check else None


def _describe(opt: Option, value) -> str:
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value)


def _from_json(opt: Option, value):
    """A value as JSON holds it (a checkpoint's options): lists as tuples, null as NaN."""
    if value is None and opt.kind in ("float", "float_or_floats"):
        return math.nan
    return tuple(value) if isinstance(value, list) else value


def text(name: str, value) -> str:
    """Option ``name``'s value as the command line writes it (a list comma-separated)."""
    opt = _BY_NAME[name]
    return _describe(opt, _from_json(opt, value))


def read(spec=None, db=None, origins=None, base=None):
    """Read, parse and check every ``-mpm_`` option; raise :class:`InputError` on the first fault.

    ``db`` is a ``PETSc.Options`` (the global database when None). Options that no analysis
    knows are errors with a suggestion of the nearest valid name. ``origins`` maps the
    options a scene file set (and the command line did not) to their ``FILE:LINE``
    (:func:`scan_file`): such an option that the chosen analysis does not use is dropped with
    a note, so one scene serves both analyses; given anywhere else it is an error.

    The result, a frozen :data:`Params` (``dataclasses.replace`` makes a changed copy),
    holds every option's value, ``given`` (the names set), ``from_file`` (those of them a
    scene file set: ``{name: "FILE:LINE"}``) and ``notes`` (lines to print before the run).
    Every option given is fetched by name, which marks it used for ``-options_left``.
    ``base`` ({name: value as JSON holds it}, a checkpoint's options) gives the values of
    the options not given, in place of the defaults.
    """
    from petsc4py import PETSc

    db = PETSc.Options() if db is None else db
    # getString marks the option used (getAll does not): -options_left then reports only
    # the options nobody read. PETSc returns "" for an option given without a value.
    given = {k[len(PREFIX):]: db.getString(k, "") for k in db.getAll() if k.startswith(PREFIX)
             and not k[len(PREFIX):].startswith(LINEAR_SOLVER)}
    return _assemble(SPEC if spec is None else spec, given, origins or {}, base or {})


def from_mapping(values, base=None):
    """The :data:`Params` that :func:`read` returns for a command line giving ``values``.

    ``values`` is ``{name: value}``, names without ``mpm_``; a value is either the text the
    command line would give (``"1,10"``) or a Python value of the option's kind (a float,
    an int, a tuple for a list, a bool, a str; None for an option given without a value).
    It is parsed and checked as that text, with the same :class:`InputError` texts; ``base``
    is :func:`read`'s. PETSc's options database is neither read nor written, so a study or
    a test can build the parameters of many scenes in one process.
    """
    return _assemble(SPEC, {name: _as_text(value) for name, value in values.items()}, {},
                     base or {})


def _as_text(value):
    """A Python value as the command line writes it (None stays None: no value given)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (tuple, list)):
        return ",".join(map(str, value))
    return None if value is None else str(value)


def _value(opt: Option, text):
    """Option ``opt`` given as ``text`` (None or "" when given without a value), parsed and
    checked."""
    text = "" if text is None else str(text)
    if opt.kind == "bool":
        low = text.strip().lower()
        if low in ("", "1", "true", "yes", "on"):
            return True
        if low in ("0", "false", "no", "off"):
            return False
        raise InputError(f"-{PREFIX}{opt.name}: '{text}' is not a boolean")
    if text.strip() == "":
        raise InputError(f"-{PREFIX}{opt.name}: needs a value")
    if opt.kind in ("float", "int") and "," in text:
        raise InputError(f"-{PREFIX}{opt.name} {text.strip()}: "
                         + ONE_VALUE.get(opt.name, "takes one value, not a list"))
    try:
        value = _parse(opt, text)
    except ValueError as exc:
        raise InputError(f"-{PREFIX}{opt.name}: '{text}': {exc}") from None
    problem = _check_value(opt, value)
    if problem:
        raise InputError(f"-{PREFIX}{opt.name} {_describe(opt, value)}: {problem}")
    return value


def _assemble(spec, given: dict, origins: dict, base: dict):
    """The Params of the options ``given`` ({name: text}) over ``base`` or the defaults:
    :func:`read` after the database is read, shared with :func:`from_mapping`."""
    by_name = {o.name: o for o in spec}
    given = dict(given)
    for name in given:
        if name not in by_name:
            near = difflib.get_close_matches(name, list(by_name), n=1)
            hint = f" (did you mean -{PREFIX}{near[0]}?)" if near else ""
            raise InputError(f"-{PREFIX}{name}: unknown option{hint}")

    values = {}
    for opt in spec:
        if opt.name in given:
            values[opt.name] = _value(opt, given[opt.name])
        elif opt.name in base:
            values[opt.name] = _from_json(opt, base[opt.name])
        else:
            values[opt.name] = opt.default

    analysis = values["analysis"]
    unused = [name for name in given if analysis not in by_name[name].used_by]
    for name in unused:
        if name not in origins:
            raise InputError(f"-{PREFIX}{name}: not used by -{PREFIX}analysis {analysis}")
    notes = []
    if unused:
        # The values are parsed and checked above (a broken scene file stays an error) but
        # left at their defaults: the analysis does not read them.
        for name in unused:
            values[name] = by_name[name].default
            del given[name]
        files = sorted({origins[n].rsplit(":", 1)[0] for n in unused})
        notes.append(f"{len(unused)} option(s) of {', '.join(files)} not used by "
                     f"-{PREFIX}analysis {analysis}, ignored: "
                     + " ".join(f"-{PREFIX}{n}" for n in sorted(unused)))
    cls = Params if spec is SPEC else params_class(spec)
    return cls(**values, given=tuple(sorted(given)),
               from_file={n: origins[n] for n in given if n in origins}, notes=tuple(notes))


def table(spec=None, values=None) -> str:
    """The option table as Markdown (the README's). ``values`` (a :func:`read` result, or
    ``{name: text}``) adds a column "value" with the values in effect (``-help``)."""
    spec = SPEC if spec is None else spec
    if values is not None and not isinstance(values, dict):
        values = {o.name: _describe(o, getattr(values, o.name)) for o in spec}
    value_head, value_rule = ("value | ", "---|") if values is not None else ("", "")
    rows = [f"| option | {value_head}default | used by | meaning |",
            f"|---|{value_rule}---|---|---|"]
    for o in spec:
        value = f"`{values[o.name]}` | " if values is not None else ""
        rows.append(f"| `-{PREFIX}{o.name}` | {value}`{_describe(o, o.default)}` | "
                    f"{', '.join(o.used_by)} | {o.help} |")
    return "\n".join(rows)


def given_text(spec=None, db=None) -> dict:
    """``{name: text}`` of every option of ``spec`` as the database holds it (the default
    for those not given), unparsed: ``-help`` shows these when :func:`read` refuses them.
    Fetching marks the options used."""
    from petsc4py import PETSc

    spec = SPEC if spec is None else spec
    db = PETSc.Options() if db is None else db
    return {o.name: db.getString(PREFIX + o.name, "") if db.hasName(PREFIX + o.name)
            else _describe(o, o.default) for o in spec}


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _pairs(args) -> list:
    """``[(name, value or None)]`` of command-line arguments, split as PETSc splits them: a
    word that starts with ``-`` and is not a number names an option; the word after it is
    its value unless it names another."""
    pairs = []
    for word in args:
        if word.startswith("-") and not _is_number(word):
            pairs.append((word[1:], None))
        elif pairs and pairs[-1][1] is None:
            pairs[-1] = (pairs[-1][0], word)
        else:
            raise InputError(f"'{word}': expected an option (-name [value])")
    return pairs


@contextlib.contextmanager
def command_line(argv, db=None):
    """PETSc's database holding the options of ``argv`` (a command line, program name
    first) for the duration of the block, then the database as it was.

    For a process where PETSc already runs (a test, a notebook, a study calling
    ``solver.__main__.main`` once per scene), where ``petsc4py.init`` can no longer take
    them. As at PETSc's start, the ``-options_file`` files are read first and the rest of
    the command line wins over them.
    """
    from petsc4py import PETSc

    db = PETSc.Options() if db is None else db
    before = db.getAll()
    try:
        pairs = _pairs(argv[1:])
        # PETSc reads an -options_file on rank 0 of COMM_WORLD and broadcasts it, which a
        # run on fewer ranks would leave half done; the files are plain (scan_file checked
        # them), so they are read here. -help is the caller's to act on: in the database it
        # would change how PETSc finalises.
        for name, value in pairs:
            if name == "options_file_yaml":
                raise InputError("-options_file_yaml: only on a command line; from Python "
                                 "give -options_file")
            if name == "options_file":
                for option, text in file_pairs(value):
                    db.setValue(option, text)
        for name, value in pairs:
            if name not in ("options_file", "help", "-help", "h"):
                db.setValue(name, value)
        yield db
    finally:
        after = db.getAll()
        for name, value in after.items():
            if name not in before:
                db.delValue(name)
            elif before[name] != value:
                db.setValue(name, before[name])
