"""Compiled kernels of the explicit two-phase step (numba, nopython, cached on disk).

:mod:`solver.stepping.twophase` keeps the state and the PETSc objects; these
functions do the work, each in one pass over the points or nodes: points to grid, the nodal
update, grid to points (with the pressure projection) and the migration test. The formulas
are those of the twophase module docstring and docs/method.md;
``tests/test_step_reference.py`` holds a plain NumPy reference they must match.

Arguments, all kept between steps (no per-step temporaries):
- ``off`` (tuple of ints): ghosted-local offsets of the cell's nodes (node a of the cell
  whose node (0, 0) is ``base`` is ``base + off[a]``). Its length (4, 8, 9) is part of
  the kernels' type, so each cell type gets its own machine code, with the shape
  functions computed into a small array on the kernel's stack: about twice as fast as one
  generic code (measured);
- ``C`` (int64), the context: the scheme's integers (slots I*), the number of local
  points and the addresses of the swarm's point fields (slots P*, 0 for a field the
  scheme does not use), and the addresses and lengths of the float64 arrays (slots A*):
  the reals R (slots R*, SI units) and the nodal arrays. Numba unboxes every array
  argument on every call (about 0.15 us each, measured): one array instead of twenty
  keeps a step of the 40-point M1 scene at a few microseconds. The arrays are viewed in
  place (``_points``, ``_array``); their owners (twophase.TwoPhase, the swarm, PETSc) keep
  them alive and in place while the addresses are in use.
- the nodal arrays are node-major, ``node * nfields + field``, as a DMDA Vec with ``dof =
  nfields`` stores them: the sums (NF or NF + 1 fields), the accelerations and
  velocities (NG = 8 fields: a_s, a_l, v_s, v_l, x and y each; NGL = 10 in layered
  material, with the Darcy flux; 2 more, the nodes' quasi-static Darcy flux, with the
  compact stencil: :func:`result_fields`), the projected pressure increments (1 field; 2
  with the corner projection: sum N_Q4 V dp and its own lumped mass sum N_Q4 V) and the
  static data
  (NB = 10 per owned node: the load's nodal force, then 1 or 0 for the free or fixed DOFs
  of v_s (x, y) and v_l (x, y), a v_l DOF with 0 being normal to an impermeable side and
  tied to v_s, see :func:`nodal_update`; then 1, or 0 on a drained side, where the corner
  projection holds the pressure; then the hydrostatic force of the water outside the
  drained sides on the mixture and on the liquid, x and y each).

Compilation: ``cache=True`` stores the machine code under
``solver/stepping/__pycache__`` (or ``NUMBA_CACHE_DIR``), so only the first
run on a machine compiles; :func:`warm_up` compiles or loads the kernels of a cell type at
model set-up, inside the ``MPMCompile`` log event, so that the step's own events never
include it. ``error_model='numpy'``: a division by zero gives inf or NaN as NumPy does (the
run's blow-up check reports it) instead of raising. ``fastmath={'contract'}`` only lets a
b + c become one fused multiply-add (one rounding instead of two); nothing is reordered or
assumed finite.
"""

from __future__ import annotations

import time

import numpy as np
from numba import carray, njit, types
from numba.core import cgutils
from numba.extending import intrinsic, overload

from ..model import shapes

_jit = njit(cache=True, **shapes.KERNEL_OPTIONS)

NF = 9        # nodal sums: S, V v_s (2), V v_l (2), f_m (2), f_l (2); + S_l when blended
NG = 8        # nodal results sent back to the points: a_s (2), a_l (2), v_s (2), v_l (2)
NGL = NG + 2  # ... and in layered material the Darcy flux q = n_q (v_l - v_s) (2)
NLS = 4       # nodal sums layered material adds (the last fields): masses, drag, drag / n
NB = 10       # static data per owned node: the load's force, free flags of v_s and v_l (0: tied),
              # free flag of the corner projection's pressure (0: drained), the hydrostatic
              # water force of drained sides on the mixture (2) and the liquid (2)

# C: point count and point-field addresses ...
(PN, PX, PXREF, PV, PVS, PVL, PSIG, PP, PJ, PVISC, PVSLOW, PLAYER, PGRADP) = range(13)
# ... float64 arrays, each an (address, length) pair: the reals; the static node data; the
# nodal sums of the ghosted-local and of the owned nodes; the results (accelerations and
# velocities) of the owned and of the ghosted-local nodes; the projected pressure
# increments of the ghosted-local and of the owned nodes (one rank: local = owned) ...
AR, AB, AGL, AGO, AOO, AOL, APL, APO = range(13, 29, 2)
# ... and the scheme's integers.
(INF,       # nodal sums per node (NF, or NF + 1 with the blended liquid basis)
 IBLEND,    # 1: the liquid in the blended basis N_hat
 ISOLIDB,   # 1: the solid's transfer (weights and interpolation) in the blended basis N_hat
 IPROJ,     # pore-pressure increments: 0 per point, 1 projected through the nodes (PNODAL),
            # 2 through the corner nodes' bilinear field (PCORNER)
 IIMPL,     # 1: implicit drag
 ICMX, ICMY,    # largest cell index per direction (cells - 1)
 ISTX, ISTY,    # ghosted-local node offset of one cell step in x and in y
 INOWN,         # owned nodes (the nodal update's range)
 ILAYERS,       # layers of the per-point material table (0: one material, the R* slots)
 IWATER,        # 1: drained sides under gravity carry the water's hydrostatic force
 ICOMPACT,      # 1: the corner projection's Darcy flux takes the compact stencil (Q4)
 ) = range(29, 42)
