"""Large-strain consolidation of a column (``-mpm_scheme implicit -mpm_kinematics large``):
its options planned, the model the loop drives and what it reports.

The engine is :class:`solver.consolidation.implicit.largestrain.LargeStrain`. The steps are
the implicit scheme's, ``-mpm_implicit_steps`` per doubling of time graded from the load
through the report times, after the undrained start (step 1). The run writes
``settlement.csv`` (the surface's settlement against time), ``profiles.csv`` (the excess
pore pressure at every point at the report times, against its height before the load),
a figure of both, the points' fields at the report times, and the summary's
``consolidation`` block. Where the scene is Xie and Leo's (2004) column (weightless,
elastic, Cauchy stress linear in ln V, k = k0 ((1 + e) / (1 + e0))^2, drained at the top,
the base or both), their closed form (:func:`solver.references.analytic.large_strain_column`)
is set beside it; the small-strain closed form (Terzaghi, m_v q H U) always is.
"""

from __future__ import annotations

import dataclasses
import os

import numpy as np
from petsc4py import PETSc

from ..common.errors import InputError, NumericalError
from ..io import checkpoint, output, provenance
from ..io.restart import given_at_start
from ..model.scene import Body, Loading
from ..model.soil import Soil
from ..references import analytic
from ..run.loop import Cadence, Saving, drive
from ..run.record import Record, begun, guarded
from .implicit.largestrain import LargeStrain, parse_k_law
from .implicit.operators import projects
from .implicit.quasistatic import step_ends

ONLY = ("k_law", "large_strain_stress")      # the options only this column reads


@dataclasses.dataclass(frozen=True)
class ColumnPlan:
    """The column's body, soil, load, permeability law and stress measure, its step ends
    (s, after t = 0), the report times {T_v: t (s)}, c_v (m2/s), whether Xie and Leo's
    closed form is its own, and the run's outputs, cadence and provenance."""

    body: Body
    soil: Soil
    loading: Loading
    k_law: tuple
    stress: str
    stabilize: bool
    ends: np.ndarray
    reports: dict
    c_v: float
    xie_leo: bool
    outputs: output.Outputs
    cadence: tuple
    restart: str
    overwrite: bool
    run: dict
    signature: str
    provenance: dict


def plan_of(p, comm) -> ColumnPlan:
    """The plan of the options ``p``; InputError for what the column does not take."""
    body, soil, loading = Body.from_options(p), Soil.from_options(p), Loading.from_options(p)
    why = [(p.element != "q4", "takes Q4 cells"),
           (loading.geostatic, "starts deposited (-mpm_initial_state deposited): its "
                               "weight acts from the undrained start"),
           (loading.partial(body.size[0]), "is loaded over its whole top"),
           (p.material != "elastic", "is elastic (-mpm_material elastic)"),
           (len(p.layers) > 1, "is one soil"),
           (any(s in body.drained for s in ("left", "right")), "drains at its top or base"),
           (p.bc_left != "x" or p.bc_right != "x", "stands on rollers (-mpm_bc_left x "
                                                   "-mpm_bc_right x)")]
    for bad, words in why:
        if bad:
            raise InputError(f"-mpm_kinematics large: the implicit large-strain column {words}")
    k_law = parse_k_law(p.k_law)
    c_v = analytic.consolidation_coefficient(soil.k, soil.constrained_modulus,
                                             soil.unit_weight_water)
    H = body.size[1]
    reports = {tv: tv * H * H / c_v for tv in sorted(set(p.Tv_report) | {p.Tv_end})
               if tv <= p.Tv_end + 1e-12}
    ends = step_ends(list(reports.values()), p.implicit_steps)
    summary = p.summary or os.path.join(p.output, "summary.json")
    options = provenance.options(p)
    given = set(p.given) | set(given_at_start(p.restart))
    return ColumnPlan(
        body=body, soil=soil, loading=loading, k_law=k_law, stress=p.large_strain_stress,
        stabilize=projects(p.pressure_stabilization, "q4"),
        ends=ends, reports=reports, c_v=c_v,
        xie_leo=k_law == ("power", 2.0) and p.large_strain_stress == "cauchy"
        and loading.gravity == 0,
        outputs=output.Outputs(p.output, summary, p.figures, p.figure_format),
        cadence=(p.checkpoint_every, p.checkpoint_seconds, p.progress),
        restart=p.restart, overwrite=p.overwrite,
        run={"id": None, "options": checkpoint.recorded(options), "given": sorted(given)},
        signature=checkpoint.signature(p), provenance=options)


