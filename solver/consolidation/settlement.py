"""The surface settlement and the degree of consolidation of a consolidation run: U from the
settlement and from the mean pore pressure against both Terzaghi references, their table,
``settlement.csv`` and the figures of U against T_v and of the settlement against time."""

from __future__ import annotations

import os

import numpy as np
from petsc4py import PETSc

from ..io import output
from . import plots
from ..references import analytic


class Surface:
    """Surface settlement and mean excess pore pressure, the two measures of the degree of
    consolidation, and their references (the scene's:
    :class:`solver.consolidation.plan.References`).

    Settlement s (m, downwards positive): the points' vertical displacement x - x0 in the
    top row of cells, fitted by least squares with a polynomial in y0 of the element's
    order (at most one less than the rows of points per cell) and taken at the surface
    y = H. A point's displacement is the element's interpolation of the nodal displacements
    (small kinematics: exactly), so the fit gives the settlement of the top nodes; the top
    row of points alone would miss the compression of the half row above it (2.5 % of the
    final settlement on M1-Q4, one point row per cell: then the fit is that row's mean).
    Mean pressure: the points' volume-weighted mean excess pore pressure over hydrostatic
    (Pa).

    References (Pa, m): p0 the mean undrained excess (with compressible water), s0 the
    undrained settlement and s_inf the final one (a load q alone: p0 = q (K_l/n) /
    (K_l/n + E_c), s0 = q H / (E_c + K_l/n), s_inf = q H / E_c; with gravity the integral of
    the effective stress, ``analytic.column_settlement``); then U_s = (s - s0) /
    (s_inf - s0) and U_p = 1 - mean p / p0, both the scene's U with compressible water
    (diffusivity c2), beside its classic form (incompressible water). A scene without a
    reference, or without a drained side, has no U: ``why`` says why.
    """

    def __init__(self, grid, soil, loading, H, ppc, refs, axis=None):
        """On ``grid`` with ``ppc`` points per cell per direction, a column of ``soil``
        and height H (m) under ``loading`` (scene.Loading), with the references ``refs``;
        ``axis`` (m): the x where a scene without a closed form measures its settlement at
        the axis too (None: a column's, the mean only)."""
        self.H, self.h, self.refs = H, grid.h[1], refs
        self.extent = loading.extent if loading.partial(grid.size[0]) else None
        self.axis, self.hx, self.width = axis, grid.h[0], grid.size[0]
        self.order = min(grid.order, ppc - 1)
        self._generation = None     # of the points when the fit's selection was made
        if len(soil.soils) > 1:
            self._of_layers(refs)
            return
        E_c = soil.constrained_modulus
        undrained = E_c + soil.K_l / soil.porosity
        q = loading.load
        if not loading.self_weight:     # the load alone (at rest under gravity before)
            self.s0, self.s_inf = q * self.H / undrained, q * self.H / E_c
            self.p0 = analytic.undrained_pressure(q, E_c, soil.K_l, soil.porosity)
            self.s0_classic = 0.0
        else:
            gamma_b = (1 - soil.porosity) * (soil.rho_s - soil.rho_l) * loading.gravity
            self.p0 = refs.q * sum(refs.initial[1]) / 2
            self.s0, self.s_inf, self.s0_classic = (
                float(analytic.column_settlement(m, H, E_c, q, gamma_b))
                for m in (self.p0, 0.0, refs.q * sum(refs.initial[0]) / 2))
        self.why = refs.why_degree or ("" if self.p0 != 0 else
                                       "no initial excess pore pressure: U is undefined")
        self.valid = not self.why

    def _of_layers(self, refs):
        """The references of layered ground (refs.layered: its column's classic and
        consistent :class:`layered.LayeredColumn`; none for a scene without a reference)."""
        self.why = refs.why_degree
        if not refs.layered:
            self.s0 = self.s_inf = self.s0_classic = self.p0 = np.nan
            self.valid = False
            return
        classic, consistent = refs.layered
        self.s0, self.s_inf, self.s0_classic = consistent.s0, consistent.s_inf, classic.s0
        self.p0 = float(consistent.mean_excess(0.0))
        self.valid = not self.why

    def measure(self, points, mpi):
        """(settlement (m), mean p (Pa)) now, and with an axis the settlement there (m), on
        every rank (every 10 steps: the selections and the fits' weights are kept until
        points move between ranks; on several ranks one Allreduce of a few numbers)."""
        # The generation changes on every rank together (migrate and resize are collective),
        # so every rank takes part in _select's reduction.
        if self._generation != points.generation:
            self._select(points, mpi)
        x, x0, pp = points.views("x", "x0", "p")
        buf, u = self._buf, x[:, 1] - x0[:, 1]
        at = 0
        for rows, basis, _ in self._fits:
            buf[at:at + len(basis)] = basis @ u[rows]
            at += len(basis)
        buf[-1] = self._volume @ pp
        if mpi.Get_size() > 1:
            from mpi4py import MPI

            mpi.Allreduce(MPI.IN_PLACE, buf, op=MPI.SUM)
        out, at = [], 0
        for _, basis, weights in self._fits:
            out.append(-float(weights @ buf[at:at + len(basis)]))
            at += len(basis)
        return (out[0], buf[-1] / self._total - self._hydrostatic, *out[1:])

    def _select(self, points, mpi):
        """The fits' points and least-squares weights of their value at the surface: the
        top cell row's points (under the load) in y0, and with an axis those of its cell
        in y0 and x0 at (axis, H); each row 0 of (A^T A)^-1 over all ranks, A the
        Vandermonde matrix in (y0 - H) / h (times that in (x0 - axis) / h_x) (collective)."""
        from mpi4py import MPI

        x0, V = points.views("x0", "volume")
        top = x0[:, 1] > self.H - self.h                   # half a row from either side
        under = top.copy()
        if self.extent is not None:                         # under the load only
            under &= (x0[:, 0] >= self.extent[0]) & (x0[:, 0] <= self.extent[1])
        n = self.order + 1
        A = np.vander((x0[under, 1] - self.H) / self.h, n, increasing=True)
        fits = [(np.flatnonzero(under), A)]
        if self.axis is not None:
            cell = min(int(self.axis // self.hx), round(self.width / self.hx) - 1)
            rows = np.flatnonzero(top & (x0[:, 0] >= cell * self.hx)
                                  & (x0[:, 0] <= (cell + 1) * self.hx))
            ys = np.vander((x0[rows, 1] - self.H) / self.h, n, increasing=True)
            xs = np.vander((x0[rows, 0] - self.axis) / self.hx, n, increasing=True)
            fits.append((rows, (ys[:, :, None] * xs[:, None, :]).reshape(len(rows), n * n)))
        # The hydrostatic part of the mean pore pressure: rho_l g sum V (H - y0) / sum V.
        sums = np.concatenate([(B.T @ B).ravel() for _, B in fits]
                              + [[float(np.sum(V)), float(V @ (self.H - x0[:, 1]))]])
        mpi.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        self._fits, at = [], 0
        for rows, B in fits:
            m = B.shape[1]
            weights = np.linalg.inv(sums[at:at + m * m].reshape(m, m))[0]
            self._fits.append((rows, B.T.copy(), weights))
            at += m * m
        self._hydrostatic = self.refs.hydrostatic * sums[-1] / sums[-2]
        self._total, self._volume = sums[-2], V
        self._buf = np.empty(sum(len(b) for _, b, _ in self._fits) + 1)
        self._generation = points.generation

    def trough(self, points, mpi):
        """The settlement (m, downwards positive) of the surface along x: for each column
        of points in the top cell row, the fit in y0 of their vertical displacements taken
        at y = H (as :meth:`measure`, column by column); (x (m), s (m)) on rank 0, None
        elsewhere (collective)."""
        x, x0 = points.views("x", "x0")
        top = x0[:, 1] > self.H - self.h
        local = np.column_stack([x0[top], x[top, 1] - x0[top, 1]])
        parts = mpi.gather(local, root=0)
        if parts is None:
            return None
        every = np.concatenate(parts)
        xs, col = np.unique(every[:, 0], return_inverse=True)
        ys, row = np.unique(every[:, 1], return_inverse=True)
        A = np.vander((ys - self.H) / self.h, min(self.order + 1, len(ys)), increasing=True)
        weights = np.linalg.pinv(A)[0]          # the fit's value at y = H, per column
        u = np.zeros((len(xs), len(ys)))
        u[col, row] = every[:, 2]
        return xs, -(u @ weights)

    def degrees(self, rows):
        """(U from settlement, U from pressure) of history rows (t, Tv, s, mean p); NaN
        where U is undefined (``why``)."""
        r = history(rows)
        if not self.valid:
            return np.full(len(r), np.nan), np.full(len(r), np.nan)
        return (r[:, 2] - self.s0) / (self.s_inf - self.s0), 1 - r[:, 3] / self.p0

    def report(self, Tv, row) -> dict:
        """The degree of consolidation at report time Tv from the history row of its step
        and both forms of the scene's reference; errors in % of the reference (without
        U: the settlement and mean pressure only)."""
        out = {"Tv": Tv, "t": row[0], "settlement_m": row[2], "mean_p_pa": row[3]}
        if self.axis is not None:
            out["settlement_axis_m"] = row[4]
        if not self.valid:
            return out
        Us, Up = (float(u[0]) for u in self.degrees([row]))
        ref = float(self.refs.degree(Tv, "classic"))
        con = float(self.refs.degree(Tv, "consistent"))
        # U from the mean pressure has its own reference in layers (References.degree_pressure).
        ref_p = float(self.refs.degree_pressure(Tv, "classic"))
        con_p = float(self.refs.degree_pressure(Tv, "consistent"))
        return {**out, "U_settlement": Us, "U_pressure": Up, "terzaghi": ref, "consistent": con,
                "error_settlement_pct": 100 * (Us - ref) / ref,
                "error_settlement_consistent_pct": 100 * (Us - con) / con,
                "error_pressure_pct": 100 * (Up - ref_p) / ref_p,
                "error_pressure_consistent_pct": 100 * (Up - con_p) / con_p}

    def summary(self, reports) -> dict:
        out = {"surface": f"fit of degree {self.order} in y0 to the top cell row's point "
                          "displacements, at y = H"
                          + ("" if self.extent is None else ", under the load: settlement_m "
                             "is their mean there")
                          + ("" if self.axis is None else f"; settlement_axis_m at x = "
                             f"{self.axis:g} m, the fit in y0 and x0 of the points of the "
                             "top cell there"),
               "s0_m": self.s0 if self.valid else None,
               "s_inf_m": self.s_inf if self.valid else None,
               "p0_pa": self.p0 if self.valid else None}
        if not self.valid:
            out["why"] = self.why
        for key in ("Tv", "t", "settlement_m", "settlement_axis_m", "mean_p_pa",
                    "U_settlement", "U_pressure",
                    "terzaghi", "consistent", "error_settlement_pct",
                    "error_settlement_consistent_pct", "error_pressure_pct",
                    "error_pressure_consistent_pct"):
            if not reports or key in reports[0]:
                out[key] = [r[key] for r in reports]
        return out

    def write_csv(self, folder, rows) -> str:
        """settlement.csv: the history with both U and both forms of the reference (the
        settlement and mean excess alone where U is undefined); rank 0, rewritten whole
        at each report time and at the end."""
        path = os.path.join(folder, "settlement.csv")
        r = history(rows)
        if not self.valid:
            table = r if self.axis is not None else r[:, :4]
            header = ("t_s,Tv,settlement_m_downwards_positive,"
                      "mean_excess_pore_pressure_pa_compression_positive")
            if self.axis is not None:     # the mean under the load, and at the axis
                header = ("t_s,Tv,settlement_mean_under_load_m_downwards_positive,"
                          "mean_excess_pore_pressure_pa_compression_positive,"
                          "settlement_axis_m_downwards_positive")
        else:
            Us, Up = self.degrees(rows)
            table = np.column_stack([r[:, 0], r[:, 1], r[:, 2], Us, Up,
                                     self.refs.degree(r[:, 1], "classic"),
                                     self.refs.degree(r[:, 1], "consistent")])
            names = "terzaghi" if self.refs.terzaghi else "classic"
            header = ("t_s,Tv,settlement_m_downwards_positive,U_settlement,U_pressure,"
                      f"U_{names},U_consistent")
        with output.atomic(path) as tmp:
            np.savetxt(tmp, table, delimiter=",", comments="", header=header)
        return path


def history(rows) -> np.ndarray:
    """The settlement history's rows (t, Tv, s, mean p[, s at the axis]) as an array (n,
    4 or 5); a row without the axis's (a checkpoint from before it was measured) has NaN."""
    if len(rows) == 0:
        return np.zeros((0, 4))
    try:
        return np.array(rows, dtype=float).reshape(len(rows), -1)
    except ValueError:      # rows of both lengths
        out = np.full((len(rows), 5), np.nan)
        for i, row in enumerate(rows):
            out[i, :len(row)] = row
        return out


def print_degree(comm, degree, surface):
    """The table of U at the report times, or why there is none (``surface``: the
    :class:`Surface` that measured them)."""
    if not surface.valid:
        PETSc.Sys.Print(f"Degree of consolidation: none ({surface.why})", comm=comm)
        return
    name = "Terzaghi" if surface.refs.terzaghi else "classic"
    lines = ["Degree of consolidation U from the surface settlement and from the mean pore "
             "pressure:",
             f"{'T_v':>6s}{'s (mm)':>9s}{'U_s':>8s}{'U_p':>8s}{name:>10s}{'error':>9s}"
             f"{'consistent':>12s}{'error':>9s}"]
    for r in degree:
        lines.append(f"{r['Tv']:6.2f}{1e3 * r['settlement_m']:9.4f}{r['U_settlement']:8.4f}"
                     f"{r['U_pressure']:8.4f}{r['terzaghi']:10.4f}"
                     f"{r['error_settlement_pct']:8.2f}%{r['consistent']:12.4f}"
                     f"{r['error_settlement_consistent_pct']:8.2f}%")
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def print_ends(comm, degree, ends, extent=None) -> dict:
    """The mean settlement under the load at the first and the last report time against
    the static solutions of the ends of consolidation ``ends`` = (undrained, final) (m);
    ``extent`` (x0, x1) (m) of the load (None: the whole top); the summary's entry."""
    first, last = degree[0], degree[-1]
    out = {"undrained_m": ends[0], "final_m": ends[1], "Tv_first": first["Tv"],
           "settlement_first_m": first["settlement_m"], "Tv_last": last["Tv"],
           "settlement_last_m": last["settlement_m"],
           "error_undrained_pct": 100 * (first["settlement_m"] / ends[0] - 1),
           "error_final_pct": 100 * (last["settlement_m"] / ends[1] - 1)}
    where = "the top" if extent is None else f"{extent[0]:g} <= x <= {extent[1]:g} m"
    PETSc.Sys.Print(
        f"Mean settlement under the load ({where}) against static solutions (KSP): "
        f"undrained {1e3 * ends[0]:.5g} mm, final {1e3 * ends[1]:.5g} mm; the run: "
        f"{1e3 * first['settlement_m']:.5g} mm at T_v = {first['Tv']:g} "
        f"({out['error_undrained_pct']:+.2f} % of the undrained), "
        f"{1e3 * last['settlement_m']:.5g} mm at T_v = {last['Tv']:g} "
        f"({out['error_final_pct']:+.2f} % of the final)", comm=comm)
    return out


TROUGH_ROWS = ("# rows with Tv = 0: the static undrained surface, Tv = inf: the static final "
               "one (solver/references/static.py at the top nodes' x); the others: the run's at "
               "its report times (at each column of points of the top cell row, the fit at "
               "y = H)")


def write_trough(folder, troughs, ends, fe=None) -> str:
    """settlement_trough.csv: the surface settlement along x at each report time
    (``troughs``: (T_v, x, s) rows) and, where known, the static ends (``ends``:
    static.Ends, at the top nodes) as rows with T_v 0 and inf, said in a comment line
    after the header; with ``fe`` (:class:`fe_reference.FEReference`) a column of its
    settlement at the same x and time (its own ends in the static rows); rank 0."""
    path = os.path.join(folder, "settlement_trough.csv")
    rows = [(Tv, x, s, fe.trough_at(Tv) if fe else None) for Tv, x, s in troughs]
    if ends:
        rows += [(Tv, ends.x, getattr(ends, name),
                  fe.ends[end]["static_x"] if fe else None)
                 for name, end, Tv in (("undrained_top", "undrained", 0.0),
                                       ("final_top", "drained", np.inf))]
    with output.atomic(path) as tmp, open(tmp, "w") as fh:
        fh.write("Tv,x_m,settlement_m_downwards_positive"
                 + (",fe_settlement_m_downwards_positive" if fe else "") + "\n"
                 + TROUGH_ROWS + ("; fe_settlement: solver/references/biot.py's at the same x and "
                                  "time (NaN where it has none), its own undrained and "
                                  "drained ends in the static rows" if fe else "") + "\n")
        for Tv, x, s, f in rows:
            cols = [np.full(len(x), Tv), x, s]
            if fe:
                cols.append(np.full(len(x), np.nan) if f is None else f)
            np.savetxt(fh, np.column_stack(cols), delimiter=",")
    return path


def write_files(outputs, surface, rows, refs, Tv_end, cells, troughs=()):
    """settlement.csv, the figure of U against T_v and that of the settlement (mm) against
    time in the scene's unit, from the history ``rows`` (t, Tv, s, mean p[, s at the
    axis]), into ``outputs`` (plan.Outputs); ``refs`` the plan's References, ``Tv_end`` the
    run's end, ``cells`` the figures' words for the grid ('Q4 1 x 10 cells'); a scene
    without a closed form's ``troughs`` (settlement_trough.csv and its figure) and its
    settlement at the axis and mean under the load against time, with the FE's; rank 0."""
    ratio, folder, formats = refs.ratio, outputs.folder, outputs.formats
    files = {"settlement_csv": surface.write_csv(folder, rows)}
    fe = refs.fe
    if troughs:
        files["settlement_trough_csv"] = write_trough(folder, troughs, refs.static, fe)
        if outputs.figures:
            fig = plots.settlement_trough(
                output.pyplot(), troughs, surface.extent, refs.static,
                f"Settlement trough, {cells}",
                [(Tv, fe.probes.trough, fe.trough_at(Tv)) for Tv, _, _ in troughs
                 if fe is not None and fe.trough_at(Tv) is not None])
            files.update(output.save_figures(fig, folder, "settlement_trough", formats))
    r = history(rows)
    if outputs.figures and surface.axis is not None:
        fig = plots.settlement_time_2d(
            output.pyplot(), r[:, 0], r[:, 4], r[:, 2], surface.axis, surface.extent,
            None if fe is None else (fe.t, fe.axis, fe.mean, fe.cells),
            refs.static[:2] if refs.static else None, f"Surface settlement, {cells}")
        files.update(output.save_figures(fig, folder, "settlement_time", formats))
    if not (outputs.figures and surface.valid):     # no U: no reference to draw against
        return files
    name = "Terzaghi" if refs.terzaghi else "Reference"
    fig = plots.consolidation_degree(
        output.pyplot(), r[:, 1], *surface.degrees(rows), ratio, Tv_end,
        f"Degree of consolidation, {cells}", refs.degree, name)
    files.update(output.save_figures(fig, folder, "settlement", formats))
    fig = plots.settlement_time(
        output.pyplot(), r[:, 0], r[:, 2], surface.s0, surface.s_inf, refs.c_v, ratio,
        surface.H, f"Surface settlement, {cells}", refs.degree, name, surface.s0_classic)
    files.update(output.save_figures(fig, folder, "settlement_time", formats))
    return files
