"""Quasi-static plane-strain Biot consolidation by u-p finite elements: the FE reference.

An implicit solution of the body that the two-phase MPM
(solver/stepping/twophase.py) models, for scenes without a closed form
(drainage through the sides, a load on part of the top, layers). SI units, per metre out of
plane; effective stress tension positive, pore pressure p compression positive, total stress
sigma = sigma' - m p:

    div(sigma' - m p) = 0,                 sigma' = D eps(u)  (linear elastic skeleton)
    (n / K_l) dp/dt + div(du/dt) - div((k / gamma_w) grad p) = 0,   gamma_w = rho_l 9.81

on [0, W] x [0, H]: displacement components fixed per side, p = 0 on the drained sides
(the others impermeable), a downward pressure q on the top over [x0, x1] from t = 0+.

Discretisation: Taylor-Hood cells on a structured NX x NY grid, Q9/Q4 (default) or Q8/Q4
(displacement on the quadratic lattice, pressure on the corner lattice; the shape functions
and Gauss rules of solver/model/shapes.py, 3 x 3 points), one monolithic symmetric AIJ matrix

    J(c) = [[K, -Q], [-Q^T, -(S + c H)]],   K = int B^T D B, Q = int B^T m N_p,
                                             S = int (n / K_l) N_p^T N_p,
                                             H = int (k / gamma_w) grad N_p^T grad N_p,

scaled symmetrically so that both blocks are O(1), solved by KSP preonly + LU (PETSc's own;
options prefix ``biot_``, e.g. ``-biot_pc_factor_mat_solver_type mumps``), factored once
per value of c. The states:

- undrained, t = 0+: J(0) y = f with the drained sides' p left free (no water has left at
  0+; the boundary layer has no thickness yet). In a uniform 1D column the exact fields
  (u linear, p uniform) lie in the FE space, so this settlement is q H / (E_c + K_l / n) to
  round-off;
- transient: TR-BDF2 with gamma = 2 - sqrt(2), one-step, second order and L-stable (the
  step load's discontinuity at the drained sides is damped, where Crank-Nicolson
  oscillates); both stages solve with J(gamma h / 2), equilibrium imposed at every stage.
  Steps are geometrically graded: ``steps`` equal steps on [0, t_s] and on every doubling
  [t_s 2^j, t_s 2^(j+1)] up to the first time asked, then on intervals of equal ratio (at
  most 2) between successive times asked (each time asked a step's end, one factorization
  per interval), t_s = t_1 / steps^4 by default (t_1 the first time asked > 0): the first
  block's error, from the sqrt(t) start of the drainage, falls only as sqrt(t_s), and this
  t_s keeps it below the graded steps' O(steps^-2) (with t_1 / 64 it dominated: order 1);
- drained, t -> infinity: p = 0, K u = f.

Convergence of the default settings (16 x 16 Q9/Q4, 16 steps per doubling: about 340
steps, a second), measured on the block of tests/test_biot.py (W = H = 1.2 m, drained left
and right, rollers on the sides, q = 15 kPa) at T = c_v t / H^2 = 0.05, 0.2, 0.5 with the
classic c_v = k E_c / gamma_w, as max |dp| / q over a 9 x 9 lattice of points
(``scripts/biot-convergence``; Q8/Q4 alike): in space, 16 -> 32 cells per side 2.3e-3,
4.2e-4, 1.1e-4 (32 -> 64: 5.8e-4, 1.1e-4, 2.7e-5; order 2.00, so the default's own error
is about 4/3 of the first row: 3e-3 q at T = 0.05, take 32 x 32 cells below 1e-3); in time,
16 -> 32 steps per doubling 1.2e-5, 2.3e-5, 1.1e-5 (order 2). The settlement |ds| / s_inf:
6.7e-4, 5.2e-4, 7.9e-5 in space, 2.7e-6, 1.3e-5, 6.1e-6 in time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sp
from petsc4py import PETSc

from ..common.errors import InputError, NumericalError, check_converged
from ..common.linalg import direct_solver
from ..model import assembly, shapes
from ..model.grid import Grid
from ..model.soil import G_REF, constrained_modulus, elasticity

# The reference states its own sides and support choices rather than importing the command
# line's: the references sit below the options (tests/test_biot.py holds them equal).
SIDES = ("left", "right", "bottom", "top")
BC_CHOICES = ("none", "x", "y", "xy")   # the displacement components a side may fix
ELEMENTS = ("q9", "q8")
DEFAULT_BCS = {"left": "x", "right": "x", "bottom": "xy", "top": "none"}
LAYERED = ("E", "nu", "k", "porosity")
# TR-BDF2: with gamma = 2 - sqrt(2) the trapezoidal and the BDF2 stage share J(gamma h / 2).
GAMMA = 2 - math.sqrt(2)
_BDF_NEW = 1 / (GAMMA * (2 - GAMMA))               # weight of the TR stage's state
_BDF_OLD = (1 - GAMMA) ** 2 / (GAMMA * (2 - GAMMA))  # weight of the step's initial state


@dataclass(frozen=True)
class Body:
    """The rectangle [0, W] x [0, H] (``size``, m), its soil, water, supports, drainage, load.

    ``E`` (Pa), ``nu``, ``k`` (m/s, defined with g = 9.81 m/s2) and ``porosity`` are each one
    number or a tuple of one value per layer of ``layers`` (thicknesses in m from the surface
    down, summing to H); ``K_l`` (Pa) and ``rho_l`` (kg/m3) are one number. ``bcs`` maps
    sides to the fixed displacement components ('x', 'y', 'xy', 'none'; sides not named:
    DEFAULT_BCS); ``drained`` names the sides where p = 0, the others are impermeable. The
    pressure ``load`` q (Pa, downwards) acts on the top over ``loaded`` = (x0, x1) (m; None:
    the whole top) from t = 0+ on. Checked on construction (InputError, one line).
    """

    size: tuple
    E: object = 10.0e6
    nu: object = 0.0
    k: object = 2.5e-4
    porosity: object = 0.3
    K_l: float = 120.0e6
    rho_l: float = 1000.0
    load: float = 10.0e3
    loaded: object = None
    drained: tuple = ("top",)
    bcs: object = None
    layers: object = None

    def __post_init__(self):
        W, H = (float(s) for s in self.size)
        set_ = object.__setattr__
        set_(self, "size", (W, H))
        set_(self, "bcs", {**DEFAULT_BCS, **(self.bcs or {})})
        set_(self, "drained", tuple(self.drained))
        set_(self, "loaded", (0.0, W) if self.loaded is None
             else tuple(float(x) for x in self.loaded))
        _check_body(self)

    def values(self, name: str) -> np.ndarray:
        """One value of ``name`` (E, nu, k, porosity) per layer, from the surface down."""
        return np.broadcast_to(np.asarray(getattr(self, name), dtype=float),
                               (len(self.thicknesses()),)).copy()

    def thicknesses(self) -> np.ndarray:
        """Layer thicknesses (m) from the surface down: one layer H when none are given."""
        return np.array([self.size[1]] if self.layers is None else self.layers, dtype=float)

    def constrained_modulus(self) -> np.ndarray:
        """E_c (Pa) per layer."""
        return np.array([constrained_modulus(E, nu)
                         for E, nu in zip(self.values("E"), self.values("nu"))])

    def unit_weight(self) -> float:
        """gamma_w = rho_l g (N/m3) with the g that defines k."""
        return self.rho_l * G_REF


def _check_body(b: Body):
    """InputError (one line) for the first fault of the body."""
    W, H = b.size
    if not (W > 0 and H > 0):
        raise InputError(f"biot size {W:g},{H:g}: both must be > 0")
    for side in list(b.bcs) + list(b.drained):
        if side not in SIDES:
            raise InputError(f"biot: unknown side '{side}' (choose from {', '.join(SIDES)})")
    for side, comp in b.bcs.items():
        if comp not in BC_CHOICES:
            raise InputError(f"biot bcs {side}={comp}: choose from {', '.join(BC_CHOICES)}")
    if b.layers is not None:
        t = np.asarray(b.layers, dtype=float)
        if t.ndim != 1 or t.size == 0 or not (t > 0).all():
            raise InputError("biot layers: thicknesses must be positive numbers")
        if abs(t.sum() - H) > 1e-9 * H:
            raise InputError(f"biot layers: thicknesses sum to {t.sum():g} m, not the "
                             f"height H = {H:g} m")
    nlayers = 1 if b.layers is None else len(b.layers)
    for name in LAYERED:
        v = np.asarray(getattr(b, name), dtype=float)
        if v.ndim > 1 or (v.ndim == 1 and v.size != nlayers):
            raise InputError(f"biot {name}: one value or one per layer ({nlayers})")
    checks = [("E", b.values("E") > 0, "> 0"), ("k", b.values("k") > 0, "> 0"),
              ("nu", (b.values("nu") >= 0) & (b.values("nu") < 0.5), "in [0, 0.5)"),
              ("porosity", (b.values("porosity") > 0) & (b.values("porosity") < 1),
               "in (0, 1)"),
              ("K_l", np.array([b.K_l > 0]), "> 0"), ("rho_l", np.array([b.rho_l > 0]), "> 0"),
              ("load", np.array([b.load >= 0]), ">= 0")]
    for name, ok, rule in checks:
        if not ok.all():
            raise InputError(f"biot {name}: must be {rule}")
    x0, x1 = b.loaded
    if not 0 <= x0 < x1 <= W:
        raise InputError(f"biot loaded {x0:g},{x1:g}: need 0 <= x0 < x1 <= W = {W:g}")
    _check_supports(b.bcs)


def _check_supports(bcs):
    """Refuse supports that leave a rigid-body motion free (a singular stiffness)."""
    fixes = {c: [s for s, comp in bcs.items() if c in comp] for c in "xy"}
    # A rotation moves a vertical side along x and a horizontal side along y.
    turns = {"left", "right"} & set(fixes["x"]) or {"bottom", "top"} & set(fixes["y"])
    if not (fixes["x"] and fixes["y"] and turns):
        raise InputError("biot bcs: the supports leave a rigid-body motion free")


def from_options(p, loaded=None) -> Body:
    """The Body of an MPM run's options ``p`` (solver/io/options.py): size, E, nu, k, porosity,
    K_l, rho_l, load, drained and bc_left/right/bottom/top; ``loaded`` = (x0, x1) in m
    (None: the whole top). The reference models a step load without gravity."""
    if getattr(p, "load_ramp", 0.0) > 0:
        raise InputError("-mpm_load_ramp: the FE reference applies the load as a step")
    if getattr(p, "gravity", 0.0) > 0:
        raise InputError("-mpm_gravity: the FE reference has no body force")
    return Body(size=p.size, E=p.E, nu=p.nu, k=p.k, porosity=p.porosity, K_l=p.K_l,
                rho_l=p.rho_l, load=p.load, loaded=loaded, drained=tuple(s for s in p.drained if s != "none"),
                bcs={s: getattr(p, f"bc_{s}") for s in SIDES})


@dataclass(frozen=True)
class Result:
    """What :func:`solve` returns. Settlements are downwards positive (m): the mean over the
    loaded part of the top, or one column per x of ``surface``."""

    times: np.ndarray               # (nt,) s, as asked
    pressure: np.ndarray            # (nt, npoints) Pa, excess pore pressure
    settlement: np.ndarray          # (nt,) or (nt, nx) m
    undrained: object               # settlement at t = 0+ (m)
    drained: object                 # settlement at t -> infinity (m)
    undrained_pressure: np.ndarray  # (npoints,) Pa at t = 0+
    steps: int                      # time steps taken (each of two solves)
    factorizations: int             # LU factorizations, the final drained one included


class _Mesh:
    """Node numbering and geometry of the Taylor-Hood grid: displacement on the quadratic
    lattice (without cell centres for Q8), pressure on the corner lattice; DOFs
    [u_x, u_y interleaved per displacement node, then p per pressure node]."""

    def __init__(self, element, cells, size):
        self.element, self.cells, self.size = element, tuple(cells), size
        self.grid = gu = Grid(PETSc.COMM_SELF, element, cells, size)
        self.h = gu.h
        conn = gu.cell_connectivity()
        used = np.zeros(gu.nodes[0] * gu.nodes[1], dtype=bool)
        used[conn.ravel()] = True
        compact = np.cumsum(used) - 1
        self.u_conn = compact[conn]
        self.u_xy = gu.lattice_coordinates()[used]
        with Grid(PETSc.COMM_SELF, "q4", cells, size) as gp:
            self.p_conn = gp.cell_connectivity()
            self.p_xy = gp.lattice_coordinates()
        self.nu_dof = 2 * len(self.u_xy)
        self.ndof = self.nu_dof + len(self.p_xy)
        self.u_dofs = np.stack([2 * self.u_conn, 2 * self.u_conn + 1], -1).reshape(
            len(conn), -1)
        self.p_dofs = self.nu_dof + self.p_conn
        self.row = np.arange(len(conn)) // cells[0]   # cy of each cell

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.grid.destroy()

    def locate(self, xy):
        """Cells (cx, cy) and natural coordinates (xi, eta) of points xy (n, 2) in m."""
        return self.grid.locate(xy)

    def on_side(self, xy, side):
        """Mask of the nodes ``xy`` (n, 2) on a side of the rectangle."""
        W, H = self.size
        tol = 1e-9 * max(W, H)
        c, v = {"left": (0, 0.0), "right": (0, W), "bottom": (1, 0.0), "top": (1, H)}[side]
        return np.abs(xy[:, c] - v) < tol

    def fixed_u(self, bcs):
        """DOFs of the fixed displacement components."""
        out = [2 * np.flatnonzero(self.on_side(self.u_xy, s)) + "xy".index(c)
               for s, comp in bcs.items() for c in comp.replace("none", "")]
        return np.unique(np.concatenate(out + [np.zeros(0, dtype=np.int64)]))

    def drained_p(self, drained):
        """DOFs of the pressures fixed to 0 on the drained sides."""
        mask = np.zeros(len(self.p_xy), dtype=bool)
        for s in drained:
            mask |= self.on_side(self.p_xy, s)
        return self.nu_dof + np.flatnonzero(mask)

    def cell_rows(self, body):
        """The layer of each cell row (NY,), bottom row first; InputError when an interface
        lies inside a cell."""
        hy, ny = self.h[1], self.cells[1]
        depth = np.cumsum(body.thicknesses())[:-1] / hy
        if np.any(np.abs(depth - np.round(depth)) > 1e-9 * ny):
            at = ", ".join(f"{v:g}" for v in depth * hy)
            raise InputError(f"biot layers: an interface lies inside a cell ({ny} cells "
                             f"of {hy:g} m up; interfaces at depths {at} m)")
        top_down = np.searchsorted(np.round(depth), np.arange(ny), side="right")
        return top_down[::-1]


def _reference(element, h):
    """Element matrices of a cell h = (hx, hy) for unit materials, 3 x 3 Gauss points:
    K_lambda, K_G (K = lambda K_lambda + G K_G), Q, S and H (without n/K_l, k/gamma_w)."""
    g, w = shapes.gauss_1d(3)
    xi, eta = (a.ravel() for a in np.meshgrid(g, g, indexing="xy"))
    wt = np.outer(w, w).ravel() * h[0] * h[1] / 4
    scale = np.array([2.0 / h[0], 2.0 / h[1]])
    _, dN = shapes.evaluate(element, xi, eta)
    N4, dN4 = shapes.evaluate("q4", xi, eta)
    B = assembly.strain_matrix(dN * scale)
    div = B[:, 0] + B[:, 1]
    grad4 = dN4 * scale
    return {"K_lambda": np.einsum("g,gi,gj->ij", wt, div, div),
            "K_G": np.einsum("g,gki,k,gkj->ij", wt, B, np.array([2.0, 2.0, 1.0]), B),
            "Q": np.einsum("g,gi,ga->ia", wt, div, N4),
            "S": np.einsum("g,ga,gb->ab", wt, N4, N4),
            "H": np.einsum("g,gad,gbd->ab", wt, grad4, grad4)}


def _coo(n, rows, cols, blocks):
    """A scipy CSR (n, n) from per-cell blocks (nc, a, b) at rows (nc, a), cols (nc, b)."""
    r = np.broadcast_to(rows[:, :, None], blocks.shape).ravel()
    c = np.broadcast_to(cols[:, None, :], blocks.shape).ravel()
    return sp.coo_matrix((blocks.ravel(), (r, c)), shape=(n, n)).tocsr()


def _operators(mesh, body):
    """The unscaled operators as scipy CSR: J(0), the storage M (p rows: Q^T u + S p) and
    the flow H (p rows: H p), all (ndof, ndof)."""
    ref = _reference(mesh.element, mesh.h)
    layer = mesh.cell_rows(body)[mesh.row]
    D = [elasticity(E, nu) for E, nu in zip(body.values("E"), body.values("nu"))]
    lam = np.array([d[0, 1] for d in D])[layer]
    G = np.array([d[2, 2] for d in D])[layer]
    storage = (body.values("porosity") / body.K_l)[layer]
    mobility = (body.values("k") / body.unit_weight())[layer]
    nc, n, u, p = len(layer), mesh.ndof, mesh.u_dofs, mesh.p_dofs
    K = lam[:, None, None] * ref["K_lambda"] + G[:, None, None] * ref["K_G"]
    Q = np.broadcast_to(ref["Q"], (nc,) + ref["Q"].shape)
    S = storage[:, None, None] * ref["S"]
    QT = Q.transpose(0, 2, 1)
    M = _coo(n, p, u, QT) + _coo(n, p, p, S)
    J0 = _coo(n, u, u, K) - _coo(n, u, p, Q) - M
    return J0, M, _coo(n, p, p, mobility[:, None, None] * ref["H"])


def _petsc(comm, A) -> PETSc.Mat:
    """A PETSc AIJ Mat from a scipy CSR matrix (serial)."""
    A = A.tocsr()
    A.sort_indices()
    return PETSc.Mat().createAIJ(size=A.shape, comm=comm, csr=(
        A.indptr.astype(PETSc.IntType), A.indices.astype(PETSc.IntType), A.data))


class _Solver:
    """LU solves of J(c) y = r with the DOFs ``fixed`` held at 0, in the scaled variables
    y = d y_hat (both blocks O(1)); one factorization kept, redone when c or the fixed set
    changes."""

    def __init__(self, comm, J0, H, d):
        self.comm, self.d = comm, d
        D = sp.diags(d)
        self.J0 = _petsc(comm, D @ J0 @ D)
        self.H = _petsc(comm, D @ H @ D)
        self.key, self.ksp, self.J, self.factorizations = None, None, None, 0
        self.x, self.b = self.J0.createVecs()

    def _factor(self, c, fixed):
        self._release()
        J = self.J0.duplicate(copy=True)
        if c:
            J.axpy(-c, self.H, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        J.zeroRowsColumns(fixed.astype(PETSc.IntType), diag=1.0)
        # J is quasi-definite (K and S + c H positive definite), so LU without pivoting is
        # stable in any ordering: PETSc's own, faster than MUMPS on 16 x 16 cells.
        ksp = direct_solver(self.comm, J, "biot_", "petsc")
        try:
            ksp.setUp()
        except PETSc.Error as exc:
            raise NumericalError(f"biot: LU factorization failed ({exc})") from None
        self.J, self.ksp = J, ksp
        self.factorizations += 1

    def solve(self, c, fixed, rhs) -> np.ndarray:
        """y (ndof,) with J(c) y = rhs on the free rows and y = 0 at ``fixed``."""
        key = (c, fixed.tobytes())
        if key != self.key:
            self._factor(c, fixed)
            self.key = key
        b = self.d * rhs
        b[fixed] = 0.0
        self.b.array = b
        self.ksp.solve(self.b, self.x)
        check_converged(self.ksp, "biot: the step's solve (options -biot_ksp_*, -biot_pc_*)")
        return self.d * self.x.array

    def _release(self):
        for obj in (self.ksp, self.J):
            if obj is not None:
                obj.destroy()
        self.ksp = self.J = None

    def destroy(self):
        """Free the factorization, the matrices and the work vectors."""
        self._release()
        for obj in (self.J0, self.H, self.x, self.b):
            obj.destroy()


def schedule(times, steps: int, start: float) -> np.ndarray:
    """Ends (s) of the time steps: ``steps`` equal steps on [0, t_s] and on each interval of
    a geometric grading through the ``times`` asked (each one an end): the doublings
    [t_s 2^j, t_s 2^(j+1)] up to the first time t_1 = t_s 2^L (L the least with t_s <=
    ``start``), then between successive times asked intervals of equal ratio, at most 2."""
    asked = np.unique(np.asarray(times, dtype=float))
    asked = asked[asked > 0]
    if asked.size == 0:
        return asked
    levels = max(0, math.ceil(math.log2(asked[0] / start) - 1e-12))
    edges = [asked[0] * 2.0 ** -np.arange(levels, -1, -1)]
    for a, b in zip(asked[:-1], asked[1:]):
        m = max(1, math.ceil(math.log2(b / a) - 1e-12))
        edges.append(np.r_[a * (b / a) ** (np.arange(1, m) / m), b])
    edges = np.concatenate(edges)
    ends = [np.linspace(0, edges[0], steps + 1)[1:]]
    ends += [np.linspace(a, b, steps + 1)[1:] for a, b in zip(edges[:-1], edges[1:])]
    return np.concatenate(ends)


def _interpolation(mesh, xy, field):
    """The sparse operator (n, ndof) giving p (``field`` 'p') or u_y ('uy') at points xy
    (n, 2) in m; InputError for a point outside the body."""
    W, H = mesh.size
    tol = 1e-9 * max(W, H)
    outside = (xy < -tol).any(axis=1) | (xy > [W + tol, H + tol]).any(axis=1)
    if outside.any():
        raise InputError("biot points: a point lies outside the body [0, W] x [0, H]")
    cx, cy, xi, eta = mesh.locate(xy)
    cell = cy * mesh.cells[0] + cx
    element, dofs = ("q4", mesh.p_dofs) if field == "p" else (mesh.element, mesh.u_dofs[:, 1::2])
    N, _ = shapes.evaluate(element, xi, eta)
    rows = np.broadcast_to(np.arange(len(xy))[:, None], N.shape)
    return sp.csr_matrix((N.ravel(), (rows.ravel(), dofs[cell].ravel())),
                         shape=(len(xy), mesh.ndof))


def _top_weights(mesh, x0, x1) -> np.ndarray:
    """e (ndof,): e . u = the integral of u_y over the top from x0 to x1 (m2), exact for the
    cells' polynomials (3 Gauss points on each cell's part of [x0, x1])."""
    nx, ny = mesh.cells
    hx = mesh.h[0]
    left = np.arange(nx) * hx
    a, b = np.maximum(x0, left), np.minimum(x1, left + hx)
    g, w = shapes.gauss_1d(3)
    span = np.maximum(b - a, 0.0)[:, None]
    x = a[:, None] + span * (g + 1) / 2
    N, _ = shapes.evaluate(mesh.element, (2 * (x - left[:, None]) / hx - 1).ravel(),
                          np.ones(x.size))
    contrib = np.einsum("cg,cga->ca", span * w / 2, N.reshape(nx, len(g), -1))
    dofs = mesh.u_dofs[(ny - 1) * nx:, 1::2]
    return np.bincount(dofs.ravel(), weights=contrib.ravel(), minlength=mesh.ndof)


def _march(solver, ops, y, ends, fixed, record):
    """TR-BDF2 from state y at t = 0+ through the step ends (s); ``record(t, y)`` at each.
    ``ops`` = (F, M, H): load vector, storage and flow operators."""
    F, M, H = ops
    t, h_used = 0.0, None
    for t_new in ends:
        h = t_new - t
        # Steps of one block differ in their last bits: keep them on one factorization.
        if h_used is None or abs(h - h_used) > 1e-9 * h:
            h_used = h
        c = GAMMA * h_used / 2
        y_tr = solver.solve(c, fixed, F - M @ y + c * (H @ y))
        y = solver.solve(c, fixed, F - M @ (_BDF_NEW * y_tr - _BDF_OLD * y))
        t = t_new
        record(t, y)


def _check_run(comm, times, points, cells, element, steps):
    if comm.getSize() != 1:
        raise InputError("biot: runs on one rank (give it PETSc.COMM_SELF)")
    if element not in ELEMENTS:
        raise InputError(f"biot element {element}: choose from {', '.join(ELEMENTS)}")
    if len(cells) != 2 or any(int(c) != c or c < 1 for c in cells):
        raise InputError(f"biot cells {cells}: two integers >= 1")
    if int(steps) != steps or steps < 1:
        raise InputError(f"biot steps {steps}: an integer >= 1")
    if times.ndim != 1 or not (np.isfinite(times) & (times >= 0)).all():
        raise InputError("biot times: finite numbers >= 0 (s)")
    if points.ndim != 2 or points.shape[1] != 2:
        raise InputError("biot points: an array of (x, y) pairs (m)")


def _discretise(mesh, body, points, surface):
    """The operators (scipy CSR) J(0), M, H, the load vector F (N), the pressure probe at
    ``points`` and the settlement operator (mean over the loaded part, or at ``surface``)."""
    J0, M, H = _operators(mesh, body)
    x0, x1 = body.loaded
    e = _top_weights(mesh, x0, x1)
    if surface is None:
        settle = sp.csr_matrix(-e / (x1 - x0))
    else:
        xs = np.asarray(surface, dtype=float).ravel()
        settle = -_interpolation(mesh, np.stack([xs, np.full_like(xs, body.size[1])], -1),
                                 "uy")
    return J0, M, H, -body.load * e, _interpolation(mesh, points, "p"), settle


def _scaling(mesh, body) -> np.ndarray:
    """d (ndof,): y = d y_hat makes K, Q and the storage block's Schur complement O(1)
    (the displacement rows by 1/sqrt(E_c), the pressure unknowns by sqrt(E_c) / h)."""
    E_c = body.constrained_modulus().max()
    d = np.full(mesh.ndof, 1 / math.sqrt(E_c))
    d[mesh.nu_dof:] = math.sqrt(E_c) / min(mesh.h)
    return d


def solve(comm, body: Body, times, points, surface=None, cells=(16, 16), element="q9",
          steps=16, start=None) -> Result:
    """Pore pressure (Pa) at ``points`` (n, 2; m) and the settlement (m, downwards) at
    ``times`` (s; 0 means t = 0+) of ``body``, on a grid of ``cells`` = (NX, NY) Taylor-Hood
    cells (``element`` q9: Q9/Q4, q8: Q8/Q4). The settlement is the mean over the loaded part
    of the top, or with ``surface`` (x values, m) the top's at each x. ``steps``: time steps
    per doubling of time; ``start`` (s): the end of the first block of steps (default: the
    first time > 0 asked, / steps^4). Serial on ``comm`` (one rank). See the module docstring."""
    times = np.asarray(times, dtype=float)
    points = np.asarray(points, dtype=float).reshape(-1, 2)
    _check_run(comm, times, points, cells, element, steps)
    asked = np.unique(times)
    first = asked[asked > 0]
    ends = schedule(asked, steps, start or (first[0] / steps**4 if first.size else 1.0))
    with _Mesh(element, tuple(int(c) for c in cells), body.size) as mesh:
        J0, M, H, F, probe, settle = _discretise(mesh, body, points, surface)
        out_p = np.empty((asked.size, len(points)))
        out_s = np.empty((asked.size, settle.shape[0]))

        def record(t, y):
            i = np.searchsorted(asked, t)
            if i < asked.size and asked[i] == t:
                out_p[i], out_s[i] = probe @ y, settle @ y

        solver = _Solver(comm, J0, H, _scaling(mesh, body))
        fixed_u = mesh.fixed_u(body.bcs)
        try:
            y0 = solver.solve(0.0, fixed_u, F)
            record(0.0, y0)
            fixed = np.union1d(fixed_u, mesh.drained_p(body.drained))
            _march(solver, (F, M, H), y0, ends, fixed, record)
            every_p = np.arange(mesh.nu_dof, mesh.ndof)
            y_inf = solver.solve(0.0, np.union1d(fixed_u, every_p), F)
        finally:
            solver.destroy()
    pick = np.searchsorted(asked, times)
    one = surface is None
    s_0, s_inf = settle @ y0, settle @ y_inf
    return Result(times=times, pressure=out_p[pick],
                  settlement=out_s[pick, 0] if one else out_s[pick],
                  undrained=float(s_0[0]) if one else s_0,
                  drained=float(s_inf[0]) if one else s_inf,
                  undrained_pressure=probe @ y0, steps=len(ends),
                  factorizations=solver.factorizations)
