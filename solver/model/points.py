"""Material points: a PETSc DMSwarm holding the points' fields, distributed over the ranks.

Each rank holds the points of the cells it owns (see :mod:`solver.model.grid`); a point that moves
into another rank's cell is sent there by :meth:`MaterialPoints.migrate`, which uses the
swarm's own migration (the ``DMSwarm_rank`` field names the destination).
"""

from __future__ import annotations

from contextlib import contextmanager

import numpy as np
from petsc4py import PETSc

from . import shapes

# Fields every point carries: position (m), volume (m3) and mass (kg).
BASE_FIELDS = {"x": 2, "volume": 1, "mass": 1}


class MaterialPoints:
    """The material points of one body, as a DMSwarm with real-valued fields."""

    def __init__(self, comm, fields=None):
        self.comm = comm
        self.layout = dict(BASE_FIELDS, **(fields or {}))
        sw = PETSc.DMSwarm().create(comm=comm)
        sw.setDimension(2)
        sw.setType(PETSc.DMSwarm.Type.BASIC)
        for name, bs in self.layout.items():
            sw.registerField(name, bs)
        sw.finalizeFieldRegister()
        self.swarm = sw
        # Bumped whenever the swarm may move its field storage (resize, migrate, destroy):
        # arrays from views() are valid while it is unchanged.
        self.generation = 0
        self._views = {}

    @property
    def n_local(self) -> int:
        return self.swarm.getLocalSize()

    @property
    def n_global(self) -> int:
        return self.swarm.getSize()

    def resize(self, n_local: int):
        self._invalidate()
        self.swarm.setLocalSizes(n_local, max(16, n_local // 4))

    def _invalidate(self):
        self.generation += 1
        self._views = {}

    @contextmanager
    def fields(self, *names):
        """Yield the named fields as arrays of shape (n_local, bs), writable in place."""
        arrays = []
        try:
            for name in names:
                a = self.swarm.getField(name)
                arrays.append(a.reshape(-1, self.layout[name]) if self.layout[name] > 1
                              else a.reshape(-1))
            yield arrays if len(arrays) > 1 else arrays[0]
        finally:
            for name in names[:len(arrays)]:
                self.swarm.restoreField(name)

    def views(self, *names):
        """The named fields as arrays (n_local, bs) or (n_local,) that stay valid, and
        writable in place, until the next resize, migrate or destroy (``generation``).

        DMSwarmGetField hands out the field's storage itself and DMSwarmRestoreField only
        clears the access flag, so the storage does not move between those events. Keeping
        the arrays saves the time stepping a get/restore pair per field and step, which is
        a noticeable share of a step of a small model. Re-fetch after ``generation``
        changed."""
        out = []
        for name in names:
            a = self._views.get(name)
            if a is None:
                with self.fields(name) as f:
                    a = self._views[name] = f
            out.append(a)
        return out if len(out) > 1 else out[0]

    def get(self, *names):
        """Copies of the named fields."""
        with self.fields(*names) as arrays:
            if len(names) == 1:
                return arrays.copy()
            return [a.copy() for a in arrays]

    def migrate(self, destination):
        """Send each local point to rank ``destination[p]`` (collective)."""
        self._invalidate()
        rank = self.swarm.getField("DMSwarm_rank")
        rank[:] = destination
        self.swarm.restoreField("DMSwarm_rank")
        self.swarm.migrate(remove_sent_points=True)

    def destroy(self):
        """Destroy the swarm; the fields' arrays from views() are invalid afterwards."""
        self._invalidate()
        self.swarm.destroy()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()


def place(grid, ppc: int, rho, placement: str = "uniform", fields=None):
    """Points of the owned cells: ppc x ppc per cell, of density rho (kg/m3): a number, or a
    function of the points' heights y (m) giving each point's (a layered soil).

    ``placement='uniform'`` puts them at the centres of a uniform ppc x ppc subdivision of each
    cell (the MPM set-up of the paper); ``'gauss'`` at Gauss points with the Gauss weights as
    volumes, which turns the assembly into a plain finite element one.
    """
    s, w = shapes.uniform_1d(ppc) if placement == "uniform" else shapes.gauss_1d(ppc)
    S, T = np.meshgrid(s, s, indexing="xy")
    W = np.outer(w, w).ravel()
    cx, cy = grid.owned_cells()
    hx, hy = grid.h
    x = np.empty((cx.size * W.size, 2))
    x[:, 0] = ((cx[:, None] + (S.ravel()[None, :] + 1) / 2) * hx).ravel()
    x[:, 1] = ((cy[:, None] + (T.ravel()[None, :] + 1) / 2) * hy).ravel()
    volume = np.tile(W * hx * hy / 4, cx.size)

    mp = MaterialPoints(grid.comm, fields)
    mp.resize(x.shape[0])
    with mp.fields("x", "volume", "mass") as (fx, fv, fm):
        fx[:] = x
        fv[:] = volume
        fm[:] = (rho(x[:, 1]) if callable(rho) else rho) * volume
    return mp
