"""The finite-element reference of a scene without a closed form: the same body solved again
by :mod:`solver.references.biot`, set beside the run.

A load over part of the top, drainage through a side, layers under a local load: no closed
form gives such a scene's consolidation, so the set-up solves the scene itself by quasi-
static Biot finite elements (Taylor-Hood Q9/Q4, TR-BDF2: :func:`solve`, on rank 0, seconds
at the sizes of cases/) at the run's own report and isochrone times and at the doublings of
time before them, and the reporting sets beside it (:func:`compare`):

- the settlement at the axis under the load (m, downwards): the surface's at x = axis;
- the mean settlement under the load (m): the surface's mean over the loaded part;
- the monitor point's excess pore pressure p / q (the FE's pressures are the excess: it has
  no gravity; a run at rest under gravity before its load, ``-mpm_initial_state
  geostatic``, compares its excess over hydrostatic);
- the pore pressure under the axis (the column of points nearest it) and the trough.

The FE is the scene's own reference: the same size, layers, supports, drained sides, load
and soil (compressible water: the MPM's model without inertia). Where it is not, there is
none (:func:`why_not`): a fresh deposit under gravity (biot has no body force), a load that
rises over time (biot applies a step), a side drained under gravity (the MPM holds p = 0 there,
not the hydrostatic pressure). Its grid (:func:`cells`) has square cells, 32 across the
shorter side where that keeps within ``TARGET_CELLS`` (about 1e-3 q: biot's docstring and
docs/method.md), the layer interfaces on cell boundaries (biot needs them there) and the
load's edges too where the MPM's cells allow. SI units.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common.errors import InputError, NumericalError
from ..io import output
from ..model import shapes
from ..references import biot
from . import plan

TARGET_CELLS = 2048     # 64 x 32 on the strip of cases/: about 5 s on one core
ACROSS = 32             # cells across the shorter side, within TARGET_CELLS
LINE = 101              # heights of the FE's profile under the axis in the figure
DOUBLINGS = 10          # doublings of time before the run's first report or isochrone
# TR-BDF2 steps per doubling of time: 8 leave 3e-5 q on the strip of cases/ (16: 1e-5 q,
# a third more time), two orders below the grid's error; docs/method.md.
STEPS = 8


@dataclass(frozen=True)
class Probes:
    """Where the run and the FE are compared (m): the ``monitor`` point (x, y), the
    ``axis``, the x of the column of points nearest it (``column``) and their heights
    (``heights``, ascending), the x of the top row's columns of points (``trough``), the
    height H of the body and the x of the static ends' surface (``ends_x``: the top
    nodes', solver/references/static.py; () without them); ``rows`` the heights of every
    row of points (ascending): with ``trough`` the lattice of every point's position."""

    monitor: tuple
    axis: float
    column: float
    heights: tuple
    trough: tuple
    H: float
    ends_x: tuple = ()
    rows: tuple = ()


@dataclass(frozen=True)
class FEReference:
    """The FE solution at the times ``t`` (s, ascending, each a time the run reaches; ``Tv``
    the run's T_v of each, as the run names its report and isochrone times): the pore
    pressure (Pa) at the ``monitor``, at the ``column``'s heights (nt, nh) and on a
    ``line`` of LINE heights from 0 to H under it (nt, LINE); the settlement (m, downwards)
    at the ``axis``, its ``mean`` under the load and the ``trough`` at the probes' x
    (nt, nx); ``ends`` {"undrained" (t = 0+), "drained" (t -> infinity): {"axis", "mean",
    "trough", "static_x" (at the probes' ends_x), "monitor" (Pa)}}. ``cells`` (NX, NY)
    Q9/Q4 cells, ``steps`` and ``factorizations`` taken, ``seconds`` of wall time; ``field``
    the pore pressure (Pa) at every point's position, (nt, len(rows), len(trough))."""

    probes: Probes
    cells: tuple
    steps: int
    factorizations: int
    seconds: float
    t: np.ndarray
    Tv: np.ndarray
    monitor: np.ndarray
    column: np.ndarray
    line: np.ndarray
    axis: np.ndarray
    mean: np.ndarray
    trough: np.ndarray
    ends: dict
    field: np.ndarray = None

    def index(self, t: float) -> int:
        """The index of time ``t`` (s) in ``self.t``; KeyError if the FE was not asked it."""
        i = int(np.argmin(np.abs(self.t - t)))
        if not math.isclose(self.t[i], t, rel_tol=1e-9):
            raise KeyError(f"the FE reference has no time {t:g} s")
        return i

    def trough_at(self, Tv: float):
        """The trough (m) at the probes' x at the run's time factor ``Tv``, or None."""
        i = np.flatnonzero(np.isclose(self.Tv, Tv, rtol=1e-12, atol=0))
        return self.trough[i[0]] if i.size else None

    def describe(self) -> str:
        """The FE in words, for the banner and the tables."""
        return (f"solver/references/biot.py, Q9/Q4 on {self.cells[0]} x {self.cells[1]} cells, "
                f"{self.steps} TR-BDF2 steps, {self.factorizations} factorizations, "
                f"{self.seconds:.1f} s")


