"""The reporting of a dynamic run: what it prints before and while stepping, and what it
writes after: histories, peaks and spectra (:mod:`solver.dynamic.histories`), the exact
response where the scene is the one-dimensional column it describes, the figures
(:mod:`solver.dynamic.plots`), the XDMF series and the summary's ``dynamic`` block."""

from __future__ import annotations

import os

import numpy as np
from petsc4py import PETSc

from ..io import output
from ..io.fields import PointSeries
from ..references import site
from . import histories, plots, twin


def print_plan(plan, model, nsteps: int, comm) -> None:
    sh = plan.shaking
    what = ("two phases (the v-w step)" if plan.phases == 2 else
            "one phase (the solid with the mixture's density)")
    base = (f"compliant base (rock: {sh.rock_speed:g} m/s, {sh.rock_rho:g} kg/m3)"
            if sh.base == "compliant" else "rigid base")
    motion = plan.motion.form
    words = "none" if motion[0] == "none" else (
        f"record {motion[1]}" if motion[0] == "file" else
        f"{motion[0]} " + ",".join(f"{v:g}" for v in motion[1:]))
    PETSc.Sys.Print(
        f"Dynamic analysis: {what}, {sh.direction} motion, {base}"
        f"{'' if plan.sides == 'rollers' else f', {plan.sides} sides'}; base motion {words}"
        f" x {plan.motion.scale:g}"
        f"{'' if plan.loading is None else f'; load {plan.loading.load:g} Pa at t = 0'}"
        + (f"\nNatural frequencies of the column on a fixed base ({plan.eigen_solver}): "
           + ", ".join(f"{f:.4g}" for f in plan.eigen_hz) + " Hz; the layered rod's: "
           if len(plan.eigen_hz) else "\nNatural frequencies of the saturated column, its "
           "phases locked by drag (the layered rod's): ")
        + ", ".join(f"{f:.4g}" for f in plan.analytic_hz) + " Hz", comm=comm)
    if plan.damping is not None:
        xi, f1, f2 = plan.damping
        PETSc.Sys.Print(f"Rayleigh damping: {100 * xi:g} % at {f1:.4g} and {f2:.4g} Hz "
                        f"(a0 = {sh.a0:.4g} 1/s, a1 = {sh.a1:.4g} s)", comm=comm)
    PETSc.Sys.Print(f"Steps: {nsteps} of {model.dt:.4g} s to {plan.t_end:g} s; records every "
                    f"{plan.record_dt:g} s at depths "
                    + ", ".join(f"{d:.4g}" for d in _depths(plan, model)) + " m", comm=comm)


def _depths(plan, model):
    return histories.record_rows(model.heights, plan.body.height, plan.depths)[1]


def progress_words(rec, t: float) -> str:
    """What a progress line says of the run at time ``t`` (s)."""
    surface = rec.samples[-1][0, 3 * rec.comp] if rec.samples else float("nan")
    return f"t = {t:.4g} s, surface a = {surface:.4g} m/s2"


def keys(plan, model) -> dict:
    """The run's keys in its block of the summary before the first step."""
    out = {"phases": plan.phases, "dt": model.dt, "t_end": plan.t_end}
    if not model.water:       # the bound the step comes from (a divisor of -mpm_record_dt)
        out.update(w_max=model.body.w_max, dt_stable=model.body.dt_stable)
    return out


class Series:
    """The fields over time as an XDMF series: the nodes' displacement, velocity and
    acceleration (one phase), or the points' fields (two phases, :class:`PointSeries`)."""

    def __init__(self, plan, model, comm, restart):
        folder, rid = plan.outputs.folder, plan.run["id"]
        self.model = model
        self.points = PointSeries(folder, comm, rid) if model.water else None
        self.writer = None
        if self.points is None and comm.getRank() == 0:
            self.writer = output.XdmfSeries(os.path.join(folder, "nodes.xdmf"), run_id=rid)
        if restart is not None:
            entries = restart.state.get("series", [])
            if self.points is not None:
                self.points.resume(entries, restart.run_id)
            elif self.writer is not None:
                self.writer.entries = [e for e in entries if os.path.isfile(
                    os.path.join(folder, str(e[1])))]
                self.writer.rewrite()

    def write(self, k: int, t: float) -> None:
        if self.points is not None:
            self.points.write(self.model.points, k, t)
            return
        data = self.model.fields()           # collective
        if self.writer is not None:
            self.writer.write(k, t, *data)

    def entries(self) -> list:
        if self.points is not None:
            return self.points.entries
        return self.writer.entries if self.writer else []

    def files(self) -> list:
        if self.points is not None:
            return self.points.files()
        if not self.entries():
            return []
        return [self.writer.path] + [os.path.join(self.writer.folder, str(e[1]))
                                     for e in self.entries()]


