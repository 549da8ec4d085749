"""Critical time steps of the explicit two-phase scheme (paper Table 1, and what it leaves out).

Table 1's four criteria use the smallest cell length L_min:
- ``cfl``        L_min / c,  c = sqrt(E_c / rho_m)                 (drained compression wave)
- ``undrained``  L_min / c1, c1 = sqrt((E_c + K_l / n) / rho_m)    (Jassim et al., 2013)
- ``diffusion``  L_min^2 / (2 c2), c2 = k / (gamma_w (1/E_c + n/K_l))
- ``oscillator`` L_min / c3, c3 = 2 pi f1 H, f1 the computed fundamental frequency
and two more that decide stability in practice:
- ``drag``       2 / lambda, lambda = (n g / k)(1 + n rho_l / ((1 - n) rho_s)): forward Euler
                 on the explicit drag, which damps the relative velocity at the rate lambda
                 (no limit with -mpm_drag implicit)
- ``discrete``   the stability limit of the linearised step itself (``discrete_limit``), with
                 either drag treatment
With -mpm_mass_scaling S every inertia is S times larger: the wave limits grow as sqrt(S),
the drag limit as S.
"""

from __future__ import annotations

import dataclasses
import math
import time

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import InputError, NotConverged, NumericalError
from ..common.linalg import reciprocal
from ..modal import frequency

from ..model import assembly, shapes
from ..model.grid import Grid
from ..model.points import place
from ..model.soil import Ground
from . import darcy

# Dense stability analysis of the whole grid up to this many unknowns, else on a patch: the
# largest of the paper's scenes (M2-Q8/Q9, M3-Q4: 1640) and no more. Its cost grows as the
# cube of the unknowns (M3-Q4 2.2 s; at 4000, the former bound, Q4 6 x 60 took 18 s, while
# 8 x 80 on its patch took 0.6 s): beyond it a refined grid's set-up stays flat.
MAX_STATE = 1700
ESTIMATE_STATE = 600   # larger grids are first analysed on a patch this small (an estimate)


def _state_size(element, cells) -> int:
    """Unknowns of the dense analysis, at most: 8 per grid node (U and y of both phases)."""
    return 8 * shapes.lattice_nodes(element, cells)


