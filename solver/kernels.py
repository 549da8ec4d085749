"""Compiled kernels of the explicit two-phase step (numba, nopython, cached on disk).

:mod:`solver.twophase` keeps the state and the PETSc objects; these functions do the work,
each in one pass over the points or nodes: points to grid, the nodal update, grid to
points (with the pressure projection) and the migration test. The formulas are those of
the twophase module docstring and docs/method.md; ``tests/test_step_reference.py`` holds
a plain NumPy reference they must match.

Data, all flat arrays kept between steps (no per-step temporaries):
- ``P`` (int64): ``P[PN]`` the number of local points, then the addresses of the swarm's
  point fields (slots PX ... PVSLOW; 0 for a field the scheme does not use). The fields are
  viewed in place through ``_field1``/``_field2``: one array argument instead of ten, since
  numba unboxes every array argument on every call (about 0.15 us each, measured), which
  for the 40 points of the M1 scenes would cost more than the arithmetic;
- ``I`` (int64) and ``R`` (float64): the scheme's integers and reals (slots I* and R*);
- ``W`` (float64, ``NROW x MAXNEN``): one point's shape-function rows (scratch);
- nodal arrays node-major, ``node * nfields + field``, as a DMDA Vec with ``dof =
  nfields`` stores them: the sums ``G`` (NF or NF + 1 fields), the accelerations and
  velocities ``O`` (NG = 8 fields: a_s, a_l, v_s, v_l, x and y each), the projected
  pressure increments (1 field) and ``B`` (5 per owned node: the load's nodal force, then 1
  or 0 for the free or fixed DOFs of v_s (x, y) and v_l (x, y)).

Compilation: ``cache=True`` stores the machine code under ``solver/__pycache__`` (or
``NUMBA_CACHE_DIR``), so only the first run on a machine compiles; :func:`warm_up` compiles
or loads every kernel at model set-up, inside the ``MPMCompile`` log event, so that the
step's own events never include it. ``error_model='numpy'``: a division by zero gives inf
or NaN as NumPy does (the run's blow-up check reports it) instead of raising.
"""

from __future__ import annotations

import time

import numpy as np
from numba import carray, njit, types
from numba.extending import intrinsic

_jit = njit(cache=True, error_model="numpy")

NF = 9        # nodal sums: S, V v_s (2), V v_l (2), f_m (2), f_l (2); + S_l when blended
NG = 8        # nodal results sent back to the points: a_s (2), a_l (2), v_s (2), v_l (2)
NB = 5        # static data per owned node: the load's force, free flags of v_s, v_l
MAXNEN = 9    # nodes of a cell, at most (Q9)

# P: point count, then field addresses.
PN, PX, PXREF, PV, PVS, PVL, PSIG, PP, PJ, PVISC, PVSLOW = range(11)
NP = 11

# I: integers of the scheme and the grid.
(IEL,       # cell type: Q4, Q8, Q9 below
 INEN,      # nodes per cell
 INF,       # nodal sums per node (NF, or NF + 1 with the blended liquid basis)
 IBLEND,    # 1: the liquid in the blended basis N_hat
 IHRZ,      # 1: HRZ lumping weights, 0: row sums (w = N)
 IPROJ,     # 1: pore-pressure increments projected through the nodes
 IIMPL,     # 1: implicit drag
 ICMX, ICMY,    # largest cell index per direction (cells - 1)
 ISTX, ISTY,    # ghosted-local node offset of one cell step in x and in y
 INOWN,         # owned nodes (the nodal update's range)
 ) = range(12)
IOFF = 12                 # MAXNEN ghosted-local node offsets of the cell's nodes
IOI = IOFF + MAXNEN       # MAXNEN lattice offsets i of the cell's nodes (0 .. p)
IOJ = IOI + MAXNEN        # and j
ICORN = IOJ + MAXNEN      # 4 local numbers of the corners, Q4 order (blended basis)
NI = ICORN + 4
Q4, Q8, Q9 = 0, 1, 2
ELEMENTS = {"q4": Q4, "q8": Q8, "q9": Q9}

# R: reals (SI units).
(RHX, RHY,     # cell size (m)
 RSX, RSY,     # d(xi, eta)/d(x, y) = 2 / h (1/m)
 RCS, RCL, RCT, RCQ,   # M_s, M_l, M~_l per unit S (kg/m3), Q per unit S (kg/m3/s)
 RN,           # porosity
 RKL,          # K_l (Pa)
 RGM, RGL,     # weights per volume, y: mixture, liquid (N/m3, with the sign of g_y)
 RETA,         # bulk viscosity eta (Pa s); 0: off
 RFAST, RSLOW,  # fast-part damping rate 2 zeta w1 and low-pass rate w1 (1/s); 0: off
 RBLEND,       # weight of the element's own functions in N_hat
 ) = range(16)