def run(plan: ColumnPlan, comm) -> int:
    """Run the column of ``plan`` on ``comm``; returns 0 (a failure raises, after the
    record has written what it can)."""
    record = Record("consolidation", comm)
    guarded(record, lambda: _run(plan, comm, record))
    return 0


def _run(plan, comm, record) -> None:
    ckpt, run_id = begun(record, plan, comm)
    model = Column(plan, comm, run_id, ckpt)
    b = plan.body
    record.results = {"kinematics": "large", "scheme": "implicit", "k_law": plan.k_law[0],
                      "k_law_exponent": plan.k_law[1], "large_strain_stress": plan.stress,
                      "cells": list(b.cells), "points": len(model.engine.x),
                      "steps_planned": model.nsteps, "c_v_m2_s": plan.c_v}
    law = f"power:{plan.k_law[1]:g}" if plan.k_law[0] == "power" else plan.k_law[0]
    PETSc.Sys.Print(
        f"Large-strain consolidation: a {b.size[1]:g} m column, Q4 {b.cells[0]} x {b.cells[1]},"
        f" {len(model.engine.x)} points, k law {law}, {plan.stress} stress; {model.nsteps} "
        f"steps (the undrained start, then graded) to t = {plan.ends[-1]:.4g} s", comm=comm)
    cp_every, cp_seconds, progress = plan.cadence
    cadence = Cadence(model.nsteps, checkpoint_every=cp_every, checkpoint_seconds=cp_seconds,
                      progress_seconds=progress, check_every=1,
                      output_steps=frozenset(model.report_steps))
    saving = Saving(os.path.join(plan.outputs.folder, "checkpoint.npz"), plan.signature,
                    plan.run)
    drive(model, cadence, record, saving, first=model.first)
    report(plan, model, record, comm)


