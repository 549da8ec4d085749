"""The load-stepped static analysis (``-mpm_analysis static``): a rigid strip footing pushed
into a weightless body to ``-mpm_footing_settlement`` in ``-mpm_load_steps`` steps, Newton
on SNES at each (steps cut in half and retried where it does not converge).

A halved step doubles again after a step that Newton takes in fewer than GROW_BELOW
iterations, up to the asked length. Writes ``load_displacement.csv`` (``settlement_m``, ``pressure_pa``: the mean contact
pressure, from the nodal internal forces under the footing), its figure with the reference
where the scene has one, and the summary's ``static`` block: ``bearing_capacity_pa`` (the
peak, or the plateau: the last step) and how it was picked, ``reference_pa`` and
``reference`` (Prandtl's (2 + pi) c_u for Tresca soil), ``error_pct``, ``newton_iterations``
and ``newton_residuals`` (per step, the residual norms).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError, NumericalError
from ..io import provenance
from ..io.output import Outputs
from ..materials import catalog
from ..model.grid import Grid
from ..model.points import place
from ..model.scene import Body
from ..run.record import Record, guarded, owned
from . import reporting
from .problem import StaticProblem

CUTS = 6            # halvings of a step before the run gives up
GROW_BELOW = 6      # a step that converged in fewer Newton iterations doubles the next


@dataclass(frozen=True)
class StaticPlan:
    """The body, its material, the footing (x0, x1 in m; rough or smooth), the settlement
    (m) in steps, B-bar, where results go, the provenance."""

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

    @classmethod
    def from_options(cls, p) -> "StaticPlan":
        material = catalog.Recipe.from_options(p).make(p.E, p.nu)
        if p.material == "mcc":
            raise InputError("-mpm_material mcc: the static analysis starts unstressed (no "
                             "gravity yet), where Cam Clay has no strength")
        if not p.footing:
            raise InputError("-mpm_footing X0,X1: the static analysis pushes a footing")
        x0, x1 = p.footing
        if not 0 <= x0 < x1 <= p.size[0]:
            raise InputError(f"-mpm_footing {x0:g},{x1:g}: outside the top (0 <= x0 < x1 "
                             f"<= {p.size[0]:g} m)")
        return cls(Body.from_options(p), material, p.material, p.cohesion, (x0, x1),
                   p.footing_interface == "rough", p.footing_settlement, p.load_steps,
                   p.bbar, Outputs(p.output, p.summary or os.path.join(p.output,
                                                                       "summary.json"),
                                   p.figures, p.figure_format), provenance.options(p))

    def reference(self) -> tuple:
        """(the reference bearing capacity (Pa), its name), or (NaN, None): Prandtl's
        (2 + pi) c_u on Tresca soil; Prandtl-Reissner's N_c c on weightless c-phi soil under
        associated flow (N_c = (N_q - 1) cot phi, N_q = e^(pi tan phi) tan^2(45 + phi/2);
        Drucker-Prager's plane-strain match has Mohr-Coulomb's collapse loads)."""
        m = self.material
        if self.material_name == "tresca":
            return (2 + math.pi) * self.cohesion, "Prandtl (2 + pi) c_u"
        if self.material_name in ("mohr-coulomb", "drucker-prager") and m.phi > 0 \
                and m.psi == m.phi and m.cohesion > 0:
            t = math.tan(math.radians(m.phi))
            N_q = math.exp(math.pi * t) * math.tan(math.radians(45 + m.phi / 2)) ** 2
            return (N_q - 1) / t * m.cohesion, f"Prandtl-Reissner N_c c (N_c {(N_q - 1) / t:.4g})"
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
    the footing's vertical DOFs."""
    held = grid.constrained_mask(plan.body.supports).reshape(-1, 2)
    I, J = grid.owned_lattice()
    x = I * grid.h[0] / grid.order
    under = (J == grid.nodes[1] - 1) & (x >= plan.footing[0] - 1e-9 * grid.h[0]) \
        & (x <= plan.footing[1] + 1e-9 * grid.h[0])
    held[under, 1] = True
    if plan.rough:
        held[under, 0] = True
    loaded = np.zeros_like(held)
    loaded[under, 1] = True
    return held.ravel(), loaded.ravel()


