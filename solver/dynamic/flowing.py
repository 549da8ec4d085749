"""``-mpm_analysis dynamic -mpm_kinematics large``: a body that flows across a background
grid larger than itself under gravity (a granular column released at once), stepped by the
explicit updated-Lagrangian step of :mod:`solver.stepping.flow` until it comes to rest.

The body is the W x H rectangle at the origin (``-mpm_size``, ``-mpm_cells`` over it,
``-mpm_ppc``), the grid ``-mpm_grid_size`` of the body's cells, its sides walls as
``-mpm_bc_*`` hold them, a Coulomb floor (``-mpm_floor_friction``) where the floor holds
y alone. The material is the materials room's (``-mpm_material``; Hencky's elasticity with
its return), the body at rest and unstressed when gravity acts (released at once). Each
rank steps its share of the points on the whole grid (its nodal sums are added over the
ranks in one all-reduce), so a point never changes rank and the ranks' work stays equal
as the body flows.

The step dt = ``-mpm_dt_safety`` h / c, h the smaller cell side and c = sqrt((K + 4 G / 3)
/ rho0) the compression-wave speed: Hencky's Kirchhoff stress is linear in the logarithmic
strain, so the current Cauchy stiffness and density scale alike with 1 / J and the current
wave speed is the initial one. The run ends when the kinetic energy has fallen to
``-mpm_rest_energy`` of its peak, or at ``-mpm_t_end``.
"""

from __future__ import annotations

import dataclasses
import math
import os

import numpy as np
from mpi4py import MPI

from ..common.errors import InputError, NumericalError
from ..io import checkpoint, output, provenance
from ..io.restart import given_at_start
from ..io.spec import FLOWING_ONLY, NOT_FLOWING
from ..materials import catalog
from ..model import lattice
from ..model.soil import Soil, constrained_modulus
from ..references.experiments import COLLAPSES
from ..run.loop import Cadence, Saving, drive
from ..run.record import Record, begun, guarded
from ..stepping.flow import Flow
from . import penetration, runout

MAX_STEPS = 5e7
SIDES = ("left", "right", "bottom", "top")


@dataclasses.dataclass(frozen=True)
class FlowPlan:
    """What a flowing run does, from the options: the body's ``size`` (m), ``cells`` and
    ``ppc``; the ``grid`` (a :class:`lattice.Lattice`); the ``density`` (kg/m3), the
    ``material`` and the compression-wave speed ``wave`` (m/s); the grid's ``walls``,
    ``friction`` of the floor, ``gravity`` (m/s2), F-bar, FLIP share, local damping; the
    step dt (s); the end (s) and rest fraction; the experiment (None or a
    :class:`references.experiments.Collapse`); a footing pushed in
    (:func:`penetration.plan_of`); outputs, cadence, restart and provenance."""

    size: tuple
    cells: tuple
    ppc: int
    grid: lattice.Lattice
    density: float
    material: object
    wave: float
    walls: dict
    friction: float
    gravity: float
    fbar: bool
    flip: float
    damping: float
    dt: float
    t_end: float
    rest_energy: float
    experiment: object
    footing: object           # None, or penetration.plan_of's dict
    outputs: output.Outputs
    cadence: tuple            # (output_every, checkpoint_every, checkpoint_seconds, progress)
    restart: str
    overwrite: bool
    run: dict
    signature: str
    provenance: dict


def _grid(size, cells, grid_size, kind, ppc) -> lattice.Lattice:
    """The background grid of ``kind``'s functions: the body's ``cells`` over its ``size``
    (m), over ``grid_size`` (m; empty: the body's); uGIMP's points ``ppc`` a cell across."""
    (W, H), h = size, (size[0] / cells[0], size[1] / cells[1])
    extents = tuple(grid_size) or (W, H)
    counts = []
    for d, (extent, body, step) in enumerate(zip(extents, (W, H), h)):
        n = extent / step
        if extent < body * (1 - 1e-12) or abs(n - round(n)) > 1e-6 * n:
            raise InputError(f"-mpm_grid_size {extents[0]:g},{extents[1]:g}: each side at "
                             f"least the body's and a whole number of its cells ({step:g} m "
                             f"{'across' if d == 0 else 'up'})")
        counts.append(int(round(n)))
    return lattice.Lattice(kind, tuple(counts), h, tuple(0.5 * s / ppc for s in h))