class Column:
    """The column as the loop drives it: step 1 the undrained start at t = 0+, step k the
    step to ``plan.ends[k - 2]``; the samples and fields are of the step's end."""

    log_stage = "Large-strain steps"

    def __init__(self, plan, comm, run_id, ckpt=None):
        self.plan = plan
        self.engine = LargeStrain(comm, plan.body, plan.soil, plan.loading, plan.k_law,
                                  plan.stress, plan.stabilize)
        self.times = np.concatenate([[0.0], plan.ends])
        self.nsteps = len(self.times)
        self.report_steps = [int(np.argmin(np.abs(self.times - t))) + 1
                             for t in plan.reports.values()]
        self.y0 = self.engine.x[:, 1].copy()
        e = self.engine
        # Every rank holds every point: rank 0's alone go into a checkpoint.
        self.rank = comm.getRank()
        self.points = checkpoint.ArrayPoints(lambda: {
            k: v if self.rank == 0 else v[:0]
            for k, v in {"x": e.x, "V0": e.V0, "sigma": e.sigma, "p": e.p,
                         **e.state}.items()})
        self.rows, self.profiles = [], []
        self.series = output.XdmfSeries(os.path.join(plan.outputs.folder, "points.xdmf"),
                                        run_id=run_id)
        self.first = 1
        if ckpt is not None:
            self._restore(ckpt)

    def time(self, k: int) -> float:
        return float(self.times[k - 1])

    def advance(self, k: int) -> None:
        h = 0.0 if k == 1 else self.times[k - 1] - self.times[k - 2]
        self.engine.step(h, self.plan.loading.load)

    def check(self, k: int) -> None:
        e = self.engine
        if not (np.isfinite(e.sigma).all() and np.isfinite(e.p).all()) or e.J.min() <= 0:
            raise NumericalError(f"the large-strain column failed at step {k} (t = "
                                 f"{self.time(k):.4g} s): a point's volume or stress is not "
                                 "finite")

    def sample(self, k: int) -> None:
        self.rows.append((self.time(k), self.engine.settlement))
        if k in self.report_steps:
            self.profiles.append((self.time(k), self.engine.p.copy()))

    def write_fields(self, k: int) -> None:
        if self.rank != 0:              # rank 0 holds the points as every rank does
            return
        e = self.engine
        z = np.zeros(len(e.x))
        self.series.write(k, self.time(k), e.x, {
            "displacement": np.column_stack([z, e.x[:, 1] - self.y0, z]),
            "pore_pressure": e.p, "effective_stress_yy": e.sigma[:, 1],
            "effective_stress_xx": e.sigma[:, 0], "volume_ratio": e.J,
            "void_ratio": e.void_ratio()})

    def state(self) -> dict:
        e = self.engine
        return {"edges": e.edges, "height": e.height, "p_nodes": e.p_nodes, "y0": self.y0,
                "rows": self.rows, "profiles": [(t, p) for t, p in self.profiles],
                "series": self.series.entries}

    def progress(self, k: int) -> str:
        return f"t = {self.time(k):.4g} s, settlement {self.engine.settlement:.5g} m"

    def _restore(self, ckpt) -> None:
        e, cols = self.engine, ckpt.columns()
        for name in ("x", "V0", "sigma", "p"):
            setattr(e, name, cols[name].reshape(np.shape(getattr(e, name))).copy())
        e.state = {k: cols[k].reshape(v.shape).astype(v.dtype) for k, v in e.state.items()}
        s = ckpt.state
        e.edges, e.height = np.array(s["edges"]), float(s["height"])
        e.p_nodes = np.array(s["p_nodes"])
        self.y0 = np.array(s["y0"])
        self.rows = [tuple(r) for r in s["rows"]]
        self.profiles = [(t, np.array(p)) for t, p in s["profiles"]]
        self.series.resume(s["series"], ckpt.run_id)
        self.first = int(s["step"]) + 1


