"""Consolidation of a soil body (paper Section 5, Tables 1, 4, 5, Figs 3-5): set-up and steps.

:func:`run` reads the options once, in the set-up, and turns them into a
:class:`solver.consolidation.plan.Plan`: the soil, the body and its loading, the time scheme
and its steps (:mod:`solver.consolidation.schedules`: the explicit step's critical time
steps, or the implicit scheme's steps graded from the load), and the references. The time
loop then drives the explicit step (:mod:`solver.stepping.twophase`) or the
implicit scheme (:mod:`solver.consolidation.implicit.quasistatic`) from t = 0 to T_v =
``-mpm_Tv_end`` with a progress line and hands its results to
:mod:`solver.consolidation.reporting`, which compares the monitor point and whole profiles at
the report times with two analytic references:
- classic Terzaghi: p0 = q, c_v = k E_c / gamma_w (what the paper compares against);
- consistent Terzaghi: p0 = q (K_l/n) / (K_l/n + E_c), diffusivity c2 (compressible water),
  which isolates the numerical error.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time

import numpy as np
from petsc4py import PETSc

from ..common import clock, signals
from ..common.errors import InputError, Interrupted, NumericalError, agree_code, entry
from ..io import checkpoint, memory, output, provenance
from ..io.checkpoint import RunState
from ..io.failure import RunFailure
from ..model import scene
from ..model.scene import Body, Loading
from ..model.soil import Ground, check_count
from ..references import static
from . import fe_reference, plan as plans, reporting, schedules, settlement, workprecision
from ..stepping import inertia
from ..stepping.scheme import Scheme, lateral_drainage_notes
from ..stepping.twophase import TwoPhase, point_fields
from .implicit import choice
from .implicit.quasistatic import QuasiStatic
from .plan import Outputs, Plan, References


def _validate(p) -> tuple:
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
    Ground.from_options(p)        # checks -mpm_layers and the per-layer values
    check_count("K0", p.K0, p.layers)
    return p, notes


def run(p, comm) -> int:
    """Run the consolidation scene ``p``; returns 0.

    A run that fails after its set-up still writes its summary (``"completed": false`` and
    the ``error``): NumericalError (a blow-up) and Interrupted (a signal, after a
    checkpoint) as they arise; any other exception (a bug, or the machine: memory, disk)
    becomes an InternalError, with a checkpoint when the points and their records (reports,
    fields) agree at a step, i.e. after a failure in the reporting that follows it. Ranks
    agree on a failure in the reporting after the last step (where rank 0 writes alone),
    and on one rank; a failure inside the stepping of a parallel run on some ranks only
    leaves the others in a collective, and reaches the caller as it is (to abort MPI).
    The PETSc objects the run made are destroyed on the way out, after the failure
    handling (its checkpoint needs the points)."""
    ctx = RunFailure(comm)
    ctx.clock = clock.Phases()
    try:
        return _handled(comm, ctx, lambda: _run(_set_up(p, comm, ctx), comm, ctx))
    finally:
        scene.destroy(*reversed(ctx.owned))


def _handled(comm, ctx, work) -> int:
    """:func:`run`'s failure handling around ``work`` (:func:`_run`). A signal during the set-up (no
    step yet) writes the summary on rank 0 alone and stops there: ranks may be anywhere
    in its collectives; during the reporting after the last step the ranks agree on it
    as on any failure there, and a checkpoint keeps the whole run."""
    failure = None
    try:
        code = work()
    except (InputError, NumericalError, PETSc.Error):
        raise                  # every rank raises these alike, where they arise
    except Interrupted as exc:
        if exc.agreed:         # the time loop's, after its checkpoint and summary
            raise
        if ctx.phase != "reporting":
            raise ctx.record(comm, str(exc), code=4, stage=exc.stage, agreed=False) from None
        failure = exc
    except Exception as exc:   # noqa: BLE001  (what the solver did not foresee)
        failure = exc
    if ctx.phase == "reporting" or comm.getSize() == 1:
        message, kind = agree_code(comm, failure)   # every rank gets here, failed or not
        if message is None:
            return code
        raise ctx.record(comm, message, code=kind) from failure
    ctx.record(comm, None, failure)
    raise failure


def _run(setup, comm, ctx) -> int:
    """The run itself (see :func:`run`) after :func:`_set_up` (``setup``, what it
    returned): :func:`_time_loop` and :func:`_finish`; ``ctx`` follows it for the failure
    handler."""
    plan, grid, points, state, t_wall = setup
    signals.stage("set-up: the model and the summary")
    if plan.method == "implicit":
        model = QuasiStatic(grid, points, plan.soil, plan.body, plan.loading, plan.stabilize)
    else:
        model = TwoPhase(grid, points, plan.soil, plan.body, plan.loading, plan.scheme)
    ctx.owned.append(model)
    reports = reporting.Reporting(plan, grid, points, state, comm)
    # A blow-up overflows before the periodic check names it in one line; NumPy's warnings
    # would only precede that line on stderr.
    fp = np.seterr(over="ignore", invalid="ignore")
    summary = _summary(plan, points, state, comm)
    ctx.summary = summary
    ckpt_path = os.path.join(plan.outputs.folder, "checkpoint.npz")
    # After a failure a checkpoint holds the last step whose points, reports and fields are
    # all written: in practice a failure in the reporting after the last step.
    ctx.save = lambda step: checkpoint.write(
        ckpt_path, comm, points, dataclasses.replace(state, step=step).to_dict(),
        plan.signature, plan.run)
    ctx.ckpt_path, ctx.start, ctx.whole = ckpt_path, state.step, state.step
    ctx.cleanup = [lambda: np.seterr(**fp)]
    # While stepping a signal only marks itself: the loop stops after the step, where the
    # ranks agree and the points hold a whole state for the checkpoint.
    ctx.clock.mark("set-up")
    with signals.deferred("stepping") as stop:
        ctx.phase = "stepping"
        pace = _time_loop(plan, model, reports, state, stop, comm, ctx, t_wall)
    if plan.method == "implicit":
        summary["implicit"] = model.summary()
    ctx.clock.mark("stepping")
    np.seterr(**fp)
    signals.stage("reporting")
    ctx.phase, ctx.cleanup = "reporting", []   # no collective from here on: ranks can agree
    return _finish(plan, reports, state, summary, pace, comm, (t_wall, ctx.clock))


def _set_up(p, comm, ctx) -> tuple:
    """Everything before the first step, printed as it goes: the options' checks, a target
    error's pick, a restart's checkpoint and output folder, the body (owned by ``ctx``),
    the monitor point, the critical time steps and the schedule. Returns (the plan, the
    grid, the points, the run's state at its first step, the wall clock at the set-up
    proper). The stage it is in goes to :mod:`solver.common.signals` (what an interruption
    names)."""
    recorded = checkpoint.recorded(p)      # the options as read: what a restart takes up
    signals.stage("set-up: the options' checks")
    p, notes = _validate(p)
    for note in notes:
        PETSc.Sys.Print(f"Note: {note}", comm=comm)
    p, goal = _target(p, comm)
    signature = checkpoint.signature(p)
    summary_path = p.summary or os.path.join(p.output, "summary.json")
    restart = checkpoint.read(p.restart, signature) if p.restart else None
    run_id = restart[3] if restart and restart[3] else checkpoint.new_run_id(comm)
    if restart is not None and not p.overwrite:
        # Before anything is computed or written: a restart never writes over another
        # run's results, not even a stopped run's summary.
        checkpoint.check_folder(p.output, summary_path, p.restart, restart[3], comm)
    options = provenance.options(p)
    ctx.begin(summary_path, run_id, options)
    signals.stage("set-up: the time scheme and mass scaling")
    ground, body, loading = Ground.from_options(p), Body.from_options(p), Loading.from_options(p)
    soil = ground.as_material()
    refs = References.of(soil, loading, body)
    if restart is not None:            # an end before the checkpoint: refused up front
        checkpoint.check_end(p.restart, restart[2], refs, p.Tv_end)
    scheme = Scheme.from_options(p, soil, min(p.Tv_report),
                                 inertia.slowest_period(comm, body, soil, loading))
    req = choice.Request.from_options(p)
    method = schedules.method(comm, req, soil, body, scheme, refs, restart and restart[2])
    fields = point_fields(scheme, ground.count > 1)
    if restart is not None:
        checkpoint.check_fields(p.restart, restart[1], fields)
    memory.check(body)             # a model that does not fit says so first
    if method == "explicit":
        inertia.check_feasible(p, scheme, soil, body)
    t_wall = time.perf_counter()
    signals.stage("set-up: the body")
    grid, points = scene.two_phase_body(comm, body, soil, fields)
    ctx.owned += [grid, points]
    if restart is not None:
        state = RunState.from_dict(restart[2], scheme.mass_scaling)
        scheme = scheme.with_mass_scaling(state.mass_scaling)
    else:
        state = RunState(mass_scaling=scheme.mass_scaling, method=method)
    monitor = _place_monitor(points, body, loading, p.monitor, p.monitor_height,
                             comm.tompi4py())
    if restart is not None:
        checkpoint.scatter(points, grid, restart[0], restart[1],
                           "x0" if scheme.kinematics == "small" else "x")
    elif loading.geostatic:
        scene.geostatic_state(points, body, soil, loading)
    limits, schedule = schedules.limits_and_schedule(comm, req, method, (body, soil, scheme),
                                                     grid.h, state, restart is not None, refs)
    if not refs.available and not loading.self_weight:
        signals.stage("set-up: the static references")
        refs = dataclasses.replace(refs, static=static.settlements(comm, body, soil, loading))
    signals.stage("set-up: the FE reference")
    refs, probes = fe_reference.attach(comm, refs, (soil, body, loading), points, schedule,
                                       monitor, p.fe_reference, p.fe_cells)
    plan = Plan(soil=soil, body=body, loading=loading, scheme=scheme, schedule=schedule,
                refs=refs, limits=limits,
                outputs=Outputs(p.output, summary_path, p.figures, p.figure_format),
                monitor_height=monitor[1], run={"id": run_id, "options": recorded},
                signature=signature, scene=workprecision.scene_signature(p),
                provenance=options, restart=p.restart,
                resumed_id=restart[3] if restart else None, goal=goal,
                target_error=p.target_error, monitor_x=monitor[0], probes=probes,
                method=method, stabilize=p.pressure_stabilization != "none")
    _print_plan(comm, plan, points.n_global)
    return plan, grid, points, state, t_wall


def _target(p, comm) -> tuple:
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


def _print_plan(comm, plan, n_points):
    """The inertia warning, the run's banner and the scheme."""
    body, scheme, schedule, refs = plan.body, plan.scheme, plan.schedule, plan.refs
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