NC = 42
PNODAL, PCORNER = 1, 2   # C[IPROJ] of the nodal and the corner projection

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
RBASE = RBOX + 8          # the base's acceleration (m/s2, x and y) in the frame of a
#                           rigid base (dynamic analysis): every mass feels -M a_b
RCAP = RBASE + 2          # the compact stencil's cap on dt (K_l / n)(k / gamma_w) (m2)
NR = RCAP + 1
# Layered material: after the NR reals, one row of NL per layer, indexed by the point's
# ``layer`` field. Masses and drag then enter the nodes as NLS more nodal sums (the last
# fields: sum w V c_s, sum w_l V c_l, sum w_l V c_q, sum w_l V c_q / n), since their ratio
# to S varies from node to node; the liquid's M~_l = rho_l S_l keeps its one coefficient
# (one fluid). The last sum gives the node's flux porosity n_q = sum w_l V c_q / sum w_l V
# c_q / n: Darcy's law lumped at the node, sum w_l V (c_q / n) q = f_l = Q w, makes the
# Darcy flux q = n_q w (n_q = n inside a layer), and the storage equation takes the
# divergence of q, which is continuous across a porosity jump where n w is not.
(LCS, LCL, LCQ,   # M_s, M_l per unit volume (kg/m3), Q per unit volume (kg/m3/s)
 LGM,             # the mixture's weight per volume, y (N/m3, with the sign of g_y)
 LN,              # porosity
 LCK,             # Q per unit volume over the porosity (kg/m3/s)
 ) = range(6)
LD = 6            # the layer's D (Pa), 3 x 3 row-major
NL = LD + 9


@_jit
def result_fields(layered, compact):
    """Nodal results per node: NG, 2 more (the Darcy flux) in ``layered`` material, 2 more
    (the quasi-static Darcy flux) with the ``compact`` stencil; those are the last two."""
    return NG + 2 * int(layered) + 2 * int(compact)


# -- point fields ---------------------------------------------------------------------------
@intrinsic
def _pointer(typingctx, address):
    """The float64 pointer at an integer address."""
    ptr = types.CPointer(types.float64)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(ptr))

    return ptr(types.int64), codegen


@intrinsic
def _on_stack(typingctx, tup):
    """Pointer to a copy of a tuple of numbers (or of such tuples, all of one type) in the
    calling kernel's stack frame: the loops over a cell's nodes index it like an array.
    (Indexing the tuple itself with the loop variable compiles to a jump table per access,
    as the compiler does not unroll these loops; a stack copy cannot alias the nodal arrays,
    unlike a scratch array, so its values stay in registers.)"""
    base = tup
    while isinstance(base, types.BaseTuple):
        base = base.dtype
    ptr = types.CPointer(base)

    def codegen(context, builder, signature, args):
        slot = cgutils.alloca_once(builder, args[0].type)
        builder.store(args[0], slot)
        return builder.bitcast(slot, context.get_value_type(ptr))

    return ptr(tup), codegen


@intrinsic
def _put(typingctx, S, tup):
    """Store a tuple of float tuples at the start of the C-contiguous array S (one store)."""
    def codegen(context, builder, signature, args):
        arr = context.make_array(signature.args[0])(context, builder, args[0])
        builder.store(args[1], builder.bitcast(arr.data, args[1].type.as_pointer()))
        return context.get_dummy_value()

    return types.none(S, tup), codegen


@_jit
def _points(C, slot, bs):
    """The point field in ``slot`` of C as (n, bs)."""
    return carray(_pointer(C[slot]), (C[PN], bs))


@_jit
def _points1(C, slot):
    """The scalar point field in ``slot`` of C as (n,)."""
    return carray(_pointer(C[slot]), C[PN])


@_jit
def _array(C, slot):
    """The float64 array whose address and length are in ``slot`` of C."""
    return carray(_pointer(C[slot]), C[slot + 1])


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
def _locate(C, R, x, y):
    """The point at (x, y) (m): the ghosted-local number of its cell's node (0, 0) and its
    local coordinates (tx, ty) in [0, 1] (natural coordinates 2 t - 1)."""
    cx, tx = _cell(x / R[RHX], float(C[ICMX]))
    cy, ty = _cell(y / R[RHY], float(C[ICMY]))
    return int(cx) * C[ISTX] + int(cy) * C[ISTY], tx, ty


def _rows(off, x, y, sx, sy):
    """N, sx dN/dxi, sy dN/deta at natural (x, y) of the cell type that len(off) names (4:
    Q4, 8: Q8, 9: Q9): the functions of solver.model.shapes."""


@overload(_rows)
def _rows_typed(off, x, y, sx, sy):
    # Chosen when the caller is compiled: the cell type is part of off's type.
    return {4: lambda off, x, y, sx, sy: shapes.q4(x, y, sx, sy),
            8: lambda off, x, y, sx, sy: shapes.q8(x, y, sx, sy),
            9: lambda off, x, y, sx, sy: shapes.q9(x, y, sx, sy)}[len(off)]


# The corner nodes in each cell type's numbering (shapes.corners), in the Q4 order.
_CORNERS4, _CORNERS8, _CORNERS9 = (tuple(int(a) for a in shapes.corners(e))
                                   for e in ("q4", "q8", "q9"))


# Rows of a point's shape functions (the array S, on the kernel's stack): N, dN/dx, dN/dy
# (1, 1/m); the HRZ lumping weights; the blended basis N_hat, dN_hat/dx, dN_hat/dy.
SN, SX, SY, SW, SNL, SLX, SLY = range(7)
NS = 7
NFMAX = NGL + 2   # columns of the stack rows: the nodal sums or results, whichever more
_ZROWS = ((0.0,) * NFMAX,) * NS      # zeros, to allocate NS x NFMAX on a kernel's stack


@_jit
def _scratch_rows(off):
    """A tuple of NS rows of the cell type's length (to allocate S on the stack)."""
    r = _rows(off, 0.0, 0.0, 1.0, 1.0)
    return r + r + (r[0],)


@_jit
def _row_numbers(hrz, blend):
    """Rows of S that hold the lumping weights w, the liquid's N_l, dN_l/dx, dN_l/dy and its
    weights w_l: N's rows, unless HRZ (w) or the blended basis (N_l, its derivatives and
    w_l = N_hat) replace them. ``hrz``, ``blend``: None (off) or True (on), whose types
    make the rows constants of the compiled variant."""
    rw = SN if hrz is None else SW
    if blend is None:
        return rw, SN, SX, SY, rw
    return rw, SNL, SLX, SLY, SNL