def report(plan, model, record, comm) -> None:
    """settlement.csv, profiles.csv, the figure, the summary's block, the closing lines."""
    b, soil, q = plan.body, plan.soil, plan.loading.load
    H, E_c = b.size[1], soil.constrained_modulus
    t = np.array([r[0] for r in model.rows])
    s = np.array([r[1] for r in model.rows])
    gamma_b = (1 - soil.porosity) * (soil.rho_s - soil.rho_l) * plan.loading.gravity
    # The small strain's settlement: the column's own (a load and its weight, the
    # excess's mean decaying from the undrained start's), Terzaghi's for a load alone.
    p_top, p_base = analytic.undrained_excess(q, H, soil.porosity, E_c, None, soil.rho_s,
                                              soil.rho_l, plan.loading.gravity)
    small = analytic.column_settlement(analytic.column_mean(
        plan.c_v * t / H ** 2, b.drained, p_top, p_base), H, E_c, q, gamma_b) \
        - analytic.column_settlement(0.5 * (p_top + p_base), H, E_c, q, gamma_b)
    # Xie and Leo's settlement at every sample and pressures (/ q) at the report times.
    ref = ref_p = None
    if plan.xie_leo:
        args = (H, q, 1 / E_c, soil.k, soil.unit_weight_water, b.drained)
        ref = analytic.large_strain_column(0.0, t, *args)[1]
        ref_p = [analytic.large_strain_column(model.y0, ti, *args)[0] / q
                 for ti in plan.reports.values()]
    block = {"settlement_final_m": float(s[-1]), "small_strain_final_m": float(small[-1]),
             "t_end_s": float(t[-1]), "reports": []}
    for j, ((tv, ti), (_, p)) in enumerate(zip(plan.reports.items(), model.profiles)):
        k = int(np.argmin(np.abs(t - ti)))
        entry = {"Tv": tv, "t_s": ti, "settlement_m": float(s[k]),
                 "small_strain_m": float(small[k])}
        if ref is not None:
            entry.update(xie_leo_m=float(ref[k]),
                         settlement_error_pct=float(100 * (s[k] / ref[k] - 1)),
                         pressure_error_pct_of_q=float(100 * np.max(np.abs(p / q - ref_p[j]))))
        block["reports"].append(entry)
    ultimate = H * (1 - np.exp(-q / E_c)) if ref is not None else None
    block.update(_half_time(t, s, ref, ultimate))
    if ref is not None:
        block["reference"] = "Xie and Leo (2004), closed form (analytic.large_strain_column)"
    if gamma_b > 0:
        block["drained_end"] = drained_end(plan, model, gamma_b)
    _print(block, comm)
    record.results.update(block)
    if comm.getRank() == 0:
        folder = plan.outputs.folder
        files = record.files
        cols = ["t_s", "Tv", "settlement_m_downwards_positive", "small_strain_settlement_m"]
        table = [t, plan.c_v * t / H ** 2, s, small]
        if ref is not None:
            cols.append("xie_leo_settlement_m")
            table.append(ref)
        files["settlement"] = _csv(os.path.join(folder, "settlement.csv"), cols,
                                   np.column_stack(table))
        files["profiles"] = _profiles(os.path.join(folder, "profiles.csv"), plan, model,
                                      ref_p)
        if plan.outputs.figures:
            from .plots import large_strain
            files.update(large_strain(plan, model, (t, s, small, ref), ref_p,
                                      pressure_scale(plan)))
        if model.series.entries:
            files["fields_xdmf"] = model.series.path
            files["fields_h5"] = [os.path.join(folder, str(e[1]))
                                  for e in model.series.entries]
    record.finish()


DRAINED = 1e-2     # the largest excess pressure, of the undrained start's, of a drained end


def drained_end(plan, model, gamma_b: float) -> dict:
    """A column under its weight at its last step against its drained end's closed form
    (:func:`analytic.large_strain_final`: the effective stress at the points' material
    heights, the settlement), where it has drained (the largest excess pore pressure at
    most DRAINED of the undrained start's at the base); else how far it is."""
    b, soil, q = plan.body, plan.soil, plan.loading.load
    H, e = b.size[1], model.engine
    start = q + gamma_b * H
    left = float(np.max(np.abs(e.p))) / start
    out = {"largest_excess_pct_of_start": 100 * left}
    if left > DRAINED:
        return out
    s_ref, _, settle = analytic.large_strain_final(model.y0, H, q, gamma_b,
                                                   soil.constrained_modulus, plan.stress)
    out.update(stress_error_pct_of_largest=float(
        100 * np.max(np.abs(-e.sigma[:, 1] - s_ref)) / np.max(s_ref)),
        closed_form_settlement_m=float(settle),
        settlement_error_pct=float(100 * (e.settlement / settle - 1)))
    return out


def _half_time(t, s, ref, ultimate) -> dict:
    """The time (s) the settlement reaches half its ``ultimate`` value (the reference's,
    H (1 - exp(-m_vl q)); without a reference half the last), log-linear between the
    samples: the column's and, beside it, the reference's."""
    def when(values, target):
        k = int(np.searchsorted(values, target))
        if k == 0 or k >= len(values):
            return float("nan")
        a, b = np.log(t[k - 1]), np.log(t[k])
        return float(np.exp(a + (b - a) * (target - values[k - 1]) / (values[k] - values[k - 1])))
    if ref is None:
        return {"t_half_s": when(s, 0.5 * s[-1])}
    target = 0.5 * ultimate
    mine, theirs = when(s, target), when(ref, target)
    return {"t_half_s": mine, "xie_leo_t_half_s": theirs,
            "t_half_error_pct": 100 * (mine / theirs - 1)}


