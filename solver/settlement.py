"""The surface settlement and the degree of consolidation of a consolidation run: U from the
settlement and from the mean pore pressure against both Terzaghi references, their table,
``settlement.csv`` and the figures of U against T_v and of the settlement against time."""

from __future__ import annotations

import os

import numpy as np
from petsc4py import PETSc

from . import analytic, figures, output


class Surface:
    """Surface settlement and mean excess pore pressure, the two measures of the degree of
    consolidation, and their references (the load case: gravity has none here).

    Settlement s (m, downwards positive): the points' vertical displacement x - x0 in the
    top row of cells, fitted by least squares with a polynomial in y0 of the element's
    order (at most one less than the rows of points per cell) and taken at the surface
    y = H. A point's displacement is the element's interpolation of the nodal displacements
    (small kinematics: exactly), so the fit gives the settlement of the top nodes; the top
    row of points alone would miss the compression of the half row above it (2.5 % of the
    final settlement on M1-Q4, one point row per cell: then the fit is that row's mean).
    Mean pressure: the points' volume-weighted mean p (Pa).

    References (Pa, m): p0 = q (K_l/n) / (K_l/n + E_c) the undrained pore pressure, s0 =
    q H / (E_c + K_l/n) the undrained settlement, s_inf = q H / E_c the final one; then
    U_s = (s - s0) / (s_inf - s0) and U_p = 1 - mean p / p0, both Terzaghi's U with
    compressible water (diffusivity c2), and classic Terzaghi's for incompressible water.
    """

    def __init__(self, grid, soil, loading, H, ppc):
        """On ``grid`` with ``ppc`` points per cell per direction, a column of ``soil``
        and height H (m) under ``loading`` (scene.Loading)."""
        self.H, self.h = H, grid.h[1]
        self.order = min(grid.order, ppc - 1)
        E_c = soil.constrained_modulus
        undrained = E_c + soil.K_l / soil.porosity
        self.valid = loading.gravity == 0 and loading.load > 0
        q = loading.load
        self.s0, self.s_inf = q * self.H / undrained, q * self.H / E_c
        self.p0 = analytic.undrained_pressure(q, E_c, soil.K_l, soil.porosity)
        self._generation = None     # of the points when the fit's selection was made

    def measure(self, points, mpi):
        """(settlement (m), mean p (Pa)) now, on every rank (every 10 steps: the selection
        and the fit's weights are kept until points move between ranks; on several ranks
        one Allreduce of a few numbers)."""
        # The generation changes on every rank together (migrate and resize are collective),
        # so every rank takes part in _select's reduction.
        if self._generation != points.generation:
            self._select(points, mpi)
        x, x0, pp = points.views("x", "x0", "p")
        top, basis, weights, volume = self._fit
        buf = self._buf
        buf[:-1] = basis @ (x[top, 1] - x0[top, 1])
        buf[-1] = self._volume @ pp
        if mpi.Get_size() > 1:
            from mpi4py import MPI

            mpi.Allreduce(MPI.IN_PLACE, buf, op=MPI.SUM)
        return -float(weights @ buf[:-1]), buf[-1] / volume

    def _select(self, points, mpi):
        """The points of the top cell row and the least-squares weights of the fit's value
        at y = H: row 0 of (A^T A)^-1 over all ranks, A the Vandermonde matrix in
        (y0 - H) / h (collective)."""
        from mpi4py import MPI

        x0, V = points.views("x0", "volume")
        top = np.flatnonzero(x0[:, 1] > self.H - self.h)   # half a row from either side
        A = np.vander((x0[top, 1] - self.H) / self.h, self.order + 1, increasing=True)
        sums = np.append((A.T @ A).ravel(), float(np.sum(V)))
        mpi.Allreduce(MPI.IN_PLACE, sums, op=MPI.SUM)
        n = self.order + 1
        weights = np.linalg.inv(sums[:-1].reshape(n, n))[0]
        self._fit = (top, A.T.copy(), weights, sums[-1])
        self._volume = V
        self._buf = np.empty(n + 1)
        self._generation = points.generation

    def degrees(self, rows):
        """(U from settlement, U from pressure) of history rows (t, Tv, s, mean p); NaN
        without a load case."""
        r = np.array(rows, dtype=float).reshape(-1, 4)
        if not self.valid:
            return np.full(len(r), np.nan), np.full(len(r), np.nan)
        return (r[:, 2] - self.s0) / (self.s_inf - self.s0), 1 - r[:, 3] / self.p0

    def report(self, Tv, row, ratio) -> dict:
        """The degree of consolidation at report time Tv from the history row of its step
        and both Terzaghi references (``ratio`` = c2 / c_v); errors in % of the reference."""
        Us, Up = (float(u[0]) for u in self.degrees([row]))
        ref = float(analytic.degree_of_consolidation(Tv))
        con = float(analytic.degree_of_consolidation(Tv * ratio))
        return {"Tv": Tv, "t": row[0], "settlement_m": row[2], "mean_p_pa": row[3],
                "U_settlement": Us, "U_pressure": Up, "terzaghi": ref, "consistent": con,
                "error_settlement_pct": 100 * (Us - ref) / ref,
                "error_settlement_consistent_pct": 100 * (Us - con) / con,
                "error_pressure_pct": 100 * (Up - ref) / ref,
                "error_pressure_consistent_pct": 100 * (Up - con) / con}

    def summary(self, reports) -> dict:
        out = {"surface": f"fit of degree {self.order} in y0 to the top cell row's point "
                          "displacements, at y = H",
               "s0_m": self.s0 if self.valid else None,
               "s_inf_m": self.s_inf if self.valid else None,
               "p0_pa": self.p0 if self.valid else None}
        for key in ("Tv", "t", "settlement_m", "mean_p_pa", "U_settlement", "U_pressure",
                    "terzaghi", "consistent", "error_settlement_pct",
                    "error_settlement_consistent_pct", "error_pressure_pct",
                    "error_pressure_consistent_pct"):
            out[key] = [r[key] for r in reports]
        return out

    def write_csv(self, folder, rows, ratio) -> str:
        """settlement.csv: the history with both U and both Terzaghi references; rank 0,
        rewritten whole at each report time and at the end."""
        path = os.path.join(folder, "settlement.csv")
        r = np.array(rows, dtype=float).reshape(-1, 4)
        Us, Up = self.degrees(rows)
        table = np.column_stack([r[:, 0], r[:, 1], r[:, 2], Us, Up,
                                 analytic.degree_of_consolidation(r[:, 1]),
                                 analytic.degree_of_consolidation(r[:, 1] * ratio)])
        with output.atomic(path) as tmp:
            np.savetxt(tmp, table, delimiter=",", comments="",
                       header="t_s,Tv,settlement_m_downwards_positive,U_settlement,"
                              "U_pressure,U_terzaghi,U_consistent")
        return path


