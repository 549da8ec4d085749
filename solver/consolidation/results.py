"""A consolidation run's results: its keys in the summary (:func:`keys`, set before the first
step), and the closing report after the last step (:func:`finish`): the tables against the
references, the degree of consolidation, a target error's verdict, the CSV files, figures
and field series, and the summary."""

from __future__ import annotations

import dataclasses
import math
import os
import time

import numpy as np
from petsc4py import PETSc

from ..io import output

from . import reporting, settlement, workprecision


def keys(plan, points, state) -> dict:
    """The run's keys in its block of the summary (``consolidation``) before the first
    step."""
    body, scheme, limits, refs = plan.body, plan.scheme, plan.limits, plan.refs
    out = {"scheme": plan.method, "element": body.element, "cells": list(body.cells),
           "ppc": body.ppc, "n_points": points.n_global, "dt": state.dt,
           "dt_critical": limits.steps, "dt_governing": limits.governing,
           "dt_exceeds": list(limits.exceeded), **scheme.summary(),
           "damping": scheme.damping, "bulk_viscosity": scheme.bulk_viscosity,
           "fast_damping": scheme.fast_damping, "flip": scheme.flip, "f1_hz": limits.f1,
           "c_v": refs.c_v, "c2": refs.c2, "p0_consistent_over_q": refs.p0,
           "regime": limits.regime, "reference": refs.summary(), **_layers(plan.soil),
           "scene": plan.scene}
    if limits.warning:
        out["warnings"] = [limits.warning]
    if plan.goal is not None:
        out["target"] = plan.goal
    return out


def _layers(soil) -> dict:
    """The summary's layers (thickness in m and the soil of each, from the surface down),
    for layered ground; nothing for one soil."""
    if len(soil.soils) == 1:
        return {}
    return {"layers": [{"thickness_m": t, **dataclasses.asdict(s)}
                       for t, s in zip(soil.thickness, soil.soils)]}


def finish(plan, model, record, comm) -> None:
    """The reporting after the last step: the run's results into ``record`` (the monitor,
    the profiles' errors, the degree of consolidation, the references, the target error's
    check), the tables printed, the output files written (rank 0) and the summary."""
    state, reports, summary = model.records, model.reports, record.results
    records = state.reports
    if model.implicit:
        summary["implicit"] = model.engine.summary()
        _implicit_line(comm, summary["implicit"])
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
        _target_verdict(plan, summary, model.pace, comm)
    last = reports.series.last()          # rank 0's: it writes the series
    if last is not None:
        summary["fields"] = {"times": len(reports.series.entries), "last_step": last[0],
                             "last_t_s": last[1]}
        PETSc.Sys.Print(f"Point fields: {summary['fields']['times']} time(s) in "
                        f"{reports.series.xdmf}, the last at t = {last[1]:.6g} s "
                        f"(step {last[0]} of {plan.schedule.nsteps})", comm=comm)
    files = record.files
    files.update(reports.files)
    files.update(_plastic_zone(plan, model.points, comm))
    if comm.getRank() == 0:
        series = reports.series.files()
        if series:
            files["fields_xdmf"], files["fields_h5"] = series[0], series[1:]
        files.update(reporting.write_files(plan, state.profiles, state.history))
        files.update(settlement.write_files(plan.outputs, reports.surface, state.settlement,
                                            plan.refs, plan.schedule.Tv_end,
                                            reporting.title(plan), state.troughs))
    record.finish()


def _implicit_line(comm, counts):
    """The implicit scheme's steps, factorizations and solve time (the summary's
    ``implicit`` block), printed."""
    if "newton_solves" in counts:       # a yielding soil: Newton at every stage
        PETSc.Sys.Print(f"Implicit scheme: {counts['steps']} steps, {counts['newton_solves']} "
                        f"Newton solves of {counts['newton_iterations']} iterations (at most "
                        f"{counts['newton_most']})", comm=comm)
        return
    PETSc.Sys.Print(f"Implicit scheme: {counts['steps']} steps, {counts['factorizations']} LU "
                    f"factorizations ({counts['factor_seconds']:.3g} s), {counts['solves']} "
                    f"solves ({counts['solve_seconds']:.3g} s)", comm=comm)


def _plastic_zone(plan, points, comm) -> dict:
    """plastic_zone.png of a yielding soil at the end (the points gathered on rank 0):
    {name: path} of what was written."""
    if plan.materials is None:
        return {}
    x, eps = points.get("x"), np.ravel(points.get("state_eps_p"))
    gathered = comm.tompi4py().gather((x, eps), root=0)
    if comm.getRank() != 0 or not plan.outputs.figures:
        return {}
    W = plan.body.size[0]
    loaded = plan.loading.extent if plan.loading.partial(W) else (0.0, W)
    return {"plastic_zone": output.plastic_zone(
        os.path.join(plan.outputs.folder, "plastic_zone.png"), plan.outputs.formats,
        np.concatenate([g[0] for g in gathered]), np.concatenate([g[1] for g in gathered]),
        plan.body.size, loaded, f"plastic zone at the end ({plan.material})")}


def _target_verdict(plan, summary, pace, comm):
    """-mpm_target_error's check of the finished run (``summary``: its block of the summary
    so far): met only when every error it reports is within the target; with the stepping
    time beside the prediction (rank 0's). Written into the plan's goal, the block's
    ``target``."""
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
