"""The load-stepped static analysis (``-mpm_analysis static``): a rigid strip footing pushed
to ``-mpm_footing_settlement`` (or a flexible load ``-mpm_load`` raised: load control) in
``-mpm_load_steps`` steps, on a weightless body or one at rest under gravity, with a
surcharge beside it or none; Newton on SNES at each step (steps cut in half and retried
where it does not converge).

A halved step doubles again after a step that Newton takes in fewer than GROW_BELOW
iterations, up to the asked length. Writes ``load_displacement.csv`` (``settlement_m``,
``pressure_pa``: the mean contact pressure, from the nodal internal forces under the
footing net of the constant external ones; under load control the mean settlement under
the load and the load), its figure with the reference where the scene has one, and the
summary's ``static`` block: ``bearing_capacity_pa`` (the peak, the plateau: the last step,
or under load control the last load carried) and how it was picked, ``reference_pa`` and
``reference`` (Prandtl's (2 + pi) c_u + q0 for Tresca soil, Prandtl-Reissner's N_c c +
N_q q0 for associated c-phi soil, weightless), ``error_pct``, ``newton_iterations`` and
``newton_residuals`` (per step, the residual norms).
"""
from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError, NumericalError
from ..common.linalg import newton_solver
from ..io import checkpoint, provenance
from ..io.output import Outputs
from ..materials import catalog
from ..model.grid import Grid
from ..model.points import place
from ..model.scene import Body, Loading
from ..model.soil import Ground
from ..run.record import Record, guarded, owned
from . import reporting, restart
from .problem import StaticProblem, at_rest

CUTS = 6            # halvings of a step before the run gives up
GROW_BELOW = 6      # a step that converged in fewer Newton iterations doubles the next


@dataclass(frozen=True)
class StaticPlan:
    """The body, its soil (densities, for gravity) and material, the footing (x0, x1 in m;
    rough or smooth; () under load control) pushed to the settlement (m) in steps, or the
    load (``loading``: q (Pa) on its extent, gravity (m/s2), K0) raised to q in steps;
    ``surcharge`` (Pa) on the rest of the top, B-bar, where results go, the provenance."""

    body: Body
    material: object
    material_name: str
    cohesion: float
    footing: tuple
    rough: bool
    settlement: float
    steps: int
    bbar: bool
    outputs: Outputs
    provenance: dict
    soil: object = None
    loading: Loading = Loading(load=0.0)
    surcharge: float = 0.0
    # Checkpoints: every N steps, the checkpoint continued ('' for a fresh run) and whether
    # it may write over another run's results, the physics' signature, the run's options.
    checkpoint_every: int = 0
    restart: str = ""
    overwrite: bool = False
    signature: str = ""
    recorded: dict | None = None

    @classmethod
    def from_options(cls, p) -> "StaticPlan":
        material = catalog.Recipe.from_options(p).make(p.E, p.nu)
        if p.material == "mcc" and p.gravity == 0 and p.surcharge == 0:
            raise InputError("-mpm_material mcc: Cam Clay has no strength in a weightless "
                             "body without a surcharge (give -mpm_gravity or -mpm_surcharge)")
        loading = Loading(load=p.load if "load" in p.given else 0.0, gravity=p.gravity,
                          geostatic=p.gravity > 0, K0=p.K0, extent=tuple(p.load_extent))
        if p.footing and loading.load:
            raise InputError("-mpm_load: the footing (-mpm_footing) is pushed; give one of "
                             "the two")
        if not p.footing and not loading.load:
            raise InputError("-mpm_footing X0,X1 or -mpm_load: the static analysis pushes a "
                             "footing or raises a load")
        x0, x1 = p.footing or (loading.extent or (0.0, p.size[0]))
        if not 0 <= x0 < x1 <= p.size[0]:
            raise InputError(f"-mpm_{'footing' if p.footing else 'load_extent'} {x0:g},"
                             f"{x1:g}: outside the top (0 <= x0 < x1 <= {p.size[0]:g} m)")
        return cls(Body.from_options(p), material, p.material, p.cohesion, (x0, x1),
                   p.footing_interface == "rough", p.footing_settlement, p.load_steps,
                   p.bbar, Outputs(p.output, p.summary or os.path.join(p.output,
                                                                       "summary.json"),
                                   p.figures, p.figure_format), provenance.options(p),
                   Ground.from_options(p).as_material(), loading, p.surcharge,
                   p.checkpoint_every, p.restart, p.overwrite, checkpoint.signature(p),
                   checkpoint.recorded(provenance.options(p)))

    @property
    def load_control(self) -> bool:
        return self.loading.load > 0

    def reference(self) -> tuple:
        """(the reference bearing capacity (Pa), its name), or (NaN, None) (with gravity):
        Prandtl's (2 + pi) c_u + q0 on Tresca soil; Prandtl-Reissner's N_c c + N_q q0 on
        weightless c-phi soil under associated flow (N_q = e^(pi tan phi) tan^2(45 +
        phi/2), N_c = (N_q - 1) cot phi; Drucker-Prager's plane-strain match has
        Mohr-Coulomb's collapse loads), q0 the surcharge."""
        m, q0 = self.material, self.surcharge
        if self.loading.gravity > 0:
            return math.nan, None
        if self.material_name == "tresca":
            return (2 + math.pi) * self.cohesion + q0, "Prandtl (2 + pi) c_u" + \
                (" + q0" if q0 else "")
        if self.material_name in ("mohr-coulomb", "drucker-prager") and m.phi > 0 \
                and m.psi == m.phi and m.cohesion > 0:
            t = math.tan(math.radians(m.phi))
            N_q = math.exp(math.pi * t) * math.tan(math.radians(45 + m.phi / 2)) ** 2
            N_c = (N_q - 1) / t
            return N_c * m.cohesion + N_q * q0, (f"Prandtl-Reissner N_c c (N_c {N_c:.4g})"
                                                 + (f" + N_q q0 (N_q {N_q:.4g})" if q0
                                                    else ""))
        return math.nan, None


