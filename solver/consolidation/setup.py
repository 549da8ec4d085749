"""The set-up of a consolidation run: the options checked against each other
(:func:`validate`), a target error's pick (:func:`target`), a restart's checkpoint and output
folder, the body, the monitor point, the time scheme with its critical time steps or graded
steps (:mod:`solver.consolidation.schedules`) and the references, as a
:class:`solver.consolidation.plan.Plan`, printed as it goes."""

from __future__ import annotations

import dataclasses
import math
import os

from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError
from ..io import checkpoint, memory, provenance, restart as restarts
from ..materials import catalog, history
from ..model import scene
from ..model.scene import Body, Loading
from ..model.soil import Ground, check_count
from ..references import static
from ..stepping import inertia
from ..stepping.scheme import Scheme, lateral_drainage_notes
from ..stepping.twophase import point_fields
from . import fe_reference, plan as plans, reporting, schedules, workprecision
from .implicit import choice
from .implicit.operators import projects
from .plan import Outputs, Plan, References
from .state import RunState, check_end


def validate(p) -> tuple:
    """InputError for options that contradict each other; returns the parameters to run
    (report times after the end dropped) and the notes to print."""
    H = p.size[1]
    notes = []
    if not math.isnan(p.monitor_height) and not 0 <= p.monitor_height <= H:
        raise InputError(f"-mpm_monitor_height {p.monitor_height}: outside the body "
                         f"(0 to {H} m)")
    if p.monitor and not math.isnan(p.monitor_height):
        raise InputError("-mpm_monitor_height: -mpm_monitor x,y places the monitor (give one)")
    if p.monitor and not (0 <= p.monitor[0] <= p.size[0] and 0 <= p.monitor[1] <= H):
        raise InputError(f"-mpm_monitor {p.monitor[0]:g},{p.monitor[1]:g}: outside the body "
                         f"(0 <= x <= {p.size[0]:g}, 0 <= y <= {H:g} m)")
    late = [t for t in p.Tv_report if t > p.Tv_end * (1 + 1e-12)]
    if late and "Tv_report" in p.given and "Tv_report" not in p.from_file:
        raise InputError(f"-mpm_Tv_report {late[0]}: after -mpm_Tv_end {p.Tv_end}")
    if late:
        # Report times of a scene file (or the defaults) after a shorter end: shortening a
        # run takes one option, -mpm_Tv_end.
        where = p.from_file.get("Tv_report", "the default")
        p = dataclasses.replace(p, Tv_report=tuple(t for t in p.Tv_report if t not in late)
                                or (p.Tv_end,))
        notes.append(f"-mpm_Tv_report ({where}): "
                     + ",".join(f"{t:g}" for t in late) + f" after -mpm_Tv_end {p.Tv_end:g} "
                     f"dropped; reporting at T_v = {','.join(f'{t:g}' for t in p.Tv_report)}")
    if p.rho_l == 0:
        raise InputError("-mpm_rho_l 0: consolidation needs pore water (rho_l > 0)")
    if p.load == 0 and p.gravity == 0:
        raise InputError("-mpm_load 0: with -mpm_gravity 0 nothing drives consolidation")
    geostatic = p.initial_state == "geostatic"
    if geostatic and p.gravity == 0:
        raise InputError("-mpm_initial_state geostatic: needs -mpm_gravity > 0 (without "
                         "gravity the state before the load is at rest already)")
    if geostatic and p.load == 0:
        raise InputError("-mpm_load 0: a column at rest under gravity (-mpm_initial_state "
                         "geostatic) without a load does not consolidate")
    if not geostatic and not math.isnan(p.K0):
        raise InputError("-mpm_K0: only with -mpm_initial_state geostatic")
    W = p.size[0]
    if p.load_extent and not 0 <= p.load_extent[0] < p.load_extent[1] <= W:
        raise InputError(f"-mpm_load_extent {p.load_extent[0]:g},{p.load_extent[1]:g}: "
                         f"outside the top (0 <= x0 < x1 <= {W:g} m)")
    Loading.from_options(p).check_extent(Body.from_options(p))
    if p.load != 0 and "y" in p.bc_top:
        # The support would carry the load: nothing would settle, and U_p = 1 would be read
        # as a finished consolidation.
        raise InputError(f"-mpm_bc_top {p.bc_top}: a top fixed vertically cannot carry "
                         f"-mpm_load {p.load:g} (use -mpm_bc_top none or x, or -mpm_load 0)")
    if "none" in p.drained and len(p.drained) > 1:
        raise InputError(f"-mpm_drained {','.join(p.drained)}: none means no drained side; "
                         "give it alone")
    choice.check(choice.Request.from_options(p))
    if p.scheme != "implicit":
        notes += lateral_drainage_notes(p.element, p.drained, p.pressure_projection)
    fe_reference.check_cells(p.fe_cells, p.layers, H)
    if p.work_precision and math.isnan(p.target_error):
        raise InputError("-mpm_work_precision: only used with -mpm_target_error")
    if not math.isnan(p.target_error) and not math.isnan(p.dt):
        raise InputError("-mpm_dt: -mpm_target_error picks the time step (leave one out)")
    ground = Ground.from_options(p)        # checks -mpm_layers and the per-layer values
    check_count("K0", p.K0, p.layers)
    recipe = catalog.Recipe.from_options(p)
    materials(recipe, ground)
    if "mcc" in recipe.names and not geostatic:
        raise InputError("-mpm_material mcc: needs -mpm_initial_state geostatic (Cam Clay's "
                         "stiffness and strength grow from the effective stress at rest)")
    return p, notes


