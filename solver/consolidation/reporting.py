"""What a consolidation run reports: the monitor point, the profiles and their errors against
the references, the tables, the CSV files and the figures (Figs 3-5).

The set-up prints the critical time steps (:func:`print_limits`); the time loop hands its
results to a :class:`Reporting` at its steps; the run's end calls :func:`print_reports` and
:func:`write_files`. Everything here takes the run's
:class:`solver.consolidation.plan.Plan` or the few values it needs, never the options.
"""

from __future__ import annotations

import math
import os

import numpy as np
from petsc4py import PETSc

from ..modal import frequency
from ..io import output
from . import plots
from ..io.fields import PointSeries
from ..references import analytic
from . import fe_reference, settlement

ISOCHRONES = (0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0, 1.5, 2.0)


def title(plan) -> str:
    """'Q4 1 x 10 cells': the cells of a plan, for figure titles."""
    body = plan.body
    return f"{body.element.upper()} {body.cells[0]} x {body.cells[1]} cells"


class Reporting:
    """Where the time loop hands its results: the monitor and settlement samples, the
    profiles and reports at the isochrone and report steps, settlement.csv at each report,
    the field series; the records go into the run's ``state``. Made after the model, it
    resumes a restart's series and says so."""

    def __init__(self, plan, grid, points, state, comm):
        self.plan, self.comm, self.mpi = plan, comm, comm.tompi4py()
        self.state, self.points, refs = state, points, plan.refs
        self.H, self.q, self.ratio = plan.body.height, refs.q, refs.ratio
        self.files = {}
        self.series = PointSeries(plan.outputs.folder, comm, plan.run["id"])
        self.surface = settlement.Surface(grid, plan.soil, plan.loading, self.H,
                                          plan.body.ppc, refs,
                                          plan.probes.axis if plan.probes else None)
        self.heights = Heights()
        self.heights.refresh(points)
        if plan.restart:
            # The series files of the checkpoint's run (an older one's have no id).
            self.series.resume(self.state.series, plan.resumed_id)
            self.state.series = self.series.entries
            step = self.state.step
            PETSc.Sys.Print(f"Restart from {plan.restart} at step {step} "
                            f"(t = {plan.schedule.time(step):.6g} s)", comm=comm)

    def sample(self, t):
        """The monitor's p / q and the surface settlement and mean p at time ``t``."""
        Tv = self.plan.refs.time_factor(t)
        p = self.plan.refs.excess(monitor_pressure(self.points, self.mpi),
                                  self.plan.monitor_height)
        self.state.history.append((t, Tv, p / self.q))
        self.state.settlement.append((t, Tv, *self.surface.measure(self.points, self.mpi)))

    def isochrone(self, k, t):
        """The profile at isochrone step ``k``; at a report step its report, degree of
        consolidation and settlement.csv."""
        plan, state, comm = self.plan, self.state, self.comm
        schedule = plan.schedule
        prof = profile(self.points, comm)
        if comm.getRank() == 0:
            state.profiles.append((schedule.iso_steps[k], t, prof))
        if k in schedule.report_steps:
            Tv = schedule.report_steps[k]
            state.reports.append(report(Tv, t, self.points, self.mpi, plan.refs,
                                        plan.monitor_height, self.heights))
            state.degree.append(self.surface.report(Tv, state.settlement[-1]))
            if plan.probes is not None:     # a scene without a closed form: its trough
                trough = self.surface.trough(self.points, self.mpi)
                if trough is not None:
                    state.troughs.append((Tv, trough[0].tolist(), trough[1].tolist()))
            if comm.getRank() == 0:
                self.files["settlement_csv"] = self.surface.write_csv(
                    plan.outputs.folder, state.settlement)

    def write_fields(self, k, t):
        """The points' fields at step ``k`` into the series (collective)."""
        self.series.write(self.points, k, t)
        self.state.series = self.series.entries


def monitor_pressure(points, mpi):
    """p at the monitor height: the points' p weighted by their monitor weights (every
    10 steps: kept arrays and a buffer reduction, none on one rank)."""
    from mpi4py import MPI

    pp, mon = points.views("p", "monitor")
    s = np.array([float(np.sum(pp * mon)), float(np.sum(mon))])
    if mpi.Get_size() > 1:
        mpi.Allreduce(MPI.IN_PLACE, s, op=MPI.SUM)
    return s[0] / s[1]


