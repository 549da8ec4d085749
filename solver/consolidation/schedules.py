"""The time scheme of a consolidation run: which one (explicit or implicit), and its steps.

:func:`method` picks and prints the scheme (:mod:`solver.consolidation.implicit.choice`);
:func:`limits_and_schedule` gives the explicit step its critical time steps, dt and equal
steps (the criteria of :mod:`solver.stepping.timestep`, f1 from
:mod:`solver.modal.frequency`), or the implicit scheme its steps graded from the load
(:func:`solver.consolidation.implicit.quasistatic.step_ends`), each report and isochrone
time a step's end. Everything here takes the typed :class:`choice.Request`, not the
options.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from petsc4py import PETSc

from ..common.errors import InputError
from . import reporting
from ..stepping import inertia, timestep
from ..stepping.inertia import MAX_STEPS
from ..stepping.timestep import Limits, choose_dt, critical_steps
from .implicit import choice
from .implicit.quasistatic import graded_steps, named_times
from .plan import Schedule


def method(comm, req, soil, body, scheme, refs, restart_state=None) -> str:
    """The scheme of the run (explicit or implicit), with the line that says why printed,
    and the notes on a scene file's options of the other scheme; a restart continues its
    checkpoint's (``restart_state``)."""
    if restart_state is None:
        chosen, why = choice.choose(req, soil, body, scheme, refs, reporting.ISOCHRONES)
    else:
        chosen = restart_state.get("method", "explicit")
        why = f"Scheme: {chosen} (the checkpoint's)"
    PETSc.Sys.Print(why, comm=comm)
    for note in choice.notes(req, chosen):
        PETSc.Sys.Print(f"Note: {note}", comm=comm)
    return chosen


def limits_and_schedule(comm, req, method, model, h, state, restarted, refs) -> tuple:
    """(:class:`Limits`, :class:`Schedule`) of the run; ``model`` (body, soil, scheme),
    ``h`` the cell sizes (m), ``state`` the run's (its dt, and the implicit steps taken by a
    restart), ``refs`` the References (T_v and time)."""
    body, soil, scheme = model
    if method == "implicit":
        limits = Limits({}, "", (), math.nan, inertia.regime(
            soil, body.height, min(req.Tv_report), scheme.damping, scheme.fast_damping, 1.0,
            scheme.wave_period, scheme.swings))
        return limits, implicit_schedule(req, refs, state)
    limits = explicit_limits(comm, req, model, h, state, restarted)
    return limits, Schedule(state.dt, *step_counts(refs, state.dt, req.Tv_end, req.Tv_report),
                            req.Tv_end, tuple(req.Tv_report), *req.cadence)


def explicit_limits(comm, req, model, h, state, restarted) -> Limits:
    """The explicit step's critical time steps, its dt (into ``state``) and the inertia
    regime, printed; InputError for a dt far beyond the stability limit."""
    body, soil, scheme = model
    limits, patch = critical_steps(comm, body, soil, scheme, h, req.stability_analysis,
                                   req.f1_solver)
    given = None if math.isnan(req.dt) else req.dt
    state.dt = state.dt if restarted else choose_dt(limits, given, req.dt_safety)
    reporting.print_limits(comm, limits, state.dt, soil, body, scheme, patch,
                           "given by -mpm_dt" if given else
                           f"{req.dt_safety} x {limits.governing}")
    return check_dt(comm, limits, state.dt, soil, body.height, scheme, min(req.Tv_report),
                    req.allow_unstable)


def implicit_schedule(req, refs, state) -> Schedule:
    """The implicit scheme's graded steps through the report and isochrone times to T_v =
    the end; a restart keeps the steps it took (``state.times``) and grades on from
    its last, so that the same options continue exactly."""
    named = named_times(refs.time, req.Tv_report, req.Tv_end, reporting.ISOCHRONES)
    ends = graded_steps(named, req.implicit_steps, req.ramp)
    done = list(state.times[:state.step])
    if done:
        ends = np.r_[done, ends[ends > done[-1] * (1 + 1e-12)]]
    ends = np.asarray(ends, dtype=float)
    state.times = ends.tolist()
    at = {tv: int(np.argmin(np.abs(ends - t))) + 1 for tv, t in named.items()}
    report = {at[tv]: tv for tv in req.Tv_report if tv in at}
    iso = {at[tv]: tv for tv in named if tv in set(reporting.ISOCHRONES) | set(req.Tv_report)}
    state.dt = float(ends[0])
    return Schedule(math.nan, len(ends), report, iso, req.Tv_end, tuple(req.Tv_report),
                    *req.cadence, times=tuple(ends.tolist()), sample_every=1)


def check_dt(comm, limits, dt, soil, H, scheme, first_tv, allow_unstable) -> Limits:
    """The limits with the ones ``dt`` (s) exceeds and the inertia regime (printed);
    InputError for a step far beyond the stability limit (unless ``allow_unstable``), a
    warning for one beyond any."""
    exceeded = [k for k, v in timestep.applicable(limits.steps, scheme.drag).items()
                if dt > v]
    regime = inertia.regime(soil, H, first_tv, scheme.damping, scheme.fast_damping,
                            scheme.mass_scaling, scheme.wave_period, scheme.swings)
    PETSc.Sys.Print(inertia.describe(regime), comm=comm)
    stability = timestep.stability_limits(limits.steps, scheme.drag)
    worst = max(stability, key=lambda k: dt / stability[k])
    if dt > 2 * stability[worst] and not allow_unstable:
        raise InputError(f"-mpm_dt {dt:.4g}: {dt / stability[worst]:.1f} x the {worst} "
                         f"critical time step {stability[worst]:.4g} s; the run would blow "
                         "up (-mpm_allow_unstable runs it anyway)")
    if exceeded:
        msg = (f"WARNING: dt = {dt:.4g} s exceeds the critical time step(s) "
               + ", ".join(f"{k} {limits.steps[k]:.4g} s" for k in exceeded)
               + ("" if set(exceeded) <= {"oscillator", "cfl", "diffusion"}
                  else ": expect the run to blow up"))
        PETSc.Sys.Print("!" * len(msg) + "\n" + msg + "\n" + "!" * len(msg), comm=comm)
    return dataclasses.replace(limits, exceeded=tuple(exceeded), regime=regime,
                               warning=inertia.warning(regime) or "")


def step_counts(refs, dt, Tv_end, Tv_report) -> tuple:
    """(the number of steps, the report steps, the isochrone steps ({step: T_v})) of a
    run with step dt (s) to T_v = ``Tv_end`` reporting at ``Tv_report``; InputError for a
    run that would not finish."""
    t_end = refs.time(Tv_end)
    if not t_end / dt < MAX_STEPS:
        raise InputError(f"-mpm_Tv_end {Tv_end}: {t_end / dt:.3g} steps of {dt:.3g} s; "
                         f"more than {MAX_STEPS:.0e} is not a run that finishes")
    nsteps = int(math.ceil(t_end / dt - 1e-9))
    H, cv = refs.H, refs.c_v
    report_steps = {int(round(tv * H * H / (cv * dt))): tv for tv in Tv_report}
    iso_steps = {int(round(tv * H * H / (cv * dt))): tv
                 for tv in sorted(set(reporting.ISOCHRONES) | set(Tv_report))
                 if tv <= Tv_end + 1e-12}
    return nsteps, report_steps, iso_steps
