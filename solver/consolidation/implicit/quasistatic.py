"""Implicit quasi-static u-p consolidation on the material points (``-mpm_scheme implicit``).

The points stay where they are (small strain, the explicit scheme's default kinematics) and
carry the integration (:mod:`.operators`). The unknowns are the nodal displacement u and the
excess pore pressure over hydrostatic p_e = p - rho_l g (H - y) (Pa): Darcy's law with the
water's weight then reads in p_e alone, and the drained sides hold p_e = 0 (the water
table at the surface). With y = (u, p_e), F(t) the load vector and c = gamma h / 2:

    undrained, t = 0+:  J(0) y = F(0+) - M y_0          (the drained sides' p left free)
    TR-BDF2 step h:     J(c) y_tr = F(t + gamma h) - M y + c H y
                        J(c) y'   = F(t + h) - M (y_tr / (gamma (2 - gamma))
                                               - (1 - gamma)^2 y / (gamma (2 - gamma)))

with J(c) = J0 - c H, gamma = 2 - sqrt(2): one-step, second order, L-stable; both stages
share J(c), so a block of equal steps costs one LU factorization. The load vector is
F = q(t) F_q + F_g: the top load and, under gravity, the mixture's weight, the water
outside the drained sides, Q p_h (the hydrostatic part of the total stress) and minus the
points' initial effective stress (the geostatic start: then F_g vanishes up to the points'
quadrature of the state at rest, as in the explicit step). A fresh deposit starts from
p = 0, i.e. p_e = -p_h, and the undrained start gives the share of its weight the water
takes (analytic.undrained_excess).

Linear algebra: KSP preonly with LU by MUMPS under the options prefix ``mpm_``
(``-mpm_ksp_type``, ``-mpm_pc_type``, ``-mpm_pc_factor_mat_solver_type``,
``-mpm_mat_mumps_icntl_*`` ...), on the symmetrically scaled system (the displacement rows
by 1 / sqrt(E_c), the pressures by sqrt(E_c) / h): both blocks O(1). Log events
MPMImplicitAssembly, MPMImplicitFactor and MPMImplicitSolve.
"""

from __future__ import annotations

import math
import time

import numpy as np
from petsc4py import PETSc

from ...common.clock import log_event
from ...io import checkpoint
from ...common.errors import NumericalError, check_converged
from ...common.linalg import direct_solver
from ...model.scene import destroy, geostatic_fields, top_forces, water_forces
from ...model.soil import G_REF
from ...references.biot import GAMMA, schedule as graded
from .operators import Operators, per_point
from .yielding import Yielding

_BDF_NEW = 1 / (GAMMA * (2 - GAMMA))
START_CUTS = 6      # halvings of the undrained start's load where the soil yields
_BDF_OLD = (1 - GAMMA) ** 2 / (GAMMA * (2 - GAMMA))


def step_ends(times, steps: int) -> np.ndarray:
    """The step ends (s) through the ``times`` asked (s, > 0): ``steps`` per doubling, graded
    from the load (:func:`solver.references.biot.schedule`, the FE reference's grading),
    the first block ending at t_1 / steps^4 (t_1 the first time asked)."""
    asked = np.unique(np.asarray(times, dtype=float))
    asked = asked[asked > 0]
    return graded(asked, steps, asked[0] / steps ** 4)


def named_times(time, Tv_report, Tv_end: float, isochrones=()) -> dict:
    """{T_v: t (s)}: the report and isochrone times up to the end T_v and the end itself,
    ``time(T_v)`` the scene's time (s) of a time factor."""
    named = {tv: time(tv) for tv in sorted(set(isochrones) | set(Tv_report))
             if tv <= Tv_end + 1e-12}
    named[Tv_end] = time(Tv_end)
    return named


def graded_steps(named: dict, steps: int, ramp: float = 0.0) -> np.ndarray:
    """The step ends (s) through the times of :func:`named_times`, and a load ramp's end
    (s; 0: none) where it falls before the last: the load's kink then falls between steps."""
    end = max(named.values())
    return step_ends(list(named.values()) + ([ramp] if 0 < ramp < end else []), steps)