RD = 16                   # the plane-strain elasticity matrix D (Pa), 3 x 3 row-major
RBOX = RD + 9             # migration box per direction: partitioned (1/0), h, lo, hi
NR = RBOX + 8

# W: rows of one point's shape functions: N, dN/dx, dN/dy (1, 1/m); N_hat and its
# derivatives; HRZ weights; 1D values and natural derivatives in x, then in y.
WN, WX, WY, WLN, WLX, WLY, WW, WVX, WDX, WVY, WDY = range(11)
NROW = 11


# -- point fields ---------------------------------------------------------------------------
@intrinsic
def _pointer(typingctx, address):
    """The float64 pointer at an integer address (the swarm field's storage)."""
    ptr = types.CPointer(types.float64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(ptr))

    return ptr(types.int64), codegen


@_jit
def _field1(P, slot):
    """The point field in ``slot`` as (n,)."""
    return carray(_pointer(P[slot]), P[PN])


@_jit
def _field2(P, slot, bs):
    """The point field in ``slot`` as (n, bs)."""
    return carray(_pointer(P[slot]), (P[PN], bs))


# -- shape functions ------------------------------------------------------------------------
@_jit
def _cell(u, cmax):
    """Cell index (as a float) and local coordinate t in [0, 1] of u = x / h: floor, clipped
    to the grid as Grid.locate does (NaN goes to cell 0 and keeps t NaN)."""
    c = np.floor(u)
    if not c >= 0.0:
        c = 0.0
    if c > cmax:
        c = cmax
    return c, u - c


@_jit
def _lagrange(t, k, W, v, d):
    """1D Lagrange values (row v of W) and natural derivatives (row d) of k = 2 or 3 nodes
    at the local coordinate t in [0, 1] (xi = 2 t - 1)."""
    if k == 2:
        W[v, 0], W[v, 1] = 1.0 - t, t
        W[d, 0], W[d, 1] = -0.5, 0.5
        return
    s = t * 2.0 - 1.0
    W[v, 0] = (s - 1.0) * s / 2
    W[v, 1] = 1.0 - s * s
    W[v, 2] = (s + 1.0) * s / 2
    W[d, 0], W[d, 1], W[d, 2] = s - 0.5, s * -2.0, s + 0.5


@_jit
def _lagrange_rows(I, R, tx, ty, W):
    """Rows N, dN/dx, dN/dy of the Lagrange cells (Q4, Q9): N_a = l_i(xi) l_j(eta) for
    node a = j (p + 1) + i."""
    k = 2 if I[IEL] == Q4 else 3
    _lagrange(tx, k, W, WVX, WDX)
    _lagrange(ty, k, W, WVY, WDY)
    sx, sy = R[RSX], R[RSY]
    for j in range(k):
        for i in range(k):
            a = j * k + i
            W[WN, a] = W[WVY, j] * W[WVX, i]
            W[WX, a] = W[WVY, j] * W[WDX, i] * sx
            W[WY, a] = W[WDY, j] * W[WVX, i] * sy


@_jit
def _serendipity_rows(I, R, x, y, W):
    """Rows of the Q8 cell at natural coordinates (x, y) (shapes._serendipity)."""
    sx, sy = R[RSX], R[RSY]
    for n in range(8):
        a = I[IOI + n] - 1.0
        b = I[IOJ + n] - 1.0
        if a != 0.0 and b != 0.0:
            N = 0.25 * (1 + a * x) * (1 + b * y) * (a * x + b * y - 1)
            dx = 0.25 * a * (1 + b * y) * (2 * a * x + b * y)
            dy = 0.25 * b * (1 + a * x) * (a * x + 2 * b * y)
        elif a == 0.0:
            N = 0.5 * (1 - x * x) * (1 + b * y)
            dx = -x * (1 + b * y)
            dy = 0.5 * b * (1 - x * x)
        else:
            N = 0.5 * (1 + a * x) * (1 - y * y)
            dx = 0.5 * a * (1 - y * y)
            dy = -y * (1 + a * x)
        W[WN, n], W[WX, n], W[WY, n] = N, dx * sx, dy * sy


