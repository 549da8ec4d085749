"""What the static analysis writes: the summary's ``static`` block and
``load_displacement.csv`` with its figure (:func:`report`), the plastic zone
(:func:`plastic_zone`) and the point fields after every step (:class:`FieldSeries`:
``points.xdmf`` and ``points_<step>.h5`` for ParaView)."""

from __future__ import annotations

import math
import os

import numpy as np
from petsc4py import PETSc

from ..io import output
from ..io.fields import PointSeries


class FieldSeries(PointSeries):
    """The points' fields after each converged step as an XDMF + HDF5 series (rank 0
    writes; every rank gathers): positions (m), displacement (the nodal displacement at the
    points, m; 3-vectors, z = 0), the effective stress components xx, yy, zz, xy (Pa, tension
    positive), the accumulated plastic multiplier and whether the point yielded in the
    step. The points keep their ranks and order (they do not move). The index, its files
    and a restart's taking it up are :class:`solver.io.fields.PointSeries`'s."""

    def write(self, points, problem, step: int, settlement: float):
        """The fields after step ``step``, the footing at ``settlement`` (m): the series'
        time (collective)."""
        mpi = self.comm.tompi4py()
        disp = problem.displacement_at_points()
        local = {"x": points.get("x"), "u": disp, "stress": problem.stress,
                 "eps_p": problem.state.get("eps_p", np.zeros(len(disp))),
                 "plastic": problem.state["plastic"].astype(float)}
        parts = {k: mpi.gather(v, root=0) for k, v in local.items()}
        if self.writer is None:
            return
        whole = {k: np.concatenate(v) for k, v in parts.items()}

        def with_z(a):
            return np.column_stack([a, np.zeros(len(a))])

        fields = {"displacement": lambda: with_z(whole["u"]),
                  "plastic_multiplier": lambda: whole["eps_p"],
                  "yielding": lambda: whole["plastic"]}
        for k, name in enumerate(("xx", "yy", "zz", "xy")):
            fields[f"effective_stress_{name}"] = (lambda k=k: whole["stress"][:, k].copy())
        self.writer.write(step, settlement, whole["x"], fields)


def banner(plan, n_points: int, comm):
    """The run's first line: what is pushed, on what, on which cells."""
    body = plan.body
    what = (f"a load of {plan.loading.load:g} Pa" if plan.load_control else
            f"a {'rough' if plan.rough else 'smooth'} footing")
    PETSc.Sys.Print(f"Static analysis: {what} {plan.footing[0]:g} to {plan.footing[1]:g} m "
                    f"on {plan.material_name}, {body.element.upper()} {body.cells[0]} x "
                    f"{body.cells[1]} cells, {n_points} points, B-bar "
                    f"{'on' if plan.bbar else 'off'}"
                    + (f", gravity {plan.loading.gravity:g} m/s2" if plan.loading.gravity
                       else "") + (f", surcharge {plan.surcharge:g} Pa" if plan.surcharge
                                   else ""), comm=comm)


def report(plan, curve, residuals, n_points, comm, record, failed: bool = False):
    """The summary's static block, load_displacement.csv and its figure; ``failed``: the
    run gave up at the next step (under load control: the soil failed there)."""
    pressure = curve[:, 1]
    peak = int(np.argmax(pressure))
    if plan.load_control:
        capacity, how = (float(pressure[-1]), "the last load carried before the soil "
                         "failed") if failed else (math.nan, "none: the whole load carried")
    elif pressure[peak] > pressure[-1] * 1.005:
        capacity, how = float(pressure[peak]), "the peak"
    else:
        capacity, how = float(pressure[-1]), "the plateau (the last step)"
    ref, name = plan.reference()
    record.results.update({
        "bearing_capacity_pa": capacity, "picked": how, "reference_pa": ref,
        "reference": name, "error_pct": 100 * (capacity / ref - 1) if name else math.nan,
        "control": "load" if plan.load_control else "settlement",
        "n_points": n_points, "newton_iterations": [len(r) - 1 for r in residuals],
        "newton_residuals": residuals,
        "settlement_m": float(curve[-1, 0])})
    PETSc.Sys.Print(f"Bearing capacity {capacity:.6g} Pa ({how})"
                    + (f"; {name} = {ref:.6g} Pa: {100 * (capacity / ref - 1):+.2f} %"
                       if name and math.isfinite(capacity) else ""), comm=comm)
    if comm.getRank() == 0:
        record.files.update(output.load_displacement(
            plan.outputs, curve, ref, name, "the load (kPa)" if plan.load_control else
            "mean contact pressure (kPa)"))


def plastic_zone(plan, points, problem, comm, record):
    """plastic_zone.png: every point coloured by its accumulated plastic multiplier (where
    the soil yielded), the footing marked (points gathered on rank 0)."""
    x = points.get("x")
    eps = problem.state.get("eps_p", np.zeros(len(x)))
    gathered = comm.tompi4py().gather((x, eps), root=0)
    if comm.getRank() != 0 or not plan.outputs.figures:
        return
    x = np.concatenate([g[0] for g in gathered])
    eps = np.concatenate([g[1] for g in gathered])
    record.files["plastic_zone"] = output.plastic_zone(
        os.path.join(plan.outputs.folder, "plastic_zone.png"), plan.outputs.formats, x, eps,
        plan.body.size, plan.footing, f"plastic zone at the last step ({plan.material_name})")