def run(p, comm) -> int:
    """The static analysis of the options ``p``; returns 0."""
    plan = StaticPlan.from_options(p)
    record = Record("static", comm)
    signals.stage("set-up: the static analysis")
    with owned(comm) as stack:
        guarded(record, lambda: _analysis(plan, comm, record, stack))
    return 0


def _held(grid, plan) -> tuple:
    """(held, loaded): masks over the owned DOFs of the supports and the footing, and of
    the vertical DOFs of the footing (or of the top under the load)."""
    held = grid.constrained_mask(plan.body.supports).reshape(-1, 2)
    I, J = grid.owned_lattice()
    x = I * grid.h[0] / grid.order
    under = (J == grid.nodes[1] - 1) & (x >= plan.footing[0] - 1e-9 * grid.h[0]) \
        & (x <= plan.footing[1] + 1e-9 * grid.h[0])
    if not plan.load_control:
        held[under, 1] = True
        if plan.rough:
            held[under, 0] = True
    loaded = np.zeros_like(held)
    loaded[under, 1] = True
    return held.ravel(), loaded.ravel()


def _analysis(plan, comm, record, stack) -> None:
    ckpt, run_id = checkpoint.take_up(plan.restart, plan.overwrite, plan.signature,
                                      plan.outputs, comm)
    record.begin(plan.outputs, run_id, plan.provenance)
    body = plan.body
    grid = Grid(comm, body.element, body.cells, body.size)
    stack.callback(grid.destroy)
    points = place(grid, body.ppc, 1.0, "uniform", restart.fields(plan.material))
    stack.callback(points.destroy)
    if ckpt is not None:
        checkpoint.scatter(points, grid, ckpt, "x")
    held, loaded = _held(grid, plan)
    sigma0, forces = at_rest(grid, points, plan.body, plan.soil, plan.loading,
                             plan.surcharge, plan.footing)
    problem = StaticProblem(grid, points, plan.material, held, loaded, plan.bbar, sigma0,
                            plan.load_control)
    stack.callback(problem.destroy)
    problem.loads(*forces(problem))
    newton = _newton(comm, problem)
    for obj in newton:
        stack.callback(obj.destroy)
    reporting.banner(plan, points.n_global, comm)
    series = reporting.FieldSeries(plan.outputs.folder, comm, run_id)
    record.enter("stepping")
    if ckpt is not None:
        progress = restart.resume(ckpt, points, problem, series, ckpt.run_id)
        PETSc.Sys.Print(f"Restart from {plan.restart}: step {len(progress.residuals)}, "
                        f"{progress.s:.5g} of {_end(plan):.5g}", comm=comm)
    else:
        if _step(newton, problem, 0.0, 0.0) is None:
            raise NumericalError("static: no equilibrium at the start (the weight and the "
                                 "surcharge alone fail the soil)")
        nominal = _end(plan) / plan.steps
        progress = restart.Progress.start(nominal, _measured(plan, problem, 0.0))
    run = {"id": run_id, "options": plan.recorded}
    _stepping(plan, problem, newton, (points, series, run), progress, comm, record)
    record.enter("reporting")
    reporting.plastic_zone(plan, points, problem, comm, record)
    if series.files():
        record.files["fields"] = series.files()
    record.finish()