@_jit
def _blended_rows(I, R, x, y, W):
    """Rows of N_hat = w N + (1 - w) N_Q4 (shapes.blended) at natural (x, y), from N."""
    nen, w = I[INEN], R[RBLEND]
    sx, sy = R[RSX], R[RSY]
    for a in range(nen):
        W[WLN, a] = w * W[WN, a]
        W[WLX, a] = w * W[WX, a]
        W[WLY, a] = w * W[WY, a]
    for c in range(4):
        i, j = c % 2, c // 2
        vx = (1 - x) / 2 if i == 0 else (1 + x) / 2
        vy = (1 - y) / 2 if j == 0 else (1 + y) / 2
        dx = -0.5 if i == 0 else 0.5
        dy = -0.5 if j == 0 else 0.5
        a = I[ICORN + c]
        W[WLN, a] += (1 - w) * (vx * vy)
        W[WLX, a] += (1 - w) * (dx * vy) * sx
        W[WLY, a] += (1 - w) * (vx * dy) * sy


@_jit
def _shape(I, R, x, y, W):
    """Shape-function rows of the point at (x, y) (m) into W, and the ghosted-local number of
    its cell's node at lattice offset (0, 0) relative to I[IOFF] (add I[IOFF + a] for node
    a). Rows: N, dN/dx, dN/dy (1, 1/m), the liquid's N_hat and its derivatives when blended,
    and the HRZ weights N^2 / sum N^2 when lumping so (row sums use N itself)."""
    cx, tx = _cell(x / R[RHX], float(I[ICMX]))
    cy, ty = _cell(y / R[RHY], float(I[ICMY]))
    el = I[IEL]
    if el == Q8 or I[IBLEND]:
        sx, sy = tx * 2.0 - 1.0, ty * 2.0 - 1.0
        if el == Q8:
            _serendipity_rows(I, R, sx, sy, W)
        else:
            _lagrange_rows(I, R, tx, ty, W)
        if I[IBLEND]:
            _blended_rows(I, R, sx, sy, W)
    else:
        _lagrange_rows(I, R, tx, ty, W)
    if I[IHRZ]:
        nen = I[INEN]
        sq = 0.0
        for a in range(nen):
            sq += W[WN, a] * W[WN, a]
        for a in range(nen):
            W[WW, a] = W[WN, a] * W[WN, a] / sq
    return int(cx) * I[ISTX] + int(cy) * I[ISTY]


@_jit
def _rows(I):
    """Rows of W that hold the lumping weights w, the liquid's weights w_l and its test
    functions N_l: w = N (row sums) or the HRZ row; N_l = w_l = N_hat when blended, else
    N_l = N and w_l = w."""
    rw = WW if I[IHRZ] else WN
    if I[IBLEND]:
        return rw, WLN, WLN
    return rw, rw, WN


# -- points to grid -------------------------------------------------------------------------
@_jit
def points_to_grid(P, I, R, W, G):
    """Nodal sums G (ghosted-local nodes x I[INF] fields, overwritten) of the points: w V,
    w V v_s (2), w_l V v_l (2), the mixture force -(sigma' - p I + eta div v_s I) V grad N
    + N V rho_m g (2, N per m), the liquid force p V grad N_l + N_l V rho_l g (2), and
    w_l V (blended basis)."""
    n, nf, nen = P[PN], I[INF], I[INEN]
    G[:] = 0.0
    xr, V = _field2(P, PXREF, 2), _field1(P, PV)
    vs, vl, sig, pp = _field2(P, PVS, 2), _field2(P, PVL, 2), _field2(P, PSIG, 3), \
        _field1(P, PP)
    eta = R[RETA] > 0.0
    visc = _field1(P, PVISC)
    rw, rwl, rnl = _rows(I)
    blend = I[IBLEND]
    rlx, rly = (WLX, WLY) if blend else (WX, WY)
    gm, gl = R[RGM], R[RGL]
    for k in range(n):
        base = _shape(I, R, xr[k, 0], xr[k, 1], W)
        Vk, p = V[k], pp[k]
        t00, t11 = p - sig[k, 0], p - sig[k, 1]
        if eta:
            t00 -= visc[k]
            t11 -= visc[k]
        t00 *= Vk
        t11 *= Vk
        t01 = -(sig[k, 2] * Vk)
        pV = p * Vk
        msx, msy = vs[k, 0] * Vk, vs[k, 1] * Vk
        mlx, mly = vl[k, 0] * Vk, vl[k, 1] * Vk
        gmV, glV = Vk * gm, Vk * gl
        for a in range(nen):
            o = (base + I[IOFF + a]) * nf
            w, wl, Nl = W[rw, a], W[rwl, a], W[rnl, a]
            dx, dy = W[WX, a], W[WY, a]
            G[o] += w * Vk
            G[o + 1] += w * msx
            G[o + 2] += w * msy
            G[o + 3] += wl * mlx
            G[o + 4] += wl * mly
            G[o + 5] += dx * t00 + dy * t01
            G[o + 6] += dx * t01 + dy * t11 + W[WN, a] * gmV
            G[o + 7] += W[rlx, a] * pV
            G[o + 8] += W[rly, a] * pV + Nl * glV
            if blend:
                G[o + 9] += Nl * Vk


