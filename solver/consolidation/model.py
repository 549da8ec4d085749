"""The consolidating body as the loop (:mod:`solver.run.loop`) drives it: the explicit v-w
step (:class:`solver.stepping.twophase.TwoPhase`) or the implicit scheme
(:class:`solver.consolidation.implicit.quasistatic.QuasiStatic`) on the plan's steps, with
the run's reporting (:class:`reporting.Reporting`: the monitor, profiles, isochrones and
the field series) and its records (:class:`state.RunState`, what a checkpoint stores)."""

from __future__ import annotations

import time

from ..stepping.twophase import TwoPhase
from . import reporting, workprecision
from .implicit.quasistatic import QuasiStatic


class Consolidation:
    """The run of ``plan`` on its ``grid`` and ``points`` from ``state`` (its first step's;
    a restart's records), reporting to ``comm``'s rank 0."""

    def __init__(self, plan, grid, points, state, comm):
        self.plan, self.records, self.points = plan, state, points
        self.implicit = plan.method == "implicit"
        if self.implicit:
            self.engine = QuasiStatic(grid, points, plan.soil, plan.body, plan.loading,
                                      plan.stabilize, plan.materials)
            self.log_stage = "Implicit steps"
        else:
            self.engine = TwoPhase(grid, points, plan.soil, plan.body, plan.loading,
                                   plan.scheme, plan.materials)
            self.log_stage = "Explicit steps"
        self.reports = reporting.Reporting(plan, grid, points, state, comm)
        # What a blow-up is measured against: the load, or the column's weight.
        self.scale = max(plan.refs.q, plan.soil.density * plan.loading.gravity
                         * plan.body.height, 1.0)
        self.pace = None
        self.comm = comm

    def begin(self) -> None:
        """Before the first step of this command: the implicit scheme's undrained start at
        t = 0+ (a restart's nodal state instead); the -mpm_target_error pace."""
        sched = self.plan.schedule
        if self.implicit:
            if self.records.step == 0:
                self.engine.start()
            else:
                self.engine.restore(self.records.nodal)
        if self.plan.goal:
            self.pace = workprecision.Pace(self.records.step + 1, sched.nsteps,
                                           time.perf_counter())

    def time(self, k: int) -> float:
        """The time (s) at the end of step ``k``."""
        return self.plan.schedule.time(k)

    def advance(self, k: int) -> None:
        sched, scheme = self.plan.schedule, self.plan.scheme
        if self.implicit:
            self.engine.step(sched.time(k - 1), sched.time(k))
        else:
            self.engine.step(sched.dt, self.plan.loading.factor(sched.time(k - 1)),
                             scheme.damping, scheme.flip)
            self.engine.migrate()
        said = self.pace and self.pace.tick(k, time.perf_counter())
        if said:
            from petsc4py import PETSc

            PETSc.Sys.Print(said, comm=self.comm)

    def check(self, k: int) -> None:
        self.engine.check(k, self.time(k), self.scale)

    def sample(self, k: int) -> None:
        """The monitor and settlement at step ``k``; at an isochrone step the profile, and at
        a report step its report."""
        self.reports.sample(self.time(k))
        if k in self.plan.schedule.iso_steps:
            self.reports.isochrone(k, self.time(k))

    def write_fields(self, k: int) -> None:
        self.reports.write_fields(k, self.time(k))

    def state(self) -> dict:
        """The records (:class:`state.RunState`), with the implicit scheme's nodal state
        (collective)."""
        if self.implicit:
            self.records.nodal = self.engine.state()
        return self.records.to_dict()

    def progress(self, k: int) -> str:
        t, history = self.time(k), self.records.history
        return (f"t = {t:.4g} s, T_v = {self.plan.refs.time_factor(t):.4f}, p/q(monitor) = "
                f"{history[-1][2] if history else float('nan'):.4f}")

    def destroy(self) -> None:
        self.engine.destroy()