def place_monitor(points, H, wanted_y, wanted_x, mpi) -> tuple:
    """Mark the monitor points in the field ``monitor``: the row of points nearest
    ``wanted_y`` (m; NaN: the highest below mid-height of a body of height H) and, unless
    ``wanted_x`` is NaN (the whole row, a column's monitor), in it the column nearest
    ``wanted_x`` (m); ties go to the larger value. Returns their (x0 or NaN, y0) (m)
    (collective)."""
    with points.fields("x0", "monitor") as (x0, mon):
        y0 = x0[:, 1]
        if math.isnan(wanted_y):
            from mpi4py import MPI

            below = y0[y0 < H / 2 - 1e-12 * H]
            y = mpi.allreduce(float(below.max()) if below.size else -np.inf, op=MPI.MAX)
        else:
            y = _nearest(y0, wanted_y, mpi, H)
        row = np.abs(y0 - y) < 1e-9 * H
        x = math.nan if math.isnan(wanted_x) else _nearest(x0[row, 0], wanted_x, mpi, H)
        mon[:] = row if math.isnan(x) else row & (np.abs(x0[:, 0] - x) < 1e-9 * H)
    return float(x), float(y)


def _nearest(values, wanted, mpi, scale):
    """The value nearest ``wanted`` of ``values`` on all ranks (ties: the larger);
    ``scale`` (m) sets the tolerance of a tie (collective)."""
    from mpi4py import MPI

    gap = np.abs(values - wanted)
    near = values[gap <= gap.min() + 1e-12 * scale].max() if values.size else np.inf
    dist = mpi.allreduce(abs(near - wanted), op=MPI.MIN)
    cand = near if abs(abs(near - wanted) - dist) < 1e-12 * scale else -np.inf
    return mpi.allreduce(cand, op=MPI.MAX)


def monitor_words(plan) -> str:
    """Where the monitor is, in words: 'at (x, y) = (0.03125, 0.46875) m' or 'at y = 0.45 m
    (the mean of its row of points)'."""
    if math.isnan(plan.monitor_x):
        return f"at y = {plan.monitor_height:.5g} m (the mean of its row of points)"
    return f"at (x, y) = ({plan.monitor_x:.5g}, {plan.monitor_height:.5g}) m"


def profile(points, comm):
    """(y0, p, volume, x) of every point, gathered on rank 0 (None elsewhere)."""
    x0, pp, V, x = points.views("x0", "p", "volume", "x")
    local = np.column_stack([x0[:, 1], pp, V, x[:, 0]])      # the one copy, 32 bytes a point
    if comm.getSize() == 1:
        return local
    parts = comm.tompi4py().gather(local, root=0)
    return np.concatenate(parts) if parts is not None else None


def report(Tv, t, points, mpi, refs, height, heights):
    """The monitor's excess pore pressure p / q at T_v = ``Tv`` (time t, s) and, where the
    scene has a reference, both forms of it at the monitor's height (m) and the profile's
    L2 errors (``heights``: :class:`Heights`); ``refs`` the plan's
    :class:`solver.consolidation.plan.References`."""
    q = refs.q
    num = refs.excess(monitor_pressure(points, mpi), height) / q
    r = {"Tv": Tv, "t": t, "p_over_q": num}
    if not refs.available:
        return r
    ref = float(refs.pressure(height, Tv, "classic"))
    con = float(refs.pressure(height, Tv, "consistent"))
    r.update({"terzaghi": ref, "consistent": con, "error_pct": 100 * (num - ref) / ref,
              "error_consistent_pct": 100 * (num - con) / con})
    r["l2_terzaghi"], r["l2_consistent"] = heights.l2_errors(
        points, mpi, q, [lambda y: refs.pressure(y, Tv, "classic"),
                         lambda y: refs.pressure(y, Tv, "consistent")],
        refs.excess if refs.hydrostatic else None)
    return r


