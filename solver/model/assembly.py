"""Material-point assembly: shape functions at the points, stiffness and mass matrices.

K = sum_p B_p^T D B_p V_p and M = sum_p m_p N_p^T N_p (paper eq. 1), added by each rank for
its own points into a parallel PETSc Mat over the DMDA, then restricted to the free DOFs:
DOFs that some point supports and that no boundary condition fixes. Removing the fixed DOFs
(rather than a penalty) leaves no spurious eigenvalues.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from . import shapes


@dataclass
class Interpolation:
    """Shape functions of the points' cells at the points."""

    N: np.ndarray       # (np, nen)
    dNdx: np.ndarray    # (np, nen, 2), 1/m
    nodes: np.ndarray   # (np, nen) ghosted-local node numbers
    dofs: np.ndarray    # (np, 2 nen) ghosted-local DOF numbers, x and y interleaved
    cells: tuple        # (cx, cy), each (np,)


def interpolation(grid, x, blended: bool = False, corner: bool = False) -> Interpolation:
    """Shape functions and their gradients at points x (np, 2), in m; with ``blended`` those
    of the blended basis N_hat (:func:`solver.model.shapes.blended`); with ``corner`` the bilinear
    functions of the cell's corner nodes, zero on its other nodes (the blend of weight 0:
    the pressure space of ``-mpm_pressure_projection corner``)."""
    cx, cy, xi, eta = grid.locate(x)
    N, dN = shapes.evaluate(grid.element, xi, eta)
    if blended or corner:
        N, dN = shapes.blended(grid.element, N, dN, xi, eta, 0.0 if corner else shapes.BLEND)
    dNdx = dN * np.stack([np.full(len(cy), 2.0 / grid.h[0]),
                          2.0 / grid.cell_heights(cy)], axis=-1)[:, None, :]
    i, j = grid.cell_nodes(cx, cy)
    nodes = grid.local_node(i, j)
    return Interpolation(N, dNdx, nodes, grid.local_dofs(i, j), (cx, cy))


def lumping_weights(N, kind: str) -> np.ndarray:
    """Weights w_ap (np, nen) that spread a point's mass-like quantities onto its nodes.

    ``rowsum``: w = N, the usual MPM lumping (row sums of the consistent matrix).
    ``hrz``: w = N^2 / sum_b N_b^2, diagonal scaling (Hinton, Rock and Zienkiewicz) per
    point; always positive, which Q8 needs: its corner row sums are negative.
    Both sum to 1 over a point's nodes, so mass and momentum are conserved.
    """
    if kind == "rowsum":
        return N
    N2 = N * N
    return N2 / N2.sum(axis=1, keepdims=True)


def strain_matrix(dNdx) -> np.ndarray:
    """B (np, 3, 2 nen) mapping nodal displacements to strains (xx, yy, 2 xy)."""
    npnt, nen, _ = dNdx.shape
    B = np.zeros((npnt, 3, 2 * nen))
    B[:, 0, 0::2] = dNdx[..., 0]
    B[:, 1, 1::2] = dNdx[..., 1]
    B[:, 2, 0::2] = dNdx[..., 1]
    B[:, 2, 1::2] = dNdx[..., 0]
    return B


def stiffness_blocks(interp: Interpolation, D, volume):
    """Each point's stiffness block B^T D B V (N/m), (np, 2 nen, 2 nen); D (Pa) is one 3 x 3
    matrix for all points or one per point, (np, 3, 3). The eigen model and the implicit
    consolidation scheme both take K from here."""
    B = strain_matrix(interp.dNdx)
    return np.einsum("pki,kl,plj->pij" if np.ndim(D) == 2 else "pki,pkl,plj->pij", B, D, B,
                     optimize=True) * volume[:, None, None]


def point_matrices(interp: Interpolation, D, volume, mass):
    """Each point's stiffness (N/m) and consistent mass (kg) blocks, (np, 2 nen, 2 nen);
    D (Pa) as :func:`stiffness_blocks` takes it."""
    Ke = stiffness_blocks(interp, D, volume)
    NN = mass[:, None, None] * interp.N[:, :, None] * interp.N[:, None, :]
    Me = np.zeros_like(Ke)
    Me[:, 0::2, 0::2] = NN
    Me[:, 1::2, 1::2] = NN
    return Ke, Me


def assemble(da, blocks, dofs) -> PETSc.Mat:
    """A parallel Mat over the DMDA's DOFs from per-point blocks at ghosted-local DOFs."""
    A = da.createMat()
    A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, True)
    idx = np.ascontiguousarray(dofs, dtype=PETSc.IntType)
    if idx.shape[0]:
        A.setValuesLocalRCV(idx, idx, np.ascontiguousarray(blocks),
                            addv=PETSc.InsertMode.ADD_VALUES)
    A.assemble()
    return A


def free_dofs(M, fixed, comm) -> PETSc.IS:
    """Global indices of the free DOFs: supported by a point (M_ii > 0) and not ``fixed``
    (a mask over the owned DOFs)."""
    diag = M.getDiagonal()
    free = (diag.getArray() > 0) & ~fixed
    start = M.getOwnershipRange()[0]
    diag.destroy()
    return PETSc.IS().createGeneral(start + np.flatnonzero(free).astype(PETSc.IntType),
                                    comm=comm)


def stiffness_and_mass(grid, points, D, bcs):
    """K and consistent M restricted to the free DOFs, and the IS of those DOFs.

    ``D``: the plane-strain elasticity (Pa), a 3 x 3 matrix for every point or a function
    of the points' heights y (m) giving one per point, (np, 3, 3) (a layered soil).
    Returns ``(K_free, M_free, free_is)``; K in N/m, M in kg, per metre of out-of-plane depth.
    """
    x, volume, mass = points.get("x", "volume", "mass")
    interp = interpolation(grid, x)
    Ke, Me = point_matrices(interp, D(x[:, 1]) if callable(D) else D, volume, mass)
    K = assemble(grid.da, Ke, interp.dofs)
    M = assemble(grid.da, Me, interp.dofs)
    free = free_dofs(M, grid.constrained_mask(bcs), grid.comm)
    Kf = K.createSubMatrix(free, free)
    Mf = M.createSubMatrix(free, free)
    K.destroy()
    M.destroy()
    return Kf, Mf, free