def materials(recipe, ground):
    """One material per layer (each layer's E and nu), or None for linear elastic soil."""
    return None if recipe.elastic else recipe.per_layer(ground.soils)


def _linear_only(refs, recipe):
    """The references of a yielding soil: none (every one of them is linear elastic)."""
    why = (f"the soil yields (-mpm_material {','.join(recipe.names)}) and every reference "
           "here is linear elastic")
    return dataclasses.replace(refs, why=why, why_degree=why, drained=(), fe_why=why)


def set_up(p, comm, record, owned) -> tuple:
    """Everything before the first step, printed as it goes: the options' checks, a target
    error's pick, a restart's checkpoint and output folder (then ``record`` begins: from
    here on a failure writes the summary), the body (its PETSc objects on ``owned``, an
    ExitStack), the monitor point, the critical time steps and the schedule. Returns (the
    plan, the grid, the points, the run's state at its first step). The stage it is in goes
    to :mod:`solver.common.signals` (what an interruption names)."""
    # The options as read: what a restart takes up.
    recorded = checkpoint.recorded(provenance.options(p))
    signals.stage("set-up: the options' checks")
    p, notes = validate(p)
    for note in notes:
        PETSc.Sys.Print(f"Note: {note}", comm=comm)
    p, goal = target(p, comm)
    signature = checkpoint.signature(p)
    outputs = Outputs(p.output, p.summary or os.path.join(p.output, "summary.json"),
                      p.figures, p.figure_format)
    ckpt, run_id = checkpoint.take_up(p.restart, p.overwrite, signature, outputs, comm)
    options = provenance.options(p)
    record.begin(outputs, run_id, options)
    signals.stage("set-up: the time scheme and mass scaling")
    ground, body, loading = Ground.from_options(p), Body.from_options(p), Loading.from_options(p)
    soil = ground.as_material()
    recipe = catalog.Recipe.from_options(p)
    yielding = materials(recipe, ground)
    refs = References.of(soil, loading, body)
    if not recipe.elastic:
        refs = _linear_only(refs, recipe)
    if ckpt is not None:            # an end before the checkpoint: refused up front
        check_end(p.restart, ckpt.state, refs, p.Tv_end)
    scheme = Scheme.from_options(p, soil, min(p.Tv_report),
                                 inertia.slowest_period(comm, body, soil, loading),
                                 inertia.load_swings(comm, body, soil, loading))
    req = choice.Request.from_options(p)
    method = schedules.method(comm, req, soil, body, scheme, refs, ckpt and ckpt.state)
    fields = {**point_fields(scheme, ground.count > 1), **history.fields(recipe)}
    if ckpt is not None:
        restarts.check_fields(p.restart, ckpt.layout, fields)
    memory.check(body)             # a model that does not fit says so first
    if method == "explicit" and ckpt is None:
        inertia.check_feasible(req, scheme, soil, body)
    signals.stage("set-up: the body")
    grid, points = scene.two_phase_body(comm, body, soil, fields)
    owned.callback(scene.destroy, points, grid)
    if ckpt is not None:
        state = RunState.from_dict(ckpt.state, scheme.mass_scaling)
        scheme = scheme.with_mass_scaling(state.mass_scaling)
    else:
        state = RunState(mass_scaling=scheme.mass_scaling, method=method)
    monitor = _place_monitor(points, body, loading, p.monitor, p.monitor_height,
                             comm.tompi4py())
    if ckpt is not None:
        checkpoint.scatter(points, grid, ckpt, "x0" if scheme.kinematics == "small" else "x")
    elif loading.geostatic:
        scene.geostatic_state(points, body, soil, loading)
    if ckpt is None and yielding is not None:
        history.start(points, history.Layered(yielding, history.layer_of(points)))
    limits, schedule = schedules.limits_and_schedule(comm, req, method, (body, soil, scheme),
                                                     grid.h, state, ckpt is not None, refs)
    if not refs.available and not loading.self_weight and recipe.elastic:
        signals.stage("set-up: the static references")
        refs = dataclasses.replace(refs, static=static.settlements(comm, body, soil, loading))
    signals.stage("set-up: the FE reference")
    refs, probes = fe_reference.attach(comm, refs, (soil, body, loading), points, schedule,
                                       monitor, p.fe_reference, p.fe_cells)
    plan = Plan(soil=soil, body=body, loading=loading, scheme=scheme, schedule=schedule,
                refs=refs, limits=limits, outputs=outputs, monitor_height=monitor[1],
                run={"id": run_id, "options": recorded}, signature=signature,
                scene=workprecision.scene_signature(p), provenance=options,
                restart=p.restart, resumed_id=ckpt.run_id if ckpt else None, goal=goal,
                target_error=p.target_error, monitor_x=monitor[0], probes=probes,
                method=method, stabilize=projects(p.pressure_stabilization, p.element),
                materials=yielding, material=",".join(recipe.names))
    print_plan(comm, plan, points.n_global)
    return plan, grid, points, state