class Heights:
    """The points' reference heights y0 (m) as the distinct values and each point's index
    into them, kept per point generation: a reference profile is evaluated once per
    distinct height (a few hundred on a structured placement) and each rank sums the
    errors of its own points, so a report at 1e6 points costs less than a step."""

    def __init__(self):
        self._generation = None

    def refresh(self, points):
        """Find the distinct heights (a sort of the points: 0.3 s at 1e6 points, done at
        set-up and again only after the points changed)."""
        if self._generation != points.generation:
            x0 = points.views("x0")
            self.values, self.index = np.unique(x0[:, 1], return_inverse=True)
            self._generation = points.generation

    def l2_errors(self, points, mpi, q, profiles, excess=None) -> list:
        """sqrt(sum V (p/q - exact)^2 / sum V) over all points for each ``profiles``
        function exact(height) (p/q, height in m); ``excess(p, y)`` turns the points'
        pore pressures into the excess the references give (None: as they are)."""
        from mpi4py import MPI

        self.refresh(points)
        pp, V = points.views("p", "volume")
        if excess is not None:
            pp = excess(pp, self.values[self.index])
        sums = np.array([float(np.sum(V * (pp / q - f(self.values)[self.index]) ** 2))
                         for f in profiles] + [float(np.sum(V))])
        if mpi.Get_size() > 1:
            mpi.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        return [float(np.sqrt(e / sums[-1])) for e in sums[:-1]]


def print_limits(comm, limits, dt, soil, body, scheme, patch, how):
    """The critical time steps, each with its formula's numbers, and the step used (how
    it was chosen: ``how``)."""
    S, f1, H = scheme.mass_scaling, limits.f1, body.height
    layers = soil.soils
    # Each wave and drag criterion is its governing layer's (timestep.criteria): the
    # fastest speed, the slowest drag decay; named when there are layers.
    each = [layer.wave_speeds(S) for layer in layers]
    speeds = {key: max(s[key] for s in each) for key in ("c", "c1", "c2")}
    rates = [layer.drag_rate(S) for layer in layers]

    def which(values, pick):
        return f" (layer {values.index(pick(values)) + 1})" if len(layers) > 1 else ""

    where = {key: which([s[key] for s in each], max) for key in ("c", "c1", "c2")}
    scaled = "" if S == 1 else f", inertia scaled by S = {S:.4g}"
    cells = frequency.f1_cells(body.element, body.cells)
    coarser = "" if cells == tuple(body.cells) else f", on {cells[0]} x {cells[1]} cells"
    notes = {"cfl": f"L/c, c = {speeds['c']:.4g} m/s{scaled}{where['c']}",
             "undrained": f"L/c1, c1 = {speeds['c1']:.4g} m/s{scaled}{where['c1']}",
             "diffusion": f"L^2/(2 c2), c2 = {speeds['c2']:.4g} m2/s{where['c2']}",
             "oscillator": f"L/c3, c3 = 2 pi f1 H = "
                           f"{2 * np.pi * f1 / np.sqrt(S) * H:.4g} m/s "
                           f"(f1 = {f1 / np.sqrt(S):.4g} Hz{scaled}{coarser})",
             "drag": f"2/lambda, lambda = {min(rates):.4g} 1/s{which(rates, min)}"
                     + ("" if scheme.drag == "explicit"
                        else " (no limit: the drag is implicit)"),
             "discrete": "stability limit of the linearised MPM step itself"
                         + ("" if tuple(patch) == tuple(body.cells)
                            else f" (found on a {patch[0]} x {patch[1]} cell patch)")}
    lines = ["Critical time steps (s):"]
    lines += [f"  {k:<11s}{v:11.3e}   {notes[k]}" for k, v in limits.steps.items()]
    lines.append(f"  used       {dt:11.3e}   ({how})")
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def print_reports(comm, reports, refs, where=""):
    """The monitor's p / q at the report times against the scene's reference (``refs``),
    or alone where the scene has none (and no FE reference, whose table has it);
    ``where``: the monitor's place in words (:func:`monitor_words`)."""
    if not refs.available:
        if refs.fe is not None:
            return
        lines = [f"Excess pore pressure p/q at the monitor point {where} (no reference):",
                 f"{'T_v':>6s}{'p/q':>9s}"]
        lines += [f"{r['Tv']:6.2f}{r['p_over_q']:9.3f}" for r in reports]
        PETSc.Sys.Print("\n".join(lines), comm=comm)
        return
    if refs.terzaghi:
        title, name, l2 = ("Normalised pore pressure p/q at the monitor point (Tables 4 "
                           "and 5):", "Terzaghi", "L2 Terz.")
    else:
        title, name, l2 = ("Excess pore pressure p/q at the monitor point against the "
                           "scene's reference:", "classic", "L2 clas.")
    lines = [title,
             f"{'T_v':>6s}{'p/q':>9s}{name:>10s}{'error':>9s}{'consistent':>12s}"
             f"{'error':>9s}{l2:>10s}{'L2 cons.':>10s}"]
    for r in reports:
        lines.append(f"{r['Tv']:6.2f}{r['p_over_q']:9.3f}{r['terzaghi']:10.3f}"
                     f"{r['error_pct']:8.2f}%{r['consistent']:12.3f}"
                     f"{r['error_consistent_pct']:8.2f}%{r['l2_terzaghi']:10.4f}"
                     f"{r['l2_consistent']:10.4f}")
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def print_fe(comm, plan, state) -> dict | None:
    """A scene without a closed form: the run against its FE reference at the report
    times (:func:`fe_reference.compare`), printed; the summary's entry (without an FE
    reference: why); None for a column."""
    refs = plan.refs
    if plan.probes is None:
        return None
    if refs.fe is None:
        return fe_reference.summary(None, refs.fe_why)
    rows = fe_reference.compare(refs.fe, refs.q, state.reports, state.degree,
                                state.profiles, refs.excess)
    loading = plan.loading
    extent = loading.extent if loading.partial(plan.body.size[0]) else (0.0, plan.body.size[0])
    fe_reference.print_comparison(comm, rows, refs.fe, extent)
    return fe_reference.summary(refs.fe, "", rows)


