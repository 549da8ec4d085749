"""Checkpoints of explicit runs: the whole state in one NumPy ``.npz`` file, written whole.

A checkpoint holds every material-point field (gathered from all ranks), the step, dt, the
monitor history and the reports so far, the options that define the physics (their
signature), and the run: its id and every ``-mpm_`` option in effect as the run read them.
A restart on any number of ranks hands each rank the points of the cells it owns, so a run
restarted from a checkpoint continues with the same state it would have had without
interruption.

``-mpm_restart CK`` alone continues the run of CK: its options stand in for the defaults
(:func:`read_options`), and options given beside it may change only :data:`FREE_OPTIONS`.
A restart writes into a folder only when what the folder holds is the same run's
(:func:`check_folder`: the run id of its summary, field series and checkpoint), unless
``-mpm_overwrite`` says to replace another run's results. Checkpoints written before the
run was stored (no ``run`` member) are read as before: every option given again.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import secrets
import time

import numpy as np

from ..common.errors import InputError
from . import output

# Options that do not change the physics of a run: they may differ on restart.
FREE_OPTIONS = {"output", "summary", "figures", "figure_format", "debug", "progress", "restart",
                "checkpoint_every", "checkpoint_seconds", "output_every", "Tv_end", "Tv_report",
                "t_end",
                "eigen_solver", "jacobi_tol", "jacobi_max_sweeps", "nmodes",
                "stability_analysis", "overwrite"}
VERSION = 2    # 2: reference positions x0 (2 components) in place of y0


@dataclasses.dataclass
class RunState:
    """The state of a run besides its points: exactly what a checkpoint stores
    (:meth:`to_dict`, the ``state`` of :func:`write`) and a restart loads
    (:meth:`from_dict`). ``step`` is the last step whose points and records agree."""

    step: int = 0
    dt: float = math.nan
    mass_scaling: float = 1.0
    history: list = dataclasses.field(default_factory=list)     # (t, Tv, p/q at the monitor)
    reports: list = dataclasses.field(default_factory=list)     # report() at the report times
    profiles: list = dataclasses.field(default_factory=list)    # (Tv, t, profile()), rank 0
    series: list = dataclasses.field(default_factory=list)      # the field series' entries
    settlement: list = dataclasses.field(default_factory=list)  # (t, Tv, s (m), mean p (Pa))
    degree: list = dataclasses.field(default_factory=list)      # degree of consolidation
    troughs: list = dataclasses.field(default_factory=list)     # (Tv, x (m), s (m)), rank 0
    method: str = "explicit"                                    # the time scheme
    times: list = dataclasses.field(default_factory=list)       # implicit: the step ends (s)
    nodal: list = dataclasses.field(default_factory=list)       # implicit: (u, p_e), natural

    def to_dict(self) -> dict:
        """The state as a checkpoint stores it (JSON after :func:`output._jsonable`)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, st: dict, mass_scaling: float) -> "RunState":
        """The state of a checkpoint's ``st``; ``mass_scaling`` where it holds none (auto
        depends on the earliest report time, which a restart may change: a restart keeps
        the factor the run started with)."""
        return cls(step=st["step"], dt=st["dt"],
                   mass_scaling=st.get("mass_scaling", mass_scaling),
                   history=[tuple(h) for h in st["history"]], reports=st["reports"],
                   profiles=[(a, b, np.array(c)) for a, b, c in st["profiles"]],
                   series=st["series"], settlement=[tuple(r) for r in st.get("settlement", [])],
                   degree=st.get("degree", []), troughs=st.get("troughs", []),
                   method=st.get("method", "explicit"), times=st.get("times", []),
                   nodal=st.get("nodal", []))



def signature(p) -> str:
    """The options that define the physics, as canonical JSON."""
    items = {k: v for k, v in vars(p).items()
             if k not in FREE_OPTIONS and k not in ("given", "from_file", "notes")}
    return json.dumps(items, sort_keys=True, default=str)


def new_run_id(comm) -> str:
    """A fresh run id, the same on every rank: the start time and 8 random hex digits
    (``20250101T120000-1a2b3c4d``)."""
    rid = None
    if comm.getRank() == 0:
        rid = f"{time.strftime('%Y%m%dT%H%M%S')}-{secrets.token_hex(4)}"
    return comm.tompi4py().bcast(rid, root=0)


