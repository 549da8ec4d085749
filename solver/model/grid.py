"""The structured background grid: a PETSc DMDA over the node lattice of a rectangle.

Cells are ``hx x hy`` rectangles; a cell of order ``order`` (1 for Q4, 2 for Q8/Q9) spans
order + 1 lattice nodes per direction, so the lattice has ``order NX + 1`` by ``order NY + 1``
nodes with two displacement DOFs each (x, y). Cell (cx, cy) belongs to the rank that owns its
lower-left node; the DMDA's box stencil of width order makes all its nodes visible there as
ghosts.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from . import shapes


def _split(cells: int, parts: int):
    """Cells per part, as even as possible."""
    return [cells // parts + (1 if i < cells % parts else 0) for i in range(parts)]


def partition(cells, order: int, size: int):
    """Process grid and node ownership ranges that cut the lattice along cell boundaries.

    Every rank gets whole cells, hence at least ``order`` node columns and rows, which the
    DMDA's stencil of width ``order`` requires. Among the factorisations px * py = size with
    px <= NX and py <= NY the one with the shortest cut wins. Raises InputError when none
    fits.
    """
    from ..common.errors import InputError

    nx, ny = cells
    best = None
    for px in range(1, size + 1):
        if size % px:
            continue
        py = size // px
        if px <= nx and py <= ny:
            cut = (px - 1) * ny + (py - 1) * nx
            if best is None or cut < best[0]:
                best = (cut, px, py)
    if best is None:
        raise InputError(f"-mpm_cells {nx},{ny}: too few cells for {size} MPI ranks "
                         "(each rank needs at least one whole cell)")
    _, px, py = best
    ranges = []
    for n, parts in ((nx, px), (ny, py)):
        nodes = [order * c for c in _split(n, parts)]
        nodes[-1] += 1
        ranges.append(nodes)
    return (px, py), tuple(ranges)


class Grid:
    """Background grid of ``cells = (NX, NY)`` cells over ``[0, W] x [0, H]`` (m)."""

    def __init__(self, comm, element: str, cells, size):
        self.comm = comm
        self.element = element
        self.order = shapes.ORDER[element]
        self.cells = tuple(int(c) for c in cells)
        self.size = tuple(float(s) for s in size)
        self.h = (self.size[0] / self.cells[0], self.size[1] / self.cells[1])
        # The cells' edges in y where the rows of cells differ in height (a body-fitted
        # column, solver.consolidation.implicit.largestrain); None: uniform.
        self.edges_y = None
        self.nodes = (self.order * self.cells[0] + 1, self.order * self.cells[1] + 1)
        self.offsets = shapes.OFFSETS[element]
        procs, ranges = partition(self.cells, self.order, comm.getSize())
        self.da = PETSc.DMDA().create(dim=2, dof=2, sizes=self.nodes, proc_sizes=procs,
                                      ownership_ranges=ranges, stencil_type="box",
                                      stencil_width=self.order, comm=comm)
        self.da.setUniformCoordinates(0.0, self.size[0], 0.0, self.size[1])
        (self.xs, self.xe), (self.ys, self.ye) = self.da.getRanges()
        (self.gxs, self.gys), (self.gxm, self.gym) = self.da.getGhostCorners()

    # -- lifetime: the grid owns its DMDA (and the DMDA its coordinates) ------------------
    def destroy(self):
        """Destroy the DMDA (and its coordinate Vec); the grid is unusable afterwards.
        Objects made from it (TwoPhase's duplicates, Vecs) are their owners' to destroy."""
        self.da.destroy()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()

    # -- cells ---------------------------------------------------------------------------
    def owned_cells(self):
        """Indices (cx, cy) of the cells this rank owns, each of shape (nc,)."""
        (x0, x1), (y0, y1) = self.owned_cell_range()
        cx, cy = np.arange(x0, x1), np.arange(y0, y1)
        CX, CY = np.meshgrid(cx, cy, indexing="xy")
        return CX.ravel(), CY.ravel()

    def owned_cell_range(self):
        """The box of cells this rank owns: ((cx0, cx1), (cy0, cy1)), half open.

        ``owned_cells`` lists the same cells; the partition cuts the lattice along cell
        boundaries, so this rank's cells are exactly those of the box."""
        order = self.order
        return ((-(-self.xs // order), min(-(-self.xe // order), self.cells[0])),
                (-(-self.ys // order), min(-(-self.ye // order), self.cells[1])))

    def cell_owner(self, cx, cy):
        """The rank that owns each cell (cx, cy): the owner of its lower-left node."""
        lx, ly = self.da.getOwnershipRanges()
        px = np.searchsorted(np.cumsum(lx), self.order * np.asarray(cx), side="right")
        py = np.searchsorted(np.cumsum(ly), self.order * np.asarray(cy), side="right")
        return py * len(lx) + px

    def locate(self, x):
        """Cell indices and natural coordinates of points x (n, 2) in m."""
        hx, hy = self.h
        cx = np.clip(np.floor(x[:, 0] / hx).astype(np.int64), 0, self.cells[0] - 1)
        xi = 2 * (x[:, 0] - cx * hx) / hx - 1
        if self.edges_y is None:
            cy = np.clip(np.floor(x[:, 1] / hy).astype(np.int64), 0, self.cells[1] - 1)
            eta = 2 * (x[:, 1] - cy * hy) / hy - 1
        else:
            cy = np.clip(np.searchsorted(self.edges_y, x[:, 1], side="right") - 1, 0,
                         self.cells[1] - 1)
            eta = 2 * (x[:, 1] - self.edges_y[cy]) / self.cell_heights(cy) - 1
        return cx, cy, xi, eta

    def cell_heights(self, cy) -> np.ndarray:
        """The heights (m) of the cells of rows cy."""
        if self.edges_y is None:
            return np.full(np.shape(cy), self.h[1])
        return np.diff(self.edges_y)[np.asarray(cy)]

    def cell_nodes(self, cx, cy):
        """Lattice indices (i, j) of the nodes of cells (cx, cy): two arrays (n, nen)."""
        i = self.order * np.asarray(cx)[:, None] + self.offsets[None, :, 0]
        j = self.order * np.asarray(cy)[:, None] + self.offsets[None, :, 1]
        return i, j

    # -- numbering -----------------------------------------------------------------------
    def local_node(self, i, j):
        """Ghosted-local node numbers of lattice nodes (i, j) (for setValuesLocal)."""
        return (np.asarray(j) - self.gys) * self.gxm + (np.asarray(i) - self.gxs)

    def local_dofs(self, i, j):
        """Ghosted-local DOF numbers (n, 2 nen), interleaved x, y per node."""
        node = self.local_node(i, j)
        return np.stack([2 * node, 2 * node + 1], axis=-1).reshape(node.shape[0], -1)

    def lattice_coordinates(self):
        """Coordinates (m) of all lattice nodes in natural order (row by row), shape (N, 2)."""
        hx, hy = self.h[0] / self.order, self.h[1] / self.order
        I, J = np.meshgrid(np.arange(self.nodes[0]), np.arange(self.nodes[1]), indexing="xy")
        return np.stack([I.ravel() * hx, J.ravel() * hy], axis=-1)

    def owned_lattice(self):
        """Lattice indices (i, j) of this rank's owned nodes, in global Vec order."""
        I, J = np.meshgrid(np.arange(self.xs, self.xe), np.arange(self.ys, self.ye),
                           indexing="xy")
        return I.ravel(), J.ravel()

    def owned_sides(self) -> dict:
        """{side: mask over the owned nodes (global Vec order) of those on that side}."""
        I, J = self.owned_lattice()
        return {"left": I == 0, "right": I == self.nodes[0] - 1,
                "bottom": J == 0, "top": J == self.nodes[1] - 1}

    def constrained_mask(self, bcs):
        """Boolean mask over the owned DOFs (global Vec order) of fixed displacements.

        ``bcs`` maps a side (left, right, bottom, top) to the fixed components ('x', 'y',
        'xy' or 'none').
        """
        sides = self.owned_sides()
        fixed = np.zeros((sides["left"].size, 2), dtype=bool)
        for side, comps in bcs.items():
            for c, name in enumerate("xy"):
                if name in comps:
                    fixed[sides[side], c] = True
        return fixed.ravel()

    def cell_connectivity(self):
        """All cells' lattice node numbers in natural order, shape (ncells, nen)."""
        cx, cy = np.meshgrid(np.arange(self.cells[0]), np.arange(self.cells[1]), indexing="xy")
        i, j = self.cell_nodes(cx.ravel(), cy.ravel())
        return j * self.nodes[0] + i

    def gather_natural(self, vec):
        """A global DMDA Vec gathered on rank 0 in natural order as (N, 2); None elsewhere."""
        nat = self.da.createNaturalVec()
        self.da.globalToNatural(vec, nat)
        scatter, seq = PETSc.Scatter.toZero(nat)
        scatter.scatter(nat, seq, PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)
        out = seq.getArray().reshape(-1, 2).copy() if self.comm.rank == 0 else None
        for obj in (scatter, seq, nat):
            obj.destroy()
        return out