def _summary(plan, points, state, comm) -> dict:
    """The summary before the first step (collective: the provenance)."""
    body, scheme, limits, refs = plan.body, plan.scheme, plan.limits, plan.refs
    summary = {"analysis": "consolidation", "scheme": plan.method, "ranks": comm.getSize(),
               "element": body.element,
               "cells": list(body.cells), "ppc": body.ppc, "n_points": points.n_global,
               "steps": 0, "dt": state.dt, "wall_seconds": 0.0, "stable": True,
               "dt_critical": limits.steps, "dt_governing": limits.governing,
               "dt_exceeds": list(limits.exceeded), **scheme.summary(),
               "damping": scheme.damping, "bulk_viscosity": scheme.bulk_viscosity,
               "fast_damping": scheme.fast_damping, "flip": scheme.flip, "f1_hz": limits.f1,
               "c_v": refs.c_v, "c2": refs.c2, "p0_consistent_over_q": refs.p0,
               "regime": limits.regime, "reference": refs.summary(),
               **_layers(plan.soil),
               "scene": plan.scene, "run_id": plan.run["id"],
               "provenance": provenance.collect(comm, plan.provenance)}
    if limits.warning:
        summary["warnings"] = [limits.warning]
    if plan.goal is not None:
        summary["target"] = plan.goal
    return summary


