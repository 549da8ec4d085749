"""Checkpoints of stepping runs: the whole state in one NumPy ``.npz`` file, written whole.

A checkpoint holds every material-point field (gathered from all ranks), the step, dt, the
monitor history and the reports so far, the options that define the physics (their
signature), and the run: its id and every ``-mpm_`` option in effect as the run read them.
A restart on any number of ranks hands each rank the points of the cells it owns, so a run
restarted from a checkpoint continues with the same state it would have had without
interruption.

:func:`read` returns the file as a :class:`Checkpoint`; what a restart may change, and the
output folder's check, are :mod:`solver.io.restart`'s.
"""

from __future__ import annotations

import dataclasses
import json
import os
import secrets
import time

import numpy as np

from ..common.errors import InputError
from . import output
from .restart import FREE_OPTIONS, check_folder

VERSION = 2    # 2: reference positions x0 (2 components) in place of y0


@dataclasses.dataclass(frozen=True)
class Checkpoint:
    """A checkpoint as :func:`read` returns it: every point's ``fields`` (rows) by their
    ``layout`` ({name: columns}), the run's ``state`` besides the points (``step``: the last
    step done) and the ``run_id`` (None in an older checkpoint)."""

    path: str
    fields: np.ndarray
    layout: dict
    state: dict
    run_id: str | None

    def columns(self) -> dict:
        """{field: its columns of every point (n, width)}, in the layout's order."""
        out, start = {}, 0
        for name, width in self.layout.items():
            out[name] = self.fields[:, start:start + width]
            start += width
        return out


class ArrayPoints:
    """Points kept as NumPy arrays (not a DMSwarm) as :func:`write` gathers them:
    ``arrays()`` gives this rank's {field: (n_local, ...) array}."""

    def __init__(self, arrays):
        self.arrays = arrays

    @property
    def layout(self) -> dict:
        return {k: int(np.prod(np.shape(v)[1:])) for k, v in self.arrays().items()}

    @property
    def n_local(self) -> int:
        return len(next(iter(self.arrays().values())))

    def get(self, name):
        return np.asarray(self.arrays()[name], dtype=float).reshape(self.n_local, -1)


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


def recorded(options: dict) -> dict:
    """The options a checkpoint stores, of the run's ``options`` as the provenance records
    them (:func:`solver.io.provenance.options` of the options as read, before a run's own
    adjustments): every ``-mpm_`` option the analysis uses but -mpm_restart, as JSON values
    (lists for tuples, null for NaN)."""
    used = options["mpm"]
    return output._jsonable({k: used[k] for k in sorted(used) if k != "restart"})


def take_up(path: str, overwrite: bool, signature: str, outputs, comm) -> tuple:
    """(the checkpoint at ``path`` (-mpm_restart) or None, the run's id: the checkpoint's, or
    a new one). Before anything is computed or written, InputError when the output folder
    (``outputs``, :class:`output.Outputs`) holds another run's results, which a restart
    never writes over (not even a stopped run's summary) unless ``overwrite``
    (-mpm_overwrite)."""
    ckpt = read(path, signature) if path else None
    if ckpt is not None and not overwrite:
        check_folder(outputs.folder, outputs.summary, path, ckpt.run_id, comm)
    return ckpt, ckpt.run_id if ckpt and ckpt.run_id else new_run_id(comm)


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


def read(path, mine: str) -> Checkpoint:
    """Load the checkpoint ``path``; raise InputError if it is missing, damaged or of another
    scene than the one whose
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
    return Checkpoint(path, fields, layout, state, run.get("id"))


def scatter(points, grid, ckpt: Checkpoint, position="x"):
    """Give this rank the points of checkpoint ``ckpt`` in the cells it owns, located by the
    field ``position`` (the one the step's shape functions use)."""
    cols = ckpt.columns()
    cx, cy, _, _ = grid.locate(cols[position])
    mine = grid.cell_owner(cx, cy) == grid.comm.getRank()
    points.resize(int(np.count_nonzero(mine)))
    for name in points.layout:
        with points.fields(name) as a:
            a[...] = cols[name][mine].reshape(a.shape)


def natural(da, vec) -> list:
    """A DMDA global Vec in natural (rank-independent) order, on every rank (a checkpoint's
    nodal state, collective)."""
    from petsc4py import PETSc

    nat = da.createNaturalVec()
    da.globalToNatural(vec, nat)
    scatter, full = PETSc.Scatter.toAll(nat)
    scatter.scatter(nat, full, PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)
    out = full.getArray().tolist()
    for obj in (scatter, full, nat):
        obj.destroy()
    return out


def from_natural(da, values, vec) -> None:
    """``vec`` (a DMDA global Vec) from :func:`natural`'s values (collective)."""
    nat = da.createNaturalVec()
    lo, hi = nat.getOwnershipRange()
    nat.setArray(np.asarray(values, dtype=float)[lo:hi])
    da.naturalToGlobal(nat, vec)
    nat.destroy()