@_jit
def _shape(off, C, R, x, y, S):
    """Shape functions N, dN/dx, dN/dy (1, 1/m) of the point at (x, y) (m) into rows SN,
    SX, SY of S; the ghosted-local number of its cell's node (0, 0) and the natural
    coordinates. (The kernels add the HRZ and blended rows themselves: with them inside,
    this function grows past what the compiler inlines, and a call per point costs a third
    of the pass.)"""
    base, tx, ty = _locate(C, R, x, y)
    xi, eta = tx * 2.0 - 1.0, ty * 2.0 - 1.0
    _put(S, _rows(off, xi, eta, R[RSX], R[RSY]))
    return base, xi, eta


@_jit
def _hrz_weights(off, S):
    """HRZ lumping weights N^2 / sum N^2 (assembly.lumping_weights) into row SW."""
    sq = 0.0
    for a in range(len(off)):
        sq += S[SN, a] * S[SN, a]
    inv = 1.0 / sq
    for a in range(len(off)):
        S[SW, a] = S[SN, a] * S[SN, a] * inv


@_jit
def _blended(off, R, xi, eta, S):
    """The blended basis N_hat = w N + (1 - w) N_Q4 (shapes.blended; N_Q4 on the corner
    nodes) and its derivatives into rows SNL, SLX, SLY, at natural coordinates (xi, eta)."""
    nen, w = len(off), R[RBLEND]
    for a in range(nen):
        S[SNL, a], S[SLX, a], S[SLY, a] = w * S[SN, a], w * S[SX, a], w * S[SY, a]
    n4, dx4, dy4 = shapes.q4(xi, eta, 1.0, 1.0)
    u = 1 - w
    ux, uy = u * R[RSX], u * R[RSY]     # (1 - w) d(xi)/dx, (1 - w) d(eta)/dy
    c = _CORNERS4 if nen == 4 else (_CORNERS8 if nen == 8 else _CORNERS9)
    for k in range(4):
        S[SNL, c[k]] += u * n4[k]
        S[SLX, c[k]] += ux * dx4[k]
        S[SLY, c[k]] += uy * dy4[k]


