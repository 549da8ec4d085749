"""The grid functions a moving material point sees on a uniform background grid (the
large-deformation step, :mod:`solver.stepping.flow`).

The grid: nodes at (i h_x, j h_y) for i = -g .. nx + g, j = -g .. ny + g (g = 1 ghost layer
for the B-splines and uGIMP, whose functions reach beyond a cell; 0 for linear), node number
(j + g) (nx + 1 + 2 g) + (i + g). A point at x gets, per direction, the functions of the
nodes whose support holds it:

- ``linear``: the standard MPM's hat functions (2 nodes), continuous but with a gradient
  that jumps where the point crosses a cell: the force a point gives its nodes jumps with
  it (cell-crossing noise);
- ``bspline``: uniform quadratic B-splines (3 nodes), C1: N = (1/2 - r)^2 / 2, 3/4 - r^2,
  (1/2 + r)^2 / 2 at r = x / h - the nearest node's index, in [-1/2, 1/2];
- ``gimp``: uGIMP, the hat functions averaged over the point's undeformed domain (half
  width l = h / (2 ppc), the lattice's ``lp``; 3 nodes), C1 where the point enters a cell:
  in cells, at a distance d from the node, 1 - (d^2 + l^2) / (2 l) for d < l, 1 - d to
  1 - l, (1 + l - d)^2 / (4 l) to 1 + l. The grid's field is the hat functions' (bilinear
  in each cell), so a slip line is as sharp as a Q4 element's; the B-splines' field is
  smooth over three cells and spreads it.

All three are partitions of unity that reproduce linear fields (sum N x_a = x; for the
B-splines the nodes are the control points of x), and the 2D functions are tensor
products. Vectorised over the points: no loop per point.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

KINDS = ("linear", "gimp", "bspline")
GHOST = {"linear": 0, "gimp": 1, "bspline": 1}
NAMES = {"linear": "hat functions", "gimp": "uGIMP", "bspline": "quadratic B-splines"}


@dataclass(frozen=True)
class Lattice:
    """The uniform grid of ``cells`` (nx, ny) cells of ``h`` (hx, hy) m from the origin,
    with ``kind``'s ghost layer around it; ``lp`` (x, y) (m): the points' half widths
    (uGIMP's; at most half a cell)."""

    kind: str
    cells: tuple
    h: tuple
    lp: tuple = (0.0, 0.0)

    def __post_init__(self):
        if self.kind == "gimp" and not all(0 < l <= 0.5 * h for l, h in zip(self.lp, self.h)):
            raise ValueError(f"uGIMP needs half widths in (0, h / 2], not {self.lp}")

    @property
    def ghost(self) -> int:
        return GHOST[self.kind]

    @property
    def shape(self) -> tuple:
        """Nodes per direction, ghosts included (x, y)."""
        return tuple(c + 1 + 2 * self.ghost for c in self.cells)

    @property
    def n_nodes(self) -> int:
        return self.shape[0] * self.shape[1]

    def positions(self) -> np.ndarray:
        """(n_nodes, 2) node positions (m)."""
        g = self.ghost
        i = (np.arange(self.shape[0]) - g) * self.h[0]
        j = (np.arange(self.shape[1]) - g) * self.h[1]
        X, Y = np.meshgrid(i, j)
        return np.stack([X.ravel(), Y.ravel()], axis=1)


def _linear(u, l=0.0):
    """1D hat functions at u = x / h: (first node index (np,), N (np, 2), dN/du (np, 2));
    ``l``, a point's half width, does not enter them."""
    i = np.floor(u).astype(np.int64)
    s = u - i
    N = np.stack([1 - s, s], axis=1)
    dN = np.tile(np.array([-1.0, 1.0]), (len(u), 1))
    return i, N, dN


def _bspline(u, l=0.0):
    """1D quadratic B-splines at u = x / h: (first node index (np,), N (np, 3), dN/du);
    ``l``, a point's half width, does not enter them."""
    c = np.floor(u + 0.5).astype(np.int64)        # the nearest node
    r = u - c
    N = np.stack([0.5 * (0.5 - r) ** 2, 0.75 - r * r, 0.5 * (0.5 + r) ** 2], axis=1)
    dN = np.stack([r - 0.5, -2 * r, r + 0.5], axis=1)
    return c - 1, N, dN


def _gimp(u, l):
    """1D uGIMP functions at u = x / h of a point of half width l (cells, 0 < l <= 1/2):
    (first node index, N (np, 3), dN/du)."""
    c = np.floor(u + 0.5).astype(np.int64)        # the nearest node
    z = (u - c)[:, None] - np.array([-1.0, 0.0, 1.0])[None, :]   # from each node (cells)
    d = np.abs(z)
    inner, outer = d < l, d > 1 - l
    N = np.where(inner, 1 - (d * d + l * l) / (2 * l),
                 np.where(outer, np.maximum(1 + l - d, 0.0) ** 2 / (4 * l), 1 - d))
    slope = np.where(inner, -d / l, np.where(outer, -np.maximum(1 + l - d, 0.0) / (2 * l),
                                             -1.0))
    return c - 1, N, slope * np.sign(z)


_ONE_D = {"linear": _linear, "gimp": _gimp, "bspline": _bspline}


def evaluate(lattice: Lattice, x) -> tuple:
    """(nodes (np, m), N (np, m), grad N (np, m, 2) in 1/m) of the points at x (np, 2) (m),
    m = 4 (linear) or 9 (uGIMP, B-splines); nodes are numbered as the module docstring
    says. Points must lie inside the grid (their supports inside its ghosts)."""
    x = np.asarray(x, dtype=float)
    one, (hx, hy), (lx, ly) = _ONE_D[lattice.kind], lattice.h, lattice.lp
    ix, Nx, dNx = one(x[:, 0] / hx, lx / hx)
    iy, Ny, dNy = one(x[:, 1] / hy, ly / hy)
    k = Nx.shape[1]
    g, nxn = lattice.ghost, lattice.shape[0]
    # Tensor products, x fastest: entry a = b k + c takes x function c and y function b.
    cols = (ix[:, None] + g + np.arange(k)[None, :])
    rows = (iy[:, None] + g + np.arange(k)[None, :])
    nodes = (rows[:, :, None] * nxn + cols[:, None, :]).reshape(len(x), k * k)
    N = (Ny[:, :, None] * Nx[:, None, :]).reshape(len(x), k * k)
    grad = np.empty((len(x), k * k, 2))
    grad[..., 0] = (Ny[:, :, None] * dNx[:, None, :]).reshape(len(x), k * k) / lattice.h[0]
    grad[..., 1] = (dNy[:, :, None] * Nx[:, None, :]).reshape(len(x), k * k) / lattice.h[1]
    return nodes, N, grad


SIDES = ("left", "right", "bottom", "top")


def walls(lattice: Lattice, held: dict) -> tuple:
    """The grid's walls: ``held`` maps a side of the grid ('left', 'right', 'bottom',
    'top') to the velocity components it holds ('x', 'y', 'xy'; sides not named are
    open). Returns (mask (n_nodes, 2): the components held at zero on the wall's nodes;
    source (n_nodes,): the node whose velocity a ghost node mirrors, itself for the
    others; sign (n_nodes, 2): -1 for a held component mirrored across its wall, +1 else).

    Why mirror: B-splines reach a ghost node beyond each side, and holding that node too
    makes the velocity near a wall flat (zero slope at the wall: a stress error of a
    quarter of the weight at a column's foot, measured); reflected, odd in the held
    components and even in the others, the field is linear through the wall as a wall
    needs."""
    g, (nxn, nyn), (nx, ny) = lattice.ghost, lattice.shape, lattice.cells
    i = np.arange(nxn) - g                      # node coordinates in cells, ghosts outside
    j = np.arange(nyn) - g
    parts = {"left": ("x", 0, 0), "right": ("x", 0, nx), "bottom": ("y", 1, 0),
             "top": ("y", 1, ny)}
    I, Jn = np.meshgrid(i, j)
    I, Jn = I.ravel(), Jn.ravel()
    mask = np.zeros((len(I), 2), dtype=bool)
    sign = np.ones((len(I), 2))
    si, sj = I.copy(), Jn.copy()
    for side, comps in held.items():
        if side not in parts:
            raise ValueError(f"unknown side {side!r}")
        _, axis, at = parts[side]
        coord = I if axis == 0 else Jn
        on = coord == at
        beyond = coord < at if at == 0 else coord > at
        for c, name in enumerate("xy"):
            if name in comps:
                mask[on, c] = True
                sign[beyond, c] *= -1.0
        mirrored = 2 * at - coord[beyond]
        (si if axis == 0 else sj)[beyond] = mirrored
    source = (sj + g) * nxn + (si + g)
    return mask, source, sign


def fill(size, cells, ppc: int) -> tuple:
    """The material points of the W x H body ``size`` (m) at the origin: ``ppc`` x ``ppc``
    per cell of its ``cells`` (NX, NY), at the sub-cells' centres, row by row from the
    bottom. Returns (positions (np, 2) (m), the volume each stands for (m3 per m))."""
    (W, H), (nx, ny) = size, cells
    s = (np.arange(ppc) + 0.5) / ppc
    X, Y = np.meshgrid((np.arange(nx)[:, None] + s).ravel() * W / nx,
                       (np.arange(ny)[:, None] + s).ravel() * H / ny)
    return np.stack([X.ravel(), Y.ravel()], axis=1), W * H / (nx * ny * ppc * ppc)