def why_not(refs, loading, wanted: bool) -> str:
    """Why the scene gets no FE reference ('' when it gets one): it has a closed form, the
    FE is turned off (``wanted`` False: -mpm_fe_reference 0) or would not be the scene's
    own. ``refs`` the plan's References, ``loading`` scene.Loading. (A side drained under
    gravity holds the water table's hydrostatic pressure, so its excess is the FE's.)"""
    if refs.available:
        return "the scene has a closed form"
    if refs.fe_why:
        return refs.fe_why
    if not wanted:
        return "turned off (-mpm_fe_reference 0)"
    if loading.self_weight:
        return ("a fresh deposit under gravity (-mpm_initial_state deposited): "
                "solver/references/biot.py has no body force")
    if loading.ramp > 0:
        return "the load rises over -mpm_load_ramp: solver/references/biot.py applies it at once"
    return ""


def _aligned(n: int, marks, length: float, mpm_cells: int) -> int:
    """The least count m >= n of cells on ``length`` (m) with every mark (m from 0) on a cell
    boundary, for marks on the MPM's ``mpm_cells`` boundaries (m a multiple of the coarsest
    such grid); n for marks off them."""
    where = [x * mpm_cells / length for x in marks]
    if any(abs(w - round(w)) > 1e-9 * mpm_cells for w in where):
        return n
    base = mpm_cells // math.gcd(mpm_cells, *(int(round(w)) for w in where))
    return base * math.ceil(n / base)


def cells(body, soil, loading) -> tuple:
    """(NX, NY) of the FE grid: square cells, ACROSS across the shorter side or as many as
    keep the grid within about TARGET_CELLS, the layer interfaces of ``soil`` on cell
    boundaries (needed) and the load's edges where they lie on the MPM's cell boundaries
    and that costs at most twice the cells across."""
    W, H = body.size
    h = max(min(W, H) / ACROSS, math.sqrt(W * H / TARGET_CELLS))
    ny = _aligned(max(1, round(H / h)), list(getattr(soil, "bottoms", ())[:-1]), H,
                  body.cells[1])
    n = max(1, round(W / h))
    edges = [x for x in loading.extent if 0 < x < W] if loading.partial(W) else []
    nx = _aligned(n, edges, W, body.cells[0])
    return (nx if nx <= 2 * n else n), ny


def check_cells(fe_cells, layers, H: float):
    """InputError when the FE grid ``fe_cells`` (-mpm_fe_cells NX,NY) puts an interface of
    the ``layers`` (thicknesses from the surface down, m, of a body H high) inside a cell."""
    if not fe_cells or len(layers) < 2:
        return
    ny = fe_cells[1]
    depth = np.cumsum(layers)[:-1] * ny / H
    if np.any(np.abs(depth - np.round(depth)) > 1e-9 * ny):
        raise InputError(f"-mpm_fe_cells {fe_cells[0]},{ny}: a layer interface lies inside "
                         f"an FE cell ({ny} cells up; interfaces at depths "
                         + ", ".join(f"{d:g}" for d in np.cumsum(layers)[:-1]) + " m)")