# -- points to grid -------------------------------------------------------------------------
@_jit
def points_to_grid(off, C, hrz, blend, layered):
    """Nodal sums (ghosted-local nodes x C[INF] fields, overwritten) of the points: w V,
    w V v_s (2), w_l V v_l (2), the mixture force -(sigma' - p I + eta div v_s I) V grad N
    + N V rho_m g (2, N per m), the liquid force p V grad N_l + N_l V rho_l g (2; corner
    projection: N_l V (rho_l g - grad p)), w_l V (blended basis), and with layers w V c_s,
    w_l V c_l, w_l V c_q, w_l V c_q / n (the layer's; the momenta then w m_s v_s,
    w_l m_l v_l)."""
    n, nf = C[PN], C[INF]
    R, G = _array(C, AR), _array(C, AGL)
    layer, im = _points1(C, PLAYER), nf - NLS
    mcs = mcl = mcq = mck = 0.0
    G[:] = 0.0
    Gn = G.reshape((G.shape[0] // nf, nf))      # by node (one index check per node)
    xr, V = _points(C, PXREF, 2), _points1(C, PV)
    vs, vl, sig, pp = _points(C, PVS, 2), _points(C, PVL, 2), _points(C, PSIG, 3), \
        _points1(C, PP)
    eta, visc, gp = R[RETA] > 0.0, _points1(C, PVISC), _points(C, PGRADP, 2)
    gm, gl = R[RGM], R[RGL]
    nen = len(off)
    offs = carray(_on_stack(off), nen)
    S = carray(_on_stack(_scratch_rows(off)), (NS, nen))
    # Row sums with the element's basis: the point's coefficients per row of S and nodal
    # field, node a's field f gaining sum_r S[r, a] K[r, f]; zero except where every point
    # writes them.
    K = carray(_on_stack(_ZROWS), (NS, NFMAX))
    rw, rnl, rlx, rly, rwl = _row_numbers(hrz, blend)
    rw = rnl if C[ISOLIDB] else rw               # w = N_hat (-mpm_lumping blended)
    r7 = rnl if C[IPROJ] == PCORNER else rlx     # the liquid force's x row (N_l: grad form)
    for k in range(n):
        base, xn, yn = _shape(off, C, R, xr[k, 0], xr[k, 1], S)
        if hrz is not None:
            _hrz_weights(off, S)
        if blend is not None:
            _blended(off, R, xn, yn, S)
        Vk, p = V[k], pp[k]
        t00, t11 = p - sig[k, 0], p - sig[k, 1]
        if eta:
            t00, t11 = t00 - visc[k], t11 - visc[k]
        t00, t11 = t00 * Vk, t11 * Vk
        t01 = -(sig[k, 2] * Vk)
        msx, msy, mlx, mly = vs[k, 0] * Vk, vs[k, 1] * Vk, vl[k, 0] * Vk, vl[k, 1] * Vk
        pV, gmV, glV = p * Vk, Vk * gm, Vk * gl
        pV, lx, glV = (0.0, -gp[k, 0] * Vk, glV - gp[k, 1] * Vk) if r7 == rnl else (pV, 0.0, glV)
        if layered is not None:
            r = NR + NL * int(layer[k])
            gmV = Vk * R[r + LGM]
            mcs, mcl, mcq = Vk * R[r + LCS], Vk * R[r + LCL], Vk * R[r + LCQ]
            mck = Vk * R[r + LCK]
            # Momenta weighted by the point's masses: the nodal velocity is sum w m v / M.
            msx, msy = msx * R[r + LCS], msy * R[r + LCS]
            mlx, mly = mlx * R[r + LCL], mly * R[r + LCL]
        elif hrz is None and blend is None:
            # w = w_l = N_l = N: three rows of coefficients, a few vector operations.
            K[SN, 0], K[SN, 1], K[SN, 2], K[SN, 3], K[SN, 4] = Vk, msx, msy, mlx, mly
            K[SX, 5], K[SY, 5] = t00, t01
            K[SX, 6], K[SY, 6], K[SN, 6] = t01, t11, gmV
            K[SX, 7], K[SY, 8], K[SN, 7], K[SN, 8] = pV, pV, lx, glV
            for a in range(nen):
                g = Gn[base + offs[a]]
                sN, sX, sY = S[SN, a], S[SX, a], S[SY, a]
                for f in range(NF):
                    g[f] += sN * K[SN, f] + sX * K[SX, f] + sY * K[SY, f]
            continue
        for a in range(nen):
            g = Gn[base + offs[a]]
            w, wl, Nl, dx, dy = S[rw, a], S[rwl, a], S[rnl, a], S[SX, a], S[SY, a]
            g[0] += w * Vk
            g[1] += w * msx
            g[2] += w * msy
            g[3] += wl * mlx
            g[4] += wl * mly
            g[5] += dx * t00 + dy * t01
            g[6] += dx * t01 + dy * t11 + S[SN, a] * gmV
            g[7] += S[r7, a] * (pV + lx)
            g[8] += S[rly, a] * pV + Nl * glV
            if blend is not None:
                g[9] += Nl * Vk
            if layered is not None:
                g[im], g[im + 1] = g[im] + w * mcs, g[im + 1] + wl * mcl
                g[im + 2], g[im + 3] = g[im + 2] + wl * mcq, g[im + 3] + wl * mck


# -- nodal update ---------------------------------------------------------------------------
@_jit
def _sign(v):
    """np.sign without branches (velocity signs are random: a mispredicted branch costs
    more than the node's arithmetic); 0 for NaN, where the velocities are NaN anyway."""
    return (1.0 if v > 0.0 else 0.0) - (1.0 if v < 0.0 else 0.0)


@_jit
def _implicit_masses(Ms, Ml, Mt, Q, dt):
    """The implicit drag's coefficients of a node, the same for both directions, from its
    masses M_s, M_l, M~_l (kg per m) and drag Q (kg/s per m): M_s, M_l, M~_l, Q,
    1 / (M_s + M_l) and 1 / (M~_l M_s / (M_s + M_l) + Q dt) (0 where a mass or the
    denominator is not positive: that phase is then held), so that the directions need no
    division of their own."""
    Mm = Ms + Ml
    if not Mm > 0.0:
        return Ms, Ml, Mt, Q, 0.0, 0.0
    # (M~_l M_s / (M_s + M_l) + Q dt) (M_s + M_l): the two divisions are independent.
    den = Mt * Ms + Q * dt * Mm
    return Ms, Ml, Mt, Q, 1.0 / Mm, Mm / den if den > 0.0 else 0.0


@_jit
def _implicit(coef, fm, fl, vsn, vln, held_s, held_l, dt):
    """Accelerations (a_s, a_l) of one DOF with backward Euler on the drag (the twophase
    module docstring): the relative acceleration b first, then a_s = (f_m - M_l b) / (M_s +
    M_l), a_l = a_s + b; a held phase (fixed, or without mass) has a = 0 and v = 0 and the
    other phase's equation alone. ``coef``: _implicit_masses'."""
    Ms, Ml, Mt, Q, inv_m, inv_den = coef
    vs = 0.0 if held_s else vsn
    vl = 0.0 if held_l else vln
    r = fl - Q * (vl - vs)                       # f_l - Q w
    if held_s:
        a_l = 0.0 if held_l or not Mt > 0.0 else r / (Mt + Q * dt)
        return 0.0, a_l
    if held_l:
        return (fm / Ms if Ms > 0.0 else 0.0), 0.0
    b = (r - Mt * inv_m * fm) * inv_den
    a_s = (fm - Ml * b) * inv_m
    return a_s, a_s + b


@_jit
def nodal_update(C, dt, load_factor, damping):
    """Accelerations and velocities O (owned nodes x :func:`result_fields`) from the sums G
    (owned nodes x C[INF]): v = sum w V v / S, the load's force, the water outside drained
    sides (C[IWATER]), local damping of the mixture's unbalanced force, explicit or implicit
    drag (eqs. 13, 14), v^{k+1} = v^k + dt a^k (eq. 6); a and v zero on fixed DOFs (times
    the free flags: NaN stays NaN); in layers the Darcy flux, with the compact stencil the
    nodes' quasi-static Darcy flux f_l / (sum N V gamma_w / k) (m/s, before the water). A
    liquid DOF whose flag is 0 is normal to an impermeable side: tied to the solid's (the
    same a and v, zero relative flux), fixed where the solid's is. In layers the masses and
    drag are the node's own sums and the momenta mass-weighted (points_to_grid)."""
    nf, blend, implicit, layered = C[INF], C[IBLEND], C[IIMPL], C[ILAYERS] > 0
    water, compact, nq = C[IWATER], C[ICOMPACT], 0.0
    R, B, G, O = _array(C, AR), _array(C, AB), _array(C, AGO), _array(C, AOO)
    cs, cl, ct, cq = R[RCS], R[RCL], R[RCT], R[RCQ]
    im, ngf = nf - NLS, result_fields(layered, compact)
    for k in range(C[INOWN]):
        g, o, b = k * nf, k * ngf, k * NB
        S = G[g]
        invS = 1.0 / S if S > 0.0 else 0.0
        Sl, invSl = S, invS
        if blend:
            # The liquid's masses and drag from its own weights: S_l = sum N_hat V.
            Sl = G[g + 9]
            invSl = 1.0 / Sl if Sl > 0.0 else 0.0
        # The masses M_s, M_l and drag Q, the inverses of M_s and M~_l, and what divides
        # the momenta: S and S_l, or the masses themselves in layered material.
        if layered:
            Ms, Ml, Q, Mt = G[g + im], G[g + im + 1], G[g + im + 2], ct * Sl
            invMs = 1.0 / Ms if Ms > 0.0 else 0.0
            invMt = 1.0 / Mt if Mt > 0.0 else 0.0
            div_s, div_l = invMs, 1.0 / Ml if Ml > 0.0 else 0.0
            Qn = G[g + im + 3]
            nq = Q / Qn if Qn > 0.0 else 0.0
        else:
            Ms, Ml, Q, Mt = cs * S, cl * Sl, cq * Sl, ct * Sl
            invMs, invMt = invS * (1.0 / cs), invSl * (1.0 / ct)
            div_s, div_l = invS, invSl
        if implicit:
            coef = _implicit_masses(Ms, Ml, Mt, Q, dt)
        for d in range(2):
            vsn, vln = G[g + 1 + d] * div_s, G[g + 3 + d] * div_l
            fm, fl = G[g + 5 + d], G[g + 7 + d]
            if compact:                 # one soil: k / gamma_w = n / Q per volume
                O[o + ngf - 2 + d] = fl * invSl * R[RN] / cq
            if d == 1:
                fm += load_factor * B[b]
            if water:
                # The water outside a drained side at its hydrostatic pressure.
                fm += B[b + 6 + d]
                fl += B[b + 8 + d]
            # In a moving rigid base's frame both phases feel -a_b (the drag sees no change).
            fm -= (Ms + Ml) * R[RBASE + d]
            fl -= Mt * R[RBASE + d]
            if damping != 0.0:
                # Local (Cundall) damping of the mixture's unbalanced force, against the
                # mixture momentum, whose sign is that of M_s v_s + M_l v_l (per unit S:
                # c_s v_s + c_l (S_l / S) v_l).
                vmix = (Ms * vsn + Ml * vln if layered else
                        cs * vsn + cl * (vln * (Sl * invS) if blend else vln))
                fm -= abs(fm) * _sign(vmix) * damping
            free_s, free_l = B[b + 1 + d], B[b + 3 + d]
            if free_l == 0.0:
                # Normal to an impermeable side: no flow relative to the skeleton, w . n = 0.
                # The liquid moves with the solid, both by the mixture's equation; the
                # liquid's equation only gives the side's reaction. Held with the solid.
                Mm = Ms + Ml
                a_s = fm / Mm if Mm > 0.0 else 0.0
                a_l, vln, free_l = a_s, vsn, free_s
            elif implicit:
                a_s, a_l = _implicit(coef, fm, fl, vsn, vln, free_s == 0.0 or S <= 0.0,
                                     Sl <= 0.0, dt)
            else:
                a_l = (fl - (vln - vsn) * Q) * invMt
                a_s = (fm - a_l * Ml) * invMs
            O[o + d] = a_s * free_s
            O[o + 2 + d] = a_l * free_l
            O[o + 4 + d] = (a_s * dt + vsn) * free_s
            O[o + 6 + d] = (a_l * dt + vln) * free_l
            if layered:
                O[o + 8 + d] = nq * (O[o + 6 + d] - O[o + 4 + d])


# -- grid to points -------------------------------------------------------------------------
@_jit
def grid_to_points(off, C, hrz, blend, layered, dt, flip):
    """Grid to points from O (ghosted-local nodes x NG, or NGL): velocities (FLIP, or
    FLIP/PIC blend ``flip``), stress (D d eps), pore pressure (eqs. 8-9; in layered
    material from the Darcy flux, dp = -(K_l / n) (div v_s + div q) dt; projected: nodal
    sums into ``pacc``, :func:`_to_nodes`), x += dt v_s^{k+1}, viscous stress eta div v_s,
    fast damping, J; the compact Darcy stencil (C[ICOMPACT], :func:`_compact`)."""
    n, project, compact = C[PN], C[IPROJ], C[ICOMPACT]
    R, O, pacc = _array(C, AR), _array(C, AOL), _array(C, APL)
    x, xr, V, vs, vl, sig, pp, J, visc, vslow, layer = _g2p_fields(C)
    gp, blended = _points(C, PGRADP, 2), blend is not None
    D, n_, cdiv, kdp, eta, fast, slow, fs, fl = _g2p_constants(R, blended, dt)
    ngf = result_fields(layered is not None, compact)
    On, nacc = O.reshape((O.shape[0] // ngf, ngf)), ngf if compact else NG   # by node
    pacc[:] = 0.0                               # (empty without the projection)
    nen = len(off)
    offs = carray(_on_stack(off), nen)
    S = carray(_on_stack(_scratch_rows(off)), (NS, nen))
    rw, rnl, rlx, rly, rwl = _row_numbers(hrz, blend)
    # The solid's velocities from N, or N_hat (-mpm_lumping blended); grad N either way.
    rs, rw = (rnl, rnl) if C[ISOLIDB] else (SN, rw)
    A = carray(_on_stack(_ZROWS), (NS, NFMAX))  # sum_a S[r, a] O[a, f], rows as S's
    nr = 3 if blend is None else NS
    for k in range(n):
        if layered is not None:
            D, n_, cdiv, kdp, fs, fl = _layer_constants(R, int(layer[k]), blended, dt)
        base, xn, yn = _shape(off, C, R, xr[k, 0], xr[k, 1], S)
        if hrz is not None and project:
            _hrz_weights(off, S)                  # the projection's weights only
        if blend is not None:
            _blended(off, R, xn, yn, S)
        A[:nr, :ngf] = 0.0
        for a in range(nen):
            h = On[base + offs[a]]
            sN, sX, sY = S[SN, a], S[SX, a], S[SY, a]
            # All fields interpolated; the gradients only of the velocities (fields 4-7).
            for f in range(nacc):
                A[SN, f] += sN * h[f]
            for f in range(4, NG):
                A[SX, f] += sX * h[f]
                A[SY, f] += sY * h[f]
            if blended:
                sNl, sLx, sLy = S[SNL, a], S[SLX, a], S[SLY, a]
                for f in range(NG):
                    A[SNL, f] += sNl * h[f]
                for f in range(4, NG):
                    A[SLX, f] += sLx * h[f]
                    A[SLY, f] += sLy * h[f]
            if layered is not None:               # the Darcy flux, in the liquid's basis
                A[rnl, 8], A[rnl, 9] = A[rnl, 8] + S[rnl, a] * h[8], A[rnl, 9] + S[rnl, a] * h[9]
                A[rlx, 8], A[rly, 9] = A[rlx, 8] + S[rlx, a] * h[8], A[rly, 9] + S[rly, a] * h[9]
        a4, a5 = A[rs, 4], A[rs, 5]                                    # v_s^{k+1}
        l00, l01, l10, l11 = A[SX, 4], A[SY, 4], A[SX, 5], A[SY, 5]    # grad v_s [i, j]
        dvl = A[rlx, 6] + A[rly, 7]                                    # div v_l
        if blended:
            # div(v_l - v_s) in the liquid's basis: storage div v_s + n div(v_l - v_s), whose
            # power the liquid force balances exactly.
            dvl -= A[SLX, 4] + A[SLY, 5]
        _advance(vs, vl, k, A, rs, rnl, flip, dt)
        e0, e1, e2 = l00 * dt, l11 * dt, (l01 + l10) * dt
        divs = l00 + l11
        for i in range(3):
            sig[k, i] += D[3 * i] * e0 + D[3 * i + 1] * e1 + D[3 * i + 2] * e2
        # In layers the flux's divergence, continuous across a porosity jump.
        dp = ((divs + A[rlx, 8] + A[rly, 9]) if layered is not None else
              (divs * cdiv + dvl * n_)) * kdp
        if project == PCORNER:
            terms = _corner_terms(A, rnl, layered, V[k], dt, kdp, n_)
            if compact:
                terms = _compact(terms, A, gp, k, R, kdp, n_)
            _to_corners(off, offs, pacc, base, xn, yn, R, divs * kdp, terms)
        elif project:
            _to_nodes(off, offs, pacc, base, S[rw], V[k], dp)
        else:
            pp[k] -= dp                          # eqs. 8-9
        x[k, 0], x[k, 1] = x[k, 0] + a4 * dt, x[k, 1] + a5 * dt
        if eta > 0.0:
            visc[k] = divs * eta
        if fast > 0.0:
            _damp_fast(vs, vl, vslow, k, fs, fl, dt * slow, dt * fast)
        J[k] *= divs * dt + 1.0                  # volume ratio of the solid


@_jit
def _advance(vs, vl, k, A, rs, rnl, flip, dt):
    """Point k's velocities (m/s) from the interpolated nodal results A (the solid's in its
    transfer basis, row rs, and the liquid's in its basis, row rnl: a_s, a_l, v_s^{k+1},
    v_l^{k+1}): FLIP, or the FLIP/PIC blend ``flip``."""
    a0, a1, a4, a5 = A[rs, 0], A[rs, 1], A[rs, 4], A[rs, 5]
    a2, a3, a6, a7 = A[rnl, 2], A[rnl, 3], A[rnl, 6], A[rnl, 7]
    if flip != 1.0:
        vs[k, 0] = flip * (vs[k, 0] + dt * a0) + (1 - flip) * a4
        vs[k, 1] = flip * (vs[k, 1] + dt * a1) + (1 - flip) * a5
        vl[k, 0] = flip * (vl[k, 0] + dt * a2) + (1 - flip) * a6
        vl[k, 1] = flip * (vl[k, 1] + dt * a3) + (1 - flip) * a7
    else:
        vs[k, 0] += a0 * dt
        vs[k, 1] += a1 * dt
        vl[k, 0] += a2 * dt
        vl[k, 1] += a3 * dt


@_jit
def _g2p_fields(C):
    """The point fields grid_to_points writes or reads, as views into the points' arrays."""
    return (_points(C, PX, 2), _points(C, PXREF, 2), _points1(C, PV), _points(C, PVS, 2),
            _points(C, PVL, 2), _points(C, PSIG, 3), _points1(C, PP), _points1(C, PJ),
            _points1(C, PVISC), _points(C, PVSLOW, 2), _points1(C, PLAYER))


@_jit
def _g2p_constants(R, blended, dt):
    """D (Pa), n, the divergence weight, dt K_l / n (Pa), eta (Pa s), the damping rates (1/s)
    and the phases' mass fractions for grid_to_points."""
    D, n_, cdiv, kdp, fs, fl = _material(R, RD, R[RN], R[RCS], R[RCL], blended, dt)
    return D, n_, cdiv, kdp, R[RETA], R[RFAST], R[RSLOW], fs, fl


@_jit
def _layer_constants(R, layer, blended, dt):
    """_g2p_constants' material part for a point of ``layer``: D (Pa), n, the divergence
    weight, dt K_l / n (Pa) and the phases' mass fractions."""
    r = NR + NL * layer
    return _material(R, r + LD, R[r + LN], R[r + LCS], R[r + LCL], blended, dt)


@_jit
def _material(R, d, n_, cs, cl, blended, dt):
    """The material constants of grid_to_points from D at R[d:d + 9] (Pa), the porosity
    n_ and the masses per unit S cs, cl: D, n, the divergence weight, dt K_l / n (Pa) and
    the phases' mass fractions."""
    cdiv = 1.0 if blended else 1.0 - n_    # div v_s + n div(v_l - v_s), or (1 - n) div v_s
    return R[d:d + 9], n_, cdiv, dt * R[RKL] / n_, cs / (cs + cl), cl / (cs + cl)


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
def _corners(off):
    """The cell type's corner nodes (local numbers, Q4 order), a tuple."""
    nen = len(off)
    return _CORNERS4 if nen == 4 else (_CORNERS8 if nen == 8 else _CORNERS9)


@_jit
def _to_nodes(off, offs, pacc, base, w, V, dp):
    """The nodal projection's sums of one point of volume V (m3) and increment dp (Pa) with
    lumping weights ``w``: w V dp."""
    for a in range(len(off)):
        pacc[base + offs[a]] += w[a] * V * dp


@_jit
def _corner_terms(A, rnl, layered, V, dt, kdp, n_):
    """(V (m3), fx, fy (Pa m)) of :func:`_to_corners` for a point of volume V: the relative
    flux times dt K_l / n in the liquid's basis (rows rnl of A), dt K_l (v_l - v_s); in
    layers the Darcy flux dt (K_l / n) q with V weighted by the storage n / K_l (1/Pa), so
    that the jump of n at an interface is no source (the weak form of (n / K_l) dp/dt =
    -div v_s - div q)."""
    if layered is not None:
        return V * (dt / kdp), A[rnl, 8] * kdp, A[rnl, 9] * kdp
    f = n_ * kdp
    return V, (A[rnl, 6] - A[rnl, 4]) * f, (A[rnl, 7] - A[rnl, 5]) * f


@_jit
def _compact(terms, A, gp, k, R, kdp, n_):
    """:func:`_corner_terms` of point k with the compact stencil's flux: f + c dq, dq (m/s)
    the point's quasi-static Darcy flux -(k / gamma_w)(grad p - rho_l g) (grad p ``gp``)
    less the nodes' interpolated (A[SN, NG:NG + 2]; one soil: k / gamma_w = n / Q), c =
    dt K_l / n = ``kdp`` (Pa s) times min(1, cap / (dt (K_l / n)(k / gamma_w))).

    Why: the liquid's nodal velocity sees grad p lumped at the nodes, and its divergence
    back at the points makes the Darcy flow's Laplacian of Q4's corner pressures the wide
    stencil G^T M^-1 G (every second node), which drains the block next to a drained side
    too slowly (4 % of q on 8 x 8 cells at T_dr 0.2). The difference takes it to the compact
    stencil, the integral of grad N . (k / gamma_w) grad p; it vanishes for a linear p. It
    is a diffusion of its own on the corner pressures, explicit, stable alone while dt
    (K_l / n)(k / gamma_w) lambda <= 2, lambda <= 4 / h_min^2 its largest eigenvalue: the
    cap h_min^2 / 4 keeps it within half that, so that it never sets the time step (K_l /
    n makes it far stiffer than consolidation), at the price of a weaker correction where
    dt is large; the stability analysis carries it (darcy.operator; docs/method.md, "The
    compact Darcy stencil")."""
    kg = n_ / R[RCQ]
    dqx = -kg * gp[k, 0] - A[SN, NG]
    dqy = -kg * (gp[k, 1] - R[RGL]) - A[SN, NG + 1]
    c = kdp * min(1.0, R[RCAP] / (kdp * kg))
    V, fx, fy = terms
    return V, fx + c * dqx, fy + c * dqy


@_jit
def _to_corners(off, offs, pacc, base, xn, yn, R, ds, terms):
    """The corner projection's sums of one point at natural (xn, yn): into the two fields
    of its cell's corners, V (N_Q4 ds - grad N_Q4 . f) and N_Q4 V, with ds = dt (K_l / n)
    div v_s (Pa) and ``terms`` = (V, fx, fy) (:func:`_corner_terms`): V (m3) and
    f = dt K_l (v_l - v_s) (Pa m) in the liquid's basis: its divergence in weak form.

    Why the weak form: the points integrate the cell's products of functions only to
    first degree (3 x 3 sub-cell centres), and the strong form's N_Q4 div(N_l) is of
    second: it made the pressure diffuse 1.6 % too fast on the quadratic columns at
    every resolution. With grad N_Q4 . N_l and the liquid force in gradient form
    (points_to_grid) the Darcy flux sums N_l V as the drag does, and the diffusion is
    exact cell by cell for a quadratic pressure (docs/method.md)."""
    V, fx, fy = terms
    n4, dx4, dy4 = shapes.q4(xn, yn, R[RSX], R[RSY])
    N = carray(_on_stack((n4, dx4, dy4)), (3, 4))
    c = carray(_on_stack(_corners(off)), 4)
    for k in range(4):
        i = 2 * (base + offs[c[k]])
        pacc[i] += V * (N[0, k] * ds - (N[1, k] * fx + N[2, k] * fy))
        pacc[i + 1] += N[0, k] * V


@_jit
def project_nodes(C):
    """Lumped projection at the owned nodes: pn = sum w V dp / S (0 where S = sum w V <=
    0), S the first of the sums per node; corner projection: pn = sum N_Q4 V dp / sum N_Q4
    V, the pair of fields per node (0 off the corners, and on a drained side: the pressure
    held there, as a Taylor-Hood element holds its pressure DOFs)."""
    G, pn, nf = _array(C, AGO), _array(C, APO), C[INF]
    if C[IPROJ] == PCORNER:
        B = _array(C, AB)
        for k in range(pn.shape[0] // 2):
            S = pn[2 * k + 1]
            pn[2 * k] *= (1.0 / S if S > 0.0 else 0.0) * B[k * NB + 5]
        return
    for k in range(pn.shape[0]):
        S = G[k * nf]
        pn[k] *= 1.0 / S if S > 0.0 else 0.0


@_jit
def project_back(off, C):
    """Pore pressures p -= sum N pn (ghosted-local nodes) at the points' reference positions
    (x0, or the new x); the corner projection's: :func:`_back_from_corners`."""
    if C[IPROJ] == PCORNER:
        _back_from_corners(off, C)
        return
    R, pn = _array(C, AR), _array(C, APL)
    xr, pp = _points(C, PXREF, 2), _points1(C, PP)
    nen = len(off)
    offs = carray(_on_stack(off), nen)
    for k in range(C[PN]):
        base, tx, ty = _locate(C, R, xr[k, 0], xr[k, 1])
        N = carray(_on_stack(_rows(off, tx * 2.0 - 1.0, ty * 2.0 - 1.0, 1.0, 1.0)[0]), nen)
        s = 0.0
        for a in range(nen):
            s += N[a] * pn[base + offs[a]]
        pp[k] -= s


@_jit
def _back_from_corners(off, C):
    """The corner projection back to the points: p -= sum N_Q4 pn and grad p -= sum grad
    N_Q4 pn (Pa/m) over the corners of each point's cell, at its reference position."""
    R, pn = _array(C, AR), _array(C, APL)
    xr, pp, gp = _points(C, PXREF, 2), _points1(C, PP), _points(C, PGRADP, 2)
    offs = carray(_on_stack(off), len(off))
    c = carray(_on_stack(_corners(off)), 4)
    for k in range(C[PN]):
        base, tx, ty = _locate(C, R, xr[k, 0], xr[k, 1])
        N = carray(_on_stack(shapes.q4(tx * 2.0 - 1.0, ty * 2.0 - 1.0, R[RSX], R[RSY])),
                   (3, 4))
        s = gx = gy = 0.0
        for a in range(4):
            pa = pn[2 * (base + offs[c[a]])]
            s += N[0, a] * pa
            gx += N[1, a] * pa
            gy += N[2, a] * pa
        pp[k] -= s
        gp[k, 0] -= gx
        gp[k, 1] -= gy

@_jit
def grid_to_points_serial(off, C, hrz, blend, layered, dt, flip):
    """One rank: grid to points, then the projection (ghosted-local = owned nodes)."""
    grid_to_points(off, C, hrz, blend, layered, dt, flip)
    if C[IPROJ]:
        project_nodes(C)
        project_back(off, C)


# -- migration ------------------------------------------------------------------------------
@_jit
def leaving(C):
    """1 if some point's cell, floor(x / h) clipped as Grid.locate does, is outside this
    rank's box lo <= x / h < hi in a partitioned direction (NaN fails the test), else 0."""
    R, xr = _array(C, AR), _points(C, PXREF, 2)
    for d in range(2):
        b = RBOX + 4 * d
        if R[b] == 0.0:
            continue
        h, lo, hi = R[b + 1], R[b + 2], R[b + 3]
        for k in range(C[PN]):
            u = xr[k, d] / h
            if not (u >= lo and u < hi):
                return 1
    return 0


# -- checks -----------------------------------------------------------------------------------
@_jit
def problems(C, pmax, width, height, tol):
    """The first local point (index; -1: none) with, in this order: a non-finite pore
    pressure or velocity; |p| > pmax (Pa); J <= 0 (inverted); a position outside [-tol,
    width + tol] x [-tol, height + tol] (m). NaN fails only the first test, as in NumPy."""
    pp, vs, vl = _points1(C, PP), _points(C, PVS, 2), _points(C, PVL, 2)
    J, x = _points1(C, PJ), _points(C, PX, 2)
    f0 = f1 = f2 = f3 = -1
    for k in range(C[PN]):
        if f0 < 0 and not (np.isfinite(pp[k]) and np.isfinite(vs[k, 0])
                           and np.isfinite(vs[k, 1]) and np.isfinite(vl[k, 0])
                           and np.isfinite(vl[k, 1])):
            f0 = k
        if f1 < 0 and abs(pp[k]) > pmax:
            f1 = k
        if f2 < 0 and J[k] <= 0.0:
            f2 = k
        if f3 < 0 and (x[k, 0] < -tol or x[k, 0] > width + tol or x[k, 1] < -tol
                       or x[k, 1] > height + tol):
            f3 = k
    return f0, f1, f2, f3


# -- compilation ----------------------------------------------------------------------------
KERNELS = (points_to_grid, nodal_update, grid_to_points, project_nodes, project_back,
           grid_to_points_serial, leaving, problems)
_warm = {}


def warm_up(nen: int, hrz, blend, layered=None) -> dict:
    """Compile (first run) or load from the cache every kernel for the argument types the
    step of a cell with ``nen`` nodes, lumping and liquid basis ``hrz`` and ``blend`` and
    material ``layered`` (each None or True) uses, once per process and variant, on empty
    data (no points, no
    nodes). Returns the seconds this took and how many kernel variants were compiled and
    loaded from the disk cache in this process so far."""
    key = (nen, hrz, blend, layered)
    if key in _warm:
        return _warm[key]
    t = time.perf_counter()
    off = (0,) * nen
    C = context({AR: np.zeros(NR), AB: np.zeros(NB), AGL: np.zeros(NF), AGO: np.zeros(NF),
                 AOL: np.zeros(NG if layered is None else NGL), AOO: np.zeros(NGL)})
    points_to_grid(off, C, hrz, blend, layered)
    nodal_update(C, 0.0, 0.0, 0.0)
    grid_to_points(off, C, hrz, blend, layered, 0.0, 1.0)
    project_nodes(C)
    project_back(off, C)
    grid_to_points_serial(off, C, hrz, blend, layered, 0.0, 1.0)
    leaving(C)
    problems(C, 0.0, 0.0, 0.0, 0.0)
    _warm[key] = dict(seconds=time.perf_counter() - t, **compile_counts())
    return _warm[key]


def context(arrays: dict, C=None):
    """The context C (a new one, or ``C`` updated) with the addresses and lengths of the
    float64 arrays ``arrays`` ({slot: array}, contiguous; empty arrays where none given in
    a new one); I* and P* slots are the caller's. The arrays must stay alive and in place
    while C is in use."""
    if C is None:
        C = np.zeros(NC, dtype=np.int64)
        C[INF] = NF
        arrays = {**{slot: _EMPTY for slot in range(AR, APO + 1, 2)}, **arrays}
    for slot, a in arrays.items():
        assert a.dtype == np.float64 and a.flags.c_contiguous
        C[slot], C[slot + 1] = a.ctypes.data, a.size
    return C


_EMPTY = np.zeros(0)


def compile_counts() -> dict:
    """Kernel variants compiled in this process and loaded from the disk cache, and the
    type signatures of each kernel (one per cell type used: the step never compiled a
    variant of its own)."""
    return {"compiled": sum(sum(k.stats.cache_misses.values()) for k in KERNELS),
            "loaded": sum(sum(k.stats.cache_hits.values()) for k in KERNELS),
            "signatures": {k.__name__: len(k.signatures) for k in KERNELS}}
