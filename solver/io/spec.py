"""Every ``-mpm_`` option, declared once: its type, default, range check, the analyses that
use it and its help line (:mod:`solver.io.options` reads them; the README's option table is
generated from this list)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from . import checks

EIGEN, CONSOLIDATION, DYNAMIC, SOILTEST, STATIC = ("eigen", "consolidation", "dynamic",
                                                   "soiltest", "static")
ANALYSES = (EIGEN, CONSOLIDATION, DYNAMIC, SOILTEST, STATIC)
BOTH = (EIGEN, CONSOLIDATION, STATIC)      # the analyses of a body on supports
MATERIAL = (CONSOLIDATION, SOILTEST, STATIC, DYNAMIC)   # the analyses that take -mpm_material
WALLS = (EIGEN, CONSOLIDATION, STATIC, DYNAMIC)      # the analyses that take -mpm_bc_*
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
    Option("bc_left", "str", "x", "fixed displacement components on x = 0", WALLS, choices=BC_CHOICES),
    Option("bc_right", "str", "x", "fixed displacement components on x = W", WALLS, choices=BC_CHOICES),
    Option("bc_bottom", "str", "xy", "fixed displacement components on y = 0", WALLS, choices=BC_CHOICES),
    Option("bc_top", "str", "none", "fixed displacement components on y = H", WALLS, choices=BC_CHOICES),
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
           "surface (dry with -mpm_rho_l 0)", (CONSOLIDATION, STATIC, DYNAMIC), checks.nonnegative),
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
    Option("k_law", "str", "constant", "-mpm_scheme implicit -mpm_kinematics large: the "
           "permeability with the void ratio: constant, power:A (k ((1 + e) / (1 + e0))^A; "
           "A = 2 is Gibson's and Xie and Leo's), kozeny-carman (k (e^3 / (1 + e)) / (e0^3 / "
           "(1 + e0)))", (CONSOLIDATION,)),
    Option("large_strain_stress", "str", "kirchhoff", "-mpm_scheme implicit -mpm_kinematics "
           "large: the stress linear in the logarithmic strain: kirchhoff (Hencky) or cauchy "
           "(a constant m_vl, Xie and Leo's)", (CONSOLIDATION,),
           choices=("kirchhoff", "cauchy")),
    Option("pressure_stabilization", "str", "auto", "implicit scheme: ppp (Dohrmann and "
           "Bochev's polynomial pressure projection, which keeps the undrained start free of "
           "oscillations), none, auto (ppp on Q4 cells; none on Q8 and Q9, the inf-sup stable "
           "Taylor-Hood pairs)", (CONSOLIDATION,), choices=("auto", "ppp", "none")),
    Option("dt", "float", float("nan"), "time step (s); default: dt_safety times the "
           "smallest critical time step", (CONSOLIDATION,), checks.positive),
    Option("dt_safety", "float", 0.5, "fraction of the smallest critical time step used",
           MOVING, lambda v: None if 0 < v <= 1 else "must lie in (0, 1]"),
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
           MOVING,
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
           "whose pure FLIP transfer feeds a slow growing mode; dynamic large: 0.99, whose 1 % PIC "
           "lets a collapse come to rest)", MOVING, checks.fraction),
    Option("lumping", "str", "auto", "lumped masses and the solid's transfer: rowsum, hrz, "
           "blended (the liquid's blended basis N_hat both ways), auto (blended for q8)",
           (CONSOLIDATION,), choices=("auto", "rowsum", "hrz", "blended")),
    Option("kinematics", "str", "auto", "where shape functions are evaluated: small (at the "
           "points' initial positions: small strains, as the constant volumes and porosity "
           "assume), large (at their current positions: moving-point MPM; the implicit scheme: "
           "the large-strain column, updated Lagrangian; dynamic: the body "
           "flows across a grid larger than itself under gravity, updated Lagrangian, "
           "Hencky's elasticity), auto (small)",
           MOVING, choices=("auto", "small", "large")),
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
    Option("small_strain_damping", "float", 0.0, "hyperbolic: the damping ratio below the "
           "hysteresis's reach, Rayleigh at f1 and 5 f1 of the small-strain column (0: the "
           "hysteresis alone)", (DYNAMIC,),
           lambda v: None if 0 <= v < 1 else "must lie in [0, 1)"),
    Option("linear_twin", "bool", True, "hyperbolic, under a base motion: also step the "
           "same deposit with its soil linear (its small-strain stiffness, the same damping "
           "and step) and report its surface PGA, PSA and peak strains beside", (DYNAMIC,)),
    Option("t_end", "float", 10.0, "end of the run (s)", (DYNAMIC,), checks.positive),
    Option("psa_damping", "float", 0.05, "the damping ratio of the pseudo-spectral "
           "accelerations' oscillators (-)", (DYNAMIC,),
           lambda v: None if 0 <= v < 1 else "must lie in [0, 1)"),
    Option("psa_periods", "floats", (0.01, 10.0, 100.0), "the periods of the pseudo-spectral "
           "accelerations: T_MIN,T_MAX,N, N periods log-spaced from T_MIN to T_MAX (s)",
           (DYNAMIC,), checks.psa_periods, length=3),
    # -- large deformation: -mpm_kinematics large in the dynamic analysis ------------------
    Option("grid_size", "floats", (), "large: the background grid W,H from the origin (m), "
           "the body at its origin, each a whole number of the body's cells (default: the "
           "body)", (DYNAMIC,), checks.all_positive, length=2),
    Option("shape", "str", "bspline", "large: grid functions: bspline (quadratic B-splines, "
           "smooth forces as points cross cells), gimp (uGIMP: the hat functions averaged "
           "over a point's share of its cell, smooth too) or linear (the hat functions of "
           "standard MPM)", (DYNAMIC,), choices=("linear", "gimp", "bspline")),
    Option("pic_viscosity", "float", 0.0, "large: the PIC share as a viscosity nu (m2/s): "
           "each step blends nu dt / h^2 of the grid's velocity into the points' (h the "
           "smaller cell side), the same dissipation on every grid, where -mpm_flip's share "
           "per step dissipates in proportion to the cell; 0: -mpm_flip", (DYNAMIC,),
           checks.nonnegative),
    Option("floor_friction", "float", 0.0, "large: Coulomb friction coefficient of the floor "
           "(with -mpm_bc_bottom y; xy holds the floor's points)", (DYNAMIC,),
           checks.nonnegative),
    Option("rest_energy", "float", 1e-4, "large: the run ends when the kinetic energy has "
           "fallen to this fraction of its peak (0: at -mpm_t_end)", (DYNAMIC,),
           lambda v: None if 0 <= v < 1 else "must lie in [0, 1)"),
    Option("experiment", "str", "none", "large: the experiment drawn and compared beside "
           "the result, of the scene's own column: none, bui-2008 (Bui et al. 2008: final "
           "free surface and failure line)", (DYNAMIC,), choices=("none", "bui-2008")),
    Option("record_depths", "floats", (), "depths below the surface of the recorded "
           "histories (m); the surface and the base always", (DYNAMIC,), checks.all_nonnegative),
    Option("record_dt", "float", 0.005, "time between recorded samples (s; the time step "
           "is a divisor of it)", (DYNAMIC,), checks.positive),
    # -- materials, soil tests and the static analysis ------------------------------------
    Option("material", "str_or_strs", "elastic", "the soil's model: elastic, tresca (undrained "
           "strength -mpm_cohesion, total stress), mohr-coulomb, drucker-prager (matched to "
           "Mohr-Coulomb in plane strain), mcc (Modified Cam Clay), hyperbolic (a multi-surface J2 "
           "soil in total stress: the hyperbolic backbone with Masing's hysteresis); "
           "consolidation: per layer",
           MATERIAL, choices=("elastic", "tresca", "mohr-coulomb", "drucker-prager", "mcc",
                              "hyperbolic")),
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
    Option("reference_strain", "float_or_floats", math.nan, "hyperbolic: the reference shear "
           "strain gamma_r (engineering) of the backbone tau = G gamma / (1 + gamma / "
           "gamma_r); consolidation: per layer", MATERIAL, checks.positive),
    Option("surfaces", "int", 25, "hyperbolic: the surfaces (elements) of the Iwan model, "
           "at least 6, over 1e-3 .. 1e2 gamma_r (the backbone exact at each decade, dense "
           "about gamma_r: 25 keep it within 0.5 %)", MATERIAL,
           lambda v: None if v >= 6 else "must be at least 6"),
    Option("soiltest", "str", "triaxial-drained", "the soil test", (SOILTEST,), choices=(
        "triaxial-drained", "triaxial-undrained", "plane-strain", "simple-shear", "oedometer",
        "simple-shear-cyclic")),
    Option("cycles", "int", 2, "simple-shear-cyclic: the full cycles of shear strain between "
           "+-strain_end after the first loading", (SOILTEST,), checks.at_least_one),
    Option("confining", "float", 100e3, "the soil test's initial isotropic effective stress, "
           "drained its cell pressure (Pa)", (SOILTEST,), checks.nonnegative),
    Option("strain_end", "float", 0.1, "the soil test's axial (simple shear: shear) strain "
           "at the end, compression positive; simple-shear-cyclic: the shear strain's "
           "amplitude", (SOILTEST,), checks.positive),
    Option("strain_steps", "int", 500, "soil test steps", (SOILTEST,), checks.at_least_one),
    Option("footing", "floats", (), "the rigid strip footing x0,x1 on the top (m; a half "
           "model: 0,B/2 with rollers on x = 0); dynamic large: pushed in at "
           "-mpm_footing_velocity", (STATIC, DYNAMIC), length=2),
    Option("footing_interface", "str", "smooth", "smooth (the footing holds the vertical "
           "displacement) or rough (both)", (STATIC, DYNAMIC), choices=("smooth", "rough")),
    Option("footing_settlement", "float", 0.01, "the footing's settlement at the end (m)",
           (STATIC, DYNAMIC), checks.positive),
    Option("footing_velocity", "float", 0.05, "dynamic large: the footing's speed (m/s), "
           "reached by a linear ramp over 20 (x1 - x0) / c_s (c_s the shear-wave speed)",
           (DYNAMIC,), checks.positive),
    Option("surcharge", "float", 0.0, "a pressure q0 on the top beside the footing or load "
           "(Pa), from the start", (STATIC,), checks.nonnegative),
    Option("load_steps", "int", 20, "equal settlement steps (each halved where Newton does "
           "not converge)", (STATIC,), checks.at_least_one),
    Option("bbar", "bool", True, "B-bar: each point's volume change its cell's (dynamic "
           "large: F-bar, the same at finite strain)", (STATIC, DYNAMIC)),
    Option("output", "str", "output", "folder for figures, fields and the summary"),
    Option("summary", "str", "", "JSON summary file (default: OUTPUT/summary.json)"),
    Option("figures", "bool", True, "write figures (in -mpm_figure_format)"),
    Option("figure_format", "str", "png", "formats of the figures, comma-separated: png, pdf, "
           "svg (e.g. png,pdf)", check=checks.figure_formats),
    Option("debug", "bool", False, "show the Python traceback of a failure"),
]

# The options the dynamic analysis reads with -mpm_kinematics large only, and those it does
# not read with it (the shaken or suddenly loaded body's, and what the flowing body lacks).
FLOWING_ONLY = ("gravity", "dt_safety", "damping", "flip", "pic_viscosity", "bbar",
                "grid_size", "shape", "floor_friction", "rest_energy", "experiment",
                "cohesion", "friction_angle", "dilation_angle", "tension_cutoff", "bc_left",
                "bc_right", "bc_bottom", "bc_top", "footing", "footing_interface",
                "footing_settlement", "footing_velocity")
NOT_FLOWING = ("phases", "base_motion", "base_motion_scale", "base_direction", "base",
               "rock_Vs", "rock_Vp", "rock_rho", "bc_sides", "rayleigh", "record_depths",
               "record_dt", "load", "load_extent", "layers", "K_l", "mu_l", "k", "drained",
               "jacobi_tol", "jacobi_max_sweeps", "element", "points", "mcc_M", "mcc_lambda",
               "mcc_kappa", "void_ratio", "mcc_ocr", "reference_strain", "surfaces",
               "psa_damping", "psa_periods", "small_strain_damping", "linear_twin")