def _end(plan) -> float:
    """Where the stepping ends: the settlement (m), or the load's whole share 1."""
    return 1.0 if plan.load_control else plan.settlement


def _measured(plan, problem, value) -> tuple:
    """(settlement (m), pressure (Pa)) of the converged state at ``value``."""
    return ((problem.settlement(), value * plan.loading.load) if plan.load_control else
            (value, problem.reaction() / (plan.footing[1] - plan.footing[0])))


def _stepping(plan, problem, newton, out, pr, comm, record) -> None:
    """The steps from ``pr`` (restart.Progress) to the end, each halved where Newton does
    not converge, up to CUTS times; a checkpoint every -mpm_checkpoint_every steps; the
    load-displacement curve reported (also when the run gives up: exit 3). ``out``: the
    points, the field series and the run (id, options) a checkpoint records."""
    points, series, run = out
    end, q = _end(plan), plan.loading.load
    unit = "load" if plan.load_control else "settlement"
    while pr.s < end * (1 - 1e-12):
        step = min(pr.ds, end - pr.s)
        its = _step(newton, problem, pr.s + step, step / pr.last if pr.last else 0.0)
        if its is None:
            pr.ds /= 2
            if pr.ds < pr.nominal / 2 ** CUTS:
                # The converged steps are written before the run gives up (exit 3).
                reporting.report(plan, np.array(pr.curve), pr.residuals, points.n_global,
                                 comm, record, failed=True)
                at = (f"the soil failed under {(pr.s + step) * q:.4g} Pa (the last load "
                      f"carried {pr.s * q:.4g} Pa): Newton found no equilibrium"
                      if plan.load_control else
                      f"Newton did not converge at settlement {pr.s + step:.4g} m")
                raise NumericalError(f"static: {at}, even with steps {2 ** CUTS} times "
                                     "shorter (-mpm_snes_*, -mpm_load_steps)")
            continue
        pr.s, pr.last = pr.s + step, step
        pr.residuals.append(its)
        if len(its) <= GROW_BELOW:       # an easy step: back towards the asked length
            pr.ds = min(2 * pr.ds, pr.nominal)
        record.steps = len(pr.residuals)
        pr.curve.append(_measured(plan, problem, pr.s))
        series.write(points, problem, len(pr.residuals), pr.curve[-1][0])
        if plan.checkpoint_every and len(pr.residuals) % plan.checkpoint_every == 0:
            restart.save(restart.path_of(plan), comm, points, problem, pr, series, plan, run)
        PETSc.Sys.Print(f"  {unit} {pr.s if not plan.load_control else pr.s * q:.5g}: "
                        f"settlement {pr.curve[-1][0]:.5g} m, pressure {pr.curve[-1][1]:.6g}"
                        f" Pa, {len(its) - 1} Newton iterations", comm=comm)
    reporting.report(plan, np.array(pr.curve), pr.residuals, points.n_global, comm, record)


def _newton(comm, problem) -> tuple:
    """(SNES newtonls with MUMPS LU, its options under -mpm_; the solution vector; a work
    vector)."""
    snes = newton_solver(comm, "mpm_", rtol=1e-9, atol=1e-12, max_it=25)
    x = problem.u.getSubVector(problem.free)
    F = x.duplicate()
    problem.u.restoreSubVector(problem.free, x)
    snes.setFunction(problem.residual, F)
    problem.J = _pattern(problem)
    snes.setJacobian(problem.jacobian, problem.J)
    return snes, F.duplicate(), F.duplicate()


def _pattern(problem):
    """The Jacobian over the free DOFs, with the points' couplings as its pattern."""
    n = problem.dofs.shape[1]
    if len(problem.volume):
        problem.K.setValuesLocalRCV(problem.dofs, problem.dofs,
                                    np.ones((len(problem.volume), n, n)),
                                    addv=PETSc.InsertMode.ADD_VALUES)
    problem.K.assemble()
    return problem.K.createSubMatrix(problem.free, problem.free)


def _step(newton, problem, settlement, ratio):
    """Newton to the settlement (m) from the last step's increment times ``ratio`` (this
    step's length over the last's): its residual norms (the first before any iteration),
    or None where it did not converge."""
    snes, x, work = newton
    problem.predict(ratio)
    problem.prescribe(settlement)
    sub = problem.u.getSubVector(problem.free)
    sub.copy(x)
    problem.u.restoreSubVector(problem.free, sub)
    snes.solve(None, x)
    if snes.getConvergedReason() <= 0:
        return None                          # the next try predicts from u_n afresh
    problem.residual(snes, x, work)          # the stresses of the converged x
    problem.commit()
    return [float(r) for r in snes.getConvergenceHistory()[0]]
