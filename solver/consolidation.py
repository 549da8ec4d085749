"""One-dimensional consolidation of the soil column (paper Section 5, Tables 1, 4, 5, Figs 3-5).

Drives :mod:`solver.twophase` from t = 0 to T_v = ``-mpm_Tv_end``: critical time steps first
(:mod:`solver.timestep`, with the fundamental frequency from :mod:`solver.eigen`), then the
explicit steps with a progress line, the monitor point and whole profiles compared at the
report times with two analytic references:
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

from . import (analytic, assembly, checkpoint, eigen, figures, inertia, jacobi, memory,
               output, provenance, scene, settlement, shapes, signals, timestep,
               workprecision)
from .errors import InputError, Interrupted, NumericalError, agree_code, entry
from .failure import RunFailure
from .fields import PointSeries
from .twophase import TwoPhase

MAX_STEPS = 1e8   # steps of a run that finishes (about a day at 1 ms per step)
ISOCHRONES = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0)


def _validate(p) -> tuple:
    """InputError for options that contradict each other; returns the parameters to run
    (report times after the end dropped) and the notes to print."""
    H = p.size[1]
    notes = []
    if not math.isnan(p.monitor_height) and not 0 <= p.monitor_height <= H:
        raise InputError(f"-mpm_monitor_height {p.monitor_height}: outside the body "
                         f"(0 to {H} m)")
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
    if p.load == 0 and p.gravity == 0:
        raise InputError("-mpm_load 0: with -mpm_gravity 0 nothing drives consolidation")
    if p.load != 0 and "y" in p.bc_top:
        # The support would carry the load: nothing would settle, and U_p = 1 would be read
        # as a finished consolidation.
        raise InputError(f"-mpm_bc_top {p.bc_top}: a top fixed vertically cannot carry "
                         f"-mpm_load {p.load:g} (use -mpm_bc_top none or x, or -mpm_load 0)")
    _check_lateral_drainage(p)
    if p.work_precision and math.isnan(p.target_error):
        raise InputError("-mpm_work_precision: only used with -mpm_target_error")
    if not math.isnan(p.target_error) and not math.isnan(p.dt):
        raise InputError("-mpm_dt: -mpm_target_error picks the time step (leave one out)")
    return p, notes


def _check_lateral_drainage(p):
    """InputError for quadratic cells drained through a side: water flowing across the
    column excites a pressure mode inside each cell that the discrete gradient does not see
    (the points' pressures alternate within a cell and never drain). Measured on a 1.2 m
    block drained left and right, 8 x 8 cells (the node spacing of Q4 16 x 16): Q9 +5 / -9 %
    of q in every cell at T_v = 0.5, 10-15 % off Q4 16 x 16; Q8 likewise (7-25 %); the
    nodal projection leaves Q9 +-3 % and blows Q8 up; Q4 converges (docs/method.md)."""
    lateral = [side for side in ("left", "right") if side in p.drained]
    if p.element != "q4" and lateral:
        raise InputError(
            f"-mpm_element {p.element}: quadratic cells drained through a side (-mpm_drained "
            f"{','.join(p.drained)}) keep a spurious pressure mode in every cell (10-15 % of q "
            "off; docs/method.md); use q4")


def load_scale(p) -> float:
    """The pressure that normalises p (Pa): the surface load q, or without one the weight
    of the column per unit area, rho_m g H."""
    return p.load if p.load > 0 else scene.mixture_density(p) * p.gravity * p.size[1]


def references(p):
    """Scales of both analytic references: (c_v, c2, p0_consistent / q)."""
    E_c = assembly.constrained_modulus(p.E, p.nu)
    gw = timestep.unit_weight(p)
    cv = analytic.consolidation_coefficient(p.k, E_c, gw)
    c2 = analytic.consistent_coefficient(p.k, E_c, gw, p.K_l, p.porosity)
    return cv, c2, analytic.undrained_pressure(1.0, E_c, p.K_l, p.porosity)


# f1 by SLEPc above this: Jacobi's dense sweeps grow as n^3 (M3-Q4's 320 DOFs 1 s, Q4
# 8 x 80's 1,280 DOFs 22 s, SLEPc 0.1 s); the paper's scenes up to M3-Q4 keep Jacobi's f1.
JACOBI_MAX_DOFS = 400


F1_MAX_DOFS = 20000   # f1 on a coarser grid above this: the shift-invert LU grows fast


def f1_cells(p) -> tuple:
    """The cells of the eigen model that gives f1: the scene's, or coarsened by a whole
    factor in both directions to at most F1_MAX_DOFS DOFs. f1 of the column converges fast
    (M1-Q4 column: 16.89343 Hz on 25 x 625 cells, 16.89343 on 100 x 2500, whose solve
    needs 2.2 GB and 21 s for that sixth digit)."""
    factor = 1
    while 2 * shapes.lattice_nodes(p.element, [c // factor for c in p.cells]) > F1_MAX_DOFS \
            and min(p.cells) // (factor + 1) >= 1:
        factor += 1
    return tuple(max(1, c // factor) for c in p.cells)


def fundamental_frequency(comm, p) -> float:
    """f1 (Hz) of the same scene's eigen model (saturated density), for dt_crit,3, on
    :func:`f1_cells`. A SLEPc solve takes its options under the prefix ``f1_``
    (``-f1_eps_view``), apart from an eigen analysis's ``-eps_*``."""
    p = dataclasses.replace(p, cells=f1_cells(p))
    made = scene.build(comm, p)
    _, _, K, M, _ = made
    try:
        if p.eigen_solver[0] == "jacobi" and K.getSize()[0] <= JACOBI_MAX_DOFS:
            res = jacobi.solve(K, M, 1, p.jacobi_tol, p.jacobi_max_sweeps)
            lam, vectors = res.eigenvalues[0], res.vectors
        else:
            res = eigen.slepc_solve(K, M, 1, prefix="f1_")
            lam, vectors = res.values[0], res.vectors
        scene.destroy(*vectors)
    finally:
        scene.destroy(*reversed(made))
    return float(eigen.frequencies([lam])[0])


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
    try:
        return _handled(p, comm, ctx)
    finally:
        scene.destroy(*reversed(ctx.owned))


def _handled(p, comm, ctx) -> int:
    """:func:`run`'s failure handling around :func:`_run`. A signal during the set-up (no
    step yet) writes the summary on rank 0 alone and stops there: ranks may be anywhere
    in its collectives; during the reporting after the last step the ranks agree on it
    as on any failure there, and a checkpoint keeps the whole run."""
    failure = None
    try:
        code = _run(p, comm, ctx)
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


def _run(p, comm, ctx) -> int:
    """The run itself (see :func:`run`): :func:`_set_up`, :func:`_time_loop` and
    :func:`_finish`; ``ctx`` follows it for the failure handler."""
    recorded = checkpoint.recorded(p)      # the options as read: what a restart takes up
    s = _set_up(p, comm, ctx)
    s.run["options"] = recorded
    p = s.p
    signals.stage("set-up: the model and the summary")
    model = TwoPhase(s.grid, s.points, p, scene.boundary_conditions(p), s.scheme)
    ctx.owned.append(model)
    reporting = _Reporting(s, comm)
    # A blow-up overflows before the periodic check names it in one line; NumPy's warnings
    # would only precede that line on stderr.
    fp = np.seterr(over="ignore", invalid="ignore")
    summary = _summary(s, comm)
    ctx.summary = summary
    state, ckpt_path = s.state, os.path.join(p.output, "checkpoint.npz")
    # After a failure a checkpoint holds the last step whose points, reports and fields are
    # all written: in practice a failure in the reporting after the last step.
    ctx.save = lambda step: checkpoint.write(
        ckpt_path, comm, s.points, dataclasses.replace(state, step=step).to_dict(), p, s.run)
    ctx.ckpt_path, ctx.start, ctx.whole = ckpt_path, state.step, state.step
    ctx.cleanup = [lambda: np.seterr(**fp)]
    # While stepping a signal only marks itself: the loop stops after the step, where the
    # ranks agree and the points hold a whole state for the checkpoint.
    with signals.deferred("stepping") as stop:
        ctx.phase = "stepping"
        _time_loop(s, model, reporting, stop, ckpt_path, comm, ctx)
    np.seterr(**fp)
    signals.stage("reporting")
    ctx.phase, ctx.cleanup = "reporting", []   # no collective from here on: ranks can agree
    return _finish(s, reporting, summary, comm)


@dataclasses.dataclass
class RunState:
    """The state of a run besides its points: exactly what a checkpoint stores
    (:meth:`to_dict`, the ``state`` of :func:`checkpoint.write`) and a restart loads
    (:meth:`from_dict`). ``step`` is the last step whose points and records agree."""

    step: int = 0
    dt: float = math.nan
    mass_scaling: float = 1.0
    history: list = dataclasses.field(default_factory=list)     # (t, Tv, p/q at the monitor)
    reports: list = dataclasses.field(default_factory=list)     # report() at the report times
    profiles: list = dataclasses.field(default_factory=list)    # (Tv, t, profile()), rank 0
    series: list = dataclasses.field(default_factory=list)      # the field series' entries
    settlement: list = dataclasses.field(default_factory=list)  # (t, Tv, s (m), mean p (Pa))
    degree: list = dataclasses.field(default_factory=list)      # degree of consolidation

    def to_dict(self) -> dict:
        """The state as a checkpoint stores it (JSON after :func:`output._jsonable`)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, st: dict, mass_scaling: float) -> "RunState":
        """The state of a checkpoint's ``st``; ``mass_scaling`` where it holds none (auto
        depends on the earliest report time, which a restart may change: a restart keeps
        the factor the run started with)."""
        return cls(step=st["step"], dt=st["dt"],
                   mass_scaling=st.get("mass_scaling", mass_scaling),
                   history=[tuple(h) for h in st["history"]], reports=st["reports"],
                   profiles=[(a, b, np.array(c)) for a, b, c in st["profiles"]],
                   series=st["series"], settlement=[tuple(r) for r in st.get("settlement", [])],
                   degree=st.get("degree", []))


@dataclasses.dataclass
class Setup:
    """What the time loop and the reporting need from :func:`_set_up`."""

    p: object                  # the options, as validated (and as a target error picked)
    scheme: dict               # assembly.step_scheme, with the run's mass scaling
    goal: dict | None          # the target error's pick, or None
    t_wall: float              # when the set-up proper started (perf_counter)
    grid: object
    points: object
    state: RunState            # at the first step: a fresh run's, or a restart's
    run: dict                  # {"id": the run's id, "options": checkpoint.recorded}
    restarted: bool = False
    resumed_id: str | None = None   # the run id a restart's checkpoint holds (None: older)
    monitor_height: float = math.nan
    f1: float = math.nan
    limits: dict = dataclasses.field(default_factory=dict)    # critical time steps (s)
    smallest: str = ""
    exceeded: list = dataclasses.field(default_factory=list)
    regime: dict = dataclasses.field(default_factory=dict)
    warn: str = ""
    cv: float = math.nan
    c2: float = math.nan
    p0: float = math.nan
    nsteps: int = 0
    report_steps: dict = dataclasses.field(default_factory=dict)   # step: Tv
    iso_steps: dict = dataclasses.field(default_factory=dict)      # step: Tv

    @property
    def dt(self) -> float:
        return self.state.dt


def _set_up(p, comm, ctx) -> Setup:
    """Everything before the first step, printed as it goes: the options' checks, a target
    error's pick, a restart's checkpoint and output folder, the body (owned by ``ctx``),
    the monitor point, the critical time steps and the step counts. The stage it is in
    goes to :mod:`solver.signals` (what an interruption names)."""
    signals.stage("set-up: the options' checks")
    p, notes = _validate(p)
    for note in notes:
        PETSc.Sys.Print(f"Note: {note}", comm=comm)
    p, goal = _target(p, comm)
    restart = checkpoint.read(p.restart, p) if p.restart else None
    run_id = restart[3] if restart and restart[3] else checkpoint.new_run_id(comm)
    if restart is not None:
        # Before anything is computed or written: a restart never writes over another
        # run's results, not even a stopped run's summary.
        checkpoint.check_folder(p, restart[3], comm)
    ctx.begin(p, run_id)
    signals.stage("set-up: the time scheme and mass scaling")
    scheme = assembly.step_scheme(p)
    memory.check(p, comm)          # a model that does not fit says so first
    _check_feasible(p, scheme)
    t_wall = time.perf_counter()
    signals.stage("set-up: the body")
    grid, points = scene.two_phase_body(comm, p)
    ctx.owned += [grid, points]
    if restart is not None:
        state = RunState.from_dict(restart[2], scheme["mass_scaling"])
        scheme["mass_scaling"] = state.mass_scaling
    else:
        state = RunState(mass_scaling=scheme["mass_scaling"])
    s = Setup(p, scheme, goal, t_wall, grid, points, state, {"id": run_id, "options": {}},
              restarted=restart is not None, resumed_id=restart and restart[3])
    s.monitor_height = _monitor_height(points, p, comm.tompi4py())
    if restart is not None:
        checkpoint.scatter(points, grid, restart[0], restart[1],
                           "x0" if scheme["kinematics"] == "small" else "x")
    _time_step(s, comm)
    signals.stage("set-up: the step counts")
    _plan(s, comm)
    return s


def _target(p, comm) -> tuple:
    """(the options, the goal) of -mpm_target_error: the pick's options, printed, and what
    the summary says of it; (p, None) without one."""
    if math.isnan(p.target_error):
        return p, None
    choice, lines, measured_tv = workprecision.pick(p, p.target_error, p.work_precision)
    p = workprecision.apply(p, choice)
    PETSc.Sys.Print("\n".join(lines), comm=comm)
    return p, {"target_pct": p.target_error, "picked": {k: choice[k] for k in
                                                         workprecision.PICKED},
               "measured_pct": choice["measure"], "measured_tv": list(measured_tv),
               "why": lines}


def _monitor_height(points, p, mpi) -> float:
    """Mark the monitor points (the row nearest -mpm_monitor_height, or the highest below
    mid-height) in the field ``monitor``; returns their height y0 (collective)."""
    from mpi4py import MPI

    H = p.size[1]
    with points.fields("x0", "monitor") as (x0, mon):
        y0 = x0[:, 1]
        if math.isnan(p.monitor_height):
            below = y0[y0 < H / 2 - 1e-12 * H]
            target = mpi.allreduce(float(below.max()) if below.size else -np.inf, op=MPI.MAX)
        else:
            near = y0[np.argmin(np.abs(y0 - p.monitor_height))] if y0.size else np.inf
            dist = mpi.allreduce(abs(near - p.monitor_height), op=MPI.MIN)
            cand = near if abs(abs(near - p.monitor_height) - dist) < 1e-12 * H else -np.inf
            target = mpi.allreduce(cand, op=MPI.MAX)
        mon[:] = np.abs(y0 - target) < 1e-9 * H
    return float(target)


def _critical_steps(s, comm) -> tuple:
    """(f1, the critical time steps, the patch of the stability analysis), in the log
    stage "Critical time steps"."""
    p, S = s.p, s.state.mass_scaling
    with PETSc.Log.Stage("Critical time steps"):
        signals.stage("set-up: the fundamental frequency f1")
        try:
            f1 = fundamental_frequency(comm, p)
        except NumericalError as exc:
            # f1 only feeds the spring-mass criterion, which does not bound stability (see
            # docs/studies.md); a singular consistent mass (1 point per Q4 cell) is no
            # reason to refuse the run, whose lumped masses are positive.
            PETSc.Sys.Print(f"Note: no fundamental frequency, hence no oscillator "
                            f"criterion: {exc}", comm=comm)
            f1 = math.nan
        if p.stability_analysis:
            # A dense eigenvalue analysis: on large grids the longest part of the set-up.
            cells = timestep.analysis_cells(p)
            signals.stage("set-up: the stability analysis")
            PETSc.Sys.Print(f"Stability analysis of the step on {cells[0]} x {cells[1]} "
                            "cells ...", comm=comm)
            t_analysis = time.perf_counter()
            dt_discrete, patch = timestep.discrete_limit(comm, p, s.scheme)
            PETSc.Sys.Print(f"Stability analysis took {time.perf_counter() - t_analysis:.1f}"
                            " s", comm=comm)
        else:
            dt_discrete, patch = math.nan, p.cells
        limits = timestep.criteria(p, f1, dt_discrete, s.grid.h, S)
        limits = {k: v for k, v in limits.items() if not math.isnan(v)}
    return f1, limits, patch


def _time_step(s, comm):
    """The critical time steps (printed) and the step dt (a restart's own), into ``s``;
    InputError for a step far beyond the stability limit, a warning for one beyond any."""
    p, scheme, S = s.p, s.scheme, s.state.mass_scaling
    s.f1, limits, patch = _critical_steps(s, comm)
    smallest = _governing(limits, scheme["drag"])
    # Rounded down to 3 significant digits: the limits come from iterative eigensolvers whose
    # last digits vary with the number of ranks, and the run should not.
    dt = p.dt if not math.isnan(p.dt) else _round_down(p.dt_safety * limits[smallest], 3)
    if s.restarted:
        dt = s.state.dt
    s.state.dt = dt
    exceeded = [k for k, v in timestep.applicable(limits, scheme["drag"]).items() if dt > v]
    speeds = timestep.wave_speeds(p, S)
    _print_limits(comm, limits, dt, smallest, speeds, s.f1, p, patch, scheme)
    s.regime = inertia.regime(p, S)
    PETSc.Sys.Print(inertia.describe(s.regime), comm=comm)
    stability = timestep.stability_limits(limits, scheme["drag"])
    worst = max(stability, key=lambda k: dt / stability[k])
    if dt > 2 * stability[worst] and not p.allow_unstable:
        raise InputError(f"-mpm_dt {dt:.4g}: {dt / stability[worst]:.1f} x the {worst} "
                         f"critical time step {stability[worst]:.4g} s; the run would blow "
                         "up (-mpm_allow_unstable runs it anyway)")
    if exceeded:
        msg = (f"WARNING: dt = {dt:.4g} s exceeds the critical time step(s) "
               + ", ".join(f"{k} {limits[k]:.4g} s" for k in exceeded)
               + ("" if set(exceeded) <= {"oscillator", "cfl", "diffusion"}
                  else ": expect the run to blow up"))
        PETSc.Sys.Print("!" * len(msg) + "\n" + msg + "\n" + "!" * len(msg), comm=comm)
    s.limits, s.smallest, s.exceeded = limits, smallest, exceeded


def _plan(s, comm):
    """The references, the number of steps and the report and isochrone steps, into ``s``
    (printed with the scheme); InputError for a run that would not finish."""
    p, dt, scheme, H = s.p, s.dt, s.scheme, s.p.size[1]
    s.cv, s.c2, s.p0 = references(p)
    cv = s.cv
    t_end = p.Tv_end * H * H / cv
    if not t_end / dt < MAX_STEPS:
        raise InputError(f"-mpm_Tv_end {p.Tv_end}: {t_end / dt:.3g} steps of {dt:.3g} s; "
                         f"more than {MAX_STEPS:.0e} is not a run that finishes")
    s.warn = inertia.warning(s.regime)
    if s.warn:
        PETSc.Sys.Print(s.warn, comm=comm)
    s.nsteps = nsteps = int(math.ceil(t_end / dt - 1e-9))
    s.report_steps = {int(round(tv * H * H / (cv * dt))): tv for tv in p.Tv_report}
    s.iso_steps = {int(round(tv * H * H / (cv * dt))): tv
                   for tv in sorted(set(ISOCHRONES) | set(p.Tv_report))
                   if tv <= p.Tv_end + 1e-12}
    PETSc.Sys.Print(f"Consolidation: {p.element.upper()}, {p.cells[0]} x {p.cells[1]} cells, "
                    f"{s.points.n_global} material points, {comm.getSize()} rank(s); "
                    f"c_v = {cv:.4g} m2/s, T_v = {p.Tv_end} at t = {t_end:.4g} s: "
                    f"{nsteps} steps of {dt:.4g} s; monitor at y = {s.monitor_height:.5g} m\n"
                    f"Scheme: {scheme['kinematics']} kinematics, lumping {scheme['lumping']}, "
                    f"liquid basis {scheme['liquid_basis']}, pressure projection "
                    f"{scheme['pressure_projection']}, {scheme['drag']} drag, mass scaling "
                    f"S = {s.state.mass_scaling:.4g} ({p.mass_scaling})", comm=comm)
    if p.element != "q4" and p.ppc < 3:
        # Measured on 1 x 20 cells (docs/studies.md): Q9 with 2 x 2 points was 10 % off
        # Terzaghi (0.4 % with 3 x 3); Q8's stable time step shrank a hundredfold.
        PETSc.Sys.Print(f"WARNING: {p.element.upper()} cells with {p.ppc} x {p.ppc} points "
                        "under-integrate the quadratic fields: use -mpm_ppc 3 or more",
                        comm=comm)


def _summary(s, comm) -> dict:
    """The summary before the first step (collective: the provenance)."""
    p = s.p
    summary = {"analysis": "consolidation", "ranks": comm.getSize(), "element": p.element,
               "cells": list(p.cells), "ppc": p.ppc, "n_points": s.points.n_global,
               "steps": 0, "dt": s.dt, "wall_seconds": 0.0, "stable": True,
               "dt_critical": s.limits, "dt_governing": s.smallest,
               "dt_exceeds": s.exceeded, **s.scheme, "damping": p.damping,
               "bulk_viscosity": p.bulk_viscosity, "fast_damping": p.fast_damping,
               "flip": p.flip, "f1_hz": s.f1, "c_v": s.cv, "c2": s.c2,
               "p0_consistent_over_q": s.p0, "regime": s.regime,
               "scene": workprecision.scene_signature(p), "run_id": s.run["id"],
               "provenance": provenance.collect(comm, p)}
    if s.warn:
        summary["warnings"] = [s.warn]
    if s.goal is not None:
        summary["target"] = s.goal
    return summary


def _time_loop(s, model, reporting, stop, ckpt_path, comm, ctx):
    """The explicit steps after the state's step to ``s.nsteps``: step, check, hand the
    results to ``reporting`` at its steps, checkpoint, stop on a signal, print progress.
    A NumericalError or Interrupted writes the summary so far (rank 0) and is raised on."""
    p, dt, state = s.p, s.dt, s.state
    H = p.size[1]
    scale = max(load_scale(p), scene.mixture_density(p) * p.gravity * H, 1.0)
    first = state.step + 1
    k = first - 1
    last_print = last_ckpt = time.perf_counter()
    # The estimate of the time left counts the steps only, not the set-up before them.
    t_steps = time.perf_counter()
    pace = s.pace = workprecision.Pace(first, s.nsteps, t_steps) if s.goal else None
    try:
        # The stage is popped however the loop ends (the handlers in _run run after it).
        with PETSc.Log.Stage("Explicit steps"):
            for k in range(first, s.nsteps + 1):
                t = k * dt
                ramp = 1.0 if p.load_ramp <= 0 else min(1.0, (k - 1) * dt / p.load_ramp)
                ctx.whole = None         # mid-step: points and records disagree until the end
                model.step(dt, ramp, p.damping, p.flip)
                due = int(p.checkpoint_seconds > 0 and comm.getRank() == 0
                          and time.perf_counter() - last_ckpt > p.checkpoint_seconds)
                signal_seen, due = model.migrate_if_needed((stop.seen, due))
                if k % 50 == 0 or k == s.nsteps or k in s.iso_steps:
                    model.check(k, t, scale)
                if k % 10 == 0 or k in s.iso_steps:
                    reporting.sample(t)
                if k in s.iso_steps:
                    reporting.isochrone(k, t)
                if (p.output_every and k % p.output_every == 0) or k in s.report_steps \
                        or k == s.nsteps:     # the run's last state too, whatever its end
                    reporting.write_fields(k, t)
                state.step = k           # the records are those of step k from here on
                if (signal_seen or due
                        or (p.checkpoint_every and k % p.checkpoint_every == 0)):
                    checkpoint.write(ckpt_path, comm, s.points, state.to_dict(), p, s.run)
                    last_ckpt = time.perf_counter()
                if signal_seen:
                    raise Interrupted(f"stopped by {stop.name} at step {k} (t = {t:.6g} s); "
                                      f"checkpoint {ckpt_path}; continue with "
                                      f"-mpm_restart {ckpt_path}", stage="stepping",
                                      agreed=True)
                said = pace and pace.tick(k, time.perf_counter())
                if said:
                    PETSc.Sys.Print(said, comm=comm)
                if p.progress and time.perf_counter() - last_print > p.progress:
                    last_print = time.perf_counter()
                    PETSc.Sys.Print(_progress(s, k, t, last_print, t_steps, first), comm=comm)
                ctx.whole = k
    except (NumericalError, Interrupted) as exc:
        for undo in ctx.cleanup:       # NumPy's FP settings
            undo()
        blew_up = isinstance(exc, NumericalError)
        ctx.summary.update(stable=not blew_up, interrupted=not blew_up, steps=k,
                           failure=str(exc), wall_seconds=time.perf_counter() - s.t_wall,
                           completed=False, error=entry(str(exc), exc.exit_code, "stepping"))
        if comm.getRank() == 0:
            output.write_json(ctx.summary_path,
                              dict(ctx.summary, files={"summary": ctx.summary_path}))
        raise


def _progress(s, k, t, now, t_steps, first) -> str:
    """The progress line at step ``k`` (time ``t``), ``now`` (perf_counter)."""
    H, nsteps, history = s.p.size[1], s.nsteps, s.state.history
    return (f"  step {k}/{nsteps} ({100 * k / nsteps:.0f} %), "
            f"t = {t:.4g} s, T_v = {s.cv * t / H ** 2:.4f}, p/q(monitor) = "
            f"{history[-1][2] if history else float('nan'):.4f}, "
            f"{now - s.t_wall:.0f} s elapsed, about "
            f"{(now - t_steps) / (k - first + 1) * (nsteps - k):.0f} s left")


class _Reporting:
    """Where the time loop hands its results: the monitor and settlement samples, the
    profiles and reports at the isochrone and report steps, settlement.csv at each report,
    the field series; the records go into the run's state. Made after the model, it
    resumes a restart's series and says so."""

    def __init__(self, s, comm):
        self.s, self.comm, self.mpi = s, comm, comm.tompi4py()
        self.state, self.points, p = s.state, s.points, s.p
        self.H, self.q, self.ratio = p.size[1], load_scale(p), s.c2 / s.cv
        self.files = {}
        self.series = PointSeries(p.output, comm, s.run["id"])
        self.surface = settlement.Surface(s.grid, p)
        self.depths = Depths(self.H)
        self.depths.refresh(s.points)
        if s.restarted:
            # The series files of the checkpoint's run (an older one's have no id).
            self.series.resume(self.state.series, s.resumed_id)
            self.state.series = self.series.entries
            step = self.state.step
            PETSc.Sys.Print(f"Restart from {p.restart} at step {step} "
                            f"(t = {step * s.dt:.6g} s)", comm=comm)

    def sample(self, t):
        """The monitor's p / q and the surface settlement and mean p at time ``t``."""
        Tv = self.s.cv * t / (self.H * self.H)
        self.state.history.append((t, Tv, _monitor(self.points, self.mpi) / self.q))
        self.state.settlement.append((t, Tv, *self.surface.measure(self.points, self.mpi)))

    def isochrone(self, k, t):
        """The profile at isochrone step ``k``; at a report step its report, degree of
        consolidation and settlement.csv."""
        s, state, comm = self.s, self.state, self.comm
        prof = profile(self.points, comm)
        if comm.getRank() == 0:
            state.profiles.append((s.iso_steps[k], t, prof))
        if k in s.report_steps:
            Tv = s.report_steps[k]
            state.reports.append(report(Tv, t, self.points, self.mpi, s.p, s.monitor_height,
                                        s.cv, s.c2, s.p0, self.depths))
            state.degree.append(self.surface.report(Tv, state.settlement[-1], self.ratio))
            if comm.getRank() == 0:
                self.files["settlement_csv"] = self.surface.write_csv(
                    s.p.output, state.settlement, self.ratio)

    def write_fields(self, k, t):
        """The points' fields at step ``k`` into the series (collective)."""
        self.series.write(self.points, k, t)
        self.state.series = self.series.entries


def _finish(s, reporting, summary, comm) -> int:
    """The reporting after the last step: the summary's results, the tables, the target
    error's check; the output files and the summary (rank 0)."""
    p, state, goal = s.p, s.state, s.goal
    reports, summary_path = state.reports, p.summary or os.path.join(p.output, "summary.json")
    summary["steps"] = s.nsteps
    summary["completed"] = True
    summary["wall_seconds"] = time.perf_counter() - s.t_wall
    summary["monitor"] = {"height": s.monitor_height,
                          "Tv": [r["Tv"] for r in reports],
                          "p_over_q": [r["p_over_q"] for r in reports],
                          "terzaghi": [r["terzaghi"] for r in reports],
                          "error_pct": [r["error_pct"] for r in reports],
                          "consistent": [r["consistent"] for r in reports],
                          "error_consistent_pct": [r["error_consistent_pct"] for r in reports]}
    summary["profile_l2"] = {"Tv": [r["Tv"] for r in reports],
                             "terzaghi": [r["l2_terzaghi"] for r in reports],
                             "consistent": [r["l2_consistent"] for r in reports]}
    summary["consolidation_degree"] = reporting.surface.summary(state.degree)
    _print_reports(comm, reports, p)
    settlement.print_degree(comm, state.degree)
    if goal is not None:
        _target_verdict(s, summary, comm)
    last = reporting.series.last()          # rank 0's: it writes the series
    if last is not None:
        summary["fields"] = {"times": len(reporting.series.entries), "last_step": last[0],
                             "last_t_s": last[1]}
        PETSc.Sys.Print(f"Point fields: {summary['fields']['times']} time(s) in "
                        f"{reporting.series.xdmf}, the last at t = {last[1]:.6g} s "
                        f"(step {last[0]} of {s.nsteps})", comm=comm)
    files = reporting.files
    files["summary"] = summary_path
    if comm.getRank() == 0:
        series = reporting.series.files()
        if series:
            files["fields_xdmf"], files["fields_h5"] = series[0], series[1:]
        files.update(_write_files(p, state.profiles, state.history, s.cv, s.c2, s.p0,
                                  s.monitor_height))
        files.update(settlement.write_files(p, reporting.surface, state.settlement, s.cv,
                                       reporting.ratio))
        output.write_json(summary_path, dict(summary, files=files))
    PETSc.Sys.Print(output.results_line(p.output, files), comm=comm)
    PETSc.Sys.Print(f"Wall time {summary['wall_seconds']:.1f} s; summary {summary_path}",
                    comm=comm)
    return 0


def _target_verdict(s, summary, comm):
    """-mpm_target_error's check of the finished run: met only when every error it reports
    is within the target; with the stepping time beside the prediction (rank 0's)."""
    goal = s.goal
    goal["achieved_pct"] = workprecision.measure(summary)
    goal["errors_pct"] = {k: {"error_pct": e, "Tv": tv}
                          for k, (e, tv) in workprecision.errors(summary).items()}
    goal["met"], said = workprecision.verdict(summary, s.p.target_error, goal["measured_tv"])
    pace = getattr(s, "pace", None)
    if pace is not None and pace.predicted is not None:
        goal["stepping_seconds"] = time.perf_counter() - pace.t0
        goal["predicted_seconds"] = pace.predicted
        said += (f"; stepping took {goal['stepping_seconds']:.3g} s (predicted "
                 f"{pace.predicted:.3g} s)")
    PETSc.Sys.Print(f"Target error {s.p.target_error:g} %: {said}", comm=comm)


def _round_down(x: float, digits: int) -> float:
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.floor(x / scale) * scale


def _monitor(points, mpi):
    """p at the monitor height: the points' p weighted by their monitor weights (every
    10 steps: kept arrays and a buffer reduction, none on one rank)."""
    from mpi4py import MPI

    pp, mon = points.views("p", "monitor")
    s = np.array([float(np.sum(pp * mon)), float(np.sum(mon))])
    if mpi.Get_size() > 1:
        mpi.Allreduce(MPI.IN_PLACE, s, op=MPI.SUM)
    return s[0] / s[1]


def profile(points, comm):
    """(y0, p, volume, x) of every point, gathered on rank 0 (None elsewhere)."""
    x0, pp, V, x = points.views("x0", "p", "volume", "x")
    local = np.column_stack([x0[:, 1], pp, V, x[:, 0]])      # the one copy, 32 bytes a point
    if comm.getSize() == 1:
        return local
    parts = comm.tompi4py().gather(local, root=0)
    return np.concatenate(parts) if parts is not None else None


def report(Tv, t, points, mpi, p, height, cv, c2, p0, depths):
    H, q = p.size[1], load_scale(p)
    num = _monitor(points, mpi) / q
    ref = float(analytic.terzaghi(H - height, Tv, H))
    con = float(analytic.terzaghi(H - height, Tv * c2 / cv, H, p0))
    r = {"Tv": Tv, "t": t, "p_over_q": num, "terzaghi": ref, "consistent": con,
         "error_pct": 100 * (num - ref) / ref, "error_consistent_pct": 100 * (num - con) / con}
    r["l2_terzaghi"], r["l2_consistent"] = depths.l2_errors(
        points, mpi, q, [lambda d: analytic.terzaghi(d, Tv, H),
                         lambda d: analytic.terzaghi(d, Tv * c2 / cv, H, p0)])
    return r


class Depths:
    """The points' depths below the surface, H - y0 (m), as the distinct values and each
    point's index into them, kept per point generation: a reference profile is evaluated
    once per distinct depth (a few hundred on a structured placement) and each rank sums
    the errors of its own points, so a report at 1e6 points costs less than a step."""

    def __init__(self, height):
        self.height, self._generation = height, None

    def refresh(self, points):
        """Find the distinct depths (a sort of the points: 0.3 s at 1e6 points, done at
        set-up and again only after the points changed)."""
        if self._generation != points.generation:
            x0 = points.views("x0")
            self.values, self.index = np.unique(self.height - x0[:, 1], return_inverse=True)
            self._generation = points.generation

    def l2_errors(self, points, mpi, q, profiles) -> list:
        """sqrt(sum V (p/q - exact)^2 / sum V) over all points for each ``profiles``
        function exact(depth) (p/q, depth in m)."""
        from mpi4py import MPI

        self.refresh(points)
        pp, V = points.views("p", "volume")
        sums = np.array([float(np.sum(V * (pp / q - f(self.values)[self.index]) ** 2))
                         for f in profiles] + [float(np.sum(V))])
        if mpi.Get_size() > 1:
            mpi.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        return [float(np.sqrt(e / sums[-1])) for e in sums[:-1]]


def _governing(limits: dict, drag: str) -> str:
    """The criterion that sets dt: the smallest, the drag limit only with explicit drag."""
    return min(timestep.applicable(limits, drag), key=limits.get)


def _estimated_steps(p, drag: str, S: float) -> float:
    """Steps of the run from the closed-form criteria alone (a lower bound: the discrete
    limit and the oscillator criterion can only lower dt)."""
    H = p.size[1]
    h = [p.size[d] / p.cells[d] for d in (0, 1)]
    limits = timestep.criteria(p, math.nan, math.nan, h, S)
    limits = {k: v for k, v in limits.items() if not math.isnan(v)}
    dt = p.dt if not math.isnan(p.dt) else p.dt_safety * limits[_governing(limits, drag)]
    return p.Tv_end * H * H / references(p)[0] / dt


def _check_feasible(p, scheme):
    """InputError, before anything is analysed or written, when the run would take more
    than MAX_STEPS steps; it names the options that bring it down, and to how many."""
    if p.restart:
        return
    drag, S = scheme["drag"], scheme["mass_scaling"]
    steps = _estimated_steps(p, drag, S)
    if steps <= MAX_STEPS:
        return
    if not math.isnan(p.dt):
        raise InputError(f"-mpm_dt {p.dt:g}: {steps:.3g} steps to T_v = {p.Tv_end:g}, more "
                         f"than {MAX_STEPS:.0e}; raise -mpm_dt or lower -mpm_Tv_end")
    ways = []                                   # (what to change, steps with it)
    if drag == "explicit":
        ways.append(("-mpm_drag implicit", _estimated_steps(p, "implicit", S)))
    if p.mass_scaling != "auto" and inertia.decay(p)[0] < 1:
        S_auto = inertia.auto_factor(p)
        ways.append((("-mpm_drag implicit " if drag == "explicit" else "")
                     + f"-mpm_mass_scaling auto (S = {S_auto:.3g})",
                     _estimated_steps(p, "implicit", S_auto)))
    if not any(n <= MAX_STEPS for _, n in ways):
        # Neither the drag nor the inertia makes this run finish: it is too long.
        raise InputError(f"-mpm_Tv_end {p.Tv_end:g}: at least {steps:.3g} steps, more than "
                         f"{MAX_STEPS:.0e} (" + "".join(f"with {w}: {n:.3g}; " for w, n in ways)
                         + "shorten the run or coarsen the grid)")
    raise InputError(f"-mpm_mass_scaling {p.mass_scaling}: at least {steps:.3g} steps to "
                     f"T_v = {p.Tv_end:g} with {drag} drag, more than {MAX_STEPS:.0e}; steps "
                     "with " + "; with ".join(f"{w}: {n:.3g}" for w, n in ways))


def _coarser(p) -> str:
    cells = f1_cells(p)
    return "" if cells == tuple(p.cells) else f", on {cells[0]} x {cells[1]} cells"


def _print_limits(comm, limits, dt, smallest, speeds, f1, p, patch, scheme):
    S = scheme["mass_scaling"]
    scaled = "" if S == 1 else f", inertia scaled by S = {S:.4g}"
    notes = {"cfl": f"L/c, c = {speeds['c']:.4g} m/s{scaled}",
             "undrained": f"L/c1, c1 = {speeds['c1']:.4g} m/s{scaled}",
             "diffusion": f"L^2/(2 c2), c2 = {speeds['c2']:.4g} m2/s",
             "oscillator": f"L/c3, c3 = 2 pi f1 H = "
                           f"{2 * np.pi * f1 / np.sqrt(S) * p.size[1]:.4g} m/s "
                           f"(f1 = {f1 / np.sqrt(S):.4g} Hz{scaled}{_coarser(p)})",
             "drag": f"2/lambda, lambda = {timestep.drag_rate(p, S):.4g} 1/s"
                     + ("" if scheme["drag"] == "explicit"
                        else " (no limit: the drag is implicit)"),
             "discrete": "stability limit of the linearised MPM step itself"
                         + ("" if tuple(patch) == tuple(p.cells)
                            else f" (found on a {patch[0]} x {patch[1]} cell patch)")}
    lines = ["Critical time steps (s):"]
    lines += [f"  {k:<11s}{v:11.3e}   {notes[k]}" for k, v in limits.items()]
    how = ("given by -mpm_dt" if not math.isnan(p.dt)
           else f"{p.dt_safety} x {smallest}")
    lines.append(f"  used       {dt:11.3e}   ({how})")
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def _print_reports(comm, reports, p):
    lines = ["Normalised pore pressure p/q at the monitor point (Tables 4 and 5):",
             f"{'T_v':>6s}{'p/q':>9s}{'Terzaghi':>10s}{'error':>9s}{'consistent':>12s}"
             f"{'error':>9s}{'L2 Terz.':>10s}{'L2 cons.':>10s}"]
    for r in reports:
        lines.append(f"{r['Tv']:6.2f}{r['p_over_q']:9.3f}{r['terzaghi']:10.3f}"
                     f"{r['error_pct']:8.2f}%{r['consistent']:12.3f}"
                     f"{r['error_consistent_pct']:8.2f}%{r['l2_terzaghi']:10.4f}"
                     f"{r['l2_consistent']:10.4f}")
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def _write_files(p, profiles, history, cv, c2, p0, monitor_height):
    """Isochrones (Figs 4-5), the pressure field (Fig 3), the monitor history; rank 0."""
    files = {}
    hist = np.array(history) if history else np.zeros((0, 3))
    files["monitor_csv"] = os.path.join(p.output, "monitor.csv")
    with output.atomic(files["monitor_csv"]) as tmp:
        np.savetxt(tmp, hist, delimiter=",", header="t_s,Tv,p_over_q_compression_positive",
                   comments="")
    # Every point's pore pressure at every isochrone time: enough to redraw Figs 3-5.
    files["profiles_csv"] = os.path.join(p.output, "profiles.csv")
    with output.atomic(files["profiles_csv"]) as tmp, open(tmp, "w") as fh:
        fh.write("Tv,t_s,x_m,y0_m,p_over_q_compression_positive,volume_m3\n")
        for Tv, t, prof in profiles:         # one isochrone at a time: 48 bytes per point
            np.savetxt(fh, np.column_stack([np.full(len(prof), Tv), np.full(len(prof), t),
                                            prof[:, 3], prof[:, 0],
                                            prof[:, 1] / load_scale(p), prof[:, 2]]),
                       delimiter=",")
    if p.figures:
        files.update(_figures(p, profiles, hist, c2 / cv, p0, monitor_height))
    return files


def _figures(p, profiles, hist, ratio, p0, monitor_height):
    """isochrones, pressure_field and monitor in the formats of -mpm_figure_format;
    ``ratio`` = c2 / c_v and ``p0`` = p0 / q scale the compressible-water reference."""
    plt = output.pyplot()
    files = output.save_figures(_isochrone_figure(plt, p, profiles, ratio, p0), p.output,
                                "isochrones", p.figure_format)
    shown = [pr for pr in profiles if pr[0] in p.Tv_report] or profiles[-1:]
    fig = figures.pressure_field(
        plt, [(Tv, prof[:, 3], prof[:, 0], prof[:, 1]) for Tv, _, prof in shown],
        load_scale(p), f"Pore pressure field, {p.element.upper()}, {len(shown[0][2])} MPs",
        width=p.size[0])
    files.update(output.save_figures(fig, p.output, "pressure_field", p.figure_format))
    files.update(output.save_figures(_monitor_figure(plt, p, hist, ratio, p0, monitor_height),
                                     p.output, "monitor", p.figure_format))
    return files


def _isochrone_figure(plt, p, profiles, ratio, p0):
    """The points' p / q at each report time over both references, coloured by T_v."""
    fig, ax = plt.subplots(figsize=(6, 6))
    colors = figures.tv_colors(plt, len(profiles))
    figures.isochrone_references(ax, [Tv for Tv, _, _ in profiles], colors, p.size[1], ratio,
                                 p0)
    for i, ((Tv, _, prof), col) in enumerate(zip(profiles, colors)):
        k = figures.drawn(len(prof))
        ax.plot(prof[k, 1] / load_scale(p), prof[k, 0], "o", color=col, ms=3, mfc="none",
                label=None if i else "MPM points")
    ax.set_title(f"Isochrones, {p.element.upper()} {p.cells[0]} x {p.cells[1]} cells")
    figures.legend_below(ax, ncol=2)
    return fig


def _monitor_figure(plt, p, hist, ratio, p0, monitor_height):
    """p / q at the monitor point against T_v, with both references at its depth."""
    H = p.size[1]
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(hist[:, 1], hist[:, 2], lw=0.8, label="MPM")
    Tv = np.geomspace(1e-4, p.Tv_end, 400)
    ax.plot(Tv, analytic.terzaghi(H - monitor_height, Tv, H), color="k",
            label="Terzaghi, classic", **figures.CLASSIC)
    ax.plot(Tv, analytic.terzaghi(H - monitor_height, Tv * ratio, H, p0), color="k",
            label="Terzaghi, compressible water", **figures.COMPRESSIBLE)
    ax.set_xscale("log")
    ax.set_xlabel("time factor T_v = c_v t / H^2 (-)")
    ax.set_ylabel(f"p / q at {monitor_height:.4g} m (-)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig
