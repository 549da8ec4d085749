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

from ..common import signals
from ..common.errors import InputError, NumericalError
from ..io import checkpoint, output, provenance
from ..io.restart import given_at_start
from ..io.spec import FLOWING_ONLY, NOT_FLOWING
from ..materials import catalog
from ..model import lattice
from ..model.soil import Soil, constrained_modulus
from ..references.experiments import COLLAPSES
from ..run.loop import Cadence, Saving, drive
from ..run.record import Record, guarded
from ..stepping.flow import Flow
from . import runout

MAX_STEPS = 5e7
SIDES = ("left", "right", "bottom", "top")


@dataclasses.dataclass(frozen=True)
class FlowPlan:
    """What a flowing run does, from the options: the body's ``size`` (m), ``cells`` and
    ``ppc``; the ``grid`` (a :class:`lattice.Lattice`); the ``density`` (kg/m3), the
    ``material`` and the compression-wave speed ``wave`` (m/s); the grid's ``walls``,
    ``friction`` of the floor, ``gravity`` (m/s2), F-bar, FLIP share, local damping; the
    step dt (s); the end (s) and rest fraction; the experiment (None or a
    :class:`references.experiments.Collapse`); outputs, cadence, restart and provenance."""

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
    outputs: output.Outputs
    cadence: tuple            # (output_every, checkpoint_every, checkpoint_seconds, progress)
    restart: str
    overwrite: bool
    run: dict
    signature: str
    provenance: dict


def _one(name: str, value):
    """The one value of a per-layer option: the flowing body is one soil."""
    if isinstance(value, tuple):
        if len(value) > 1:
            raise InputError(f"-mpm_{name}: one value (the flowing body is one soil)")
        value = value[0]
    return value


def _grid(p) -> lattice.Lattice:
    """The background grid: the body's cells over ``-mpm_grid_size`` (default: the body)."""
    W, H = p.size
    h = (W / p.cells[0], H / p.cells[1])
    size = tuple(p.grid_size) or (W, H)
    cells = []
    for d, (extent, body, step) in enumerate(zip(size, (W, H), h)):
        n = extent / step
        if extent < body * (1 - 1e-12) or abs(n - round(n)) > 1e-6 * n:
            raise InputError(f"-mpm_grid_size {size[0]:g},{size[1]:g}: each side at least "
                             f"the body's and a whole number of its cells ({step:g} m "
                             f"{'across' if d == 0 else 'up'})")
        cells.append(int(round(n)))
    return lattice.Lattice(p.shape, tuple(cells), h)


def _material(p):
    """The material of the options, one soil, of constant elasticity (Hencky's)."""
    names = {n: _one(n, getattr(p, n)) for n in ("material", "cohesion", "friction_angle",
                                                 "dilation_angle", "tension_cutoff", "E",
                                                 "nu")}
    if names["material"] == "mcc":
        raise InputError("-mpm_material mcc: not at finite strain (its elasticity depends on "
                         "the pressure; Hencky's needs a constant one)")
    material = catalog.make(names["material"], names["E"], names["nu"], names["cohesion"],
                            names["friction_angle"], names["dilation_angle"],
                            tension=names["tension_cutoff"])
    return material, names


def _check_given(p) -> None:
    """InputError for an option that the flowing body does not read."""
    given = set(p.given)
    for name in NOT_FLOWING:
        if name in given:
            raise InputError(f"-mpm_{name}: not read by -mpm_analysis dynamic with "
                             "-mpm_kinematics large")


def check_shaken(p) -> None:
    """InputError for an option of the flowing body given to the shaken one."""
    for name in FLOWING_ONLY:
        if name in p.given:
            raise InputError(f"-mpm_{name}: read by -mpm_analysis dynamic with "
                             "-mpm_kinematics large only")


def plan_of(p) -> FlowPlan:
    """The plan of the options ``p`` (InputError for what contradicts itself)."""
    _check_given(p)
    material, values = _material(p)
    grid = _grid(p)
    walls = {side: getattr(p, f"bc_{side}") for side in SIDES
             if getattr(p, f"bc_{side}") != "none"}
    if p.floor_friction and walls.get("bottom") != "y":
        raise InputError(f"-mpm_floor_friction {p.floor_friction:g}: with -mpm_bc_bottom y "
                         "(a floor that holds y alone; xy holds its points)")
    if p.gravity <= 0:
        raise InputError("-mpm_gravity: the flowing body moves under gravity (give it, "
                         "e.g. 9.81)")
    soil = Soil(E=values["E"], nu=values["nu"], rho_s=_one("rho_s", p.rho_s),
                porosity=_one("porosity", p.porosity), rho_l=p.rho_l)
    wave = math.sqrt(constrained_modulus(values["E"], values["nu"]) / soil.density)
    experiment = None
    if p.experiment != "none":
        experiment = COLLAPSES[p.experiment]
        mine = (tuple(p.size), values["friction_angle"], values["cohesion"])
        if (not np.allclose(mine[0], experiment.size) or mine[1] != experiment.phi
                or mine[2] != experiment.cohesion
                or values["material"] not in ("mohr-coulomb", "drucker-prager")):
            raise InputError(f"-mpm_experiment {p.experiment}: of a {experiment.size[0]:g} x "
                             f"{experiment.size[1]:g} m column of friction angle "
                             f"{experiment.phi:g} and no cohesion (-mpm_size, "
                             "-mpm_friction_angle, -mpm_cohesion, -mpm_material)")
    flip = 0.99 if p.flip == "auto" else float(p.flip)
    dt = p.dt_safety * min(grid.h) / wave
    summary = p.summary or os.path.join(p.output, "summary.json")
    options = provenance.options(p)
    given = set(p.given) | set(given_at_start(p.restart))
    return FlowPlan(
        size=tuple(p.size), cells=tuple(p.cells), ppc=p.ppc, grid=grid,
        density=soil.density, material=material, wave=wave, walls=walls,
        friction=p.floor_friction, gravity=p.gravity, fbar=p.bbar, flip=flip,
        damping=p.damping, dt=dt, t_end=p.t_end, rest_energy=p.rest_energy,
        experiment=experiment,
        outputs=output.Outputs(p.output, summary, p.figures, p.figure_format),
        cadence=(p.output_every, p.checkpoint_every, p.checkpoint_seconds, p.progress),
        restart=p.restart, overwrite=p.overwrite,
        run={"id": None, "options": checkpoint.recorded(options), "given": sorted(given)},
        signature=checkpoint.signature(p), provenance=options)


