"""Compiled transfers of the large-deformation step (:mod:`solver.stepping.flow`) between
its points and the uniform background grid of :mod:`solver.model.lattice` (numba,
nopython, cached on disk): one pass over the points each way, with each point's grid
functions computed on the fly (hat functions, k = 2 per direction; uGIMP or quadratic
B-splines, k = 3) as :func:`solver.model.lattice.evaluate` gives them; tests/test_flow.py
holds these kernels to that NumPy reference.

The points run in their order, one after another, so the sums are the same on every run
and machine (a parallel run adds the ranks' sums in one all-reduce).
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..model import shapes

_jit = njit(cache=True, **shapes.KERNEL_OPTIONS)

NS = 5        # the nodal sums: mass, momentum (x, y), internal force (x, y)


@_jit
def _weights(u, form, l, N, dN):
    """The 1D functions of ``form`` (the index in lattice.KINDS: 0 hat functions, 1 uGIMP
    of half width l cells, 2 quadratic B-splines) at u = x / h (in cells) into N, dN (dN
    per cell); returns the index of the first node."""
    if form == 0:
        i = np.int64(np.floor(u))
        s = u - i
        N[0], N[1] = 1.0 - s, s
        dN[0], dN[1] = -1.0, 1.0
        return i
    c = np.int64(np.floor(u + 0.5))
    r = u - c
    if form == 2:
        N[0], N[1], N[2] = 0.5 * (0.5 - r) ** 2, 0.75 - r * r, 0.5 * (0.5 + r) ** 2
        dN[0], dN[1], dN[2] = r - 0.5, -2.0 * r, r + 0.5
        return c - 1
    for j in range(3):
        z = r + 1.0 - j                     # from node c - 1 + j (cells)
        d = abs(z)
        sign = 1.0 if z > 0 else (-1.0 if z < 0 else 0.0)
        if d < l:
            N[j], dN[j] = 1.0 - (d * d + l * l) / (2.0 * l), -z / l
        elif d <= 1.0 - l:
            N[j], dN[j] = 1.0 - d, -sign
        elif d < 1.0 + l:
            N[j], dN[j] = (1.0 + l - d) ** 2 / (4.0 * l), -sign * (1.0 + l - d) / (2.0 * l)
        else:
            N[j], dN[j] = 0.0, 0.0
    return c - 1


@_jit
def _point(x, p, form, l, ghost, h, Nx, dNx, Ny, dNy):
    """Point p's functions into Nx, dNx, Ny, dNy and the (column, row) of its first node."""
    return (_weights(x[p, 0] / h[0], form, l[0], Nx, dNx) + ghost,
            _weights(x[p, 1] / h[1], form, l[1], Ny, dNy) + ghost)


@_jit
def _node(b, c, h, Nx, dNx, Ny, dNy):
    """(N, dN/dx, dN/dy) of the point's node c across, b up (1/m)."""
    return Ny[b] * Nx[c], Ny[b] * dNx[c] / h[0], dNy[b] * Nx[c] / h[1]


@_jit
def points_to_grid(x, v, m, V, sigma, form, l, ghost, h, nxn, extent, sums):
    """Add the points' masses m (kg per m), momenta m v and internal forces -V sigma grad N
    (N per m) into ``sums`` (n_nodes, NS), zeroed here: x, v (np, 2) (m, m/s), the
    current volumes V (np,) (m2), the Cauchy stresses sigma (np, 4) (xx, yy, zz, xy; Pa),
    the functions ``form`` (:func:`_weights`; uGIMP's half widths ``l`` (2,) in cells) on
    cells ``h`` (2,) (m), ``ghost`` layers, ``nxn`` nodes per row. Returns -1, or the
    first point outside the grid [0, extent] (its nodes would lie beyond the arrays:
    nothing more is added)."""
    sums[:] = 0.0
    Nx, dNx, Ny, dNy = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    k = 2 if form == 0 else 3
    for p in range(x.shape[0]):
        if not (0.0 <= x[p, 0] <= extent[0] and 0.0 <= x[p, 1] <= extent[1]):
            return p
        ix, iy = _point(x, p, form, l, ghost, h, Nx, dNx, Ny, dNy)
        mp, vx, vy = m[p], v[p, 0], v[p, 1]
        sxx, syy, sxy, Vp = sigma[p, 0], sigma[p, 1], sigma[p, 3], V[p]
        for b in range(k):
            row = (iy + b) * nxn + ix
            for c in range(k):
                a = row + c
                N, gx, gy = _node(b, c, h, Nx, dNx, Ny, dNy)
                sums[a, 0] += N * mp
                sums[a, 1] += N * mp * vx
                sums[a, 2] += N * mp * vy
                sums[a, 3] -= Vp * (sxx * gx + sxy * gy)
                sums[a, 4] -= Vp * (sxy * gx + syy * gy)
    return -1


@_jit
def grid_to_points(x, a, vnew, form, l, ghost, h, nxn, ap, vp, L):
    """The points' interpolated nodal accelerations ``ap`` and new velocities ``vp`` (np, 2)
    and velocity gradients ``L`` = sum vnew (x) grad N (np, 2, 2) (1/s), written here, from
    the nodal a and vnew (n_nodes, 2) at the points' positions x (np, 2) (m)."""
    Nx, dNx, Ny, dNy = np.empty(3), np.empty(3), np.empty(3), np.empty(3)
    k = 2 if form == 0 else 3
    for p in range(x.shape[0]):
        ix, iy = _point(x, p, form, l, ghost, h, Nx, dNx, Ny, dNy)
        s0 = s1 = s2 = s3 = 0.0
        l00 = l01 = l10 = l11 = 0.0
        for b in range(k):
            row = (iy + b) * nxn + ix
            for c in range(k):
                n = row + c
                N, gx, gy = _node(b, c, h, Nx, dNx, Ny, dNy)
                s0 += N * a[n, 0]
                s1 += N * a[n, 1]
                s2 += N * vnew[n, 0]
                s3 += N * vnew[n, 1]
                l00 += vnew[n, 0] * gx
                l01 += vnew[n, 0] * gy
                l10 += vnew[n, 1] * gx
                l11 += vnew[n, 1] * gy
        ap[p, 0], ap[p, 1], vp[p, 0], vp[p, 1] = s0, s1, s2, s3
        L[p, 0, 0], L[p, 0, 1], L[p, 1, 0], L[p, 1, 1] = l00, l01, l10, l11
