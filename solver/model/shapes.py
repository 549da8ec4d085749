"""Shape functions of the quadrilateral background cells: Q4, Q8 (serendipity), Q9 (Lagrange).

A cell of order ``order`` (1 for Q4, 2 for Q8/Q9) spans ``order + 1`` nodes of the grid's
node lattice in each direction. Local node ``a`` sits at lattice offset
``OFFSETS[element][a]`` (``(i, j)`` with ``0 <= i, j <= order``), natural coordinates
``xi = -1 + 2 i / order``. Q8 uses the Q9 lattice without its centre node.

The formulas are written once, as functions of one point's natural coordinates (:func:`q4`,
:func:`q8`, :func:`q9`) that serve twice: as plain Python over NumPy arrays of points
(:func:`evaluate`, :func:`lagrange1d`: one IEEE operation per ufunc), and compiled by numba
into the explicit step's kernels (solver.stepping.kernels), at one point, with
the kernels' options (``KERNEL_OPTIONS``: their ``a b + c`` may become one fused
multiply-add). numba's disk cache of the kernels does not notice edits of this file: after
changing a formula, delete ``solver/stepping/__pycache__/kernels*.nb*``
(tests/test_shapes.py compares the two).
"""

from __future__ import annotations

import numpy as np
from numba.extending import register_jitable

ORDER = {"q4": 1, "q8": 2, "q9": 2}

# The step kernels' compiler options (solver.stepping.kernels: division by
# zero gives inf or NaN, and only a b + c -> fma is allowed), with which they compile the
# functions below.
KERNEL_OPTIONS = dict(error_model="numpy", fastmath={"contract"})
_scalar = register_jitable(**KERNEL_OPTIONS)


def lattice_nodes(element: str, cells) -> int:
    """Nodes of the lattice of ``cells = (NX, NY)`` cells of this type:
    (order NX + 1)(order NY + 1)."""
    order = ORDER[element]
    return (order * cells[0] + 1) * (order * cells[1] + 1)


def _lattice(order, skip_centre=False):
    pts = [(i, j) for j in range(order + 1) for i in range(order + 1)]
    if skip_centre:
        pts.remove((1, 1))
    return np.array(pts, dtype=np.int64)


OFFSETS = {"q4": _lattice(1), "q8": _lattice(2, skip_centre=True), "q9": _lattice(2)}


# -- one point (or arrays of points, elementwise), natural coordinates in [-1, 1] ----------
@_scalar
def linear(s):
    """1D linear Lagrange polynomials at s: values l_0, l_1 and derivatives dl/ds."""
    return (1 - s) / 2, (1 + s) / 2, -0.5, 0.5


@_scalar
def quadratic(s):
    """1D quadratic Lagrange polynomials (nodes -1, 0, 1) at s: values, then dl/ds."""
    return s * (s - 1) / 2, 1 - s * s, s * (s + 1) / 2, s - 0.5, -2 * s, s + 0.5


@_scalar
def q4(x, y, sx, sy):
    """N, sx dN/dxi, sy dN/deta of the Q4 cell at (xi, eta) = (x, y), three tuples over the
    nodes in OFFSETS order: N_a = l_i(x) l_j(y) for node a = 2 j + i. ``sx``, ``sy``:
    d(xi)/dx, d(eta)/dy (1/m) for the derivatives in x and y, or 1.0 for the natural ones."""
    x0, x1, d0, d1 = linear(x)
    y0, y1, e0, e1 = linear(y)
    # The scaled 1D derivatives first (+-sx / 2: exact, and hoisted out of the kernels'
    # loops over the points): one product per entry, as the step had it before.
    d0, d1, e0, e1 = d0 * sx, d1 * sx, e0 * sy, e1 * sy
    return ((x0 * y0, x1 * y0, x0 * y1, x1 * y1),
            (d0 * y0, d1 * y0, d0 * y1, d1 * y1),
            (x0 * e0, x1 * e0, x0 * e1, x1 * e1))


@_scalar
def q9(x, y, sx, sy):
    """N, sx dN/dxi, sy dN/deta of the Q9 cell (as :func:`q4`): N_a = l_i(x) l_j(y) for
    node a = 3 j + i."""
    x0, x1, x2, d0, d1, d2 = quadratic(x)
    y0, y1, y2, e0, e1, e2 = quadratic(y)
    return ((x0 * y0, x1 * y0, x2 * y0, x0 * y1, x1 * y1, x2 * y1, x0 * y2, x1 * y2, x2 * y2),
            (d0 * y0 * sx, d1 * y0 * sx, d2 * y0 * sx, d0 * y1 * sx, d1 * y1 * sx,
             d2 * y1 * sx, d0 * y2 * sx, d1 * y2 * sx, d2 * y2 * sx),
            (x0 * e0 * sy, x1 * e0 * sy, x2 * e0 * sy, x0 * e1 * sy, x1 * e1 * sy,
             x2 * e1 * sy, x0 * e2 * sy, x1 * e2 * sy, x2 * e2 * sy))