def _csv(path, cols, rows) -> str:
    output.write_text(path, ",".join(cols) + "\n" + "".join(
        ",".join(f"{v:.10g}" for v in row) + "\n" for row in rows))
    return path


def pressure_scale(plan) -> tuple:
    """(the scale (Pa) the excess pore pressure is written and drawn over, its name): q;
    under gravity p0 = q + gamma' H, the undrained start's at the base."""
    soil, H = plan.soil, plan.body.size[1]
    if plan.loading.gravity > 0:
        gamma_b = (1 - soil.porosity) * (soil.rho_s - soil.rho_l) * plan.loading.gravity
        return plan.loading.load + gamma_b * H, "p0"
    return plan.loading.load, "q"


def _profiles(path, plan, model, ref_p) -> str:
    """profiles.csv: every point's excess pressure / q (under gravity / p0,
    :func:`pressure_scale`) at each report time, beside Xie and Leo's ``ref_p`` (one array
    per report time, or None)."""
    q, name = pressure_scale(plan)
    cols = ["Tv", "t_s", "y0_m", "p_over_q_compression_positive" if name == "q" else
            "excess_p_over_p0_compression_positive"]
    if ref_p is not None:
        cols.append("xie_leo_p_over_q")
    rows = []
    for j, ((tv, ti), (_, p)) in enumerate(zip(plan.reports.items(), model.profiles)):
        extra = [ref_p[j]] if ref_p is not None else []
        rows += [np.column_stack([np.full(len(p), tv), np.full(len(p), ti), model.y0, p / q,
                                  *extra])]
    return _csv(path, cols, np.concatenate(rows) if rows else np.zeros((0, len(cols))))


def _print(block, comm) -> None:
    for r in block["reports"]:
        line = (f"T_v = {r['Tv']:.5g} (t = {r['t_s']:.5g} s): settlement {r['settlement_m']:.5g}"
                f" m (small strain {r['small_strain_m']:.5g} m)")
        if "xie_leo_m" in r:
            line += (f"; Xie and Leo {r['xie_leo_m']:.5g} m ({r['settlement_error_pct']:+.2f} "
                     f"%), excess pressure within {r['pressure_error_pct_of_q']:.3g} % of q")
        PETSc.Sys.Print(line, comm=comm)
    d = block.get("drained_end")
    if d is not None:
        PETSc.Sys.Print(
            f"Drained end (its weight, closed form): effective stress within "
            f"{d['stress_error_pct_of_largest']:.3g} % of its largest, settlement "
            f"{block['settlement_final_m']:.5g} m against {d['closed_form_settlement_m']:.5g}"
            f" m ({d['settlement_error_pct']:+.2f} %)" if "closed_form_settlement_m" in d
            else f"Not drained at the end (the largest excess pore pressure "
            f"{d['largest_excess_pct_of_start']:.3g} % of the undrained start's): its "
            "drained end not compared", comm=comm)
    if "xie_leo_t_half_s" in block:
        PETSc.Sys.Print(f"Half the final settlement at t = {block['t_half_s']:.5g} s; Xie and "
                        f"Leo {block['xie_leo_t_half_s']:.5g} s "
                        f"({block['t_half_error_pct']:+.2f} %)", comm=comm)


def check_given(given, from_file, large: bool) -> None:
    """InputError for the column's own options given on the command line to another
    consolidation run (a scene file's are left unread: the same column run small)."""
    if not large:
        for name in ONLY:
            if name in given and name not in from_file:
                raise InputError(f"-mpm_{name}: read with -mpm_scheme implicit "
                                 "-mpm_kinematics large only")