def write_files(plan, profiles, history):
    """Isochrones (Figs 4-5), the pressure field (Fig 3), the monitor history; rank 0."""
    files, folder, refs = {}, plan.outputs.folder, plan.refs
    q, gravity = refs.q, refs.hydrostatic > 0
    hist = np.array(history) if history else np.zeros((0, 3))
    files["monitor_csv"] = os.path.join(folder, "monitor.csv")
    with output.atomic(files["monitor_csv"]) as tmp:
        np.savetxt(tmp, hist, delimiter=",", comments="", header="t_s,Tv," + (
            "excess_p_over_q" if gravity else "p_over_q") + "_compression_positive")
    # Every point's pore pressure at every isochrone time: enough to redraw Figs 3-5; under
    # gravity the total and the excess over hydrostatic.
    files["profiles_csv"] = os.path.join(folder, "profiles.csv")
    with output.atomic(files["profiles_csv"]) as tmp, open(tmp, "w") as fh:
        fh.write("Tv,t_s,x_m,y0_m,p_over_q_compression_positive,volume_m3"
                 + (",excess_p_over_q_compression_positive\n" if gravity else "\n"))
        for Tv, t, prof in profiles:         # one isochrone at a time: 48 bytes per point
            cols = [np.full(len(prof), Tv), np.full(len(prof), t), prof[:, 3], prof[:, 0],
                    prof[:, 1] / q, prof[:, 2]]
            if gravity:
                cols.append(refs.excess(prof[:, 1], prof[:, 0]) / q)
            np.savetxt(fh, np.column_stack(cols), delimiter=",")
    if refs.fe is not None:
        files["fe_reference_csv"] = fe_reference.write_csv(folder, refs.fe, refs)
    if plan.outputs.figures:
        files.update(_figures(plan, profiles, hist))
    return files


def _figures(plan, profiles, hist):
    """isochrones, pressure_field and monitor in the plan's figure formats."""
    plt, out = output.pyplot(), plan.outputs
    draw = _axis_figure if plan.probes is not None else _isochrone_figure
    files = output.save_figures(draw(plt, plan, profiles), out.folder, "isochrones",
                                out.formats)
    shown = [pr for pr in profiles if pr[0] in plan.schedule.Tv_report] or profiles[-1:]
    excess = plan.refs.excess
    fig = plots.pressure_field(
        plt, [(Tv, prof[:, 3], prof[:, 0], excess(prof[:, 1], prof[:, 0]))
              for Tv, _, prof in shown],
        plan.refs.q, f"Pore pressure field, {plan.body.element.upper()}, "
                     f"{len(shown[0][2])} MPs", width=plan.body.size[0],
        height=plan.body.size[1], soil=plan.soil)
    files.update(output.save_figures(fig, out.folder, "pressure_field", out.formats))
    files.update(output.save_figures(_monitor_figure(plt, plan, hist), out.folder, "monitor",
                                     out.formats))
    return files