# -- nodal update ---------------------------------------------------------------------------
@_jit
def _sign(v):
    """np.sign: -1, 0, 1, NaN for NaN."""
    if v > 0.0:
        return 1.0
    if v < 0.0:
        return -1.0
    return v * 0.0


@_jit
def _implicit(S, Sl, fm, fl, vsn, vln, fixed_s, fixed_l, R, dt):
    """Accelerations (a_s, a_l) of one DOF with backward Euler on the drag (the twophase
    module docstring): the relative acceleration b first, then a_s = (f_m - M_l b) / (M_s +
    M_l), a_l = a_s + b; a held phase (fixed, or without mass) has a = 0 and v = 0 and the
    other phase's equation alone."""
    Ms, Ml, Mt, Q = R[RCS] * S, R[RCL] * Sl, R[RCT] * Sl, R[RCQ] * Sl
    held_s = fixed_s or S <= 0.0
    held_l = fixed_l or Sl <= 0.0
    vs = 0.0 if held_s else vsn
    vl = 0.0 if held_l else vln
    Mm = Ms + Ml
    inv_m = 1.0 / Mm if Mm > 0.0 else 0.0
    r = fl - Q * (vl - vs)                       # f_l - Q w
    den = Mt * Ms * inv_m + Q * dt
    b = (r - Mt * inv_m * fm) / den if den > 0.0 else 0.0
    a_s = (fm - Ml * b) * inv_m
    a_l = a_s + b
    if held_l:
        a_l = 0.0
    elif held_s:
        a_l = r / (Mt + Q * dt) if Sl > 0.0 else 0.0
    if held_s:
        a_s = 0.0
    elif held_l:
        a_s = fm / Ms if S > 0.0 else 0.0
    return a_s, a_l


@_jit
def nodal_update(I, R, B, G, O, dt, load_factor, damping):
    """Accelerations and velocities O (owned nodes x NG) from the sums G (owned nodes x
    I[INF]): v = sum w V v / S, the load's force, local damping of the mixture's
    unbalanced force, explicit or implicit drag (eqs. 13, 14), v^{k+1} = v^k + dt a^k
    (eq. 6); a and v are zero on fixed DOFs (multiplied by the free flags: NaN stays NaN)."""
    nf, blend, implicit = I[INF], I[IBLEND], I[IIMPL]
    cs, cl, ct, cq = R[RCS], R[RCL], R[RCT], R[RCQ]
    for k in range(I[INOWN]):
        g, o, b = k * nf, k * NG, k * NB
        S = G[g]
        invS = 1.0 / S if S > 0.0 else 0.0
        Sl, invSl = S, invS
        if blend:
            # The liquid's masses and drag from its own weights: S_l = sum N_hat V.
            Sl = G[g + 9]
            invSl = 1.0 / Sl if Sl > 0.0 else 0.0
        for d in range(2):
            vsn, vln = G[g + 1 + d] * invS, G[g + 3 + d] * invSl
            fm, fl = G[g + 5 + d], G[g + 7 + d]
            if d == 1:
                fm += load_factor * B[b]
            if damping != 0.0:
                # Local (Cundall) damping of the mixture's unbalanced force, against the
                # mixture momentum, whose sign is that of c_s v_s + c_l (S_l / S) v_l.
                vmix = cs * vsn + cl * (vln * (Sl * invS) if blend else vln)
                fm -= abs(fm) * _sign(vmix) * damping
            free_s, free_l = B[b + 1 + d], B[b + 3 + d]
            if implicit:
                a_s, a_l = _implicit(S, Sl, fm, fl, vsn, vln, free_s == 0.0, free_l == 0.0,
                                     R, dt)
            else:
                a_l = (fl - (vln - vsn) * (cq * Sl)) * (invSl * (1.0 / ct))
                a_s = (fm - a_l * (cl * Sl)) * (invS * (1.0 / cs))
            O[o + d] = a_s * free_s
            O[o + 2 + d] = a_l * free_l
            O[o + 4 + d] = (a_s * dt + vsn) * free_s
            O[o + 6 + d] = (a_l * dt + vln) * free_l