def body_of(soil, body, loading) -> biot.Body:
    """The biot.Body of the run's ``soil`` (a Soil or a soil.Ground), ``body`` and
    ``loading``: the load q as a step on its extent."""
    soils = soil.soils
    layered = len(soils) > 1

    def per(name):
        values = tuple(getattr(s, name) for s in soils)
        return values if layered else values[0]

    return biot.Body(size=body.size, E=per("E"), nu=per("nu"), k=per("k"),
                     porosity=per("porosity"), K_l=soils[0].K_l, rho_l=soils[0].rho_l,
                     load=loading.load,
                     loaded=loading.extent if loading.partial(body.size[0]) else None,
                     drained=body.drained, bcs=body.supports,
                     layers=tuple(soil.thickness) if layered else None)


def probes(points, body, axis: float, monitor: tuple, mpi, ends_x=()) -> Probes:
    """The probes of the run's ``points`` (collective): the column of points nearest the
    ``axis`` (m; ties: the larger x) and the top row's columns; ``monitor`` (x, y) (m),
    ``ends_x`` the static ends' x (m)."""
    W, H = body.size
    hy = body.cell_size()[1]
    x0 = points.views("x0")
    top = np.unique(np.concatenate(mpi.allgather(np.unique(x0[x0[:, 1] > H - hy, 0]))))
    gap = np.abs(top - axis)
    column = float(top[np.flatnonzero(gap <= gap.min() + 1e-12 * W)[-1]])
    mine = x0[np.abs(x0[:, 0] - column) < 1e-9 * W, 1]
    heights = np.unique(np.concatenate(mpi.allgather(np.unique(mine))))
    rows = np.unique(np.concatenate(mpi.allgather(np.unique(x0[:, 1]))))
    return Probes(tuple(float(v) for v in monitor), float(axis), column,
                  tuple(heights.tolist()), tuple(top.tolist()), H,
                  tuple(float(x) for x in ends_x), tuple(rows.tolist()))


def times(schedule, time_factor) -> tuple:
    """(t (s), T_v): the times the FE is asked, the run's report and isochrone steps'
    (exactly the run's times, with the T_v the run names them by) and DOUBLINGS halvings
    of time before the first, down to the run's first sample (10 explicit steps, or the
    implicit scheme's first step): the steps biot's schedule takes anyway (T_v from
    ``time_factor(t)``)."""
    named = {**schedule.iso_steps, **schedule.report_steps}
    steps = sorted(k for k in named if k > 0)
    first = schedule.time(steps[0])
    before = first * 2.0 ** -np.arange(DOUBLINGS, 0, -1)
    before = before[before >= schedule.time(schedule.sample_every)]
    return (np.r_[before, [schedule.time(k) for k in steps]],
            np.r_[[time_factor(t) for t in before], [named[k] for k in steps]])


def _mean_points(fe_cells, W: float, extent) -> tuple:
    """(x, weights): Gauss points on each FE cell's part of the loaded ``extent`` and the
    weights whose sum with the surface settlement there is its mean under the load: exact
    for the cells' polynomials."""
    x0, x1 = extent
    edges = np.linspace(0.0, W, fe_cells[0] + 1)
    a, b = np.maximum(edges[:-1], x0), np.minimum(edges[1:], x1)
    keep = b > a
    g, w = shapes.gauss_1d(3)
    span = (b - a)[keep][:, None]
    x = a[keep][:, None] + span * (g + 1) / 2
    return x.ravel(), (span * w / 2).ravel() / (x1 - x0)


