"""The u-p operators of quasi-static Biot consolidation, integrated over the material points.

Each point p of volume V_p and its layer's soil adds (SI units, per metre out of plane;
effective stress tension positive, pore pressure compression positive):

    K = sum V B^T D B                      (assembly.stiffness_blocks: the eigen model's K)
    Q = sum V B^T m N_p                    (coupling, m = (1, 1, 0))
    S = sum V (n / K_l) N_p N_p^T          (storage of the compressible water)
    H = sum V (k / gamma_w) grad N_p . grad N_p^T     (Darcy flow, gamma_w = rho_l 9.81)

N_p is the pressure basis: the bilinear functions of the cells' corner nodes (on Q4 cells
the displacement's own, on Q8 and Q9 cells the Taylor-Hood Q8/Q4 and Q9/Q4 pairs). The
unknowns share a DMDA of three DOFs per lattice node (u_x, u_y, p): a pressure DOF on a
quadratic cell's mid-side or centre node, and the Q8 centre node's displacement, belong to
no basis function and are held (:meth:`Operators.unused`).

Q4/Q4 violates the inf-sup condition: an undrained load then gives a checkerboard pressure.
Dohrmann and Bochev's polynomial pressure projection (2004) adds to the storage

    S_stab = (tau) sum_cells [ sum_p V N_p N_p^T - m_c m_c^T / V_c ],   m_c = sum_p V N_p,

(the L2 distance of the pressure from its cell mean) with tau = STAB / E_c, which is
consistent (zero on a cell-wise constant pressure) and needs no tuning to the mesh.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ...materials.model import Elastic
from ...model import assembly
from ...model.soil import G_REF

# tau E_c of the projection. Its penalty on a pressure of gradient g in a cell of length h
# is tau h^2 g^2 / 12 per volume: tau = 3 / E_c makes it the perturbation h^2 / (4 E_c)
# that Aguilar, Gaspar, Lisbona and Rodrigo (2008) proved free of oscillations for linear
# elements in 1D. Measured (docs/method.md, "Pressure stabilization"): the first steps of
# a 1 x 40 Q4 column overshoot by 5.3 % of q (STAB 4: 0.22 %, 2: 12 %), and the larger tau
# smears the drained boundary's layer for longer: the laterally drained block's largest
# error at T_dr 0.2 is 1.85 % of q (STAB 4: 2.40 %), the strip's at T_v 0.01 0.71 % (0.97).
STAB = 3.0


def projects(choice: str, element: str) -> bool:
    """Whether the implicit scheme takes the pressure projection: ``ppp`` always, ``none``
    never, ``auto`` (the default) on Q4/Q4 alone. Q4/Q4 fails the inf-sup condition (its
    undrained start overshoots by 40 % of q next to a drained side without it); the
    Taylor-Hood pairs Q8/Q4 and Q9/Q4 pass it, and the projection only smears their early
    pressures: on the paper's Q9 column the profile's L2 error against Terzaghi at T_v =
    0.02 is 0.52 % of q without it and 1.06 % with it, and on a laterally drained block the
    largest error under the load against the FE at T_dr = 0.05 is 1.1 % and 4.5 % of q
    (docs/method.md, "Pressure stabilization")."""
    return choice == "ppp" or (choice == "auto" and element == "q4")


def per_point(soil, name: str, layer) -> np.ndarray:
    """A soil property at each point: one value for one soil, else its layer's (``layer``
    the points' layer indices from the surface down)."""
    values = np.array([getattr(s, name) for s in soil.soils], dtype=float)
    return values[np.asarray(layer, dtype=int)] if len(values) > 1 else \
        np.full(len(layer), values[0])