def target(p, comm) -> tuple:
    """(the options, the goal) of -mpm_target_error: the pick's options, printed, and what
    the summary says of it; (p, None) without one."""
    if math.isnan(p.target_error):
        return p, None
    given = {k: getattr(p, k) for k in workprecision.PICKED if k in p.given}
    scheme = {k: getattr(p, k) for k in workprecision.SCHEME_KEYS}
    choice, lines, measured_tv = workprecision.pick(workprecision.scene_signature(p), given,
                                                    p.target_error, p.work_precision, scheme)
    p = workprecision.apply(p, choice)
    PETSc.Sys.Print("\n".join(lines), comm=comm)
    return p, {"target_pct": p.target_error, "picked": {k: choice[k] for k in
                                                         workprecision.PICKED},
               "measured_pct": choice["measure"], "measured_tv": list(measured_tv),
               "why": lines}


def _place_monitor(points, body, loading, at, height, mpi) -> tuple:
    """Mark the monitor points (:func:`reporting.place_monitor`) at ``at`` (x, y) (m,
    -mpm_monitor) or at the ``height`` (m, -mpm_monitor_height); by default a column's row
    of points highest below mid-height, and in a scene without a closed form the point of
    that row nearest its axis under the load (:func:`plan.axis`). Returns their (x or
    NaN, y) (m)."""
    wanted_y, wanted_x = height, math.nan
    if at:
        wanted_x, wanted_y = at
    elif plans.no_reference(body, loading):
        wanted_x = plans.axis(body, loading)
    return reporting.place_monitor(points, body.height, wanted_y, wanted_x, mpi)


def print_plan(comm, plan, n_points):
    """The inertia warning, the run's banner and the scheme."""
    body, schedule, refs = plan.body, plan.schedule, plan.refs
    if plan.limits.warning:
        PETSc.Sys.Print(plan.limits.warning, comm=comm)
    if not refs.terzaghi:        # the paper's scenes: Terzaghi's, as Tables 4 and 5 say
        PETSc.Sys.Print(refs.describe(), comm=comm)
    t_end = refs.time(schedule.Tv_end)
    PETSc.Sys.Print(f"Consolidation: {body.element.upper()}, {body.cells[0]} x "
                    f"{body.cells[1]} cells, {n_points} material points, {comm.getSize()} "
                    f"rank(s); c_v = {refs.c_v:.4g} m2/s, T_v = {schedule.Tv_end} at t = "
                    f"{t_end:.4g} s: {_steps_words(plan)}; monitor "
                    f"{reporting.monitor_words(plan)}\n" + _scheme_words(plan), comm=comm)
    if body.element != "q4" and body.ppc < 3:
        # Measured on 1 x 20 cells (docs/studies.md): Q9 with 2 x 2 points was 10 % off
        # Terzaghi (0.4 % with 3 x 3); Q8's stable time step shrank a hundredfold.
        PETSc.Sys.Print(f"WARNING: {body.element.upper()} cells with {body.ppc} x {body.ppc} "
                        "points under-integrate the quadratic fields: use -mpm_ppc 3 or more",
                        comm=comm)


def _steps_words(plan) -> str:
    """'N steps of DT s' (explicit) or 'N steps graded from the load' (implicit)."""
    sched = plan.schedule
    if plan.method == "implicit":
        return f"{sched.nsteps} steps graded from the load, the first {sched.time(1):.3g} s"
    return f"{sched.nsteps} steps of {sched.dt:.4g} s"


def _scheme_words(plan) -> str:
    """The banner's line on the time scheme."""
    scheme, body = plan.scheme, plan.body
    if plan.method == "implicit":
        pair = "Q4/Q4" if body.element == "q4" else f"{body.element.upper()}/Q4 Taylor-Hood"
        return (f"Scheme: implicit quasi-static u-p, {pair}"
                + (", pressure projection (Dohrmann-Bochev)" if plan.stabilize else "")
                + ", TR-BDF2, LU (MUMPS)")
    return (f"Scheme: {scheme.kinematics} kinematics, lumping {scheme.lumping}, "
            f"liquid basis {scheme.liquid_basis}, pressure projection "
            f"{scheme.pressure_projection}, {scheme.drag} drag, mass scaling "
            f"S = {scheme.mass_scaling:.4g} ({scheme.mass_scaling_choice})"
            + (f", FLIP fraction {scheme.flip:g}" if scheme.flip != 1 else ""))
