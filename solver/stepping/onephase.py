"""A soil body shaken at its base: explicit one-phase dynamics on the material points, the
step of ``-mpm_analysis dynamic -mpm_phases 1``.

One phase (the solid with the mixture's density, a dry or total-stress analysis), linear
elastic, small strain: the points stay where they are, so the step is the eigen model's own
K (``scene.build``: the same points, the same integration) and its mass lumped by diagonal
scaling (HRZ, positive for every cell), with Rayleigh damping C = a0 M + a1 K and a sudden
surface load f:

    m (v' - v) / dt = f - K u - a0 m (v - v_base) - a1 K (v' + v) / 2 [- m a_b(t)] [+ dashpot],
    u' = u + dt v'      (central differences, v at half steps)

Damping acts on the deformation only: K and the mass part both vanish for a rigid-body
translation, the mass part taken on the velocity relative to the base row's mass-weighted
mean v_base (along the shaking; 0 on a rigid base, whose frame is the base's). On a compliant
base the frame is absolute: on v itself the mass part would drag the column against it at
long periods (the transfer function rho_r V_r / (rho_r V_r + a0 M) below 1, M the column's
mass per area).

The stiffness-proportional damping is Crank-Nicolson (one LU of m + dt a1 K / 2, made once):
taken explicitly it damps the grid's fastest mode at xi = a1 w_max / 2 and its stability
limit cuts the step many-fold. The base moves in one direction (``x``: vertically
propagating shear waves, the sides held vertically; ``y``: compression waves, the sides on
rollers):
- ``rigid``: the input is the motion of the base itself (a "within" motion). In the frame
  of the base, u_rel = u - u_b, the base is fixed and every mass feels -m a_b(t); the
  absolute acceleration is the relative one plus a_b;
- ``compliant``: an elastic half-space under the soil (rho_r, V_r: Vs_r for x, Vp_r for y),
  a Lysmer-Kuhlemeyer dashpot rho_r V_r on each base node's share of the base, driven by
  the rock's outcrop motion: the incident wave is half of it, applied as the force
  2 rho_r V_r v_inc = rho_r V_r v_outcrop. The dashpot is taken implicitly (explicit, it is
  unstable once dt rho_r V_r A / m exceeds 2, which the wave step reaches).
Periodic sides tie each right-side node to the left-side one of its row by a tying matrix T
(reduced DOFs): K_r = T^T K T, masses, dashpots and forces summed by T^T.

The step: dt = SAFETY (2 / w_max)(sqrt(1 + xi^2) - xi), w_max^2 <= max_i sum_j |K_ij| / m_i
(Gershgorin: a bound, so the step is stable) and xi = a0 / (2 w_max) the damping of the
fastest mode by the explicit mass-proportional part. Vectors are PETSc Vecs over the free
(reduced) DOFs, one MatMult a step (two, and a triangular solve, with a1).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from petsc4py import PETSc

from ..common.errors import InputError
from ..common.linalg import direct_solver
from ..materials.history import elasticity_of
from ..model import scene, shapes
from ..model.scene import Body, Loading, top_forces
from .pointforces import PointForces

SAFETY = 0.9


@dataclasses.dataclass(frozen=True)
class Shaking:
    """How the base moves: ``direction`` x | y, ``base`` rigid | compliant, the rock
    (``rock_rho`` kg/m3, ``rock_speed`` m/s: Vs for x, Vp for y; compliant only) and the
    Rayleigh coefficients (a0 1/s, a1 s)."""

    direction: str = "x"
    base: str = "compliant"
    rock_rho: float = 0.0
    rock_speed: float = 0.0
    a0: float = 0.0
    a1: float = 0.0

    def __post_init__(self):
        if self.direction not in ("x", "y"):
            raise InputError(f"base direction {self.direction!r}: x or y")
        if self.base not in ("rigid", "compliant"):
            raise InputError(f"base {self.base!r}: rigid or compliant")
        if self.base == "compliant" and not (self.rock_rho > 0 and self.rock_speed > 0):
            raise InputError("a compliant base needs the rock's density and wave speed > 0")
        if self.a0 < 0 or self.a1 < 0:
            raise InputError("Rayleigh coefficients must be >= 0")

    def supports(self, sides: str = "rollers") -> tuple:
        """The sides' fixed components: the other direction held everywhere on the sides
        (rollers; free where they are tied, periodic, or absorbing), the base fixed in both
        (rigid) or in the other direction only (compliant)."""
        other = "y" if self.direction == "x" else "x"
        bottom = "xy" if self.base == "rigid" else other
        side = other if sides == "rollers" else "none"
        return (("left", side), ("right", side), ("bottom", bottom), ("top", "none"))


def rayleigh(xi: float, f1: float, f2: float) -> tuple:
    """(a0, a1) of Rayleigh damping with ratio xi at f1 and f2 (Hz)."""
    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2
    return 2 * xi * w1 * w2 / (w1 + w2), 2 * xi / (w1 + w2)


class ShakenBody:
    """The body of ``body`` (its grid, points, cells; its supports replaced by
    :meth:`Shaking.supports`) made of ``soil`` on ``comm``, shaken as ``shaking`` says;
    ``sides``: rollers, periodic (each right-side node tied to the left-side node of its
    row: the body moves as a column of any width) or absorbing (Lysmer dashpots, rho Vp
    normal and rho Vs tangential, for waves leaving a body whose far field is at rest);
    ``loading`` presses on the top from t = 0; ``materials`` (one hyperbolic soil per layer
    of ``soil``; None: linear) make the internal forces the points' stresses'
    (:class:`solver.stepping.pointforces.PointForces`) in place of K u, K (the small-strain
    stiffness) kept for the step and the damping. :meth:`run` steps it, or :meth:`start`
    and :meth:`step` one step at a time.
    The caller destroys it."""

    def __init__(self, comm, body: Body, soil, shaking: Shaking, sides: str = "rollers",
                 loading: Loading | None = None, materials=None):
        self.shaking = shaking
        periodic = sides == "periodic"
        body = dataclasses.replace(body, bcs=shaking.supports(sides))
        self.body = body
        self.grid, self.points, K, M, self.free = scene.build(comm, body, soil,
                                                              D=elasticity_of(soil))
        m = self._lumped(M, K)
        M.destroy()
        idx = self.free.getIndices()
        self.comp = idx % 2
        node = idx // 2
        nx = self.grid.nodes[0]
        self.row, i = node // nx, node % nx
        self.along_full = self.comp == (0 if shaking.direction == "x" else 1)
        c = np.zeros(len(idx))
        base = self.along_full & (self.row == 0)
        if shaking.base == "compliant":
            share = top_forces(self.grid, Loading(load=1.0))   # int N ds of each base node
            c[base] = shaking.rock_rho * shaking.rock_speed * share[i[base]]
        if sides == "absorbing":
            side = (i == 0) | (i == nx - 1)
            c[side] += side_dashpots(self.grid, soil)[self.row[side], self.comp[side]]
        f = np.zeros(len(idx))
        if loading is not None and loading.load > 0:
            top = (self.comp == 1) & (self.row == self.grid.nodes[1] - 1)
            f[top] = -top_forces(self.grid, loading)[i[top]]
        # The free DOFs that are their own reduced DOF: all but the tied right side's.
        self.kept = (i != nx - 1) if periodic else np.ones(len(idx), dtype=bool)
        self.T = _ties(K, idx, nx) if periodic else None
        self.K = K.PtAP(self.T) if periodic else K
        if periodic:
            K.destroy()
        self.m, self.c, self.f = (self._reduce(a) for a in (m, c, f))
        self.along = self._reduce(self.along_full.astype(float)) > 0
        # The base row's DOFs along the shaking (reduced: the kept ones) and their masses'
        # shares of the row's: the mass-proportional damping acts on the velocity relative
        # to theirs (:meth:`step`), a0 m on the DOFs along the shaking.
        self.mpi = self.K.getComm().tompi4py()
        self.base_dofs = np.flatnonzero((self.along_full & (self.row == 0))[self.kept])
        m_base = self.mpi.allreduce(float(np.sum(self.m[self.base_dofs])))
        self.base_share = self.m[self.base_dofs] / m_base if m_base > 0 else None
        self.a0_m_along = shaking.a0 * self.m * self.along
        self.dt = self.dt_stable = self._stable_step()
        self.hysteretic = None
        if materials is not None:
            y = self.points.get("x")[:, 1]
            layer = soil.layer_of(y) if len(soil.soils) > 1 else np.zeros(len(y), dtype=int)
            self.hysteretic = PointForces(self.grid, self.points, self.free, self.T,
                                          materials, layer)
        self.solver = None
        self.u = self.v = None

    def _lumped(self, M, K) -> np.ndarray:
        """HRZ: M's diagonal scaled so that each direction keeps the body's mass."""
        d = M.getDiagonal()
        total = M.createVecLeft()
        ones = M.createVecRight()
        ones.set(1.0)
        M.mult(ones, total)
        diag, rows = d.getArray().copy(), total.getArray().copy()
        comm = K.getComm().tompi4py()
        scale = comm.allreduce(float(rows.sum())) / comm.allreduce(float(diag.sum()))
        for v in (d, total, ones):
            v.destroy()
        return diag * scale

    def _reduce(self, a: np.ndarray) -> np.ndarray:
        """A nodal quantity summed onto the tied DOFs (T^T a): masses, dashpots, forces."""
        if self.T is None:
            return a
        red, full = self.T.createVecs()
        full.setArray(a)
        self.T.multTranspose(full, red)
        out = red.getArray().copy()
        full.destroy()
        red.destroy()
        return out

    def expand(self, vec, out) -> np.ndarray:
        """The free DOFs' values (this rank's, natural DOF numbers in ``self.free``) of the
        reduced Vec ``vec``, through ``out`` (a Vec of the free DOFs, or None untied)."""
        if self.T is None:
            return vec.getArray()
        self.T.mult(vec, out)
        return out.getArray()

    def _stable_step(self) -> float:
        ai, _, av = self.K.getValuesCSR()
        rowsum = np.add.reduceat(np.abs(av), ai[:-1]) if len(av) else np.zeros(0)
        local = float(np.max(rowsum / self.m)) if len(rowsum) else 0.0
        w = math.sqrt(self.K.getComm().tompi4py().allreduce(local, op=_max()))
        self.w_max = w                 # rad/s, the Gershgorin bound of the fastest mode
        # The stiffness-proportional damping is taken implicitly (:meth:`step`): only the
        # mass-proportional part lowers the limit.
        xi = self.shaking.a0 / (2 * w)
        return SAFETY * 2 / w * (math.sqrt(1 + xi * xi) - xi)

    def start(self, dt: float, state=None) -> None:
        """Set the step dt (s) and the state: at rest, or ``state`` (u, v: this rank's
        reduced values, :meth:`state`)."""
        self.dt = dt
        self.u, self.v, self.r, self.Kv = (self.K.createVecRight() for _ in range(4))
        if state is not None:
            self.u.setArray(state[0])
            self.v.setArray(state[1])
        sh = self.shaking
        if sh.a1:
            # m v' + dt a1 K (v' + v) / 2 = ...: Crank-Nicolson in the stiffness-proportional
            # damping, whose explicit limit the grid's fastest mode would set (xi ~ a1 w / 2).
            A = self.K.copy()
            A.scale(dt * sh.a1 / 2)
            diag = A.createVecLeft()
            diag.setArray(self.m + dt * self.c)
            A.setDiagonal(diag, addv=PETSc.InsertMode.ADD_VALUES)
            diag.destroy()
            package = "petsc" if self.K.getComm().getSize() == 1 else "mumps"
            self.solver = direct_solver(self.K.getComm(), A, "mpm_", package)
            A.destroy()

    def step(self, t: float, velocity, acceleration) -> np.ndarray:
        """One step from t (s) under the base motion (functions of time: the base's own
        for a rigid base, the outcrop's for a compliant one); returns the acceleration at
        t (this rank's reduced values, relative to the base when it is rigid)."""
        sh, m, c, dt = self.shaking, self.m, self.c, self.dt
        ua, va = self.u.getArray(), self.v.getArray()
        # The forces at t move v from t - dt/2 to t + dt/2: the acceleration (v' - v) / dt
        # is that of t.
        if self.hysteretic is None:
            self.K.mult(self.u, self.r)
        else:
            self.hysteretic.forces(self.u, self.r)
        fa = self.f - self.r.getArray()
        if sh.base == "rigid":
            fa[self.along] -= m[self.along] * acceleration(t)
        fa += c * velocity(t + dt / 2)
        if sh.base == "compliant" and sh.a0:
            # Damping on the deformation only: the mass part on the velocity relative to the
            # base row's (mass-weighted mean), which a rigid-body translation shares, so the
            # column is not dragged against the fixed frame at long periods. On a fixed base
            # that velocity is 0 (the rigid case: no base DOFs), the modes' ratios as before.
            fa += self.a0_m_along * self.base_velocity(va)
        old = va.copy()
        if self.solver is None:
            # The dashpot (c) implicit, the rest explicit: v' = (m v + dt f) / (m + dt c).
            va[:] = (m * (1 - dt * sh.a0) * va + dt * fa) / (m + dt * c)
        else:
            self.K.mult(self.v, self.Kv)
            ra = self.r.getArray()
            ra[:] = m * (1 - dt * sh.a0) * va - (dt * sh.a1 / 2) * self.Kv.getArray() + dt * fa
            self.solver.solve(self.r, self.v)
            va = self.v.getArray()
        ua += dt * va
        return (va - old) / dt

    def base_velocity(self, va: np.ndarray) -> float:
        """The mass-weighted mean velocity (m/s) along the shaking of the base row's nodes
        in ``va`` (this rank's reduced values), over all ranks: one allreduce (the base row
        may live on one rank)."""
        mine = float(self.base_share @ va[self.base_dofs])
        # Skipped on one rank: a pickled allreduce would add about a tenth to the step.
        return self.mpi.allreduce(mine) if self.mpi.Get_size() > 1 else mine

    def state(self) -> tuple:
        """(u, v): this rank's reduced values (m, m/s), copies."""
        return self.u.getArray().copy(), self.v.getArray().copy()

    def run(self, t_end: float, velocity, acceleration, dt: float | None = None) -> dict:
        """Step to ``t_end`` (s) under the base motion, given as functions of time (s): its
        ``velocity`` (m/s) and ``acceleration`` (m/s2) (the outcrop's for a compliant base,
        the base's own for a rigid one). Returns {"t": times (s), "surface": the mean
        absolute acceleration of the top nodes in the shaking direction (m/s2), "base": the
        base's}, on every rank."""
        self.start(dt or self.dt)
        dt = self.dt
        n = int(math.ceil(t_end / dt - 1e-9))
        mpi = self.K.getComm().tompi4py()
        top = self.along_full & (self.row == self.grid.nodes[1] - 1)
        base = self.along_full & (self.row == 0)
        ntop, nbase = (mpi.allreduce(int(np.sum(mask))) for mask in (top, base))
        full = self.T.createVecLeft() if self.T is not None else None
        rigid = self.shaking.base == "rigid"
        t = dt * np.arange(n + 1)
        surface, at_base = np.zeros(n + 1), np.zeros(n + 1)
        a_vec = self.K.createVecRight()
        for k in range(n + 1):
            a_vec.setArray(self.step(t[k], velocity, acceleration))
            a = self.expand(a_vec, full)
            a_abs = a + (acceleration(t[k]) if rigid else 0.0)
            surface[k] = mpi.allreduce(float(np.sum(a_abs[top]))) / ntop
            at_base[k] = (acceleration(t[k]) if rigid else
                          mpi.allreduce(float(np.sum(a[base]))) / nbase)
        scene.destroy(a_vec, full)
        return {"t": t, "surface": surface, "base": at_base, "dt": dt}

    def destroy(self):
        scene.destroy(self.hysteretic, self.solver, self.u, self.v, getattr(self, "r", None),
                      getattr(self, "Kv", None), self.T, self.K, self.free, self.points,
                      self.grid)


def side_dashpots(grid, soil) -> np.ndarray:
    """(node rows, 2): the Lysmer dashpots (N s/m per m depth) of a side node of each row,
    rho Vp on x (normal) and rho Vs on y (tangential), each the integral of the node's 1D
    shape function along the side with its cells' layer's impedance."""
    s, w = shapes.gauss_1d(3)
    order, h, cells = grid.order, grid.h[1], grid.cells[1]
    edge = (w[:, None] * shapes.lagrange1d(order, s)[0]).sum(axis=0) * h / 2
    layer_of = getattr(soil, "layer_of", lambda y: np.zeros(len(y), dtype=int))
    layers = layer_of((np.arange(cells) + 0.5) * h)
    out = np.zeros((grid.nodes[1], 2))
    for cy in range(cells):                  # the set-up only: once per run
        m = soil.soils[int(layers[cy])]
        Vp = math.sqrt(m.constrained_modulus / m.density)
        Vs = math.sqrt(m.shear_modulus / m.density)
        rows = slice(order * cy, order * cy + order + 1)
        out[rows, 0] += m.density * Vp * edge
        out[rows, 1] += m.density * Vs * edge
    return out


def _ties(K, idx, nx: int):
    """The tying matrix T (free DOFs x reduced DOFs, one 1 a row) of periodic sides: each
    right-side DOF (node column nx - 1) takes the reduced DOF of the left-side one of its
    row and component, every other DOF its own. Rows in K's order (the ranks' free DOFs,
    natural numbers ``idx``, one after the other)."""
    comm = K.getComm()
    mpi = comm.tompi4py()
    every = np.concatenate(mpi.allgather(np.asarray(idx)))
    start = mpi.exscan(len(idx)) or 0
    right = (every // 2) % nx == nx - 1
    reduced = np.cumsum(~right) - 1                  # numbers of the kept DOFs
    partner = every - 2 * (nx - 1) * right           # the same row's left node
    mine = slice(start, start + len(idx))
    order = np.argsort(every)                        # where each partner stands in K
    at = order[np.searchsorted(every[order], partner[mine])]
    cols = reduced[at].astype(PETSc.IntType)
    ptr = np.arange(len(idx) + 1, dtype=PETSc.IntType)
    T = PETSc.Mat().createAIJ(((len(idx), None), (int(np.sum(~right[mine])), None)),
                              csr=(ptr, cols, np.ones(len(idx))), comm=comm)
    T.assemble()
    return T


def _max():
    from mpi4py import MPI

    return MPI.MAX