def _layers(soil) -> dict:
    """The summary's layers (thickness in m and the soil of each, from the surface down),
    for layered ground; nothing for one soil."""
    if len(soil.soils) == 1:
        return {}
    return {"layers": [{"thickness_m": t, **dataclasses.asdict(s)}
                       for t, s in zip(soil.thickness, soil.soils)]}


def _time_loop(plan, model, reports, state, stop, comm, ctx, t_wall):
    """The explicit steps after the state's step to the last: step, check, hand the
    results to ``reports`` at its steps, checkpoint, stop on a signal, print progress;
    returns the -mpm_target_error pace (or None). A NumericalError or Interrupted writes
    the summary so far (rank 0) and is raised on."""
    sched, scheme, loading = plan.schedule, plan.scheme, plan.loading
    dt, nsteps, points = sched.dt, sched.nsteps, reports.points
    implicit = plan.method == "implicit"
    if implicit:
        advance = lambda k: model.step(sched.time(k - 1), sched.time(k))  # noqa: E731
        if state.step == 0:
            model.start()              # the undrained state at t = 0+
        else:
            model.restore(state.nodal)
    else:
        advance = lambda k: model.step(dt, loading.factor(sched.time(k - 1)),  # noqa: E731
                                       scheme.damping, scheme.flip)
    scale = max(plan.refs.q, plan.soil.density * loading.gravity * plan.body.height, 1.0)
    ckpt_path = ctx.ckpt_path
    first = state.step + 1
    k = first - 1
    last_print = last_ckpt = time.perf_counter()
    # The estimate of the time left counts the steps only, not the set-up before them.
    t_steps = time.perf_counter()
    pace = workprecision.Pace(first, nsteps, t_steps) if plan.goal else None
    try:
        # The stage is popped however the loop ends (the handlers in _run run after it).
        with PETSc.Log.Stage("Implicit steps" if implicit else "Explicit steps"):
            for k in range(first, nsteps + 1):
                t = sched.time(k)
                ctx.whole = None         # mid-step: points and records disagree until the end
                advance(k)
                due = int(sched.checkpoint_seconds > 0 and comm.getRank() == 0
                          and time.perf_counter() - last_ckpt > sched.checkpoint_seconds)
                signal_seen, due = model.migrate_if_needed((stop.seen, due))
                if k % 50 == 0 or k == nsteps or k in sched.iso_steps:
                    model.check(k, t, scale)
                if k % sched.sample_every == 0 or k in sched.iso_steps:
                    reports.sample(t)
                if k in sched.iso_steps:
                    reports.isochrone(k, t)
                if (sched.output_every and k % sched.output_every == 0) \
                        or k in sched.report_steps or k == nsteps:  # the last state too
                    reports.write_fields(k, t)
                state.step = k           # the records are those of step k from here on
                if (signal_seen or due
                        or (sched.checkpoint_every and k % sched.checkpoint_every == 0)):
                    if implicit:
                        state.nodal = model.state()
                    checkpoint.write(ckpt_path, comm, points, state.to_dict(), plan.signature,
                                     plan.run)
                    last_ckpt = time.perf_counter()
                if signal_seen:
                    raise Interrupted(f"stopped by {stop.name} at step {k} (t = {t:.6g} s); "
                                      f"checkpoint {ckpt_path}; continue with "
                                      f"-mpm_restart {ckpt_path}", stage="stepping",
                                      agreed=True)
                said = pace and pace.tick(k, time.perf_counter())
                if said:
                    PETSc.Sys.Print(said, comm=comm)
                if sched.progress and time.perf_counter() - last_print > sched.progress:
                    last_print = time.perf_counter()
                    PETSc.Sys.Print(_progress(plan, state, k, last_print, t_steps, first,
                                              t_wall), comm=comm)
                ctx.whole = k
        if implicit:
            state.nodal = model.state()    # for a checkpoint after a failure in the reporting
    except (NumericalError, Interrupted) as exc:
        for undo in ctx.cleanup:       # NumPy's FP settings
            undo()
        blew_up = isinstance(exc, NumericalError)
        ctx.summary.update(stable=not blew_up, interrupted=not blew_up, steps=k,
                           failure=str(exc), wall_seconds=time.perf_counter() - t_wall,
                           completed=False, error=entry(str(exc), exc.exit_code, "stepping"))
        if comm.getRank() == 0:
            output.write_json(ctx.summary_path,
                              dict(ctx.summary, files={"summary": ctx.summary_path}))
        raise
    return pace


