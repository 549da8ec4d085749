"""The reporting of a flowing body (:mod:`solver.dynamic.flowing`): what it prints before
stepping, its point fields as they flow, and after the last step the kinetic energy
against time (``energy.csv``), the final free surface (``profile.csv``), the figure of the
deposit over the initial shape (with the scene's experiment where it has one) and the
summary's ``dynamic`` block.

The free surface: over bins of half a cell across the grid, the highest top of the body,
a point's top being its centre plus half its current height (sqrt of its area); 0 where no
point is. The toe: the farthest point's centre plus half its width.
"""

from __future__ import annotations

import os

import numpy as np
from petsc4py import PETSc

from ..io import output
from ..model import lattice
from . import penetration


def print_plan(plan, model, comm) -> None:
    g, m = plan.grid, plan.material
    floor = plan.walls.get("bottom", "none")
    floor = {"xy": "fixed floor", "y": (f"floor friction {plan.friction:g}" if plan.friction
                                        else "smooth floor"), "x": "floor holding x",
             "none": "no floor"}[floor]
    PETSc.Sys.Print(
        f"Dynamic analysis, large deformation: a {plan.size[0]:g} x {plan.size[1]:g} m body "
        f"of {type(m).__name__} " + (f"flowing under gravity {plan.gravity:g} m/s2"
                                    if plan.gravity else "without weight") + "\n"
        f"Grid: {g.cells[0]} x {g.cells[1]} cells of {g.h[0]:.4g} x {g.h[1]:.4g} m, "
        f"{lattice.NAMES[g.kind]}, "
        f"{model.n_global} points ({plan.ppc} x {plan.ppc} per cell), {floor}"
        f"{', F-bar' if plan.fbar else ''}, FLIP {plan.flip:.6g}"
        f"{'; ' + penetration.describe(plan) if plan.footing else ''}\n"
        f"Steps: at most {model.nsteps} of {model.dt:.4g} s (h / c at c = {plan.wave:.4g} "
        f"m/s x {plan.dt * plan.wave / min(g.h):g}) to {plan.t_end:.4g} s"
        + ("" if plan.footing else ", or until the kinetic energy has fallen to "
           f"{plan.rest_energy:g} of its peak"), comm=comm)


def keys(plan, model) -> dict:
    """The run's keys in its block of the summary before the first step."""
    g = plan.grid
    return {"kinematics": "large", "shape": g.kind, "grid_cells": list(g.cells),
            "cell_size_m": list(g.h), "points": model.n_global, "dt_s": model.dt,
            "flip": plan.flip, "t_end_s": plan.t_end, "rest_energy": plan.rest_energy,
            "mass_initial_kg": model.mass}


class Series:
    """The points' fields as an XDMF + HDF5 series (``points.xdmf``; rank 0 writes):
    displacement, velocity (m, m/s; 3-vectors), the Cauchy stress (Pa, tension positive),
    the plastic multiplier and the volume ratio J, the points in their numbers' order."""

    def __init__(self, folder, comm, run_id):
        self.comm = comm
        self.writer = output.XdmfSeries(os.path.join(folder, "points.xdmf"), run_id=run_id) \
            if comm.getRank() == 0 else None

    @property
    def entries(self) -> list:
        return self.writer.entries if self.writer else []

    def resume(self, entries, run_id) -> None:
        if self.writer:
            self.writer.resume(entries, run_id)

    def files(self) -> list:
        if not self.entries:
            return []
        return [self.writer.path] + [os.path.join(self.writer.folder, str(e[1]))
                                     for e in self.entries]

    def write(self, model, step: int, t: float) -> None:
        """The fields of ``model`` (a :class:`flowing.Flowing`) at ``step``, ``t`` (s)."""
        f = model.flow
        whole = gather(model, {"x": f.x, "u": f.x - f.x0, "v": f.v, "sigma": f.sigma,
                               "eps_p": f.state.get("eps_p", np.zeros(len(f.x))),
                               "J": f.J})
        if self.writer is None:
            return

        def with_z(a):
            return np.column_stack([a, np.zeros(len(a))])
        s = whole["sigma"]
        self.writer.write(step, t, whole["x"], {
            "displacement": with_z(whole["u"]), "velocity": with_z(whole["v"]),
            "stress_xx": s[:, 0], "stress_yy": s[:, 1], "stress_zz": s[:, 2],
            "stress_xy": s[:, 3], "plastic_multiplier": whole["eps_p"],
            "volume_ratio": whole["J"]})


def gather(model, arrays: dict) -> dict | None:
    """The points' ``arrays`` {name: (n_local, ...)} of every rank on rank 0, in the order
    of the points' numbers (None on the other ranks; collective)."""
    mpi = model.comm.tompi4py()
    ids = mpi.gather(model.ids, root=0)
    parts = {k: mpi.gather(np.asarray(v, dtype=float), root=0) for k, v in arrays.items()}
    if ids is None:
        return None
    order = np.argsort(np.concatenate(ids), kind="stable")
    return {k: np.concatenate(v)[order] for k, v in parts.items()}