def _material(recipe, E, nu):
    """The material of the ``recipe`` (:class:`catalog.Recipe`) of constant elasticity
    (Hencky's): one soil."""
    if recipe.name in ("mcc", "hyperbolic"):
        raise InputError(f"-mpm_material {recipe.name}: not at finite strain (Hencky's "
                         "return needs a constant elasticity and a stress that its elastic "
                         "strain gives)")
    return recipe.make(E, nu)


def _experiment(name, size, recipe):
    """The experiment ``name`` (None for none), checked to be of the scene's column."""
    if name == "none":
        return None
    e = COLLAPSES[name]
    if (not np.allclose(size, e.size) or recipe.phi != e.phi or recipe.cohesion != e.cohesion
            or recipe.name not in ("mohr-coulomb", "drucker-prager")):
        raise InputError(f"-mpm_experiment {name}: of a {e.size[0]:g} x {e.size[1]:g} m "
                         f"column of friction angle {e.phi:g} and no cohesion (-mpm_size, "
                         "-mpm_friction_angle, -mpm_cohesion, -mpm_material)")
    return e


def check_given(given, kinematics: str) -> None:
    """InputError for an option ``given`` that the dynamic analysis does not read with
    ``kinematics`` (large: the flowing body; else the shaken one)."""
    if kinematics == "large":
        for name in NOT_FLOWING:
            if name in given:
                raise InputError(f"-mpm_{name}: not read by -mpm_analysis dynamic with "
                                 "-mpm_kinematics large")
        return
    for name in FLOWING_ONLY:
        if name in given:
            raise InputError(f"-mpm_{name}: read by -mpm_analysis dynamic with "
                             "-mpm_kinematics large only")


def plan_of(p) -> FlowPlan:
    """The plan of the options ``p`` (InputError for what contradicts itself)."""
    check_given(p.given, "large")
    recipe = catalog.Recipe.from_options(p)
    material = _material(recipe, p.E, p.nu)
    walls = {side: getattr(p, f"bc_{side}") for side in SIDES
             if getattr(p, f"bc_{side}") != "none"}
    if p.floor_friction and walls.get("bottom") != "y":
        raise InputError(f"-mpm_floor_friction {p.floor_friction:g}: with -mpm_bc_bottom y "
                         "(a floor that holds y alone; xy holds its points)")
    if p.gravity <= 0 and not p.footing:
        raise InputError("-mpm_gravity: the flowing body moves under gravity or a footing "
                         "(give -mpm_gravity, e.g. 9.81, or -mpm_footing)")
    for name in ("rho_s", "porosity"):
        if isinstance(getattr(p, name), tuple):
            raise InputError(f"-mpm_{name}: one value (the flowing body is one soil)")
    grid = _grid(p.size, p.cells, p.grid_size, p.shape, p.ppc)
    soil = Soil(E=p.E, nu=p.nu, rho_s=p.rho_s, porosity=p.porosity, rho_l=p.rho_l)
    wave = math.sqrt(constrained_modulus(p.E, p.nu) / soil.density)
    footing = None
    if p.footing:
        if "t_end" in p.given or "rest_energy" in p.given:
            raise InputError("-mpm_t_end, -mpm_rest_energy: a pushed footing's run ends at "
                             "its settlement (-mpm_footing_settlement)")
        footing = penetration.plan_of(
            tuple(p.footing), p.footing_interface == "rough", p.footing_velocity,
            p.footing_settlement, (tuple(p.size), tuple(p.cells), p.ppc),
            math.sqrt(p.E / (2 * (1 + p.nu)) / soil.density),
            p.cohesion if p.material == "tresca" and p.gravity == 0 else math.nan)
    dt = p.dt_safety * min(grid.h) / wave
    summary = p.summary or os.path.join(p.output, "summary.json")
    options = provenance.options(p)
    given = set(p.given) | set(given_at_start(p.restart))
    return FlowPlan(
        size=tuple(p.size), cells=tuple(p.cells), ppc=p.ppc, grid=grid,
        density=soil.density, material=material, wave=wave, walls=walls,
        friction=p.floor_friction, gravity=p.gravity, fbar=p.bbar,
        flip=_flip(p.flip, p.pic_viscosity, "flip" in p.given, dt, min(grid.h)),
        damping=p.damping, dt=dt,
        t_end=penetration.duration(grid, tuple(p.size), footing) if footing else p.t_end,
        rest_energy=0.0 if footing else p.rest_energy,
        experiment=_experiment(p.experiment, tuple(p.size), recipe), footing=footing,
        outputs=output.Outputs(p.output, summary, p.figures, p.figure_format),
        cadence=(p.output_every, p.checkpoint_every, p.checkpoint_seconds, p.progress),
        restart=p.restart, overwrite=p.overwrite,
        run={"id": None, "options": checkpoint.recorded(options), "given": sorted(given)},
        signature=checkpoint.signature(p), provenance=options)