# -- grid to points -------------------------------------------------------------------------
@_jit
def grid_to_points(P, I, R, W, O, pacc, dt, flip):
    """Grid to points from O (ghosted-local nodes x NG): point velocities (FLIP, or the
    FLIP/PIC blend ``flip``), effective stress (D d eps), pore pressure (eqs. 8-9; with the
    projection its increments' nodal sums w V dp go to ``pacc`` instead), positions x +=
    dt v_s^{k+1}, the viscous stress eta div v_s, fast-part damping and the volume ratio J."""
    n, nen = P[PN], I[INEN]
    x, xr, V = _field2(P, PX, 2), _field2(P, PXREF, 2), _field1(P, PV)
    vs, vl, sig, pp = _field2(P, PVS, 2), _field2(P, PVL, 2), _field2(P, PSIG, 3), \
        _field1(P, PP)
    J, visc, vslow = _field1(P, PJ), _field1(P, PVISC), _field2(P, PVSLOW, 2)
    rw, rwl, rnl = _rows(I)
    blend, project = I[IBLEND], I[IPROJ]
    rlx, rly = (WLX, WLY) if blend else (WX, WY)
    D = R[RD:RD + 9]
    n_ = R[RN]
    cdiv = 1.0 if blend else 1.0 - n_      # div v_s + n div(v_l - v_s), or (1 - n) div v_s
    kdp = dt * R[RKL] / n_
    eta, fast, slow = R[RETA], R[RFAST], R[RSLOW]
    fs, fl = R[RCS] / (R[RCS] + R[RCL]), R[RCL] / (R[RCS] + R[RCL])
    pic = flip != 1.0
    if project:
        pacc[:] = 0.0
    for k in range(n):
        base = _shape(I, R, xr[k, 0], xr[k, 1], W)
        a0 = a1 = a2 = a3 = a4 = a5 = a6 = a7 = 0.0
        l00 = l01 = l10 = l11 = 0.0
        dvl = dvs = 0.0
        for a in range(nen):
            o = (base + I[IOFF + a]) * NG
            N, Nl = W[WN, a], W[rnl, a]
            dx, dy, dlx, dly = W[WX, a], W[WY, a], W[rlx, a], W[rly, a]
            h4, h5, h6, h7 = O[o + 4], O[o + 5], O[o + 6], O[o + 7]
            a0 += N * O[o]
            a1 += N * O[o + 1]
            a2 += Nl * O[o + 2]
            a3 += Nl * O[o + 3]
            a4 += N * h4
            a5 += N * h5
            if pic:
                a6 += Nl * h6
                a7 += Nl * h7
            l00 += h4 * dx
            l01 += h4 * dy
            l10 += h5 * dx
            l11 += h5 * dy
            dvl += h6 * dlx + h7 * dly
            if blend:
                dvs += h4 * dlx + h5 * dly
        if blend:
            # div (v_l - v_s) in the liquid's basis: the storage term is then div v_s +
            # n div(v_l - v_s), whose power the liquid force balances exactly.
            dvl -= dvs
        if pic:
            vs[k, 0] = flip * (vs[k, 0] + dt * a0) + (1 - flip) * a4
            vs[k, 1] = flip * (vs[k, 1] + dt * a1) + (1 - flip) * a5
            vl[k, 0] = flip * (vl[k, 0] + dt * a2) + (1 - flip) * a6
            vl[k, 1] = flip * (vl[k, 1] + dt * a3) + (1 - flip) * a7
        else:
            vs[k, 0] += a0 * dt
            vs[k, 1] += a1 * dt
            vl[k, 0] += a2 * dt
            vl[k, 1] += a3 * dt
        e0, e1, e2 = l00 * dt, l11 * dt, (l01 + l10) * dt
        divs = l00 + l11
        for i in range(3):
            sig[k, i] += D[3 * i] * e0 + D[3 * i + 1] * e1 + D[3 * i + 2] * e2
        dp = (divs * cdiv + dvl * n_) * kdp
        if project:
            wV = V[k]
            for a in range(nen):
                pacc[base + I[IOFF + a]] += W[rw, a] * wV * dp
        else:
            pp[k] -= dp                          # eqs. 8-9
        x[k, 0] += a4 * dt
        x[k, 1] += a5 * dt
        if eta > 0.0:
            visc[k] = divs * eta
        if fast > 0.0:
            _damp_fast(vs, vl, vslow, k, fs, fl, dt * slow, dt * fast)
        J[k] *= divs * dt + 1.0                  # volume ratio of the solid