def recorded(p) -> dict:
    """The options of the run ``p`` (as read, before a run's own adjustments) that a
    checkpoint stores: every ``-mpm_`` option the analysis uses but -mpm_restart, as JSON
    values (lists for tuples, null for NaN)."""
    from .options import SPEC

    used = {o.name for o in SPEC if p.analysis in o.used_by} - {"restart"}
    return output._jsonable({k: getattr(p, k) for k in sorted(used)})


def _run_of(path):
    """The ``run`` member of checkpoint ``path`` ({"id", "options"}), None in an older
    checkpoint; InputError when the file is missing or unreadable."""
    if not os.path.isfile(path):
        raise InputError(f"-mpm_restart {path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as z:
            run = json.loads(str(z["run"])) if "run" in z.files else None
        if run is not None and not isinstance(run["options"]["analysis"], str):
            raise TypeError("no analysis")
    except Exception as exc:  # noqa: BLE001  (any damage: truncated zip, bad JSON)
        raise InputError(f"-mpm_restart {path}: not a readable checkpoint "
                         f"({type(exc).__name__})") from None
    return run


def given_at_start(path) -> tuple:
    """The options the run of checkpoint ``path`` was given when it began (its ``run``'s
    ``given``; () when it does not say): what a restart, whose options come from the
    checkpoint, counts as given."""
    run = _run_of(path) if path else None
    return tuple(run.get("given", ())) if run else ()


def read_options(origins, db=None):
    """The options of this command (:func:`options.read`); with -mpm_restart, the
    checkpoint's options in place of the defaults, and InputError for an option given
    beside it (on the command line or in a scene file) that would change the run's physics
    or grid: only :data:`FREE_OPTIONS` may differ from the checkpoint's."""
    from petsc4py import PETSc

    from . import options

    db = PETSc.Options() if db is None else db
    path = db.getString(options.PREFIX + "restart", "") if db.hasName(
        options.PREFIX + "restart") else ""
    run = _run_of(path) if path else None
    if not run:
        return options.read(db=db, origins=origins)
    base = run["options"]
    analysis = db.getString(options.PREFIX + "analysis", "")
    if analysis and analysis != base["analysis"]:
        # Before the options are read: they would be judged by the other analysis.
        raise InputError(f"-mpm_analysis {analysis}: the run of -mpm_restart {path} has "
                         f"{base['analysis']}; a restart continues that run")
    p = options.read(db=db, origins=origins, base=base)
    for name in p.given:
        if name in FREE_OPTIONS or name not in base:
            continue
        mine = output._jsonable(getattr(p, name))
        if json.dumps(mine) != json.dumps(base[name]):
            raise InputError(
                f"-mpm_{name} {options.text(name, getattr(p, name))}: the run of -mpm_restart "
                f"{path} has {options.text(name, base[name])}; a restart continues that "
                "run (give another -mpm_output and no -mpm_restart for a new one)")
    return p


def check_end(path, state: dict, refs, Tv_end: float) -> None:
    """InputError when -mpm_Tv_end ends the run before the step of the checkpoint ``path``
    (its ``state``): a restart goes on from there, and would report a run it never made
    as completed. ``refs``: the scene's :class:`plan.References` (T_v and time)."""
    step, dt = state["step"], state["dt"]
    if int(math.ceil(refs.time(Tv_end) / dt - 1e-9)) < step:
        t = step * dt
        raise InputError(f"-mpm_Tv_end {Tv_end:g}: before the state of -mpm_restart {path} "
                         f"(step {step}, t = {t:.6g} s, T_v = {refs.time_factor(t):.4g}); a "
                         "restart goes on from there: give a later -mpm_Tv_end, or run "
                         "anew without -mpm_restart")


def write(path, comm, points, state: dict, sig: str, run: dict):
    """Gather the points on rank 0 and write ``path`` (collective); ``sig`` the run's
    :func:`signature`, ``run``: {"id": the run id, "options": :func:`recorded`}."""
    names = list(points.layout)
    local = np.column_stack([points.get(n).reshape(points.n_local, -1) for n in names]) \
        if points.n_local else np.zeros((0, sum(points.layout.values())))
    parts = comm.tompi4py().gather(local, root=0)
    if comm.getRank() != 0:
        return
    data = np.concatenate(parts)
    with output.atomic(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, version=VERSION, fields=data,
                     layout=json.dumps(points.layout), signature=sig,
                     state=json.dumps(output._jsonable(state)),
                     run=json.dumps(output._jsonable(run)))


def read(path, mine: str):
    """Load a checkpoint: (fields, layout, state, run id or None for an older checkpoint);
    raise InputError if it is missing, damaged or of another scene than the one whose
    :func:`signature` is ``mine``."""
    if not os.path.isfile(path):
        raise InputError(f"-mpm_restart {path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as z:
            version = int(z["version"])
            fields = np.array(z["fields"], dtype=float)
            layout = json.loads(str(z["layout"]))
            sig = str(z["signature"])
            state = json.loads(str(z["state"]))
            run = json.loads(str(z["run"])) if "run" in z.files else {}
    except Exception as exc:  # any damage: truncated zip, missing member, bad JSON
        raise InputError(f"-mpm_restart {path}: not a readable checkpoint "
                         f"({type(exc).__name__})") from None
    if version != VERSION:
        raise InputError(f"-mpm_restart {path}: checkpoint version {version}, "
                         f"this solver reads {VERSION}")
    if sig != mine:
        mine, theirs = json.loads(mine), json.loads(sig)
        # Compared as JSON: NaN (an unset -mpm_dt) differs from itself as a float.
        diff = sorted(k for k in set(mine) | set(theirs)
                      if json.dumps(mine.get(k)) != json.dumps(theirs.get(k)))
        raise InputError(f"-mpm_restart {path}: written for other options "
                         f"(-mpm_{diff[0]} differs)")
    if fields.ndim != 2 or fields.shape[1] != sum(layout.values()):
        raise InputError(f"-mpm_restart {path}: inconsistent point data")
    return fields, layout, state, run.get("id")


def check_folder(folder, summary_path, restart, run_id, comm) -> None:
    """InputError on every rank, before anything is computed, when the results of another
    run than ``run_id`` (the one the checkpoint ``restart`` continues) lie where this one
    writes (``folder``, ``summary_path``): the summary, the field series (points.xdmf) or a
    checkpoint other than ``restart``, each marked with the id of the run that wrote it
    (none: an older or another program's result, another run). ``run_id`` None (an older
    checkpoint, which does not say which results are its own): not checked, as before.
    The caller skips the check under -mpm_overwrite."""
    problem = None
    if comm.getRank() == 0 and run_id is not None:
        ckpt = os.path.join(folder, "checkpoint.npz")
        for path, read in ((summary_path, _summary_id),
                           (os.path.join(folder, "points.xdmf"), output.series_run_id),
                           (ckpt, _checkpoint_id)):
            if not os.path.isfile(path) or (path == ckpt and os.path.isfile(restart)
                                            and os.path.samefile(path, restart)):
                continue
            other = read(path)
            if other != run_id:
                problem = (f"-mpm_output {folder}: {os.path.basename(path)} holds the "
                           f"results of another run ({other or 'without a run id'}; "
                           f"-mpm_restart {restart} continues run {run_id}): give another "
                           "-mpm_output, or -mpm_overwrite to replace them")
                break
    problem = comm.tompi4py().bcast(problem, root=0)
    if problem:
        raise InputError(problem)


def _summary_id(path):
    try:
        with open(path, encoding="utf-8") as fh:
            return json.load(fh).get("run_id")
    except (OSError, ValueError, AttributeError):
        return None


def _checkpoint_id(path):
    try:
        run = _run_of(path)
    except InputError:
        return None
    return run.get("id") if run else None


def check_fields(path, layout: dict, fields: dict) -> None:
    """InputError when the checkpoint's points (``layout``) lack a field that the run's
    scheme keeps (``fields``, :func:`twophase.point_fields`): a checkpoint written before
    a default scheme changed (the quadratic cells' pressure projection became 'corner',
    which keeps the pressure's gradient)."""
    missing = [name for name in fields if name not in layout]
    if missing:
        raise InputError(f"-mpm_restart {path}: its points lack the field '{missing[0]}' "
                         "that the scheme of these options keeps (written before a default "
                         "changed); run the scene again")


def scatter(points, grid, fields, layout, position="x"):
    """Give this rank the checkpointed points of the cells it owns, located by the field
    ``position`` (the one the step's shape functions use)."""
    cols, start = {}, 0
    for name, bs in layout.items():
        cols[name] = slice(start, start + bs)
        start += bs
    x = fields[:, cols[position]]
    cx, cy, _, _ = grid.locate(x)
    mine = fields[grid.cell_owner(cx, cy) == grid.comm.getRank()]
    points.resize(len(mine))
    for name in points.layout:
        with points.fields(name) as a:
            a[...] = mine[:, cols[name]].reshape(a.shape)
