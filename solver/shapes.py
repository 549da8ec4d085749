"""Shape functions of the quadrilateral background cells: Q4, Q8 (serendipity), Q9 (Lagrange).

A cell of order ``p`` (1 for Q4, 2 for Q8/Q9) spans ``p + 1`` nodes of the grid's node
lattice in each direction. Local node ``a`` sits at lattice offset ``OFFSETS[element][a]``
(``(i, j)`` with ``0 <= i, j <= p``), natural coordinates ``xi = -1 + 2 i / p``.
Q8 uses the Q9 lattice without its centre node.
"""

from __future__ import annotations

import numpy as np

ORDER = {"q4": 1, "q8": 2, "q9": 2}


def lattice_nodes(element: str, cells) -> int:
    """Nodes of the lattice of ``cells = (NX, NY)`` cells of this type: (p NX + 1)(p NY + 1)."""
    p = ORDER[element]
    return (p * cells[0] + 1) * (p * cells[1] + 1)


def _lattice(p, skip_centre=False):
    pts = [(i, j) for j in range(p + 1) for i in range(p + 1)]
    if skip_centre:
        pts.remove((1, 1))
    return np.array(pts, dtype=np.int64)


OFFSETS = {"q4": _lattice(1), "q8": _lattice(2, skip_centre=True), "q9": _lattice(2)}


def lagrange1d(p, s):
    """Values and derivatives of the 1D Lagrange polynomials of order p at s (n,) -> (n, p+1)."""
    s = np.asarray(s, dtype=float)[:, None]
    if p == 1:
        v = np.hstack([(1 - s) / 2, (1 + s) / 2])
        d = np.hstack([np.full_like(s, -0.5), np.full_like(s, 0.5)])
    else:
        v = np.hstack([s * (s - 1) / 2, 1 - s * s, s * (s + 1) / 2])
        d = np.hstack([s - 0.5, -2 * s, s + 0.5])
    return v, d


def evaluate(element: str, xi, eta):
    """Shape functions and natural derivatives at points (xi, eta), each of shape (n,).

    Returns ``N`` (n, nen) and ``dN`` (n, nen, 2) with ``dN[..., 0] = dN/dxi``.
    """
    xi = np.asarray(xi, dtype=float)
    eta = np.asarray(eta, dtype=float)
    off = OFFSETS[element]
    if element == "q8":
        return _serendipity(xi, eta, off)
    p = ORDER[element]
    vx, dx = lagrange1d(p, xi)
    vy, dy = lagrange1d(p, eta)
    i, j = off[:, 0], off[:, 1]
    N = vx[:, i] * vy[:, j]
    dN = np.stack([dx[:, i] * vy[:, j], vx[:, i] * dy[:, j]], axis=-1)
    return N, dN


def _serendipity(xi, eta, off):
    # Node natural coordinates from the lattice offsets (0, 1, 2 -> -1, 0, 1).
    a = (off[:, 0] - 1).astype(float)[None, :]
    b = (off[:, 1] - 1).astype(float)[None, :]
    x = xi[:, None]
    y = eta[:, None]
    corner = (a != 0) & (b != 0)
    mid_x = a == 0          # nodes on the edges eta = +-1, midway in xi
    N = np.where(corner, 0.25 * (1 + a * x) * (1 + b * y) * (a * x + b * y - 1),
                 np.where(mid_x, 0.5 * (1 - x * x) * (1 + b * y),
                          0.5 * (1 + a * x) * (1 - y * y)))
    dNx = np.where(corner, 0.25 * a * (1 + b * y) * (2 * a * x + b * y),
                   np.where(mid_x, -x * (1 + b * y), 0.5 * a * (1 - y * y)))
    dNy = np.where(corner, 0.25 * b * (1 + a * x) * (a * x + 2 * b * y),
                   np.where(mid_x, 0.5 * b * (1 - x * x), -y * (1 + a * x)))
    return N, np.stack([dNx, dNy], axis=-1)


def gauss_1d(n: int):
    """Gauss-Legendre points and weights on [-1, 1]."""
    return np.polynomial.legendre.leggauss(n)


def uniform_1d(n: int):
    """Centres of n equal sub-intervals of [-1, 1] and their weights (the MPM placement)."""
    return -1 + (2 * np.arange(n) + 1) / n, np.full(n, 2.0 / n)


def corners(element: str) -> np.ndarray:
    """Local numbers of the cell's four corner nodes, in the Q4 order (0,0), (p,0), (0,p),
    (p,p)."""
    off, p = OFFSETS[element], ORDER[element]
    return np.array([int(np.flatnonzero((off[:, 0] == i) & (off[:, 1] == j))[0])
                     for j in (0, p) for i in (0, p)])


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