@_jit
def _damp_fast(vs, vl, vslow, k, fs, fl, slow, fast):
    """Fast-part damping of point k: both phases lose ``fast`` (v_m - v_slow), v_m = fs v_s
    + fl v_l the mixture velocity and v_slow its low-pass (``slow`` = dt w1); the relative
    velocity (Darcy flow) is untouched."""
    for d in range(2):
        vm = vs[k, d] * fs + vl[k, d] * fl
        vslow[k, d] += slow * (vm - vslow[k, d])
        f = (vm - vslow[k, d]) * fast
        vs[k, d] -= f
        vl[k, d] -= f


@_jit
def project_nodes(G, nf, pn):
    """Lumped projection at the nodes: pn = sum w V dp / S (0 where S = sum w V <= 0), S the
    first of the nf sums per node in G."""
    for k in range(pn.shape[0]):
        S = G[k * nf]
        pn[k] *= 1.0 / S if S > 0.0 else 0.0


@_jit
def project_back(P, I, R, W, pn):
    """Pore pressures p -= sum N pn at the points' reference positions (x0, or the new x)."""
    n, nen = P[PN], I[INEN]
    xr, pp = _field2(P, PXREF, 2), _field1(P, PP)
    for k in range(n):
        base = _shape(I, R, xr[k, 0], xr[k, 1], W)
        s = 0.0
        for a in range(nen):
            s += W[WN, a] * pn[base + I[IOFF + a]]
        pp[k] -= s


@_jit
def grid_to_points_serial(P, I, R, W, G, O, pn, dt, flip):
    """One rank: grid to points, then the projection (ghosted-local = owned nodes)."""
    grid_to_points(P, I, R, W, O, pn, dt, flip)
    if I[IPROJ]:
        project_nodes(G, I[INF], pn)
        project_back(P, I, R, W, pn)


# -- migration ------------------------------------------------------------------------------
@_jit
def leaving(P, R):
    """1 if some point's cell, floor(x / h) clipped as Grid.locate does, is outside this
    rank's box lo <= x / h < hi in a partitioned direction (NaN fails the test), else 0."""
    xr = _field2(P, PXREF, 2)
    for d in range(2):
        b = RBOX + 4 * d
        if R[b] == 0.0:
            continue
        h, lo, hi = R[b + 1], R[b + 2], R[b + 3]
        for k in range(P[PN]):
            u = xr[k, d] / h
            if not (u >= lo and u < hi):
                return 1
    return 0


# -- compilation ----------------------------------------------------------------------------
KERNELS = (points_to_grid, nodal_update, grid_to_points, project_nodes, project_back,
           grid_to_points_serial, leaving)
_warm = {}


def warm_up() -> dict:
    """Compile (first run) or load from the cache every kernel for the argument types the
    step uses, once per process, on empty data (no points, no nodes). Returns the seconds
    this took and how many kernels were compiled and loaded from the cache in this process."""
    if _warm:
        return _warm
    t = time.perf_counter()
    P, I = np.zeros(NP, dtype=np.int64), np.zeros(NI, dtype=np.int64)
    R, W = np.zeros(NR), np.zeros((NROW, MAXNEN))
    G, O, pn, B = np.zeros(NF), np.zeros(NG), np.zeros(0), np.zeros(NB)
    points_to_grid(P, I, R, W, G)
    nodal_update(I, R, B, G, O, 0.0, 0.0, 0.0)
    grid_to_points(P, I, R, W, O, pn, 0.0, 1.0)
    project_nodes(G, NF, pn)
    project_back(P, I, R, W, pn)
    grid_to_points_serial(P, I, R, W, G, O, pn, 0.0, 1.0)
    leaving(P, R)
    _warm.update(seconds=time.perf_counter() - t, **compile_counts())
    return _warm


def compile_counts() -> dict:
    """Kernels compiled in this process and loaded from the disk cache, and the number of
    type signatures each kernel has (1: the step never compiled a second variant)."""
    return {"compiled": sum(sum(k.stats.cache_misses.values()) for k in KERNELS),
            "loaded": sum(sum(k.stats.cache_hits.values()) for k in KERNELS),
            "signatures": {k.__name__: len(k.signatures) for k in KERNELS}}