def print_degree(comm, degree):
    lines = ["Degree of consolidation U from the surface settlement and from the mean pore "
             "pressure:",
             f"{'T_v':>6s}{'s (mm)':>9s}{'U_s':>8s}{'U_p':>8s}{'Terzaghi':>10s}{'error':>9s}"
             f"{'consistent':>12s}{'error':>9s}"]
    for r in degree:
        lines.append(f"{r['Tv']:6.2f}{1e3 * r['settlement_m']:9.4f}{r['U_settlement']:8.4f}"
                     f"{r['U_pressure']:8.4f}{r['terzaghi']:10.4f}"
                     f"{r['error_settlement_pct']:8.2f}%{r['consistent']:12.4f}"
                     f"{r['error_settlement_consistent_pct']:8.2f}%")
    PETSc.Sys.Print("\n".join(lines), comm=comm)


def write_files(outputs, surface, rows, refs, Tv_end, cells):
    """settlement.csv, the figure of U against T_v and that of the settlement (mm) against
    time in the scene's unit, from the history ``rows`` (t, Tv, s, mean p), into
    ``outputs`` (plan.Outputs); ``refs`` the plan's References, ``Tv_end`` the run's end,
    ``cells`` the figures' words for the grid ('Q4 1 x 10 cells'); rank 0."""
    ratio, folder, formats = refs.ratio, outputs.folder, outputs.formats
    files = {"settlement_csv": surface.write_csv(folder, rows, ratio)}
    if outputs.figures:
        fig = figures.consolidation_degree(
            output.pyplot(), np.array(rows, dtype=float).reshape(-1, 4)[:, 1],
            *surface.degrees(rows), ratio, Tv_end, f"Degree of consolidation, {cells}")
        files.update(output.save_figures(fig, folder, "settlement", formats))
    if outputs.figures and surface.valid:      # a load case: its settlement has references
        r = np.array(rows, dtype=float).reshape(-1, 4)
        fig = figures.settlement_time(
            output.pyplot(), r[:, 0], r[:, 2], surface.s0, surface.s_inf, refs.c_v, ratio,
            surface.H, f"Surface settlement, {cells}")
        files.update(output.save_figures(fig, folder, "settlement_time", formats))
    return files
