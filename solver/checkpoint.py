"""Checkpoints of explicit runs: the whole state in one NumPy ``.npz`` file, written whole.

A checkpoint holds every material-point field (gathered from all ranks), the step, dt, the
monitor history and the reports so far, and the options that define the physics. A restart
on any number of ranks hands each rank the points of the cells it owns, so a run restarted
from a checkpoint continues with the same state it would have had without interruption.
"""

from __future__ import annotations

import json
import os

import numpy as np

from . import output
from .errors import InputError

# Options that do not change the physics of a run: they may differ on restart.
FREE_OPTIONS = {"output", "summary", "figures", "figure_format", "debug", "progress", "restart",
                "checkpoint_every", "checkpoint_seconds", "output_every", "Tv_end", "Tv_report",
                "eigen_solver", "jacobi_tol", "jacobi_max_sweeps", "nmodes",
                "stability_analysis"}
VERSION = 2    # 2: reference positions x0 (2 components) in place of y0


def signature(p) -> str:
    """The options that define the physics, as canonical JSON."""
    items = {k: v for k, v in vars(p).items()
             if k not in FREE_OPTIONS and k not in ("given", "from_file", "notes")}
    return json.dumps(items, sort_keys=True, default=str)


def write(path, comm, points, state: dict, p):
    """Gather the points on rank 0 and write ``path`` (collective)."""
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
                     layout=json.dumps(points.layout), signature=signature(p),
                     state=json.dumps(output._jsonable(state)))


def read(path, p):
    """Load a checkpoint; raise InputError if it is missing, damaged or of another scene."""
    if not os.path.isfile(path):
        raise InputError(f"-mpm_restart {path}: no such file")
    try:
        with np.load(path, allow_pickle=False) as z:
            version = int(z["version"])
            fields = np.array(z["fields"], dtype=float)
            layout = json.loads(str(z["layout"]))
            sig = str(z["signature"])
            state = json.loads(str(z["state"]))
    except Exception as exc:  # any damage: truncated zip, missing member, bad JSON
        raise InputError(f"-mpm_restart {path}: not a readable checkpoint "
                         f"({type(exc).__name__})") from None
    if version != VERSION:
        raise InputError(f"-mpm_restart {path}: checkpoint version {version}, "
                         f"this solver reads {VERSION}")
    if sig != signature(p):
        mine, theirs = json.loads(signature(p)), json.loads(sig)
        # Compared as JSON: NaN (an unset -mpm_dt) differs from itself as a float.
        diff = sorted(k for k in set(mine) | set(theirs)
                      if json.dumps(mine.get(k)) != json.dumps(theirs.get(k)))
        raise InputError(f"-mpm_restart {path}: written for other options "
                         f"(-mpm_{diff[0]} differs)")
    if fields.ndim != 2 or fields.shape[1] != sum(layout.values()):
        raise InputError(f"-mpm_restart {path}: inconsistent point data")
    return fields, layout, state


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