def _patch(element, cells, max_state) -> tuple:
    """The cells analysed for a grid of ``cells``: all of them when the dense state has at
    most ``max_state`` unknowns, else a patch of at most 4 x 10 cells (of the same size),
    halved along its longer side until it fits."""
    if _state_size(element, cells) <= max_state:
        return tuple(cells)
    patch = [min(cells[0], 4), min(cells[1], 10)]
    while _state_size(element, patch) > max_state and max(patch) > 1:
        k = int(patch[1] >= patch[0])
        patch[k] = max(1, patch[k] // 2)
    return tuple(patch)


def analysis_cells(element: str, cells) -> tuple:
    """The patches (each (NX, NY)) that :func:`discrete_limit` analyses: the whole grid,
    or, when it has more than ``MAX_STATE`` unknowns, a tall patch of at most 4 x 10 cells
    and a wide one of at most 10 x 4 (of the same cell size). The tall one holds the modes
    up a column; the wide one those along a side: on the laterally drained Q8 block (8 x 8
    cells, an impermeable top that settles) the 4 x 8 patch's limit is 3.9 % above the
    whole grid's, the 8 x 4 patch's the whole grid's; on a 5 x 50 Q4 column the 5 x 4
    patch's is 0.07 % below it (2 cells high: 1.6 %)."""
    if _state_size(element, cells) <= MAX_STATE:
        return (tuple(cells),)
    tall = _patch(element, cells, MAX_STATE)
    wide = _patch(element, (min(cells[0], 10), min(cells[1], 4)), MAX_STATE)
    return (tall,) if wide[0] <= tall[0] else (tall, wide)


def discrete_limit(comm, body, soil, scheme) -> tuple:
    """The stability limit (s) of the explicit step itself on ``body`` (scene.Body) of
    ``soil`` under ``scheme`` (scheme.Scheme), and the cells it was found on.

    Linearised (points fixed, no local damping), one step maps the nodal accumulated
    displacements U = (U_s, U_l) and the projected point velocities y = (y_s, y_l) as
        a = L_U U + L_y y                    (nodal accelerations, eqs. 13-14, drag included)
        U' = U + dt P y + dt^2 a             (strain and pore pressure use v = P y + dt a)
        y' = S y + dt R a                    (FLIP / PIC velocity update, projected back)
    with R = M^-1 sum_p w m_p N_p (the point round trip, not the identity),
    S = flip I + (1 - flip) R P, and P the identity but where a liquid DOF normal to an
    impermeable side takes the solid's velocity (``_tie``). With implicit drag L_U and L_y
    depend on dt (the nodal 2 x 2 solve of ``_accelerations``); with Q4's compact Darcy
    stencil the state has the pressure it adds too (``darcy``). The limit is the largest dt
    with spectral radius <= 1, found by bisection on dense eigenvalues to 1e-4 relative.
    This is what the run does: on M2-Q4 with the nodal projection it gives 7.85e-5 s (runs
    at 7.5e-5 s are stable, at 8.0e-5 s they blow up), where a grid-only symplectic Euler
    analysis (R = S = I) would give 9.23e-5 s.

    Grids with more than ``MAX_STATE`` unknowns are analysed on a patch of at most 4 x 10
    cells of the same size and element; the instability is local to the cells. Grids with
    more than ``ESTIMATE_STATE`` are first analysed on a smaller patch, whose limit (the
    same on M3-Q4, within 0.3 % on the quadratic columns) brackets the search on the grid
    itself: two or a few dense eigenvalue problems instead of about seventeen.
    """
    limit = failure = cells = None
    if comm.getRank() == 0:
        try:
            limit, cells = min(_limit_of(body, soil, scheme, one)
                               for one in analysis_cells(body.element, body.cells))
            limit *= viscous_factor(scheme.bulk_viscosity)
        except UnstableBelow as e:
            failure = str(e)
    limit, cells, failure = comm.tompi4py().bcast((limit, cells, failure), root=0)
    if failure:
        raise InputError(failure)
    return limit, cells


def _limit_of(body, soil, scheme, cells) -> tuple:
    """(the limit (s) on a patch of ``cells``, the cells) for :func:`discrete_limit`."""
    small = _patch(body.element, cells, ESTIMATE_STATE)
    # Layered ground: the whole grid with each point's material; on a patch, every layer
    # gets its patch and so does every interface (the nodes on it mix both layers'
    # masses, drag and flux porosity), and the smallest limit governs.
    if len(soil.soils) == 1 or tuple(cells) == tuple(body.cells):
        grounds = (soil,)
    else:
        grounds = tuple(soil.soils) + _interfaces(soil, body, cells)
    estimate = None if small == cells else min(
        _limit_on(body, one, scheme, small, layers=len(soil.soils)) for one in grounds)
    return min(_limit_on(body, one, scheme, cells, estimate, len(soil.soils))
               for one in grounds), tuple(cells)


class UnstableBelow(Exception):
    """The explicit step grows at a step below the limit that the bisection found."""


def _interfaces(ground, body, cells) -> tuple:
    """Two-layer grounds (soil.Ground) for patches of ``cells`` cells of the body's size, one
    for each interface of ``ground``: the layers above and below it, the interface in the
    middle of the patch at the same place within its cell as in the body."""
    h = body.size[1] / body.cells[1]
    Hp = cells[1] * h
    tops = body.size[1] - np.cumsum(ground.thickness)[:-1]      # interface heights (m)
    out = []
    for i, y in enumerate(tops):
        frac = y / h - np.floor(y / h)
        yi = min(max((cells[1] // 2 + frac) * h, 0.5 * h), Hp - 0.5 * h)
        out.append(Ground((Hp - yi, yi), ground.soils[i:i + 2]))
    return tuple(out)


def _limit_on(body, soil, scheme, cells, estimate=None, layers=None) -> float:
    """The undamped step's limit (s) on a grid of ``cells`` cells of the body's cell size
    (one rank), searched near ``estimate`` when one is given; ``layers`` the body's (None:
    ``soil``'s), whose step may differ from a patch's soil (darcy.applies)."""
    size = tuple(L * c / n for L, c, n in zip(body.size, cells, body.cells))
    with Grid(PETSc.COMM_SELF, body.element, cells, size) as grid, \
            place(grid, body.ppc, soil.point_density, "uniform") as points:
        S = scheme.mass_scaling
        guess = min(min(grid.h) / layer.wave_speeds(S)["c1"] for layer in soil.soils)
        if scheme.drag == "explicit":
            guess = min(2 / soil.drag_rate(S), guess)
        parts = _linear_parts(grid, points, body, soil, scheme, layers)
        limit = _bisect_limit(parts, scheme.flip, guess, estimate=estimate)
        if "compact" in parts and tuple(cells) != tuple(body.cells):
            limit *= COMPACT_PATCH
        if scheme.lumping == "hrz" and scheme.damping == 0:
            _check_below(parts, scheme.flip, limit)
        return limit


# A patch's limit with Q4's compact Darcy stencil, taken at this fraction: the stencil's
# largest eigenvalue grows with the grid towards 4 / h_min^2, so a patch's limit lies above
# its grid's (1 x 10 cells 1.1 % above 1 x 80; 4 x 10 and 10 x 4 0.8 % above 5 x 50).
COMPACT_PATCH = 0.98

# Halvings below the limit at which a step with HRZ lumping is checked (_check_below).
LADDER = 8


def _check_below(parts, flip, limit):
    """UnstableBelow when the step grows at limit / 2^k, k = 1..LADDER. HRZ spreads a
    point's momentum with weights other than the N that brings the velocity back, so the
    round trip R is not symmetric, the semi-discrete operator not either, and its
    stability need not be monotone in dt: Q8 cells 8 wide with an impermeable side that
    moves (the laterally drained block) grow by 7e-4 per step at 1/8 and 1/16 of the limit
    that bisection finds on its 4 x 8 patch, and at every step on the whole grid. Row sums
    and the blended basis weigh with the N they interpolate with (R symmetric in the mass
    inner product): their limit is a threshold. Checked without local damping only: the
    paper's Q8 column (HRZ, its damping 0.5) on 1 x 20 cells grows by 2.3e-6 per step at
    1/256 of its limit undamped, and the damping takes such growth out (it runs)."""
    for k in range(1, LADDER + 1):
        dt = limit / 2 ** k
        radius = _spectral_radius(parts, flip, dt)
        if radius > 1 + RADIUS_TOL:
            raise UnstableBelow(
                f"-mpm_lumping hrz: the explicit step grows by {radius - 1:.2g} per step at "
                f"dt = {dt:.3g} s, below the limit {limit:.3g} s found above it (HRZ's "
                f"transfer is not symmetric); use -mpm_lumping blended (Q8's default) or "
                f"-mpm_scheme implicit")


def viscous_factor(b1: float) -> float:
    """How much a linear bulk viscosity b1 shrinks the explicit limit (applied to the dense
    analysis, which is of the undamped step). In 1D the viscous stress b1 rho c h div(v) gives
    the highest grid mode (omega = 2 c / h) the damping ratio xi = b1, and central differences
    are stable for omega dt <= 2 (sqrt(1 + xi^2) - xi). Measured on M1-Q4 (implicit drag, no
    local damping) the step's own limit falls faster: to 0.905, 0.68 and 0.46 of the undamped
    one for b1 = 0.1, 0.25 and 0.5, where xi = b1 gives 0.905, 0.78, 0.62 and xi = 2 b1 gives
    0.82, 0.62, 0.41; xi = 2 b1 is taken, which stays on the safe side."""
    xi = 2 * b1
    return float(np.sqrt(1 + xi * xi) - xi)


def _linear_step(grid, points, body, soil, scheme, dt=0.0):
    """Dense L_U, L_y, R of the linearised step over the free DOFs (one rank), at the time
    step dt (only implicit drag depends on it; dt = 0 is the semi-discrete operator)."""
    parts = _linear_parts(grid, points, body, soil, scheme)
    return (*_accelerations(parts, dt), parts["R"])


def _linear_parts(grid, points, body, soil, scheme, layers=None):
    """What the linearised step is made of, over the free DOFs: the nodal forces on U
    (``fm``, ``fl``), the lumped masses and drag per DOF, the fixed-phase masks, R, and the
    compact Darcy stencil's operator where the body's step (of ``layers`` layers; None:
    ``soil``'s) takes it."""
    x, V = points.get("x", "volume")
    # The material of each point: its layer's in layered ground, else scalars (the same
    # arithmetic as before layers).
    mat = _point_material(soil, x[:, 1])
    n = mat["porosity"]
    it = assembly.interpolation(grid, x)
    N, dN, nodes = it.N, it.dNdx, it.nodes
    npnt, nen = N.shape
    nn = grid.gxm * grid.gym
    rows = np.repeat(np.arange(npnt), nen)

    def spread(values):
        out = np.zeros((npnt, nn))
        np.add.at(out, (rows, nodes.ravel()), values.ravel())
        return out

    Nm = spread(N)
    Dx, Dy = spread(dN[..., 0]), spread(dN[..., 1])
    Z = np.zeros_like(Dx)
    B = np.stack([np.hstack([Dx, Z]), np.hstack([Z, Dy]), np.hstack([Dy, Dx])], axis=1)
    div = B[:, 0] + B[:, 1]
    Wm, Ns, Wl, Nl, Dl = _transfer_bases(grid, x, it, Nm, div, scheme, spread)
    # Inertia scaled by S (-mpm_mass_scaling); drag and forces are not.
    S = scheme.mass_scaling
    ms, ml, mt = (1 - n) * mat["rho_s"] * S * V, n * soil.rho_l * S * V, soil.rho_l * S * V
    Ms = Wm.T @ ms
    Ml, Mt, Q = (Wl.T @ v for v in (ml, mt, mat["drag_coefficient"] * V))
    D = mat["D"]
    sig = np.einsum("ij,pjk->pik" if D.ndim == 2 else "pij,pjk->pik", D, B)
    sig = np.concatenate([sig, np.zeros_like(sig)], axis=2)            # on (U_s, U_l)
    # dp = -(K_l / n) (div u_s + n div(u_l - u_s)), the relative motion in the liquid's
    # basis: (1 - n) div u_s + n div u_l when that is N. In layers the relative motion is
    # the nodes' Darcy flux n_q (u_l - u_s), n_q = Q / sum w_l V c_q / n (kernels).
    n, flux = np.reshape(n, (-1, 1)), None
    if len(soil.soils) > 1:
        nq = Q * reciprocal(Wl.T @ (mat["drag_coefficient"] / n.ravel() * V))
        flux = nq / n                 # (K_l / n) q = K_l (n_q / n) w, per point and node
        pres = -(soil.K_l / n) * np.hstack([div - Dl * np.tile(nq, 2), Dl * np.tile(nq, 2)])
    else:
        pres = -(soil.K_l / n) * np.hstack([div - n * Dl, n * Dl])
    if scheme.pressure_projection == "nodal":
        # p = Pi p: lumped projection onto the nodes (weights w V) and back with N.
        Sw = Wm.T @ V
        pres = Nm @ ((reciprocal(Sw)[:, None] * (Wm * V[:, None]).T) @ pres)
    fl = compact = None
    if scheme.pressure_projection == "corner":
        pres, fl, corner = _corner_pressure(grid, x, body, V, n, soil.K_l, div, Nl, spread,
                                            flux)
        if darcy.applies(grid.element, "corner", scheme.liquid_basis, layers or len(soil.soils)):
            compact = darcy.operator(corner, Nl, V, n, soil, mat["drag_coefficient"],
                                     darcy.cap(grid.h), Dx, Dy)
    sig[:, 0] -= pres
    sig[:, 1] -= pres
    # sum_p V_p B_p^T sig_p as one matrix product (BLAS; einsum's loops took seconds on M3).
    npt, ncomp, ncol = B.shape
    fm = -(B * V[:, None, None]).reshape(npt * ncomp, ncol).T @ sig.reshape(npt * ncomp, -1)
    if fl is None:
        fl = Dl.T @ (V[:, None] * pres)
    Rs = reciprocal(Ms)[:, None] * ((Wm * ms[:, None]).T @ Ns)
    Rl = reciprocal(Ml)[:, None] * ((Wl * ml[:, None]).T @ Nl)
    R = np.zeros((4 * nn, 4 * nn))
    for b, Rb in enumerate((Rs, Rs, Rl, Rl)):
        R[b * nn:(b + 1) * nn, b * nn:(b + 1) * nn] = Rb
    # Grid node (i, j) is local node j * nx + i on one rank; DOFs are (x block, y block).
    # A liquid DOF normal to an impermeable side is tied to the solid's: held with it, else
    # moved by the mixture's equation with the solid's velocity (``tie``, ``kernels``).
    fixed_s = grid.constrained_mask(body.supports).reshape(-1, 2).T.ravel()
    tied = grid.constrained_mask(body.impermeable).reshape(-1, 2).T.ravel()
    free = np.flatnonzero(np.concatenate([~fixed_s, ~(tied & fixed_s)]) & np.tile(Ms > 0, 4))
    parts = {"fm": fm, "fl": fl, "mass": [np.concatenate([a, a]) for a in (Ms, Ml, Mt, Q)],
             "fixed_s": fixed_s, "tied": tied, "free": free, "R": R[np.ix_(free, free)],
             "P": _tie(free, tied), "implicit": scheme.drag == "implicit"}
    if compact is not None:
        parts["compact"] = {**compact, "A": compact["A"][:, free]}
    return parts


def _transfer_bases(grid, x, it, Nm, div, scheme, spread) -> tuple:
    """(Wm, Ns, Wl, Nl, Dl), points x nodes (Dl points x 2 nodes): the solid's transfer
    weights and interpolation (w and N, or N_hat for both with -mpm_lumping blended; its
    strain rate takes B either way), the liquid's weights, interpolation and divergence
    (w, N and div, or the blended N_hat for all three). ``it`` the points' interpolation,
    Nm and div its N and divergence spread over the nodes."""
    if "blended" in (scheme.liquid_basis, scheme.lumping):
        bl = assembly.interpolation(grid, x, blended=True)
        Nhat = spread(bl.N)
    if scheme.lumping == "blended":
        Wm = Ns = Nhat
    else:
        Wm, Ns = spread(assembly.lumping_weights(it.N, scheme.lumping)), Nm
    if scheme.liquid_basis == "blended":
        Dl = np.hstack([spread(bl.dNdx[..., 0]), spread(bl.dNdx[..., 1])])
        return Wm, Ns, Nhat, Nhat, Dl
    return Wm, Ns, Wm, Nm, div


def _corner_pressure(grid, x, body, V, n, K_l, div, Nl, spread, flux=None):
    """The corner projection's point pressures and liquid force, linear in U = (U_s, U_l)
    (kernels._to_corners): nodal P = (sum V [-(K_l/n) N4 div u_s + K_l grad N4 . w]) /
    sum N4 V, w = N_l (u_l - u_s) (in layers N_l (n_q / n) (u_l - u_s), ``flux`` the
    points' x nodes' n_q / n: the Darcy flux over the point's n), held (0) on the drained
    sides; p = N4 P at the points (npnt x 4 nn) and f_l = -sum N_l V grad(N4 P)
    (2 nn x 4 nn)."""
    ci = assembly.interpolation(grid, x, corner=True)
    L, Lx, Ly = spread(ci.N), spread(ci.dNdx[..., 0]), spread(ci.dNdx[..., 1])
    Z = np.zeros_like(Nl)
    Nw = Nl if flux is None else Nl * flux
    wx, wy = np.hstack([-Nw, Z, Nw, Z]), np.hstack([Z, -Nw, Z, Nw])
    ds = np.hstack([div, np.zeros_like(div)])
    # In layers weighted by the storage n / K_l (kernels._corner_terms).
    Vc = V[:, None] * (n / K_l if flux is not None else 1.0)
    num = L.T @ (-(K_l / n) * Vc * ds) + K_l * (Lx.T @ (Vc * wx) + Ly.T @ (Vc * wy))
    held = grid.constrained_mask({side: "x" for side in body.drained})[::2]
    P = np.where(held, 0.0, reciprocal(L.T @ Vc.ravel()))[:, None] * num
    fl = -np.vstack([Nl.T @ (V[:, None] * (Lx @ P)), Nl.T @ (V[:, None] * (Ly @ P))])
    return L @ P, fl, {"A": P, "L": L, "Lx": Lx, "Ly": Ly, "held": held}


def _point_material(soil, y) -> dict:
    """Porosity, grain density (kg/m3), drag coefficient (kg/m3/s) and D (Pa) of the points
    at heights y (m): per point in layered ground (soil.Ground), else the soil's scalars
    and its one D."""
    if len(soil.soils) == 1:
        one = soil.soils[0]
        return {"porosity": one.porosity, "rho_s": one.rho_s,
                "drag_coefficient": one.drag_coefficient, "D": one.elasticity()}
    out = {name: soil.at(name, y) for name in ("porosity", "rho_s", "drag_coefficient")}
    return {**out, "D": soil.elasticity_at(y)}


def _tie(free, tied):
    """The nodal velocity's selection over the free DOFs: v = P y + dt a, with P the
    identity but for a tied liquid DOF, whose velocity is the solid's (its row of P picks
    the solid DOF's column)."""
    m = len(free)
    P = np.eye(m)
    half = len(tied) * 2                          # solid DOFs come first, then liquid
    where = {int(d): i for i, d in enumerate(free)}
    for i, d in enumerate(free):
        if d >= half and tied[d - half]:
            P[i, i] = 0.0
            P[i, where[int(d - half)]] = 1.0
    return P


def _accelerations(parts, dt, columns=True):
    """L_U, L_y over the free DOFs at the time step dt (``columns`` False: L_U's columns
    all of the forces' columns, for forces on another state).

    Explicit drag: a_l = (f_l - Q (y_l - y_s)) / M~_l, a_s = (f_m - M_l a_l) / M_s.
    Implicit drag (``kernels.nodal_update``): per DOF, with r = f_l - Q (y_l - y_s),
        M_s a_s + M_l a_l = f_m,    (M~_l + Q dt) a_l - Q dt a_s = r,
    solved in closed form, det = M_s M~_l + Q dt (M_s + M_l); a solid held fixed leaves the
    liquid alone (a_l = r / (M~_l + Q dt)), its velocity zero: its columns of L_y drop out
    with the fixed DOFs. Either drag: a liquid DOF tied to the solid (impermeable side)
    moves with it, a_s = a_l = f_m / (M_s + M_l), no drag."""
    fm, fl = parts["fm"], parts["fl"]
    Ms2, Ml2, Mt2, Q2 = parts["mass"]
    if not parts["implicit"]:
        LU_l = reciprocal(Mt2)[:, None] * fl
        Ly_l = np.hstack([np.diag(reciprocal(Mt2) * Q2), -np.diag(reciprocal(Mt2) * Q2)])
        LU = np.vstack([reciprocal(Ms2)[:, None] * (fm - Ml2[:, None] * LU_l), LU_l])
        Ly = np.vstack([-reciprocal(Ms2)[:, None] * (Ml2[:, None] * Ly_l), Ly_l])
    else:
        fixed_s = parts["fixed_s"]
        Qdt = Q2 * dt
        inv_det = reciprocal(Ms2 * Mt2 + Qdt * (Ms2 + Ml2))
        # a_s = A_ss f_m + A_sl r, a_l = A_ls f_m + A_ll r
        A_ss, A_sl = (Mt2 + Qdt) * inv_det, -Ml2 * inv_det
        A_ls = np.where(fixed_s, 0.0, Qdt * inv_det)
        A_ll = np.where(fixed_s, reciprocal(Mt2 + Qdt), Ms2 * inv_det)
        Ly_r = np.hstack([np.diag(Q2), -np.diag(Q2)])          # r's part on (y_s, y_l)
        LU = np.vstack([A_ss[:, None] * fm + A_sl[:, None] * fl,
                        A_ls[:, None] * fm + A_ll[:, None] * fl])
        Ly = np.vstack([A_sl[:, None] * Ly_r, A_ll[:, None] * Ly_r])
    tied = np.flatnonzero(parts["tied"])
    if len(tied):
        mix = reciprocal(Ms2 + Ml2)[tied, None] * fm[tied]
        for rows in (tied, tied + len(Ms2)):
            LU[rows], Ly[rows] = mix, 0.0
    sub = np.ix_(parts["free"], parts["free"])
    return (LU[sub] if columns else LU[parts["free"]]), Ly[sub]


def _spectral_radius(parts, flip, dt):
    LU, Ly = _accelerations(parts, dt)
    R, P = parts["R"], parts["P"]
    m = LU.shape[0]
    I = np.eye(m)
    S = flip * I + (1 - flip) * R @ P
    T = np.block([[I + dt * dt * LU, dt * P + dt * dt * Ly],
                  [dt * R @ LU, S + dt * R @ Ly]])
    compact = parts.get("compact")
    if compact is not None:
        # The compact stencil's pressure state Z: forces on U and y, Z' = Z + E (A U + Z).
        LZ, _ = _accelerations({**parts, "fm": compact["fm"], "fl": compact["fl"]}, dt,
                               columns=False)
        E = darcy.step(compact, dt)
        nz = E.shape[0]
        T = np.block([[T, np.vstack([dt * dt * LZ, dt * R @ LZ])],
                      [E @ compact["A"], np.zeros((nz, m)), np.eye(nz) + E]])
    return float(np.max(np.abs(np.linalg.eigvals(T))))


# Zero-energy (hourglass) modes, e.g. of Q4 cells with one point each, give eigenvalue 1 in
# Jordan blocks, which dense eigensolvers return as 1 + O(sqrt(eps)): linear, not exponential
# growth, and no instability. Just above a true limit the spectral radius exceeds 1 by far
# more than this.
RADIUS_TOL = 1e-6


def _bisect_limit(parts, flip, guess, rtol=1e-4, estimate=None):
    """The largest stable dt (s), to ``rtol``: bisection from a wide bracket around
    ``guess``, or from a narrow one around ``estimate`` when that holds the limit."""
    def stable(dt):
        return _spectral_radius(parts, flip, dt) <= 1 + RADIUS_TOL

    lo, hi = _bracket(stable, estimate, 1 + rtol) if estimate else (None, None)
    lo = lo or guess / 64
    if hi is None:
        hi = max(lo, guess) * 4
        while stable(hi):
            lo, hi = hi, hi * 4
    # A bracket of exactly 1 + rtol is done (rounding must not cost one more eigensolve).
    while hi / lo > (1 + rtol) * (1 + 1e-12):
        mid = np.sqrt(lo * hi)
        if stable(mid):
            lo = mid
        else:
            hi = mid
    return lo


def _bracket(stable, estimate, step, tries=5):
    """(stable dt, unstable dt) around ``estimate``, the step raised to the 4th power each
    time the limit lies further; a side not found in ``tries`` steps is None (the estimate
    was poor: the wide bracket takes over)."""
    up = stable(estimate)
    near = estimate
    for _ in range(tries):
        far = near * step if up else near / step
        if stable(far) != up:
            return (near, far) if up else (far, near)
        near, step = far, step ** 4
    return (near, None) if up else (None, near)


def criteria(soil, H: float, f1: float, dt_discrete: float, h, S: float = 1.0) -> dict:
    """All critical time steps (s) of a column of ``soil`` and height H (m), keyed as in
    the summary: cell sizes h (m), f1 the physical fundamental frequency (Hz), S the mass
    scaling (f1 falls as 1/sqrt(S), the wave limits grow as sqrt(S), the drag limit as S)."""
    L = min(h)
    c3 = 2 * np.pi * f1 / np.sqrt(S) * H
    out = {}
    # In layered ground (soil.Ground) each criterion is its governing layer's.
    for layer in soil.soils:
        s = layer.wave_speeds(S)
        mine = {"cfl": L / s["c"], "undrained": L / s["c1"], "diffusion": L * L / (2 * s["c2"]),
                "drag": 2 / layer.drag_rate(S)}
        out = {k: min(v, out.get(k, v)) for k, v in mine.items()}
    return {"cfl": out["cfl"], "undrained": out["undrained"], "diffusion": out["diffusion"],
            "oscillator": L / c3, "drag": out["drag"], "discrete": dt_discrete}


def applicable(limits: dict, drag: str) -> dict:
    """The criteria that apply to the step: all of them, less the drag limit 2/lambda
    when the drag is implicit (backward Euler on the drag has none)."""
    return {k: v for k, v in limits.items() if k != "drag" or drag == "explicit"}


def stability_limits(limits: dict, drag: str) -> dict:
    """The criteria that bound the stability of the step: the undrained wave, the discrete
    limit, and the drag limit 2/lambda only when the drag is explicit."""
    return {k: v for k, v in applicable(limits, drag).items()
            if k in ("undrained", "drag", "discrete")}


def governing(limits: dict, drag: str) -> str:
    """The criterion that sets dt: the smallest, the drag limit only with explicit drag."""
    return min(applicable(limits, drag), key=limits.get)


@dataclasses.dataclass(frozen=True)
class Limits:
    """The critical time steps (s) by criterion, the one that governs dt, those dt
    exceeds, f1 (Hz) and the inertia regime
    (:func:`solver.stepping.inertia.regime`)."""

    steps: dict
    governing: str
    exceeded: tuple
    f1: float = math.nan
    regime: dict = dataclasses.field(default_factory=dict)
    warning: str = ""


def critical_steps(comm, body, soil, scheme, h, stability, f1_solver) -> tuple:
    """(the critical time steps as :class:`Limits`, f1 and the governing one set, and the
    patch of the stability analysis), in the log stage "Critical time steps"; ``h`` the
    cell sizes (m); ``stability``: run the stability analysis; ``f1_solver`` (solver,
    tolerance, sweeps) the arguments of :func:`frequency.fundamental_frequency`."""
    S = scheme.mass_scaling
    with PETSc.Log.Stage("Critical time steps"):
        signals.stage("set-up: the fundamental frequency f1")
        try:
            f1 = frequency.fundamental_frequency(comm, body, soil, *f1_solver)
        except NotConverged:
            raise                    # a solver the options chose (-f1_eps_*) that failed
        except NumericalError as exc:
            # f1 only feeds the spring-mass criterion, which does not bound stability (see
            # docs/studies.md); a singular consistent mass (1 point per Q4 cell) is no
            # reason to refuse the run, whose lumped masses are positive.
            PETSc.Sys.Print(f"Note: no fundamental frequency, hence no oscillator "
                            f"criterion: {exc}", comm=comm)
            f1 = math.nan
        if stability:
            # A dense eigenvalue analysis: on large grids the longest part of the set-up.
            patches = " and ".join(f"{c[0]} x {c[1]}"
                                   for c in analysis_cells(body.element, body.cells))
            signals.stage("set-up: the stability analysis")
            PETSc.Sys.Print(f"Stability analysis of the step on {patches} cells ...",
                            comm=comm)
            t_analysis = time.perf_counter()
            dt_discrete, patch = discrete_limit(comm, body, soil, scheme)
            PETSc.Sys.Print(f"Stability analysis took {time.perf_counter() - t_analysis:.1f}"
                            " s", comm=comm)
        else:
            dt_discrete, patch = math.nan, body.cells
        steps = criteria(soil, body.height, f1, dt_discrete, h, S)
        steps = {k: v for k, v in steps.items() if not math.isnan(v)}
    return Limits(steps, governing(steps, scheme.drag), (), f1), patch


def choose_dt(limits, given, safety) -> float:
    """The step (s): ``given``, or ``safety`` times the governing limit rounded down to 3
    significant digits: the limits come from iterative eigensolvers whose last digits vary
    with the number of ranks, and the run should not."""
    if given is not None:
        return given
    return _round_down(safety * limits.steps[limits.governing], 3)


def _round_down(x: float, digits: int) -> float:
    scale = 10.0 ** (math.floor(math.log10(x)) - digits + 1)
    return math.floor(x / scale) * scale