def _analysis(plan, comm, record, stack) -> None:
    record.begin(plan.outputs, None, plan.provenance)
    body = plan.body
    grid = Grid(comm, body.element, body.cells, body.size)
    stack.callback(grid.destroy)
    points = place(grid, body.ppc, 1.0, "uniform")
    stack.callback(points.destroy)
    held, loaded = _held(grid, plan)
    problem = StaticProblem(grid, points, plan.material, held, loaded, plan.bbar)
    stack.callback(problem.destroy)
    newton = _newton(comm, problem)
    for obj in newton:
        stack.callback(obj.destroy)
    width = plan.footing[1] - plan.footing[0]
    PETSc.Sys.Print(f"Static analysis: a {'rough' if plan.rough else 'smooth'} footing "
                    f"{plan.footing[0]:g} to {plan.footing[1]:g} m on {plan.material_name}, "
                    f"{body.element.upper()} {body.cells[0]} x {body.cells[1]} cells, "
                    f"{points.n_global} points, B-bar {'on' if plan.bbar else 'off'}",
                    comm=comm)
    series = reporting.FieldSeries(plan.outputs.folder, comm)
    record.enter("stepping")
    curve, residuals = [(0.0, 0.0)], []
    s, ds, last = 0.0, plan.settlement / plan.steps, 0.0
    while s < plan.settlement * (1 - 1e-12):
        step = min(ds, plan.settlement - s)
        its = _step(newton, problem, s + step, step / last if last else 0.0)
        if its is None:
            ds /= 2
            if ds < plan.settlement / plan.steps / 2 ** CUTS:
                # The converged steps are written before the run gives up (exit 3).
                reporting.report(plan, np.array(curve), residuals, points.n_global, comm,
                                 record)
                raise NumericalError(f"static: Newton did not converge at settlement "
                                     f"{s + step:.4g} m, even with steps {2 ** CUTS} times "
                                     "shorter (-mpm_snes_*, -mpm_load_steps)")
            continue
        s, last = s + step, step
        residuals.append(its)
        if len(its) <= GROW_BELOW:       # an easy step: back towards the asked length
            ds = min(2 * ds, plan.settlement / plan.steps)
        record.steps = len(residuals)
        curve.append((s, problem.reaction() / width))
        series.write(points, problem, len(residuals), s)
        PETSc.Sys.Print(f"  settlement {s:.5g} m: pressure {curve[-1][1]:.6g} Pa, "
                        f"{len(its) - 1} Newton iterations", comm=comm)
    record.enter("reporting")
    reporting.report(plan, np.array(curve), residuals, points.n_global, comm, record)
    reporting.plastic_zone(plan, points, problem, comm, record)
    if series.files():
        record.files["fields"] = series.files()
    record.finish()


def _newton(comm, problem) -> tuple:
    """(SNES newtonls with MUMPS LU, its options under -mpm_; the solution vector; a work
    vector)."""
    snes = PETSc.SNES().create(comm)
    snes.setOptionsPrefix("mpm_")
    snes.setType("newtonls")
    x = problem.u.getSubVector(problem.free)
    F = x.duplicate()
    problem.u.restoreSubVector(problem.free, x)
    snes.setFunction(problem.residual, F)
    problem.J = _pattern(problem)
    snes.setJacobian(problem.jacobian, problem.J)
    snes.setTolerances(rtol=1e-9, atol=1e-12, max_it=25)
    snes.setConvergenceHistory(reset=True)
    ksp = snes.getKSP()
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    snes.setFromOptions()
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