class QuasiStatic:
    """The implicit scheme's state and solver on one grid; the time loop calls
    :meth:`start` once (t = 0+) and :meth:`step` per step; both write the points' fields.
    ``stabilize``: the pressure projection (:mod:`.operators`); ``materials``: one per layer
    where the soil yields (:mod:`.yielding`: Newton per stage), None for linear elastic
    soil. The caller destroys it."""

    def __init__(self, grid, points, soil, body, loading, stabilize: bool, materials=None):
        self.grid, self.points, self.loading = grid, points, loading
        self.comm = grid.comm
        self.mpi = self.comm.tompi4py()
        x0, volume = points.get("x0", "volume")
        layer = points.get("layer").ravel() if "layer" in points.layout else \
            np.zeros(len(volume), dtype=int)
        self.x0 = x0.copy()
        with log_event("MPMImplicitAssembly"):
            self.ops = ops = Operators(grid, x0, volume, layer, soil, stabilize)
        self.nen = ops.u.N.shape[1]
        g, H = loading.gravity, body.height
        self.gamma_h = soil.soils[0].rho_l * g      # the hydrostatic gradient (Pa/m)
        self.p_h = self.gamma_h * (H - x0[:, 1])
        self.mobility = per_point(soil, "k", layer) / (soil.soils[0].rho_l * G_REF)
        self.porosity = per_point(soil, "porosity", layer)
        # The initial effective stress, from the scene (a restart's points hold later ones).
        self.sigma0 = geostatic_fields(x0, body, soil, loading)[1] if loading.geostatic \
            else np.zeros((len(volume), 3))
        # The state, the load parts and the step's work vectors, made once.
        self.y, self.F_q, self.F_g, self.work, self.rhs, self.tmp, self.y_tr = (
            ops.da.createGlobalVec() for _ in range(7))
        self.loc = ops.da.createLocalVec()
        self._loads(body, soil, volume, layer)
        self.held_undrained = ops.rows(ops.mask(body.supports))
        self.held = ops.rows(ops.mask(body.supports, body.drained))
        self.d = self.y.duplicate()
        d = self.d.getArray().reshape(-1, 3)
        d[:, :2] = 1 / math.sqrt(ops.E_c)
        d[:, 2] = math.sqrt(ops.E_c) / min(grid.h)
        self.ksp = self.J = None
        self.key = self.h_used = None
        self.factorizations, self.solves, self.steps = 0, 0, 0
        self.solve_seconds = self.factor_seconds = 0.0
        self.u_prev = np.zeros((len(volume), 2))
        if not loading.geostatic and g > 0:
            self._start_at_zero_pressure()
        self.yielding = None if materials is None else \
            Yielding(ops, materials, layer, self.sigma0, volume, self.comm)
        self._load_scale = None

    # -- set-up ---------------------------------------------------------------------------
    def _start_at_zero_pressure(self):
        """p_e = -p_h = -rho_l g (H - y) at the corner nodes (Pa): a fresh deposit's p = 0."""
        g = self.grid
        _, J = g.owned_lattice()
        y = J * g.h[1] / g.order
        arr = self.y.getArray().reshape(-1, 3)
        arr[:, 2] = np.where(self.ops.unused()[:, 2], 0.0, -self.gamma_h * (g.size[1] - y))

    def _loads(self, body, soil, volume, layer):
        """F_q (the scene's load q on the top) and F_g (gravity's, see the module
        docstring), global Vecs (N per m depth)."""
        g, ops, loading = self.grid, self.ops, self.loading
        I, J = g.owned_lattice()
        top = J == g.nodes[1] - 1
        fq = self.F_q.getArray().reshape(-1, 3)
        fq[top, 1] = -top_forces(g, loading)[I[top]]
        self.loc.zeroEntries()
        if loading.gravity > 0:
            loc = self.loc.getArray().reshape(-1, 3)
            u, B, n2 = ops.u, ops.B, 2 * self.nen
            rho = per_point(soil, "density", layer)
            weight = -(volume * rho * loading.gravity)[:, None] * u.N
            np.add.at(loc[:, 1], u.nodes, weight)
            # Q p_h - int B^T sigma'_0: the hydrostatic water and the initial effective stress.
            total = self.sigma0.copy()
            total[:, :2] -= self.p_h[:, None]
            f = -volume[:, None] * np.einsum("pki,pk->pi", B, total)
            np.add.at(loc[:, 0], u.nodes, f[:, 0:n2:2])
            np.add.at(loc[:, 1], u.nodes, f[:, 1:n2:2])
        self.F_g.zeroEntries()
        ops.da.localToGlobal(self.loc, self.F_g, addv=PETSc.InsertMode.ADD_VALUES)
        if loading.gravity > 0:
            water = water_forces(g, body.drained, soil.soils[0].rho_l * loading.gravity)
            fg = self.F_g.getArray().reshape(-1, 3)
            fg[:, :2] += water[J, I]

    # -- linear algebra ---------------------------------------------------------------------
    def _factor(self, c, held):
        self._release()
        t0 = time.perf_counter()
        with log_event("MPMImplicitFactor"):
            J = self.ops.J0.duplicate(copy=True)
            if c:
                J.axpy(-c, self.ops.H, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            J.diagonalScale(self.d, self.d)
            J.zeroRowsColumns(held, diag=1.0)
            ksp = direct_solver(self.comm, J, "mpm_")
            try:
                ksp.setUp()
            except PETSc.Error as exc:
                raise NumericalError(f"implicit scheme: the factorization failed ({exc})") \
                    from None
        self.J, self.ksp = J, ksp
        self.factorizations += 1
        self.factor_seconds += time.perf_counter() - t0

    def _solve(self, c, held, rhs):
        """y with J(c) y = rhs on the free rows, 0 on ``held`` (rhs is overwritten)."""
        key = (c, held is self.held)
        if key != self.key:
            self._factor(c, held)
            self.key = key
        t0 = time.perf_counter()
        with log_event("MPMImplicitSolve"):
            rhs.pointwiseMult(rhs, self.d)
            rhs.setValues(held, np.zeros(len(held)))
            rhs.assemble()
            self.ksp.solve(rhs, self.work)
            check_converged(self.ksp, "implicit scheme: the step's solve (options "
                                      "-mpm_ksp_*, -mpm_pc_*)")
            self.work.pointwiseMult(self.work, self.d)
        self.solves += 1
        self.solve_seconds += time.perf_counter() - t0
        return self.work

    def _rhs(self, t, y_store, c=0.0, y_flow=None):
        """F(t) - M y_store + c H y_flow, in the work vector ``rhs``."""
        r, m = self.rhs, self.tmp
        self.F_g.copy(r)
        r.axpy(self.loading.factor(t), self.F_q)
        self.ops.M.mult(y_store, m)
        r.axpy(-1.0, m)
        if c:
            self.ops.H.mult(y_flow, m)
            r.axpy(c, m)
        return r

    def load_scale(self) -> float:
        """|d (F_q + F_g)|: the scaled size of the whole load (what Newton's tolerance is
        relative to)."""
        if self._load_scale is None:
            self.F_q.copy(self.tmp)
            self.tmp.axpy(1.0, self.F_g)
            self.tmp.pointwiseMult(self.tmp, self.d)
            self._load_scale = self.tmp.norm() or 1.0
        return self._load_scale

    def _stage(self, c, held, rhs, when: str):
        """The stage's solution (the work vector): linear, or Newton from the state y where
        the soil yields."""
        if self.yielding is None:
            return self._solve(c, held, rhs)
        self.y.copy(self.work)
        return self.yielding.solve(self, c, held, rhs, self.work, when)

    # -- the scheme ---------------------------------------------------------------------------
    def start(self):
        """The undrained state at t = 0+ (water has not moved; the drained sides' p free).
        Where the soil yields the load goes on in 1, 2, 4 ... up to 2^START_CUTS equal
        undrained increments until Newton converges on each (the path matters)."""
        self.key = None
        if self.yielding is None:
            self._solve(0.0, self.held_undrained, self._rhs(0.0, self.y)).copy(self.y)
            self.to_points(None)
            return
        y0, stored = self.y.copy(), self.y.duplicate()
        self.ops.M.mult(y0, stored)
        f = self.loading.factor(0.0)
        for cut in range(START_CUTS + 1):
            n = 2 ** cut
            try:
                for k in range(1, n + 1):
                    r = self.rhs
                    self.F_g.copy(r)
                    r.axpy(f * k / n, self.F_q)
                    r.axpy(-1.0, stored)
                    self._stage(0.0, self.held_undrained, r, "at t = 0+ (undrained)"
                                ).copy(self.y)
                break
            except NumericalError:
                if cut == START_CUTS:
                    raise
                y0.copy(self.y)
                self.yielding.reset(y0)
        y0.destroy()
        stored.destroy()
        self.to_points(None)

    def step(self, t0: float, t1: float):
        """One TR-BDF2 step from t0 to t1 (s)."""
        h = t1 - t0
        # Steps of one graded block differ in their last bits: keep them on one factorization.
        if self.h_used is None or abs(h - self.h_used) > 1e-9 * h:
            self.h_used = h
        c = GAMMA * self.h_used / 2
        y_tr = self.y_tr
        when = f"in the step to t = {t1:.6g} s"
        self._stage(c, self.held, self._rhs(t0 + GAMMA * h, self.y, c, self.y), when
                    ).copy(y_tr)
        # The BDF2 stage's storage argument, (y_tr - (1 - gamma)^2 y) / (gamma (2 - gamma)).
        y_tr.scale(_BDF_NEW)
        y_tr.axpy(-_BDF_OLD, self.y)
        self._stage(c, self.held, self._rhs(t1, y_tr), when).copy(self.y)
        self.steps += 1
        self.to_points(h)

    def to_points(self, h):
        """The points' displacement, velocities (over the step h, s; None: zero), effective
        stress, pore pressure, volume ratio and pressure gradient from the nodal state."""
        ops, n2 = self.ops, 2 * self.nen
        ops.da.globalToLocal(self.y, self.loc)
        arr = self.loc.getArray()
        ue, pe = arr[ops.dofs[:, :n2]], arr[ops.dofs[:, n2:]]
        N = ops.u.N
        u = np.stack([np.sum(N * ue[:, 0::2], 1), np.sum(N * ue[:, 1::2], 1)], -1)
        eps = np.einsum("pki,pi->pk", ops.B, ue)
        D = ops.D
        sig = np.einsum("kl,pl->pk" if np.ndim(D) == 2 else "pkl,pl->pk", D, eps)
        grad = np.einsum("pad,pa->pd", ops.p.dNdx, pe)
        vs = np.zeros_like(u) if not h else (u - self.u_prev) / h
        self.u_prev = u
        with self.points.fields("x", "vs", "vl", "stress", "p", "J") as (x, v_s, v_l, st, pp,
                                                                         Jv):
            x[:] = self.x0 + u
            v_s[:] = vs
            v_l[:] = vs - (self.mobility / self.porosity)[:, None] * grad
            if self.yielding is None:
                st[:] = self.sigma0 + sig
            pp[:] = self.p_h + np.sum(ops.p.N * pe, 1)
            Jv[:] = 1 + eps[:, 0] + eps[:, 1]
        if self.yielding is not None:
            self.yielding.to_fields(self.points)
        if "gradp" in self.points.layout:
            with self.points.fields("gradp") as gp:
                gp[:] = grad
                gp[:, 1] -= self.gamma_h      # grad p = grad p_e + grad p_h

    def check(self, step: int, t: float, scale: float):
        """NumericalError on every rank for a non-finite state."""
        ok = bool(np.isfinite(self.y.norm()))
        if not ok:
            raise NumericalError(f"implicit scheme: non-finite state at step {step}, "
                                 f"t = {t:.6g} s")

    # -- checkpoints --------------------------------------------------------------------------
    def state(self) -> list:
        """The nodal state in natural order (every rank; a checkpoint's)."""
        return checkpoint.natural(self.ops.da, self.y)

    def restore(self, values):
        """The nodal state of :meth:`state` (natural order), and the points' fields."""
        checkpoint.from_natural(self.ops.da, values, self.y)
        if self.yielding is not None:
            self.yielding.from_fields(self.points, self.y)
        self.to_points(None)

    def summary(self) -> dict:
        out = {"steps": self.steps, "factorizations": self.factorizations,
               "solves": self.solves, "factor_seconds": self.factor_seconds,
               "solve_seconds": self.solve_seconds}
        if self.yielding is not None:
            its = self.yielding.iterations
            out.update(newton_solves=len(its), newton_iterations=int(sum(its)),
                       newton_most=int(max(its, default=0)))
        return out

    def _release(self):
        destroy(self.ksp, self.J)
        self.ksp = self.J = None

    def destroy(self):
        """Free the factorization, the operators and the vectors."""
        self._release()
        if self.yielding is not None:
            self.yielding.destroy()
        destroy(self.y, self.F_q, self.F_g, self.work, self.rhs, self.tmp, self.y_tr, self.loc,
                self.d, self.ops)