def _solve_here(fe_body, probes_: Probes, asked, fe_cells) -> FEReference:
    """The FE solution at the probes (rank 0's part of :func:`solve`)."""
    pr = probes_
    W, H = fe_body.size
    line = np.linspace(0.0, H, LINE)
    col = np.r_[pr.heights, line]
    X, Y = np.meshgrid(pr.trough, pr.rows, indexing="xy")
    pts = np.vstack([[pr.monitor], np.column_stack([np.full(len(col), pr.column), col]),
                     np.column_stack([X.ravel(), Y.ravel()])])
    gx, gw = _mean_points(fe_cells, W, fe_body.loaded)
    nt = len(pr.trough)
    ne = len(pr.ends_x)
    surface = np.r_[pr.axis, pr.trough, pr.ends_x, gx]
    t0 = time.perf_counter()
    r = biot.solve(PETSc.COMM_SELF, fe_body, asked[0], pts, surface=surface, cells=fe_cells,
                   steps=STEPS)
    seconds = time.perf_counter() - t0

    def split(s):
        # The surface's columns: the axis, the trough's x, the static ends' x, the mean's
        # Gauss points.
        s = np.atleast_2d(s)
        return s[:, 0], s[:, 1 + nt + ne:] @ gw, s[:, 1:1 + nt], s[:, 1 + nt:1 + nt + ne]

    nh = len(pr.heights)
    axis, mean, trough, _ = split(r.settlement)
    ends = {}
    for name, values, p in (("undrained", r.undrained, r.undrained_pressure[0]),
                            ("drained", r.drained, 0.0)):
        a, m, tr, st = split(values)
        ends[name] = {"axis": float(a[0]), "mean": float(m[0]), "trough": tr[0],
                      "static_x": st[0], "monitor": float(p)}
    return FEReference(pr, tuple(fe_cells), r.steps, r.factorizations, seconds,
                       asked[0], asked[1], r.pressure[:, 0], r.pressure[:, 1:1 + nh],
                       r.pressure[:, 1 + nh:1 + len(col)], axis, mean, trough, ends,
                       r.pressure[:, 1 + len(col):].reshape(-1, len(pr.rows),
                                                            len(pr.trough)))


def solve(comm, soil, body, loading, schedule, probes_: Probes, time_factor,
          fe_cells=()) -> tuple:
    """(the FEReference, '') of the scene, or (None, why not) where biot refuses it; solved
    on rank 0, the same on every rank (collective); ``time_factor(t)`` the run's T_v of
    time t (s); ``fe_cells`` (NX, NY) the FE's grid (empty: :func:`cells`'). Prints what
    it solved and its time."""
    fe_cells = tuple(fe_cells) or cells(body, soil, loading)
    result = None
    if comm.getRank() == 0:
        try:
            result = _solve_here(body_of(soil, body, loading), probes_,
                                 times(schedule, time_factor), fe_cells)
        except (InputError, NumericalError) as exc:
            result = f"solver/references/biot.py: {exc}"
    result = comm.tompi4py().bcast(result, root=0)
    if isinstance(result, str):
        PETSc.Sys.Print(f"No FE reference: {result}", comm=comm)
        return None, result
    PETSc.Sys.Print(f"FE reference: this scene by quasi-static finite elements "
                    f"({result.describe()}), set against the run at its report times",
                    comm=comm)
    return result, ""


def attach(comm, refs, scene_, points, schedule, monitor, wanted, fe_cells=()) -> tuple:
    """(the references ``refs`` with the FE reference of a scene without a closed form,
    or why it has none; its :class:`Probes`, None for a column); ``scene_`` (soil, body,
    loading), ``monitor`` (x, y) (m), ``wanted`` -mpm_fe_reference, ``fe_cells``
    -mpm_fe_cells (collective)."""
    if refs.available:
        return refs, None
    soil, body, loading = scene_
    found = probes(points, body, plan.axis(body, loading), monitor, comm.tompi4py(),
                   refs.static.x if refs.static else ())
    why = why_not(refs, loading, wanted)
    if why:
        PETSc.Sys.Print(f"No FE reference: {why}", comm=comm)
        return dataclasses.replace(refs, fe_why=why), found
    fe, why = solve(comm, soil, body, loading, schedule, found, refs.time_factor, fe_cells)
    return dataclasses.replace(refs, fe=fe, fe_why=why), found


