"""``-mpm_analysis dynamic``: the body shaken at its base, or loaded suddenly, stepped in time.

One phase (:class:`column.ShakenBody`: the solid with the mixture's density, a dry or
total-stress analysis) under a base motion and a sudden surface load; two phases
(:mod:`solver.dynamic.saturated`: the explicit v-w step of the consolidation analysis
without its damping) under a sudden load. The set-up reads the options once
(:func:`plan_of`), computes the lowest natural frequencies of the same column by our Jacobi
solver (the default Rayleigh frequencies f1 and 5 f1, and the marks on the transfer
function), then steps, recording the row means at the recorded depths every
``-mpm_record_dt`` and the peaks of every row (:mod:`solver.dynamic.histories`),
checkpointing as asked and on SIGTERM; the reporting writes the histories, spectra,
peaks with depth, figures, the nodal or point fields (XDMF) and the summary's ``dynamic`` block.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError, Interrupted, NumericalError, describe, entry
from ..modal.frequency import lowest
from ..io import checkpoint, output, provenance
from ..io import records as record_files
from ..model import scene
from ..model.motion import Motion, parse
from ..model.scene import Body, Loading
from ..model.soil import Ground
from ..references import layered
from . import histories, reporting
from ..stepping.onephase import ShakenBody, Shaking, rayleigh

EIGEN_DOFS = 2000          # the dense Jacobi solve's largest problem here (about 30 s)
MAX_STEPS = 5e7


@dataclasses.dataclass
class DynamicPlan:
    """What a dynamic run does, resolved from the options: the body, ground and shaking,
    the sides (rollers, periodic, absorbing), the load (None: none), the motion, the
    phases, the end (s), the recorded depths (m), the natural frequencies (Hz; Jacobi's and
    the layered rod's), the Rayleigh damping (xi, F1, F2 or None), the outputs and the
    run's provenance."""

    body: Body
    ground: Ground
    shaking: Shaking
    sides: str
    loading: Loading | None
    motion: Motion
    phases: int
    t_end: float
    record_dt: float
    depths: tuple
    eigen_hz: np.ndarray
    eigen_solver: str
    analytic_hz: np.ndarray
    damping: tuple | None
    outputs: output.Outputs
    run: dict
    signature: str
    restart: str
    cadence: tuple          # (output_every, checkpoint_every, checkpoint_seconds, progress)


@dataclasses.dataclass(frozen=True)
class Request:
    """The dynamic options, typed: read once at the edge (:meth:`from_options`)."""

    body: Body                 # its supports still the options' (plan_of sets the shaking's)
    ground: Ground
    phases: int
    motion: str                # -mpm_base_motion as given
    scale: float
    direction: str
    base: str
    rock: tuple                # (rho (kg/m3), Vs, Vp (m/s))
    sides: str                 # rollers | periodic | absorbing
    rayleigh: tuple
    t_end: float
    record_dt: float
    depths: tuple
    loading: Loading | None    # the sudden load, when given
    water: bool                # rho_l > 0
    jacobi: tuple              # (tolerance, sweeps)
    outputs: output.Outputs
    cadence: tuple             # (output_every, checkpoint_every, checkpoint_seconds, progress)
    restart: str
    overwrite: bool
    run: dict                  # {"id": None, "options": the options as read}
    signature: str
    provenance: dict

    @classmethod
    def from_options(cls, p) -> "Request":
        summary = p.summary or os.path.join(p.output, "summary.json")
        # The load acts when given (its default is consolidation's), by this command or by
        # the start of the run a restart continues.
        given = set(p.given) | set(checkpoint.given_at_start(p.restart))
        loading = Loading(load=p.load, extent=tuple(p.load_extent)) if "load" in given \
            else None
        return cls(body=Body.from_options(p), ground=Ground.from_options(p), phases=p.phases,
                   motion=p.base_motion, scale=p.base_motion_scale,
                   # Two phases under a load alone move vertically.
                   direction="y" if p.phases == 2 and parse(p.base_motion)[0] == "none"
                   else p.base_direction, base=p.base,
                   rock=(p.rock_rho, p.rock_Vs, p.rock_Vp), sides=p.bc_sides,
                   rayleigh=tuple(p.rayleigh), t_end=p.t_end, record_dt=p.record_dt,
                   depths=tuple(p.record_depths), loading=loading, water=p.rho_l > 0,
                   jacobi=(p.jacobi_tol, p.jacobi_max_sweeps),
                   outputs=output.Outputs(p.output, summary, p.figures, p.figure_format),
                   cadence=(p.output_every, p.checkpoint_every, p.checkpoint_seconds,
                            p.progress), restart=p.restart, overwrite=p.overwrite,
                   run={"id": None, "options": checkpoint.recorded(p),
                        "given": sorted(given)},
                   signature=checkpoint.signature(p), provenance=provenance.options(p))


def validate(req: Request) -> None:
    """InputError for options that contradict each other."""
    W, H = req.body.size
    moving = parse(req.motion)[0] != "none"
    if req.phases == 2 and moving and req.base != "rigid":
        raise InputError(f"-mpm_base {req.base}: two phases (-mpm_phases 2) are shaken on "
                         "a rigid base (-mpm_base rigid; the motion is the base's own)")
    if req.phases == 2 and req.sides != "rollers":
        raise InputError(f"-mpm_bc_sides {req.sides}: two phases take rollers")
    if req.phases == 2 and not req.water:
        raise InputError("-mpm_rho_l 0: two phases need pore water (rho_l > 0)")
    if not moving and req.loading is None:
        raise InputError("-mpm_base_motion none: nothing moves the body (give a base "
                         "motion or -mpm_load)")
    if req.loading is not None and req.direction == "x" and req.sides == "rollers":
        raise InputError("-mpm_load: with -mpm_base_direction x the sides are held "
                         "vertically and carry it; give -mpm_base_direction y"
                         + (", or -mpm_bc_sides periodic" if req.phases == 1 else ""))
    extent = req.loading.extent if req.loading is not None else ()
    if extent and not 0 <= extent[0] < extent[1] <= W:
        raise InputError(f"-mpm_load_extent {extent[0]:g},{extent[1]:g}: outside the top "
                         f"(0 <= x0 < x1 <= {W:g} m)")
    if req.sides == "absorbing" and moving:
        raise InputError("-mpm_bc_sides absorbing: dashpots for waves leaving a body whose "
                         "far field is at rest (a sudden load, no base motion); "
                         "a shaken body takes periodic sides")
    if req.sides == "periodic" and extent and req.loading.partial(W):
        raise InputError(f"-mpm_bc_sides periodic: a load on part of the top "
                         f"(-mpm_load_extent {extent[0]:g},{extent[1]:g}) is not the same on "
                         "every column; use rollers")
    deep = [d for d in req.depths if d > H]
    if deep:
        raise InputError(f"-mpm_record_depths {deep[0]:g}: below the base ({H:g} m deep)")
    if req.rayleigh and req.phases == 2:
        raise InputError("-mpm_rayleigh: for one phase (the v-w step's drag damps the "
                         "two-phase waves)")
    if req.t_end / req.record_dt > 1e6:
        raise InputError(f"-mpm_record_dt {req.record_dt:g}: more than 1e6 samples to "
                         f"-mpm_t_end {req.t_end:g} s")


def motion_of(req: Request) -> tuple:
    """(the base motion of ``-mpm_base_motion`` times its scale, the notes): a record file
    is read here (InputError: missing, unreadable, times not increasing)."""
    form = parse(req.motion)
    table = record_files.read(form[1]) if form[0] == "file" else None
    motion = Motion(form, req.scale, table)
    notes = []
    if motion.end < req.t_end:
        notes.append(f"-mpm_base_motion {form[1]}: the record ends at {motion.end:.6g} s, "
                     f"before -mpm_t_end {req.t_end:g} s; zero acceleration after it")
    return motion, notes


def plan_of(req: Request, comm) -> DynamicPlan:
    """The plan of the request (printed as it goes): the motion read, the shaken body's
    supports, the natural frequencies, the Rayleigh coefficients."""
    validate(req)
    motion, notes = motion_of(req)
    for note in notes:
        PETSc.Sys.Print(f"Note: {note}", comm=comm)
    rho, Vs, Vp = req.rock
    shaking = Shaking(req.direction, "rigid" if req.phases == 2 else req.base, rho,
                      Vs if req.direction == "x" else Vp)
    body = dataclasses.replace(req.body, bcs=shaking.supports(req.sides))
    if req.loading is not None:
        req.loading.check_extent(body)
    eig, solver = np.zeros(0), "none"
    soils = req.ground.soils
    if req.phases == 1:
        signals.stage("set-up: the natural frequencies")
        eigen_body = dataclasses.replace(body, bcs=Shaking(req.direction, "rigid").supports())
        eig, solver = lowest(comm, eigen_body, req.ground, 3, "jacobi", *req.jacobi,
                             "eigen_", EIGEN_DOFS)
        modulus = [s.shear_modulus if req.direction == "x" else s.constrained_modulus
                   for s in soils]
    else:         # the waves of a saturated column: undrained, the phases locked by drag
        modulus = [s.shear_modulus if req.direction == "x" else
                   s.constrained_modulus + s.K_l / s.porosity for s in soils]
    analytic = layered.rod_frequencies(req.ground.thickness, modulus,
                                       [s.density for s in soils], 3)
    damping = None
    if req.rayleigh:
        xi = req.rayleigh[0]
        f1, f2 = req.rayleigh[1:] if len(req.rayleigh) == 3 else (eig[0], 5 * eig[0])
        damping = (xi, f1, f2)
        shaking = dataclasses.replace(shaking, **dict(zip(("a0", "a1"), rayleigh(xi, f1,
                                                                                   f2))))
    return DynamicPlan(body=body, ground=req.ground, shaking=shaking, sides=req.sides,
                       loading=req.loading, motion=motion, phases=req.phases,
                       t_end=req.t_end, record_dt=req.record_dt, depths=req.depths,
                       eigen_hz=eig, eigen_solver=solver, analytic_hz=analytic,
                       damping=damping, outputs=req.outputs, run=dict(req.run),
                       signature=req.signature, restart=req.restart, cadence=req.cadence)


def run(p, comm) -> int:
    """Run the dynamic scene of the options ``p``; returns 0."""
    t_wall = time.perf_counter()
    signals.stage("set-up: the options' checks")
    req = Request.from_options(p)
    restart = checkpoint.read(req.restart, req.signature) if req.restart else None
    if restart is not None and not req.overwrite:
        checkpoint.check_folder(req.outputs.folder, req.outputs.summary, req.restart,
                                restart[3], comm)
    plan = plan_of(req, comm)
    plan.run["id"] = restart[3] if restart and restart[3] else checkpoint.new_run_id(comm)
    if plan.phases == 2:
        from .saturated import SaturatedColumn as Model
    else:
        Model = NodalModel
    model = Model(comm, plan)
    done = False
    try:
        code = _run(plan, model, restart, comm, t_wall, req.provenance)
        done = True
        return code
    finally:
        # After a failure on some ranks only, the others wait in a collective: destroying
        # (collective too) would hang; the caller aborts MPI.
        if done or comm.getSize() == 1:
            model.destroy()


class NodalModel:
    """One phase on the nodes (:class:`ShakenBody`) as the time loop drives it: the step,
    the row means of a sample, the state of a checkpoint, the fields of the XDMF series."""

    water = False
    lag = 0.0               # a sample is of the step's start

    def __init__(self, comm, plan: DynamicPlan):
        signals.stage("set-up: the body")
        self.plan = plan
        self.body = ShakenBody(comm, plan.body, plan.ground, plan.shaking, plan.sides,
                               plan.loading)
        b = self.body
        self.dt, self.every = histories.sample_step(plan.record_dt, b.dt)
        b.start(self.dt)
        ny, nx = b.grid.nodes[1], b.grid.nodes[0]
        self.heights = np.linspace(0.0, plan.body.height, ny)
        self.key, self.nx = b.row * 2 + b.comp, nx
        self.full = b.T.createVecLeft() if b.T is not None else None
        self.vec = b.K.createVecRight()
        self.mpi = comm.tompi4py()
        self.a = np.zeros(len(b.m))
        self.points = b.points

    def step(self, t: float) -> None:
        m = self.plan.motion
        self.a = self.body.step(t, m.velocity, m.acceleration)

    def _full(self, values) -> np.ndarray:
        self.vec.setArray(values)
        return self.body.expand(self.vec, self.full).copy()

    def means(self, t: float) -> np.ndarray:
        """The row means (rows x COLUMNS) at t (s), the step from t just taken."""
        a = self.a
        u, v = self._at_step_start()
        ny = len(self.heights)
        b = self.body
        sums = np.stack([np.bincount(self.key, weights=self._full(x), minlength=2 * ny)
                         for x in (a, v, u)])
        sums = self.mpi.allreduce(sums) / self.nx
        out = np.full((ny, 7), np.nan)
        for c in (0, 1):
            out[:, 3 * c:3 * c + 3] = sums[:, c::2].T
        comp = 3 * (0 if b.shaking.direction == "x" else 1)
        if b.shaking.base == "rigid":        # the frame of the base: absolute a and v
            m = self.plan.motion
            out[:, comp] += m.acceleration(t)
            out[:, comp + 1] += m.velocity(t)
        else:                                # displacements relative to the base
            out[:, [2, 5]] -= out[0, [2, 5]]
        return out

    def _at_step_start(self) -> tuple:
        """(u, v) at the time t of the step just taken (this rank's reduced values): the
        step left u at t + dt and v at t + dt / 2."""
        v_half = self.body.v.getArray()
        return self.body.u.getArray() - self.dt * v_half, v_half - self.a * self.dt / 2

    def check(self, step: int, t: float) -> None:
        local = float(np.max(np.abs(self.body.v.getArray()), initial=0.0))
        if not math.isfinite(self.mpi.allreduce(local, op=_max())):
            raise NumericalError(f"the run blew up at step {step} (t = {t:.6g} s)")

    def _gathered(self, *values):
        """Rows (natural DOF number, each of ``values`` on the free DOFs: this rank's
        reduced values) of every free DOF, in natural order, on rank 0; None elsewhere."""
        columns = [self.body.free.getIndices()] + [self._full(x) for x in values]
        parts = self.mpi.gather(np.column_stack(columns), root=0)
        if parts is None:
            return None
        whole = np.concatenate(parts)
        return whole[np.argsort(whole[:, 0])]

    def state(self) -> dict:
        """u, v of every free DOF (natural numbers, gathered on rank 0)."""
        whole = self._gathered(*self.body.state())
        return {} if whole is None else {"nodal": whole.tolist()}

    def restore(self, restart) -> None:
        """Take up the state of a checkpoint (:func:`checkpoint.read`'s)."""
        whole = np.array(restart[2]["nodal"], dtype=float)
        idx = self.body.free.getIndices()
        at = np.searchsorted(whole[:, 0], idx)
        self.body.u.setArray(whole[at, 1][self.body.kept])
        self.body.v.setArray(whole[at, 2][self.body.kept])

    def fields(self) -> tuple:
        """(node coordinates (N, 2), {name: (N, 3)}) of every node at the time of the step
        just taken, natural order (rank 0; None elsewhere): displacement, velocity and
        acceleration (relative to a rigid base)."""
        b = self.body
        whole = self._gathered(*self._at_step_start(), self.a)
        if whole is None:
            return None
        nx, ny = b.grid.nodes
        n = nx * ny
        out = {name: np.zeros((n, 3)) for name in ("displacement", "velocity",
                                                    "acceleration")}
        node, comp = whole[:, 0].astype(int) // 2, whole[:, 0].astype(int) % 2
        for col, name in enumerate(("displacement", "velocity", "acceleration")):
            out[name][node, comp] = whole[:, col + 1]
        j, i = np.divmod(np.arange(n), nx)
        xy = np.column_stack([i * b.grid.size[0] / (nx - 1), self.heights[j]])
        return xy, out

    def destroy(self):
        scene.destroy(self.vec, self.full, self.body)


def _run(plan, model, restart, comm, t_wall, recorded) -> int:
    """The time loop and the reporting."""
    dt, every = model.dt, model.every
    nsteps = int(math.ceil(plan.t_end / dt - 1e-9))
    if nsteps > MAX_STEPS:
        raise InputError(f"-mpm_t_end {plan.t_end:g}: {nsteps:.3g} steps of {dt:.3g} s; "
                         f"more than {MAX_STEPS:.0e} is not a run that finishes")
    rec = histories.Recorder(model.heights, plan.body.height, plan.depths,
                             plan.shaking.direction)
    first = 0
    if restart is not None:
        state = restart[2]
        first = state["step"]
        if first > nsteps:
            raise InputError(f"-mpm_t_end {plan.t_end:g}: before the state of -mpm_restart "
                             f"{plan.restart} (t = {first * dt:.6g} s)")
        model.restore(restart)
        rec.restore(state["records"])
    series = reporting.Series(plan, model, comm, restart)
    summary = reporting.summary_head(plan, model, nsteps, recorded)
    reporting.print_plan(plan, model, nsteps, comm)
    ckpt = os.path.join(plan.outputs.folder, "checkpoint.npz")
    save = lambda k: checkpoint.write(  # noqa: E731
        ckpt, comm, model.points, {"step": k, "dt": dt, "records": rec.to_dict(),
                                        "series": series.entries(), **model.state()},
        plan.signature, plan.run)
    output_every, ckpt_every, ckpt_seconds, progress = plan.cadence
    out_every = output_every or max(1, nsteps // 50)
    last_print = last_ckpt = t0 = time.perf_counter()
    k = first
    with signals.deferred("stepping") as stop, PETSc.Log.Stage("Dynamic steps"):
        try:
            for k in range(first, nsteps + 1):
                t = k * dt
                model.step(t)
                if k % every == 0:
                    rec.sample(t + model.lag, model.means(t))
                if k % 200 == 0 or k == nsteps:
                    model.check(k, t)
                if k % out_every == 0 or k == nsteps:
                    series.write(k, t)
                due = ckpt_seconds > 0 and time.perf_counter() - last_ckpt > ckpt_seconds
                # Every rank stops at the same step: a signal (bit 1) or a checkpoint due
                # by the clock (bit 0) on any rank is every rank's.
                flags = model.mpi.allreduce(2 * stop.seen + int(due), op=_bor()) \
                    if (ckpt_seconds > 0 or k % 50 == 0) else 0
                if flags or (ckpt_every and k % ckpt_every == 0):
                    save(k + 1)
                    last_ckpt = time.perf_counter()
                if flags & 2:
                    raise Interrupted(f"stopped by {stop.name} at step {k} (t = {t:.6g} "
                                      f"s); checkpoint {ckpt}; continue with -mpm_restart "
                                      f"{ckpt}", stage="stepping", agreed=True)
                if progress and time.perf_counter() - last_print > progress:
                    last_print = time.perf_counter()
                    PETSc.Sys.Print(reporting.progress_line(rec, k, nsteps, t, t0, first),
                                    comm=comm)
        except (Exception, Interrupted) as exc:   # noqa: BLE001  (written, then raised on)
            known = isinstance(exc, (NumericalError, Interrupted))
            summary.update(completed=False, step=k, wall_seconds=time.perf_counter() - t_wall,
                           error=entry(str(exc) if known else describe(exc),
                                       exc.exit_code if known else 5, "stepping"))
            if isinstance(exc, Interrupted):
                summary["interrupted"] = True
            if comm.getRank() == 0:
                output.write_json(plan.outputs.summary,
                                  dict(summary, files={"summary": plan.outputs.summary}))
            raise
    signals.stage("reporting")
    return reporting.finish(plan, model, rec, series, summary, comm, t_wall)


def _max():
    from mpi4py import MPI

    return MPI.MAX


def _bor():
    from mpi4py import MPI

    return MPI.BOR