def run(p, comm) -> int:
    """Run the flowing body of the options ``p`` on ``comm``; returns 0 (a failure raises,
    after the record has written what it can)."""
    signals.stage("set-up: the options' checks")
    plan = plan_of(p)
    record = Record("dynamic", comm)
    guarded(record, lambda: _run(plan, comm, record))
    return 0


def _run(plan, comm, record) -> None:
    ckpt, run_id = checkpoint.take_up(plan.restart, plan.overwrite, plan.signature,
                                      plan.outputs, comm)
    record.begin(plan.outputs, run_id, plan.provenance)
    plan.run["id"] = run_id
    model = Flowing(plan, comm, run_id, ckpt)
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


class Points:
    """The points of one rank as a checkpoint gathers them (``layout``, ``n_local``,
    ``get``): the flow's arrays, by name, each (n_local, width)."""

    def __init__(self, model):
        self.model = model

    @property
    def arrays(self) -> dict:
        f = self.model.flow
        return {"id": self.model.ids, "x": f.x, "x0": f.x0, "v": f.v, "V0": f.V0, "m": f.m,
                "sigma": f.sigma, **f.state}

    @property
    def layout(self) -> dict:
        return {k: int(np.prod(np.shape(v)[1:])) for k, v in self.arrays.items()}

    @property
    def n_local(self) -> int:
        return len(self.model.ids)

    def get(self, name):
        return np.asarray(self.arrays[name], dtype=float).reshape(self.n_local, -1)


class Flowing:
    """The flowing body as the loop drives it (:class:`solver.run.loop.Model`): step k
    takes the flow from t_(k-1) = (k - 1) dt to k dt, its samples and fields are of its
    end."""

    log_stage = "Flow steps"

    def __init__(self, plan, comm, run_id, ckpt=None):
        self.plan, self.comm, self.mpi = plan, comm, comm.tompi4py()
        x, volume = lattice.fill(plan.size, plan.cells, plan.ppc)
        self.n_global = len(x)
        self.ids = np.array_split(np.arange(len(x)), comm.getSize())[comm.getRank()]
        self.flow = Flow(plan.grid, x[self.ids], volume, plan.density, plan.material,
                         g=plan.gravity, walls=plan.walls, damping=plan.damping,
                         flip=plan.flip, fbar=plan.fbar, friction=plan.friction, comm=comm)
        self.dt = plan.dt
        self.nsteps = int(math.ceil(plan.t_end / self.dt - 1e-9))
        if self.nsteps > MAX_STEPS:
            raise InputError(f"-mpm_t_end {plan.t_end:g}: {self.nsteps:.3g} steps of "
                             f"{self.dt:.3g} s; more than {MAX_STEPS:.0e} is not a run that "
                             "finishes")
        self.points = Points(self)
        self.mass = self.total(self.flow.m)
        # (t (s), kinetic energy (J per m)) every `every` steps; its peak; the last value.
        self.every = max(1, int(round(1e-3 / self.dt)))
        self.energy, self.peak, self.kinetic, self.rest = [], 0.0, 0.0, False
        self.series = runout.Series(plan.outputs.folder, comm, run_id)
        self.first = 1
        if ckpt is not None:
            self._restore(ckpt)

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

    def state(self) -> dict:
        return {"dt": self.dt, "peak": self.peak, "kinetic": self.kinetic,
                "energy": self.energy, "series": self.series.entries}

    def progress(self, k: int) -> str:
        share = 100 * self.kinetic / self.peak if self.peak else 0.0
        return (f"t = {self.time(k):.4g} s, kinetic energy {self.kinetic:.3g} J/m "
                f"({share:.2g} % of its peak), toe at {self.toe():.4g} m")

    def _restore(self, ckpt) -> None:
        """Take up the points and records of the checkpoint ``ckpt``: this rank's share of
        the points by their numbers, as the run that wrote it had them."""
        fields, layout = ckpt.fields, ckpt.layout
        cols, start = {}, 0
        for name, width in layout.items():
            cols[name] = fields[:, start:start + width]
            start += width
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
        self.series.resume(state["series"], ckpt.run_id)