def _column_error(fe, j: int, prof, q: float, excess) -> float:
    """The largest |p/q - FE| (% of q) over the run's column of points under the axis in
    the profile ``prof`` ((y0, p, volume, x) rows,
    :func:`solver.consolidation.reporting.profile`)."""
    pr = fe.probes
    spacing = np.min(np.diff(pr.trough)) if len(pr.trough) > 1 else pr.H
    mine = prof[np.abs(prof[:, 3] - pr.column) < spacing / 4]
    heights = np.asarray(pr.heights)
    k = np.clip(np.searchsorted(heights, mine[:, 0] - 1e-9 * pr.H), 0, len(heights) - 1)
    p = excess(mine[:, 1], mine[:, 0]) / q
    return float(100 * np.max(np.abs(p - fe.column[j, k] / q))) if len(mine) else math.nan


def _point_errors(fe, j: int, prof, q: float, excess) -> tuple:
    """(the RMS, the largest |.|) of p/q - FE (% of q) over every point of the profile
    ``prof`` ((y0, p, volume, x) rows), the FE at each point's position."""
    pr = fe.probes
    xs, ys = np.asarray(pr.trough), np.asarray(pr.rows)
    if not len(prof) or fe.field is None or not len(ys):
        return math.nan, math.nan
    i = np.clip(np.searchsorted(ys, prof[:, 0] - 1e-9 * pr.H), 0, len(ys) - 1)
    # The current x is within a displacement of the column's: the nearest column.
    k = np.clip(np.searchsorted((xs[1:] + xs[:-1]) / 2, prof[:, 3]), 0, len(xs) - 1)
    d = excess(prof[:, 1], prof[:, 0]) / q - fe.field[j, i, k] / q
    return float(100 * np.sqrt(np.mean(d * d))), float(100 * np.max(np.abs(d)))


def compare(fe, q: float, reports, degree, profiles=(), excess=None) -> list:
    """The run against the FE at its report times: from the run's ``reports`` (p / q at
    the monitor) and ``degree`` (the settlement at the axis and the mean under the load),
    with the FE's and the errors (a settlement's in % of the FE's, p's in % of q ``q``
    (Pa)); with ``profiles`` (rank 0's (T_v, t, profile) records) and ``excess(p, y)`` the
    largest error in the column under the axis. NaN where the FE was not asked the time
    (a restart that changed the report times)."""
    by_t = {t: prof for _, t, prof in profiles}
    rows = []
    for r, d in zip(reports, degree):
        row = {"Tv": r["Tv"], "t": r["t"]}
        try:
            j = fe.index(r["t"])
            fes = (fe.axis[j], fe.mean[j], fe.monitor[j] / q)
        except KeyError:
            j, fes = None, (math.nan,) * 3
        runs = (d.get("settlement_axis_m", math.nan), d["settlement_m"], r["p_over_q"])
        for key, mpm, ref in zip(("settlement_axis", "settlement_mean"), runs, fes):
            row.update({f"{key}_m": mpm, f"fe_{key}_m": ref,
                        f"error_{key}_pct": 100 * (mpm / ref - 1)})
        row.update(p_over_q=runs[2], fe_p_over_q=fes[2],
                   error_p_pct_of_q=100 * (runs[2] - fes[2]))
        if j is not None and r["t"] in by_t and excess is not None:
            row["error_profile_max_pct_of_q"] = _column_error(fe, j, by_t[r["t"]], q, excess)
            row["error_rms_pct_of_q"], row["error_max_pct_of_q"] = _point_errors(
                fe, j, by_t[r["t"]], q, excess)
        rows.append(row)
    return rows