def _progress(plan, state, k, now, t_steps, first, t_wall) -> str:
    """The progress line at step ``k``, ``now`` (perf_counter)."""
    nsteps, history, t = plan.schedule.nsteps, state.history, plan.schedule.time(k)
    return (f"  step {k}/{nsteps} ({100 * k / nsteps:.0f} %), "
            f"t = {t:.4g} s, T_v = {plan.refs.time_factor(t):.4f}, p/q(monitor) = "
            f"{history[-1][2] if history else float('nan'):.4f}, "
            f"{now - t_wall:.0f} s elapsed, about "
            f"{(now - t_steps) / (k - first + 1) * (nsteps - k):.0f} s left")


def _finish(plan, reports, state, summary, pace, comm, clocks) -> int:
    """The reporting after the last step: the summary's results, the tables, the target
    error's check; the output files and the summary (rank 0); the wall time of the run's
    phases. ``clocks``: (the perf_counter of the set-up proper, the run's
    :class:`clock.Phases`)."""
    t_wall, phases = clocks
    records, summary_path = state.reports, plan.outputs.summary
    summary["steps"] = plan.schedule.nsteps
    if "implicit" in summary:
        _implicit_line(comm, summary["implicit"])
    summary["completed"] = True
    summary["wall_seconds"] = time.perf_counter() - t_wall
    summary["monitor"] = {"height": plan.monitor_height,
                          **({} if math.isnan(plan.monitor_x) else {"x": plan.monitor_x}),
                          **{key: [r[key] for r in records] for key in (
                              "Tv", "p_over_q", "terzaghi", "error_pct", "consistent",
                              "error_consistent_pct") if not records or key in records[0]}}
    if plan.refs.available:
        summary["profile_l2"] = {"Tv": [r["Tv"] for r in records],
                                 "terzaghi": [r["l2_terzaghi"] for r in records],
                                 "consistent": [r["l2_consistent"] for r in records]}
    summary["consolidation_degree"] = reports.surface.summary(state.degree)
    reporting.print_reports(comm, records, plan.refs, reporting.monitor_words(plan))
    fe = reporting.print_fe(comm, plan, state)
    if fe is not None:
        summary["fe_reference"] = fe
    settlement.print_degree(comm, state.degree, reports.surface)
    if plan.refs.static:
        summary["static_references"] = settlement.print_ends(
            comm, state.degree, plan.refs.static, reports.surface.extent)
    if plan.goal is not None:
        _target_verdict(plan, summary, pace, comm)
    last = reports.series.last()          # rank 0's: it writes the series
    if last is not None:
        summary["fields"] = {"times": len(reports.series.entries), "last_step": last[0],
                             "last_t_s": last[1]}
        PETSc.Sys.Print(f"Point fields: {summary['fields']['times']} time(s) in "
                        f"{reports.series.xdmf}, the last at t = {last[1]:.6g} s "
                        f"(step {last[0]} of {plan.schedule.nsteps})", comm=comm)
    files = reports.files
    files["summary"] = summary_path
    if comm.getRank() == 0:
        series = reports.series.files()
        if series:
            files["fields_xdmf"], files["fields_h5"] = series[0], series[1:]
        files.update(reporting.write_files(plan, state.profiles, state.history))
        files.update(settlement.write_files(plan.outputs, reports.surface, state.settlement,
                                            plan.refs, plan.schedule.Tv_end,
                                            reporting.title(plan), state.troughs))
    phases.mark("reporting")
    summary["wall"] = {f"{phase.replace('-', '')}_s": s
                       for phase, s in phases.seconds().items()}
    if comm.getRank() == 0:
        output.write_json(summary_path, dict(summary, files=files))
    PETSc.Sys.Print(output.results_line(plan.outputs.folder, files), comm=comm)
    PETSc.Sys.Print(f"{phases.line()}; summary {summary_path}", comm=comm)
    return 0


