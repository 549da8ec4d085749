"""The internal forces of a soil whose stiffness is not one matrix: the points' stresses
updated by their material from the strains' increments and spread back onto the nodes,

    eps_p = B u,      sigma_p <- update(sigma_p, eps_p - eps_p_old),      f = B^T (V sigma),

B the strain-displacement operator of every point (np x 3 rows: xx, yy, 2 xy) over the
free DOFs (a parallel PETSc Mat, its rows the points this rank holds, its columns the
stiffness matrix's: the same DOFs, reduced by a tying matrix T on periodic sides), so that
the ranks' shares meet through PETSc's scatters, as K's product does. The points stay
where they are (small strain): B is made once. For a linear soil B^T V D B is the
stiffness K itself; this is what the shaken body steps with when its soil is hyperbolic
(:func:`solver.materials.hyperbolic.iwan`: one compiled loop over the points, every layer
at once).
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ..materials.hyperbolic import iwan_plane, tables
from ..model import assembly


class PointForces:
    """The points of ``points`` on ``grid`` (np local), made of ``materials`` (one
    hyperbolic soil per layer, ``layer`` (np,) each point's), over the free DOFs ``free``
    (an IS of the DMDA's numbers) reduced by ``T`` (None: untied). :meth:`forces` gives
    the internal forces of a displacement; the state (stress, strain, the elements'
    deviators) is the points' at the last call. The caller destroys it."""

    def __init__(self, grid, points, free, T, materials, layer):
        self.x, self.volume = points.get("x", "volume")
        it = assembly.interpolation(grid, self.x)
        B = assembly.strain_matrix(it.dNdx)                   # (np, 3, 2 nen)
        n, width = len(self.volume), B.shape[2]
        cols = grid.da.getLGMap().apply(it.dofs.ravel().astype(PETSc.IntType))
        comm = grid.comm
        rows = PETSc.Mat().createAIJ(
            ((3 * n, None), (grid.da.getGlobalVec().getLocalSize(), None)),
            csr=(np.arange(3 * n + 1, dtype=PETSc.IntType) * width,
                 np.repeat(cols.reshape(n, width), 3, axis=0).ravel().astype(PETSc.IntType),
                 B.reshape(-1)), comm=comm)
        rows.assemble()
        start = rows.getOwnershipRange()[0]
        mine = PETSc.IS().createStride(3 * n, first=start, step=1, comm=comm)
        Bf = rows.createSubMatrix(mine, free)
        self.B = Bf.matMult(T) if T is not None else Bf
        for obj in (rows, mine) + ((Bf,) if T is not None else ()):
            obj.destroy()
        self.layer = np.ascontiguousarray(layer, dtype=np.int64)
        self.G, self.radius, self.K = tables(materials)
        self.stress = np.zeros((n, 4))
        self.strain = np.zeros((n, 3))                        # xx, yy, 2 xy
        self.elements = np.zeros((n, self.G.shape[1], 4))
        self.eps, self.sv = self.B.createVecLeft(), self.B.createVecLeft()

    def forces(self, u, out) -> None:
        """The internal forces (N per m depth) of the displacement ``u`` (a Vec of the
        reduced free DOFs, m) into ``out``: the points' strains and stresses move to u's."""
        self.B.mult(u, self.eps)
        iwan_plane(self.eps.getArray().reshape(-1, 3), self.strain, self.stress,
                   self.elements, self.G, self.radius, self.K, self.layer, self.volume,
                   self.sv.getArray().reshape(-1, 3))
        self.B.multTranspose(self.sv, out)

    def arrays(self) -> dict:
        """This rank's points as a checkpoint keeps them: position (m), stress (Pa),
        strain and the elements' deviators (Pa)."""
        return {"x": self.x, "stress": self.stress, "strain": self.strain,
                "elements": self.elements.reshape(len(self.x), -1)}

    def restore(self, columns: dict) -> None:
        """Take up every point's state of a checkpoint (``columns``: {field: (n, width)} of
        all points, :meth:`arrays`'s fields), each matched to this rank's by its position
        (the same scene places the same points, on any number of ranks)."""
        whole = columns["x"][:, 0] + 1j * columns["x"][:, 1]   # sorted as (x, y)
        order = np.argsort(whole)
        wanted = self.x[:, 0] + 1j * self.x[:, 1]
        idx = order[np.minimum(np.searchsorted(whole[order], wanted), len(whole) - 1)]
        if len(idx) and not np.array_equal(whole[idx], wanted):
            raise ValueError("the checkpoint's points are not this scene's")
        self.stress[:] = columns["stress"][idx]
        self.strain[:] = columns["strain"][idx]
        self.elements[:] = columns["elements"][idx].reshape(self.elements.shape)

    def destroy(self):
        for obj in (self.B, self.eps, self.sv):
            obj.destroy()