@_scalar
def _corner(a, b, x, y):
    """Q8 corner node at natural (a, b): N and its natural derivatives at (x, y)."""
    return (0.25 * (1 + a * x) * (1 + b * y) * (a * x + b * y - 1),
            0.25 * a * (1 + b * y) * (2 * a * x + b * y),
            0.25 * b * (1 + a * x) * (a * x + 2 * b * y))


@_scalar
def _mid_x(b, x, y):
    """Q8 mid-side node (0, b) on the edge eta = b."""
    return 0.5 * (1 - x * x) * (1 + b * y), -x * (1 + b * y), 0.5 * b * (1 - x * x)


@_scalar
def _mid_y(a, x, y):
    """Q8 mid-side node (a, 0) on the edge xi = a."""
    return 0.5 * (1 + a * x) * (1 - y * y), 0.5 * a * (1 - y * y), -y * (1 + a * x)


@_scalar
def q8(x, y, sx, sy):
    """N, sx dN/dxi, sy dN/deta of the Q8 (serendipity) cell (as :func:`q4`), nodes in the
    Q9 lattice order without the centre (OFFSETS['q8'])."""
    n0, n1, n2 = _corner(-1.0, -1.0, x, y), _mid_x(-1.0, x, y), _corner(1.0, -1.0, x, y)
    n3, n4 = _mid_y(-1.0, x, y), _mid_y(1.0, x, y)
    n5, n6, n7 = _corner(-1.0, 1.0, x, y), _mid_x(1.0, x, y), _corner(1.0, 1.0, x, y)
    return ((n0[0], n1[0], n2[0], n3[0], n4[0], n5[0], n6[0], n7[0]),
            (n0[1] * sx, n1[1] * sx, n2[1] * sx, n3[1] * sx, n4[1] * sx, n5[1] * sx,
             n6[1] * sx, n7[1] * sx),
            (n0[2] * sy, n1[2] * sy, n2[2] * sy, n3[2] * sy, n4[2] * sy, n5[2] * sy,
             n6[2] * sy, n7[2] * sy))


BASIS = {"q4": q4, "q8": q8, "q9": q9}


# -- arrays of points ---------------------------------------------------------------------
def lagrange1d(order, s):
    """Values and derivatives of the 1D Lagrange polynomials of order ``order`` (1 or 2) at
    s (n,) -> two arrays (n, order + 1)."""
    s = np.asarray(s, dtype=float)
    rows = np.broadcast_arrays(*(linear(s) if order == 1 else quadratic(s)))
    return np.stack(rows[:order + 1], axis=-1), np.stack(rows[order + 1:], axis=-1)


def evaluate(element: str, xi, eta):
    """Shape functions and natural derivatives at points (xi, eta), each of shape (n,).

    Returns ``N`` (n, nen) and ``dN`` (n, nen, 2) with ``dN[..., 0] = dN/dxi``.
    """
    xi = np.asarray(xi, dtype=float)
    eta = np.asarray(eta, dtype=float)
    N, dx, dy = (np.stack(rows, axis=-1) for rows in BASIS[element](xi, eta, 1.0, 1.0))
    return N, np.stack([dx, dy], axis=-1)


def gauss_1d(n: int):
    """Gauss-Legendre points and weights on [-1, 1]."""
    return np.polynomial.legendre.leggauss(n)


def uniform_1d(n: int):
    """Centres of n equal sub-intervals of [-1, 1] and their weights (the MPM placement)."""
    return -1 + (2 * np.arange(n) + 1) / n, np.full(n, 2.0 / n)


def corners(element: str) -> np.ndarray:
    """Local numbers of the cell's four corner nodes, in the Q4 order: lattice offsets (0, 0),
    (order, 0), (0, order), (order, order)."""
    off, order = OFFSETS[element], ORDER[element]
    return np.array([int(np.flatnonzero((off[:, 0] == i) & (off[:, 1] == j))[0])
                     for j in (0, order) for i in (0, order)])


# Weight of the element's own functions in the blended liquid basis: corner values of
# w N_Q8 + (1 - w) N_Q4 stay positive for w < 3/4; 1/2 is the measured choice (docs/method.md).
BLEND = 0.5


def blended(element: str, N, dN, xi, eta, weight: float = BLEND):
    """The blended basis N_hat = w N + (1 - w) N_Q4 (N_Q4 the bilinear functions of the
    corner nodes) and its natural derivatives, from the element's N (n, nen) and dN
    (n, nen, 2) at (xi, eta). It reproduces constant and linear fields, as N does, and its
    row sums (lumped weights) are positive where Q8's corner row sums are negative."""
    N4, dN4 = evaluate("q4", xi, eta)
    c = corners(element)
    Nh, dNh = weight * N, weight * dN
    Nh[:, c] += (1 - weight) * N4
    dNh[:, c] += (1 - weight) * dN4
    return Nh, dNh