def _flip(flip, nu, flip_given, dt, h) -> float:
    """The FLIP share of each step: ``flip`` (-mpm_flip; auto: 0.99), or from the PIC
    viscosity ``nu`` (m2/s; -mpm_pic_viscosity, 0: none) the PIC share nu dt / h^2 of steps
    dt (s) on cells of the smaller side h (m); InputError where both are given. Why a
    viscosity: the PIC share damps what the grid does not resolve as a viscosity
    (1 - FLIP) h^2 / dt, in proportion to the cell where the share per step is held; held
    as nu, every grid dissipates alike, and the grids agree once their cells resolve it
    (docs/studies.md: the collapse at 2e-3 m2/s from 10 mm cells, not yet at 1e-3)."""
    if not nu:
        return 0.99 if flip == "auto" else float(flip)
    if flip_given:
        raise InputError("-mpm_flip, -mpm_pic_viscosity: give one (the PIC share per step, "
                         "or as a viscosity)")
    share = nu * dt / (h * h)
    if share > 1:
        raise InputError(f"-mpm_pic_viscosity {nu:g}: a PIC share of {share:.3g} a step on "
                         f"these cells (dt {dt:.3g} s, h {h:g} m); at most 1")
    return 1.0 - share


def run(plan: FlowPlan, comm) -> int:
    """Run the flowing body of ``plan`` (:func:`plan_of`) on ``comm``; returns 0 (a failure
    raises, after the record has written what it can)."""
    record = Record("dynamic", comm)
    guarded(record, lambda: _run(plan, comm, record))
    return 0