def surface(x, top, h: float, width: float) -> tuple:
    """(bin centres (m), the highest ``top`` (m) of the points at ``x`` (np,) in each bin
    of h / 2 over [0, width]; 0 where none is)."""
    edges = np.linspace(0.0, width, int(round(2 * width / h)) + 1)
    idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
    height = np.zeros(len(edges) - 1)
    np.maximum.at(height, idx, top)
    return 0.5 * (edges[1:] + edges[:-1]), height


def compare(experiment, xc, height, toe) -> dict:
    """The deposit against the experiment's: the RMS of the surface's heights at the
    experiment's points (m; the surface linear between bin centres) and the toe's error
    relative to the experiment's."""
    sim = np.interp(experiment.surface[:, 0], xc, height)
    return {"name": experiment.name, "citation": experiment.citation,
            "surface_rms_m": float(np.sqrt(np.mean((sim - experiment.surface[:, 1]) ** 2))),
            "toe_m": experiment.toe, "toe_error": (toe - experiment.toe) / experiment.toe}


def finish(plan, model, record, comm) -> None:
    """The outputs after the last step, the summary's block and the closing lines."""
    f = model.flow
    half = 0.5 * np.sqrt(f.V0 * f.J)
    final = gather(model, {"x": f.x, "x0": f.x0, "top": f.x[:, 1] + half,
                           "eps_p": f.state.get("eps_p", np.zeros(len(f.x)))})
    toe = model.toe()
    block = {"steps": record.steps, "t_final_s": model.time(record.steps),
             "at_rest": model.rest, "kinetic_energy_peak_J_per_m": model.peak,
             "kinetic_energy_final_J_per_m": model.kinetic,
             "mass_final_kg": model.total(f.m), "toe_m": toe,
             "runout_m": toe - plan.size[0]}
    files = record.files
    if comm.getRank() == 0:
        folder = plan.outputs.folder
        width = plan.grid.cells[0] * plan.grid.h[0]
        xc, height = surface(final["x"][:, 0], final["top"], plan.grid.h[0], width)
        block["height_final_m"] = float(height.max())
        if plan.experiment is not None:
            block["experiment"] = compare(plan.experiment, xc, height, toe)
        files.update(tables(plan, model, figures=True))
        files["profile"] = _csv(os.path.join(folder, "profile.csv"), "x_m,surface_m",
                                np.column_stack([xc, height]))
        if plan.outputs.figures:
            from .plots import deposit
            files.update(deposit(plan, model, final, (xc, height), toe))
        series = model.series.files()
        if series:
            files["fields_xdmf"], files["fields_h5"] = series[0], series[1:]
    block = comm.tompi4py().bcast(block, root=0)
    if plan.footing:
        block["footing"] = penetration.block(plan, model.curve)
    _print_results(block, plan, comm)
    record.results.update(block)
    record.finish()


def tables(plan, model, figures: bool) -> dict:
    """energy.csv and, under a footing, load_displacement.csv (with its figure where
    ``figures``) as far as ``model`` (a :class:`flowing.Flowing`) has got; rank 0. Written
    at each output of the point fields as well, so that a run that fails or is killed keeps
    its curves to there. Returns the files by key."""
    files = {}
    if plan.footing:
        penetration.write(plan, model.curve, files, figures)
    files["energy"] = _csv(os.path.join(plan.outputs.folder, "energy.csv"),
                           "t_s,kinetic_energy_J_per_m", np.array(model.energy).reshape(-1, 2))
    return files


def _csv(path, header, rows) -> str:
    output.write_text(path, header + "\n" + "".join(
        ",".join(f"{v:.9g}" for v in row) + "\n" for row in rows))
    return path


def _print_results(block, plan, comm) -> None:
    rest = ("at rest (kinetic energy " f"{block['kinetic_energy_final_J_per_m']:.3g} J/m, "
            f"{plan.rest_energy:g} of its peak {block['kinetic_energy_peak_J_per_m']:.3g})"
            if block["at_rest"] else "not yet at rest")
    if "footing" in block:
        PETSc.Sys.Print(f"Final state at t = {block['t_final_s']:.4g} s; mass "
                        f"{block['mass_final_kg']:.6g} kg per m", comm=comm)
        penetration.print_results(block["footing"], comm)
        return
    PETSc.Sys.Print(f"Final state at t = {block['t_final_s']:.4g} s, {rest}: toe at "
                    f"{block['toe_m']:.4g} m (runout {block['runout_m']:.4g} m), height "
                    f"{block['height_final_m']:.4g} m; mass {block['mass_final_kg']:.6g} kg "
                    "per m", comm=comm)
    if "experiment" in block:
        e = block["experiment"]
        PETSc.Sys.Print(f"Against the experiment ({e['citation']}): free surface RMS "
                        f"{1e3 * e['surface_rms_m']:.3g} mm, toe {e['toe_m']:.4g} m "
                        f"({100 * e['toe_error']:+.1f} %)", comm=comm)