def rings(plan) -> bool:
    """Whether the response never dies out: a rigid base, no Rayleigh damping (two phases:
    the drag damps little of it, and nothing of a shear wave that locks the phases)."""
    sh = plan.shaking
    return sh.base == "rigid" and sh.a0 == 0 and sh.a1 == 0


def exact_column(plan):
    """The exact one-dimensional reference of the scene (:class:`site.Column`) where it is
    one: one phase, horizontal shaking, no load, no mass-proportional damping (the
    stiffness-proportional part is the column's viscosity), a linear soil, and a response
    that dies out (a compliant base or damping); else None."""
    sh = plan.shaking
    if plan.phases != 1 or sh.direction != "x" or plan.loading is not None or sh.a0 > 0 \
            or plan.motion.form[0] == "none" or plan.materials is not None:
        return None
    if rings(plan):
        return None         # undamped on a rigid base it rings forever: no FFT answer
    soils = plan.ground.soils
    Vs = tuple(float(np.sqrt(s.shear_modulus / s.density)) for s in soils)
    rock = (sh.rock_speed, sh.rock_rho, 0.0) if sh.base == "compliant" else None
    return site.Column(tuple(plan.ground.thickness), Vs, tuple(s.density for s in soils),
                       rock=rock, viscosity=sh.a1)


def finish(plan, model, rec, series, record, comm, nsteps: int = 0) -> None:
    """The outputs after the last step (rank 0 writes), the results into the summary's
    ``dynamic`` block (``record.results``) and the closing lines; a hysteretic soil's
    loops and its linear twin of ``nsteps`` steps (:func:`hysteretic`)."""
    folder = plan.outputs.folder
    t = np.array(rec.t)
    block = {"record_depths_m": rec.depths.tolist(), "eigen_hz": plan.eigen_hz.tolist(),
             "material": "elastic" if plan.materials is None else "hyperbolic",
             "eigen_solver": plan.eigen_solver, "analytic_hz": plan.analytic_hz.tolist(),
             "peak_surface_acceleration": float(np.max(np.abs(rec.history(
                 histories.COLUMNS[3 * rec.comp]))))}
    spec = exact = None
    if plan.motion.form[0] != "none" and len(t) > 8:
        a_in = plan.motion.acceleration(t)
        spec = histories.spectral(rec, a_in, model.spectra.psa(model.mpi), plan.psa)
        steps = len(model.spectra.rows) == len(rec.depths)      # the same on every rank
        spec["at_depths"] = histories.at_depths(
            rec, a_in, spec, model.spectra.at_depths(model.mpi) if steps else None)
        block.update(pga_input=float(np.max(np.abs(a_in))),
                     pga_surface=block["peak_surface_acceleration"])
        if not rings(plan):
            block["peaks_hz"] = spec["peaks"].tolist()
        else:   # an undamped column on a rigid base: its record's spectrum has no peaks
            spec["peaks"] = np.zeros(0)
        col = exact_column(plan)
        if col is not None:
            base = "outcrop" if col.rock is not None else "within"
            exact = site.response(col, t[1] - t[0], a_in, base, pad=8)
            surface = rec.history(histories.COLUMNS[0])
            block["exact_error_pct_of_peak"] = float(
                100 * np.max(np.abs(surface - exact)) / np.max(np.abs(exact)))
            spec["exact_transfer"] = np.abs(site.transfer(col, spec["f"], base))
    if plan.damping is not None:
        block["rayleigh"] = dict(zip(("xi", "f1_hz", "f2_hz"), plan.damping),
                                 a0=plan.shaking.a0, a1=plan.shaking.a1)
    if model.water:
        block.update(model.references(rec))
    warning = strain_warning(rec, plan.body.height) if plan.materials is None else ""
    if warning:
        block["warnings"] = [warning]
    _print_results(block, comm)
    record.results.update(block)
    files = record.files
    if comm.getRank() == 0:
        files["histories"] = os.path.join(folder, "histories.csv")
        histories.write_histories(files["histories"], rec, model.water)
        files["peaks"] = os.path.join(folder, "peaks.csv")
        mid = 0.5 * (rec.heights[1:] + rec.heights[:-1])
        modulus = plan.ground.at("shear_modulus" if rec.comp == 0 else
                                 "constrained_modulus", mid)
        histories.write_peaks(files["peaks"], rec, plan.body.height, model.water, modulus,
                              None if model.loops is None else model.loops.peak_stress)
        if spec is not None:
            files["spectra"] = os.path.join(folder, "spectra.csv")
            histories.write_spectra(files["spectra"], spec)
            files["spectra_depths"] = os.path.join(folder, "spectra_depths.csv")
            histories.write_at_depths(files["spectra_depths"], spec["at_depths"])
        if plan.outputs.figures:
            files.update(plots.draw(plan, rec, spec, exact, model.water))
        fields = series.files()
        if fields:
            files["fields_xdmf"], files["fields_h5"] = fields[0], fields[1:]
    if model.loops is not None:     # after the run's own files: the twin takes a while
        hysteretic(plan, model, rec, spec, nsteps, record, comm)
    record.finish()