def _run(plan, comm, record) -> None:
    ckpt, run_id = begun(record, plan, comm)
    model = Flowing(plan, comm, run_id, ckpt, files=record.files)
    record.results = runout.keys(plan, model)
    runout.print_plan(plan, model, comm)
    output_every, ckpt_every, ckpt_seconds, progress = plan.cadence
    cadence = Cadence(model.nsteps, output_every=output_every or max(1, model.nsteps // 50),
                      checkpoint_every=ckpt_every, checkpoint_seconds=ckpt_seconds,
                      progress_seconds=progress)
    saving = Saving(os.path.join(plan.outputs.folder, "checkpoint.npz"), plan.signature,
                    plan.run)
    drive(model, cadence, record, saving, first=model.first)
    runout.finish(plan, model, record, comm)


class Flowing:
    """The flowing body as the loop drives it (:class:`solver.run.loop.Model`): step k
    takes the flow from t_(k-1) = (k - 1) dt to k dt, its samples and fields are of its
    end."""

    log_stage = "Flow steps"

    def __init__(self, plan, comm, run_id, ckpt, files: dict):
        self.plan, self.comm, self.mpi = plan, comm, comm.tompi4py()
        self.files = files              # the record's: what is on disk
        x, volume = lattice.fill(plan.size, plan.cells, plan.ppc)
        self.n_global = len(x)
        self.ids = np.array_split(np.arange(len(x)), comm.getSize())[comm.getRank()]
        footing = penetration.make(plan.grid, plan.size, plan.footing) if plan.footing \
            else None
        self.flow = Flow(plan.grid, x[self.ids], volume, plan.density, plan.material,
                         g=plan.gravity, walls=plan.walls, damping=plan.damping,
                         flip=plan.flip, fbar=plan.fbar, friction=plan.friction, comm=comm,
                         footing=footing)
        self.dt = plan.dt
        self.nsteps = int(math.ceil(plan.t_end / self.dt - 1e-9))
        self.curve = penetration.Curve(footing, self.nsteps) if footing else None
        if self.nsteps > MAX_STEPS:
            raise InputError(f"-mpm_t_end {plan.t_end:g}: {self.nsteps:.3g} steps of "
                             f"{self.dt:.3g} s; more than {MAX_STEPS:.0e} is not a run that "
                             "finishes")
        self.points = checkpoint.ArrayPoints(self._arrays)
        self.mass = self.total(self.flow.m)
        # (t (s), kinetic energy (J per m)) every `every` steps; its peak; the last value.
        self.every = max(1, int(round(1e-3 / self.dt)))
        self.energy, self.peak, self.kinetic, self.rest = [], 0.0, 0.0, False
        self.series = runout.Series(plan.outputs.folder, comm, run_id)
        self.first = 1
        if ckpt is not None:
            self._restore(ckpt)

    def _arrays(self) -> dict:
        """This rank's points, the flow's arrays by name, as a checkpoint stores them."""
        f = self.flow
        return {"id": self.ids, "x": f.x, "x0": f.x0, "v": f.v, "V0": f.V0, "m": f.m,
                "sigma": f.sigma, **f.state}

    def total(self, values, op=MPI.SUM) -> float:
        """The sum (or ``op``) over every rank of the local ``values``."""
        local = float(np.sum(values)) if op == MPI.SUM else float(np.max(values, initial=0))
        return self.mpi.allreduce(local, op=op)

    def time(self, k: int) -> float:
        return k * self.dt

    def advance(self, k: int) -> None:
        self.flow.step(self.dt)

    def check(self, k: int) -> None:
        bad = self.total(~np.isfinite(self.flow.sigma).all(axis=1) |
                         ~np.isfinite(self.flow.v).all(axis=1))
        if bad:
            raise NumericalError(f"the flow blew up at step {k} (t = {self.time(k):.4g} s): "
                                 f"{int(bad)} points with non-finite stress or velocity; "
                                 "lower -mpm_dt_safety")

    def sample(self, k: int) -> None:
        self.kinetic = self.total(0.5 * self.flow.m * np.sum(self.flow.v ** 2, axis=1))
        self.peak = max(self.peak, self.kinetic)
        if k % self.every == 0 or k == self.nsteps:
            self.energy.append((self.time(k), self.kinetic))
        fraction = self.plan.rest_energy
        self.rest = bool(fraction and self.kinetic < self.peak
                         and self.kinetic <= fraction * self.peak)
        if self.curve is not None:
            self.curve.sample(k, k == self.nsteps)

    def finished(self, k: int) -> bool:
        if self.rest and (not self.energy or self.energy[-1][0] < self.time(k)):
            self.energy.append((self.time(k), self.kinetic))
        return self.rest

    def toe(self) -> float:
        """The farthest reach of the body from the wall (m): a point's centre plus half its
        current width."""
        f = self.flow
        return self.total(f.x[:, 0] + 0.5 * np.sqrt(f.V0 * f.J), op=MPI.MAX)

    def write_fields(self, k: int) -> None:
        self.series.write(self, k, self.time(k))
        if self.comm.getRank() == 0:
            self.files.update(runout.tables(self.plan, self, figures=False))

    def state(self) -> dict:
        return {"dt": self.dt, "peak": self.peak, "kinetic": self.kinetic,
                "energy": self.energy, "series": self.series.entries,
                **(self.curve.state() if self.curve is not None else {})}

    def progress(self, k: int) -> str:
        share = 100 * self.kinetic / self.peak if self.peak else 0.0
        where = self.curve.progress() if self.curve is not None else \
            f"toe at {self.toe():.4g} m"
        return (f"t = {self.time(k):.4g} s, kinetic energy {self.kinetic:.3g} J/m "
                f"({share:.2g} % of its peak), {where}")

    def _restore(self, ckpt) -> None:
        """Take up the points and records of the checkpoint ``ckpt``: this rank's share of
        the points by their numbers, as the run that wrote it had them."""
        cols = ckpt.columns()
        order = np.argsort(cols["id"][:, 0], kind="stable")
        if len(order) != self.n_global:
            raise InputError(f"-mpm_restart {ckpt.path}: {len(order)} points, this scene "
                             f"has {self.n_global}")
        mine = order[self.ids]
        f = self.flow
        for name in ("x", "x0", "v", "V0", "m", "sigma"):
            setattr(f, name, cols[name][mine].reshape(getattr(f, name).shape).copy())
        f.state = {k: cols[k][mine].reshape(v.shape).astype(v.dtype)
                   for k, v in f.state.items()}
        state = ckpt.state
        self.first = int(state["step"]) + 1
        f.time = (self.first - 1) * self.dt
        self.peak, self.kinetic = float(state["peak"]), float(state["kinetic"])
        self.energy = [tuple(row) for row in state["energy"]]
        if self.curve is not None:
            self.curve.restore(state)
        self.series.resume(state["series"], ckpt.run_id)