def _isochrone_figure(plt, plan, profiles):
    """The points' p / q at each report time over both references, coloured by T_v."""
    refs = plan.refs
    fig, ax = plt.subplots(figsize=(6, 6))
    colors = plots.tv_colors(plt, len(profiles))
    if refs.available:
        plots.isochrone_references(
            ax, [Tv for Tv, _, _ in profiles], colors, refs.H, refs.ratio, refs.p0,
            None if refs.terzaghi else refs.pressure)
    for i, ((Tv, _, prof), col) in enumerate(zip(profiles, colors)):
        k = plots.drawn(len(prof))
        ax.plot(refs.excess(prof[k, 1], prof[k, 0]) / refs.q, prof[k, 0], "o", color=col,
                ms=3, mfc="none", label=None if i else "MPM points")
    output.layer_interfaces(ax, plan.soil, label=True)
    ax.set_title(f"Isochrones, {title(plan)}")
    plots.legend_below(ax, ncol=2)
    return fig


def _axis_figure(plt, plan, profiles):
    """A scene without a closed form: the excess p / q of the column of points nearest its
    axis against height at each isochrone time, with the FE's profile there."""
    refs, pr = plan.refs, plan.probes
    fe = refs.fe
    spacing = np.min(np.diff(pr.trough)) if len(pr.trough) > 1 else refs.H
    snapshots, lines = [], []
    for Tv, t, prof in profiles:
        mine = prof[np.abs(prof[:, 3] - pr.column) < spacing / 4]
        order = np.argsort(mine[:, 0])
        y = mine[order, 0]
        snapshots.append((Tv, y, refs.excess(mine[order, 1], y) / refs.q))
        try:
            j = fe.index(t) if fe is not None else None
        except KeyError:
            j = None
        if j is not None:
            lines.append((Tv, np.linspace(0.0, refs.H, fe.line.shape[1]), fe.line[j] / refs.q))
    return plots.axis_profiles(
        plt, snapshots, lines, refs.H,
        f"Pore pressure under the axis (x = {pr.column:.4g} m), {title(plan)}"
        + (f"\nFE reference: Q9/Q4 {fe.cells[0]} x {fe.cells[1]} cells" if fe is not None
           else ""), plan.soil)


def _monitor_figure(plt, plan, hist):
    """p / q at the monitor point against T_v, with both references at its depth."""
    refs, height = plan.refs, plan.monitor_height
    H = refs.H
    fig, ax = plt.subplots(figsize=(7, 4))
    ax.plot(hist[:, 1], hist[:, 2], lw=0.8, label="MPM")
    Tv = np.geomspace(1e-4, plan.schedule.Tv_end, 400)
    if refs.terzaghi:
        ax.plot(Tv, analytic.terzaghi(H - height, Tv, H), color="k",
                label="Terzaghi, classic", **plots.CLASSIC)
        ax.plot(Tv, analytic.terzaghi(H - height, Tv * refs.ratio, H, refs.p0), color="k",
                label="Terzaghi, compressible water", **plots.COMPRESSIBLE)
    elif refs.available:
        ax.plot(Tv, refs.pressure(height, Tv, "classic"), color="k",
                label="reference, classic", **plots.CLASSIC)
        ax.plot(Tv, refs.pressure(height, Tv, "consistent"), color="k",
                label="reference, compressible water", **plots.COMPRESSIBLE)
    elif refs.fe is not None:
        fe = refs.fe
        ax.plot(refs.time_factor(fe.t), fe.monitor / refs.q, "k", marker=".",
                label=f"FE reference ({fe.cells[0]} x {fe.cells[1]} Q9/Q4)", **plots.CLASSIC)
    ax.set_xscale("log")
    ax.set_xlabel("time factor T_v = c_v t / H^2 (-)")
    ax.set_ylabel(f"p / q at {height:.4g} m (-)" if math.isnan(plan.monitor_x)
                  else f"excess p / q at ({plan.monitor_x:.4g}, {height:.4g}) m (-)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    return fig