def print_comparison(comm, rows, fe, extent):
    """The table of :func:`compare`'s rows; ``extent`` (x0, x1) (m) of the load."""
    pr = fe.probes
    profile = bool(rows) and "error_profile_max_pct_of_q" in rows[0]
    lines = [f"Against the FE reference ({fe.describe()}): the settlement (mm) at the axis "
             f"x = {pr.axis:g} m and its mean under the load ({extent[0]:g} <= x <= "
             f"{extent[1]:g} m), errors in % of the FE's; the excess pore pressure p/q at "
             f"the monitor (x, y) = ({pr.monitor[0]:.5g}, {pr.monitor[1]:.5g}) m"
             + (f" and its largest error in the column under the axis (x = {pr.column:.5g}"
                " m) and the RMS and largest error over every point (the FE at each point's"
                " position)"
                if profile else "") + ", errors in % of q:",
             f"{'T_v':>6s}{'axis':>9s}{'FE':>9s}{'error':>8s}{'mean':>9s}{'FE':>9s}"
             f"{'error':>8s}{'p/q':>8s}{'FE':>8s}{'error':>8s}"
             + (f"{'column':>8s}{'RMS':>8s}{'max':>8s}" if profile else "")]
    for r in rows:
        mm = [1e3 * r[k] for k in ("settlement_axis_m", "fe_settlement_axis_m",
                                  "settlement_mean_m", "fe_settlement_mean_m")]
        lines.append(f"{r['Tv']:6.3g}{mm[0]:9.4f}{mm[1]:9.4f}"
                     f"{r['error_settlement_axis_pct']:+7.2f}%{mm[2]:9.4f}{mm[3]:9.4f}"
                     f"{r['error_settlement_mean_pct']:+7.2f}%{r['p_over_q']:8.3f}"
                     f"{r['fe_p_over_q']:8.3f}{r['error_p_pct_of_q']:+8.2f}"
                     + (f"{r.get('error_profile_max_pct_of_q', math.nan):8.2f}"
                        f"{r.get('error_rms_pct_of_q', math.nan):8.3f}"
                        f"{r.get('error_max_pct_of_q', math.nan):8.2f}" if profile else ""))
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def summary(fe, why: str, rows=()) -> dict:
    """The summary's entry of the FE reference: where it was solved and how, its ends,
    and the comparison's ``rows`` as lists; or why there is none."""
    if fe is None:
        return {"available": False, "why": why}
    pr = fe.probes
    out = {"available": True, "solver": "solver/references/biot.py", "element": "q9/q4",
           "cells": list(fe.cells), "steps_per_doubling": STEPS, "steps": fe.steps,
           "factorizations": fe.factorizations,
           "wall_seconds": fe.seconds, "monitor_m": list(pr.monitor), "axis_x_m": pr.axis,
           "column_x_m": pr.column,
           **{name: {f"settlement_{k}_m": e[k] for k in ("axis", "mean")}
              for name, e in fe.ends.items()}}
    for key in rows[0] if rows else ():
        out[key] = [r.get(key) for r in rows]
    return out


def write_csv(folder, fe, refs) -> str:
    """fe_reference.csv: the FE's settlement at the axis and mean under the load and the
    monitor's excess p / q at each of its times, then its ends as rows t = 0 (undrained,
    t = 0+) and t = inf (drained); ``refs`` the plan's References (T_v, q); rank 0."""
    path = os.path.join(folder, "fe_reference.csv")
    ends = [fe.ends["undrained"], fe.ends["drained"]]
    t = np.r_[fe.t, 0.0, np.inf]
    table = np.column_stack([t, refs.time_factor(t),
                             np.r_[fe.axis, [e["axis"] for e in ends]],
                             np.r_[fe.mean, [e["mean"] for e in ends]],
                             np.r_[fe.monitor, [e["monitor"] for e in ends]] / refs.q])
    with output.atomic(path) as tmp, open(tmp, "w") as fh:
        fh.write("t_s,Tv,settlement_axis_m_downwards_positive,"
                 "settlement_mean_under_load_m_downwards_positive,"
                 "monitor_excess_p_over_q_compression_positive\n"
                 f"# solver/references/biot.py, Q9/Q4 on {fe.cells[0]} x {fe.cells[1]} cells; the "
                 f"axis x = {fe.probes.axis:g} m, the monitor (x, y) = ({fe.probes.monitor[0]:g}, "
                 f"{fe.probes.monitor[1]:g}) m; the last two rows are the FE's ends: t_s = 0 "
                 "undrained (t = 0+), t_s = inf drained (p = 0)\n")
        np.savetxt(fh, table, delimiter=",")
    return path