class Operators:
    """J0 = [[K, -Q], [-Q^T, -S]], the flow H = [[0, 0], [0, H]] and the storage
    M = [[0, 0], [Q^T, S]] as parallel AIJ matrices over the three-DOF DMDA ``da``,
    assembled from each rank's own points (ADD_VALUES), and the points' interpolation.

    ``grid`` the background grid, ``x0`` (np, 2) the points' positions (m), ``volume`` (np,)
    (m3), ``layer`` (np,) their layers, ``soil`` a Soil or a Ground, ``stabilize`` whether
    to add the pressure projection. The caller destroys it."""

    def __init__(self, grid, x0, volume, layer, soil, stabilize: bool):
        self.grid = grid
        self.da = grid.da.duplicate(dof=3)
        self.u = assembly.interpolation(grid, x0)
        self.p = self.u if grid.element == "q4" else \
            assembly.interpolation(grid, x0, corner=True)
        nen = self.u.N.shape[1]
        nodes = self.u.nodes
        self.dofs = np.concatenate([np.stack([3 * nodes, 3 * nodes + 1], -1).reshape(
            len(nodes), 2 * nen), 3 * nodes + 2], axis=1).astype(PETSc.IntType)
        E_c = per_point(soil, "constrained_modulus", layer)
        self.E_c = float(np.max(E_c)) if len(E_c) else 1.0
        # The elastic law of the materials room, per point in layers.
        laws = [Elastic(s.E, s.nu).plane() for s in soil.soils]
        D = laws[0] if len(laws) == 1 else np.stack(laws)[np.asarray(layer, dtype=int)]
        self.D = D
        self.B = assembly.strain_matrix(self.u.dNdx)
        K = assembly.stiffness_blocks(self.u, D, volume)
        div = self.B[:, 0] + self.B[:, 1]                              # (np, 2 nen)
        Np, dNp = self.p.N, self.p.dNdx
        Q = volume[:, None, None] * div[:, :, None] * Np[:, None, :]
        NN = volume[:, None, None] * Np[:, :, None] * Np[:, None, :]
        storage = per_point(soil, "porosity", layer) / per_point(soil, "K_l", layer)
        S = storage[:, None, None] * NN
        tau = STAB / E_c if stabilize else None
        if stabilize:
            S = S + tau[:, None, None] * NN
        mobility = per_point(soil, "k", layer) / (per_point(soil, "rho_l", layer) * G_REF)
        Hb = (volume * mobility)[:, None, None] * np.einsum("pad,pbd->pab", dNp, dNp)
        n2 = 2 * nen
        zeros = np.zeros((len(volume), 3 * nen, 3 * nen))
        J0 = zeros.copy()
        J0[:, :n2, :n2] = K
        J0[:, :n2, n2:] = -Q
        J0[:, n2:, :n2] = -Q.transpose(0, 2, 1)
        J0[:, n2:, n2:] = -S
        Mb = zeros.copy()
        Mb[:, n2:, :n2] = Q.transpose(0, 2, 1)
        Mb[:, n2:, n2:] = S
        Hf = zeros
        Hf[:, n2:, n2:] = Hb
        del K, Q, NN, S, Hb
        self.J0 = self._assemble(J0)
        self.M = self._assemble(Mb)
        self.H = self._assemble(Hf)
        if stabilize:
            self._cell_means(volume, tau)

    def _assemble(self, blocks) -> PETSc.Mat:
        A = self.da.createMat()
        A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
        if len(blocks):
            A.setValuesLocalRCV(self.dofs, self.dofs, np.ascontiguousarray(blocks),
                                addv=PETSc.InsertMode.ADD_VALUES)
        A.assemble()
        return A

    def _cell_means(self, volume, tau):
        """The projection's cell part, - tau m_c m_c^T / V_c, added to -S in J0 (with the
        opposite sign) and to S in M; every cell's points are on the rank that owns it."""
        cx, cy = self.u.cells
        cell = cy * self.grid.cells[0] + cx
        cells, first, inverse = np.unique(cell, return_index=True, return_inverse=True)
        nen = self.p.N.shape[1]
        m = np.zeros((len(cells), nen))
        np.add.at(m, inverse, volume[:, None] * self.p.N)
        V = np.bincount(inverse, weights=volume, minlength=len(cells))
        t = np.bincount(inverse, weights=volume * tau, minlength=len(cells)) / V
        block = (t / V)[:, None, None] * m[:, :, None] * m[:, None, :]
        pd = np.ascontiguousarray(self.dofs[first, 2 * nen:])
        for A, sign in ((self.J0, 1.0), (self.M, -1.0)):
            if len(cells):
                A.setValuesLocalRCV(pd, pd, np.ascontiguousarray(sign * block),
                                    addv=PETSc.InsertMode.ADD_VALUES)
            A.assemble()

    def mask(self, bcs, drained=()) -> np.ndarray:
        """Boolean mask (n_owned, 3) of the held DOFs: the supports ``bcs`` ({side:
        components}), the pressure on the ``drained`` sides, and the unused DOFs."""
        g = self.grid
        held = self.unused()
        held[:, :2] |= g.constrained_mask(bcs).reshape(-1, 2)
        sides = g.owned_sides()
        for side in drained:
            held[sides[side], 2] = True
        return held

    def unused(self) -> np.ndarray:
        """(n_owned, 3): DOFs no basis function has (see the module docstring)."""
        I, J = self.grid.owned_lattice()
        order = self.grid.order
        held = np.zeros((len(I), 3), dtype=bool)
        held[:, 2] = (I % order != 0) | (J % order != 0)
        if self.grid.element == "q8":
            held[(I % 2 == 1) & (J % 2 == 1), :2] = True
        return held

    def rows(self, mask) -> np.ndarray:
        """Global row numbers of a (n_owned, 3) mask's True entries."""
        start = self.J0.getOwnershipRange()[0]
        return (start + np.flatnonzero(mask.ravel())).astype(PETSc.IntType)

    def destroy(self):
        for obj in (self.J0, self.M, self.H, self.da):
            obj.destroy()