def hysteretic(plan, model, rec, spec, nsteps: int, record, comm) -> None:
    """A hysteretic soil's outputs: the loops at the recorded depths (loops.csv and its
    figure) and, under a base motion, its linear twin stepped now unless -mpm_linear_twin
    0 (:mod:`twin`: the summary's ``linear_twin`` block, a line, twin.csv and its
    figure)."""
    folder, files = plan.outputs.folder, record.files
    kind = "shear" if rec.comp == 0 else "axial"
    twin_rec = twin_psa = None
    if plan.motion.form[0] != "none" and plan.twin:
        twin_rec, twin_psa = twin.run(plan, comm, nsteps)
        b = twin.block(rec, twin_rec, spec, twin_psa)
        record.results["linear_twin"] = b
        PETSc.Sys.Print(twin.words(b, kind), comm=comm)
    if comm.getRank() != 0:
        return
    files["loops"] = os.path.join(folder, "loops.csv")
    histories.write_loops(files["loops"], model.loops, kind)
    if twin_rec is not None:
        files["twin"] = os.path.join(folder, "twin.csv")
        twin.write(files["twin"], rec, twin_rec, spec, twin_psa)
    if plan.outputs.figures:
        plt = output.pyplot()
        files.update(output.save_figures(twin.loops_figure(plt, model.loops, kind), folder,
                                         "loops", plan.outputs.formats))
        if twin_rec is not None:
            files.update(output.save_figures(
                twin.figure(plt, rec, twin_rec, spec, twin_psa, kind), folder, "twin",
                plan.outputs.formats))


LINEAR_STRAIN = 1e-4     # past it a real soil has lost a tenth of its modulus or more


def strain_warning(rec, H: float) -> str:
    """What a run must say when its linear soil strained past LINEAR_STRAIN (the peak
    strain and where), or ''."""
    if not len(rec.peak_strain):
        return ""
    k = int(np.argmax(rec.peak_strain))
    peak = float(rec.peak_strain[k])
    if peak <= LINEAR_STRAIN:
        return ""
    depth = H - 0.5 * (rec.heights[k] + rec.heights[k + 1])
    kind = "shear" if rec.comp == 0 else "axial"
    return (f"the peak {kind} strain {peak:.3g} ({100 * peak:.3g} %) at {depth:.4g} m depth "
            f"is past {LINEAR_STRAIN:g}, where real soils soften and damp by hysteresis; "
            "this soil is linear elastic, so its response there is overstated")


def _print_results(block, comm) -> None:
    lines = []
    if "pga_input" in block:
        lines.append(f"Peak acceleration: input {block['pga_input']:.4g} m/s2, surface "
                     f"{block['pga_surface']:.4g} m/s2")
        small = ", small strain" if block.get("material") == "hyperbolic" else ""
        jacobi = (f"natural frequencies (Jacobi{small}): " + ", ".join(
            f"{f:.4g}" for f in block["eigen_hz"]) + " Hz; ") if block["eigen_hz"] else ""
        found = ", ".join(f"{f:.4g}" for f in block["peaks_hz"]) + " Hz" \
            if "peaks_hz" in block else ("not sought (an undamped column on a rigid base "
                                         "rings on: its transfer function has no width)")
        lines.append("Transfer function peaks: " + found + "; " + jacobi + "layered rod: "
                     + ", ".join(f"{f:.4g}" for f in block["analytic_hz"]) + " Hz")
    if "exact_error_pct_of_peak" in block:
        lines.append(f"Surface acceleration against the exact response of the column: "
                     f"largest difference {block['exact_error_pct_of_peak']:.3g} % of its "
                     "peak")
    for key, text in (("front", "Front"), ("jump", "Pressure jump"), ("late", "Late")):
        if key in block:
            lines.append(f"{text}: {block[key]['words']}")
    lines += [f"Warning: {w}" for w in block.get("warnings", ())]
    for line in lines:
        PETSc.Sys.Print(line, comm=comm)