def _implicit_line(comm, counts):
    """The implicit scheme's steps, factorizations and solve time (the summary's
    ``implicit`` block), printed."""
    PETSc.Sys.Print(f"Implicit scheme: {counts['steps']} steps, {counts['factorizations']} LU "
                    f"factorizations ({counts['factor_seconds']:.3g} s), {counts['solves']} "
                    f"solves ({counts['solve_seconds']:.3g} s)", comm=comm)


def _target_verdict(plan, summary, pace, comm):
    """-mpm_target_error's check of the finished run: met only when every error it reports
    is within the target; with the stepping time beside the prediction (rank 0's)."""
    goal, target = plan.goal, plan.target_error
    goal["achieved_pct"] = workprecision.measure(summary)
    goal["errors_pct"] = {k: {"error_pct": e, "Tv": tv}
                          for k, (e, tv) in workprecision.errors(summary).items()}
    goal["met"], said = workprecision.verdict(summary, target, goal["measured_tv"])
    if pace is not None and pace.predicted is not None:
        goal["stepping_seconds"] = time.perf_counter() - pace.t0
        goal["predicted_seconds"] = pace.predicted
        said += (f"; stepping took {goal['stepping_seconds']:.3g} s (predicted "
                 f"{pace.predicted:.3g} s)")
    PETSc.Sys.Print(f"Target error {target:g} %: {said}", comm=comm)

