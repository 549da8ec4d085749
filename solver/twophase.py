"""Explicit single-point two-phase (v-w) MPM step (paper Section 2.2, eqs. 6-15).

Sign conventions: stresses are tension positive, the pore pressure p compression positive,
so the total stress is sigma = sigma' - m p (the paper's eq. 15 in compression-positive form).

One step, with every nodal quantity lumped (a diagonal, stored as a PETSc Vec):
1. Points to grid: solid and liquid masses M_s, M_l, the liquid "mass" M~_l = sum rho_l V,
   the drag Q = sum (n mu_l / kappa_l) V (eq. 12), both momenta, the mixture force
   f_m = f_ext - sum B^T sigma V and the liquid force f_l = sum p grad(N) V (+ gravity).
   All of them are one ghosted local Vec of 12 fields, summed over the ranks by one
   localToGlobal(ADD).
2. Nodal accelerations (eqs. 13, 14), pointwise: a_l = (f_l - Q (v_l - v_s)) / M~_l,
   a_s = (f_m - M_l a_l) / M_s; optional local damping; fixed DOFs held; then
   v^{k+1} = v^k + dt a^k (eq. 6).
3. Grid to points: point velocities (FLIP, or a FLIP/PIC blend), strain rate from the nodal
   v_s^{k+1}, effective stress by linear elasticity, pore pressure from eqs. 8-9
   (dp = -K_l / n [(1 - n) div v_s + n div v_l] dt), positions x += dt v_s^{k+1}.
Porosity, volumes and masses stay at their initial values (small strain: the paper neglects
spatial variation of density and porosity, and the analytic references are linear).
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from . import assembly, shapes
from .errors import NumericalError
from .timestep import drag_coefficient, impermeable

NF = 12   # packed nodal fields: Ms, Ml, Mt, Q, Ps(2), Pl(2), Fm(2), Fl(2)
NG = 8    # fields sent back to the points: a_s(2), a_l(2), v_s(2), v_l(2)

# Material-point fields of the consolidation run (besides x, volume, mass).
POINT_FIELDS = {"vs": 2, "vl": 2, "stress": 3, "p": 1, "y0": 1, "monitor": 1, "id": 1,
                "J": 1}


class TwoPhase:
    """State and operators of the explicit v-w scheme on one grid."""

    def __init__(self, grid, points, p, bcs, lumping):
        self.grid, self.points, self.p = grid, points, p
        self.lumping = lumping
        self.D = assembly.elasticity(p.E, p.nu)
        self.gvec = np.array([0.0, -p.gravity])
        n = p.porosity
        self.n = n
        self.drag = drag_coefficient(p)                     # eq. 12 (kg/m3/s)
        self.da_f = grid.da.duplicate(dof=NF)
        self.da_g = grid.da.duplicate(dof=NG)
        self.loc_f, self.glob_f = self.da_f.createLocalVec(), self.da_f.createGlobalVec()
        self.loc_g, self.glob_g = self.da_g.createLocalVec(), self.da_g.createGlobalVec()
        self.ng = grid.gxm * grid.gym
        self.fixed_s = grid.constrained_mask(bcs).reshape(-1, 2)
        self.fixed_l = grid.constrained_mask(impermeable(p.drained)).reshape(-1, 2)
        self.traction = self._traction(p.load)
        self.cols = np.arange(NF)

    # -- set-up ----------------------------------------------------------------------------
    def _traction(self, q):
        """Owned nodal forces (N per m depth) of a downward pressure q on the top edge."""
        g = self.grid
        s, w = shapes.gauss_1d(3)
        N = shapes.lagrange1d(g.p, s)[0]                  # 1D edge shape functions
        edge = (w[:, None] * N).sum(axis=0) * g.h[0] / 2    # integral of each over one edge
        top = np.zeros(g.nodes[0])
        for a in range(g.p + 1):
            top[a:a + g.p * g.cells[0]:g.p] += edge[a]
        force = np.zeros(((g.ye - g.ys), (g.xe - g.xs)))
        if g.ye == g.nodes[1]:
            force[-1] = -q * top[g.xs:g.xe]
        return force.ravel()

    # -- one step --------------------------------------------------------------------------
    def step(self, dt: float, load_factor: float, damping: float, flip: float):
        p = self.p
        with self.points.fields("x", "volume", "mass", "vs", "vl", "stress", "p", "J") as (
                x, V, m, vs, vl, sig, pp, J):
            it = assembly.interpolation(self.grid, x)
            N, dN, nodes = it.N, it.dNdx, it.nodes
            w = assembly.lumping_weights(N, self.lumping)
            ms = (1 - self.n) * p.rho_s * V
            ml = self.n * p.rho_l * V
            mt = p.rho_l * V
            npnt, nen = N.shape

            # 1. points -> grid, one packed array of NF fields per (point, node).
            C = np.empty((npnt, nen, NF))
            C[..., 0] = w * ms[:, None]
            C[..., 1] = w * ml[:, None]
            C[..., 2] = w * mt[:, None]
            C[..., 3] = w * (self.drag * V)[:, None]
            C[..., 4:6] = (w * ms[:, None])[..., None] * vs[:, None, :]
            C[..., 6:8] = (w * ml[:, None])[..., None] * vl[:, None, :]
            sxx = (sig[:, 0] - pp) * V
            syy = (sig[:, 1] - pp) * V
            sxy = sig[:, 2] * V
            C[..., 8] = -(dN[..., 0] * sxx[:, None] + dN[..., 1] * sxy[:, None])
            C[..., 9] = -(dN[..., 0] * sxy[:, None] + dN[..., 1] * syy[:, None])
            C[..., 10:12] = dN * (pp * V)[:, None, None]
            if p.gravity:
                C[..., 8:10] += (N * (ms + ml)[:, None])[..., None] * self.gvec
                C[..., 10:12] += (N * mt[:, None])[..., None] * self.gvec
            flat = np.bincount((nodes[..., None] * NF + self.cols).ravel(), weights=C.ravel(),
                               minlength=self.ng * NF)
            self.loc_f.setArray(flat)
            self.glob_f.set(0.0)
            self.da_f.localToGlobal(self.loc_f, self.glob_f, addv=PETSc.InsertMode.ADD_VALUES)

            # 2. nodal accelerations and velocities (owned nodes).
            G = self.glob_f.getArray().reshape(-1, NF)
            Ms, Ml, Mt, Q = G[:, 0], G[:, 1], G[:, 2], G[:, 3]
            has = Ms > 0
            inv = lambda M: np.divide(1.0, M, out=np.zeros_like(M), where=has)  # noqa: E731
            vs_n = G[:, 4:6] * inv(Ms)[:, None]
            vl_n = G[:, 6:8] * inv(Ml)[:, None]
            fm = G[:, 8:10].copy()
            fm[:, 1] += load_factor * self.traction
            if damping:
                # Local (Cundall) damping of the mixture's unbalanced force only: it takes
                # the undrained wave out, in which both phases move together, and leaves the
                # drag (which the liquid equation integrates explicitly) untouched.
                v_mix = (Ms[:, None] * vs_n + Ml[:, None] * vl_n)
                fm -= damping * np.abs(fm) * np.sign(v_mix)
            al = (G[:, 10:12] - Q[:, None] * (vl_n - vs_n)) * inv(Mt)[:, None]
            as_ = (fm - Ml[:, None] * al) * inv(Ms)[:, None]
            as_[self.fixed_s] = 0.0
            vs_n[self.fixed_s] = 0.0
            al[self.fixed_l] = 0.0
            vl_n[self.fixed_l] = 0.0
            out = self.glob_g.getArray().reshape(-1, NG)
            out[:, 0:2] = as_
            out[:, 2:4] = al
            out[:, 4:6] = vs_n + dt * as_
            out[:, 6:8] = vl_n + dt * al
            self.da_g.globalToLocal(self.glob_g, self.loc_g)

            # 3. grid -> points.
            Hn = self.loc_g.getArray().reshape(-1, NG)[nodes]          # (np, nen, NG)
            at = np.einsum("pa,paf->pf", N, Hn)
            if flip == 1.0:
                vs += dt * at[:, 0:2]
                vl += dt * at[:, 2:4]
            else:
                vs[:] = flip * (vs + dt * at[:, 0:2]) + (1 - flip) * at[:, 4:6]
                vl[:] = flip * (vl + dt * at[:, 2:4]) + (1 - flip) * at[:, 6:8]
            Ls = np.einsum("pai,paj->pij", Hn[..., 4:6], dN)             # grad v_s
            div_l = np.einsum("pai,pai->p", Hn[..., 6:8], dN)
            eps = np.stack([Ls[:, 0, 0], Ls[:, 1, 1], Ls[:, 0, 1] + Ls[:, 1, 0]], axis=1)
            sig += dt * eps @ self.D.T
            div_s = Ls[:, 0, 0] + Ls[:, 1, 1]
            pp -= dt * p.K_l / self.n * ((1 - self.n) * div_s + self.n * div_l)
            x += dt * at[:, 4:6]
            J *= 1 + dt * div_s           # volume ratio of the solid, to catch inversion

    def check(self, step: int, t: float, scale: float):
        """Stop (NumericalError, on every rank) on non-finite values, unbounded pore pressure,
        an inverted material point or one that left the grid; name the point and the step."""
        with self.points.fields("p", "vs", "vl", "J", "x", "id") as (pp, vs, vl, J, x, ids):
            W, H = self.grid.size
            tol = 1e-9 * max(W, H)
            problems = [
                ~(np.isfinite(pp) & np.isfinite(vs).all(axis=1) & np.isfinite(vl).all(axis=1)),
                np.abs(pp) > 1e3 * scale,
                J <= 0,
                (x[:, 0] < -tol) | (x[:, 0] > W + tol) | (x[:, 1] < -tol) | (x[:, 1] > H + tol),
            ]
            first = [int(ids[m][0]) if m.any() else -1 for m in problems]
            detail = {}
            for kind, m in enumerate(problems):
                if m.any():
                    i = np.flatnonzero(m)[0]
                    detail[kind] = (float(pp[i]), float(J[i]), x[i].tolist())
        from mpi4py import MPI

        mpi = self.grid.comm.tompi4py()
        found = np.zeros(len(first), dtype=np.int64)
        mpi.Allreduce((np.array(first) >= 0).astype(np.int64), found, op=MPI.MAX)
        if not found.any():
            return
        kind = int(np.flatnonzero(found)[0])
        owner = mpi.allreduce(self.grid.comm.getRank() if first[kind] >= 0 else -1, op=MPI.MAX)
        pid, info = mpi.bcast((first[kind], detail.get(kind)), root=owner)
        pval, Jval, pos = info
        where = f"material point {pid} at ({pos[0]:.4g}, {pos[1]:.4g}) m, step {step}, " \
                f"t = {t:.6g} s"
        raise NumericalError([
            f"blow-up: non-finite values at {where}",
            f"blow-up: pore pressure {pval:.3g} Pa (> 1000 x {scale:.3g}) at {where}",
            f"inverted: volume ratio J = {Jval:.3g} at {where}",
            f"material point {pid} left the grid at ({pos[0]:.4g}, {pos[1]:.4g}) m by step "
            f"{step}, t = {t:.6g} s",
        ][kind])

    def migrate_if_needed(self, flags=(0,)):
        """Send points that entered another rank's cells there (collective).

        ``flags`` are small integers every rank contributes; their maxima over the ranks
        come back, so that decisions such as stopping are taken together in the same
        reduction."""
        with self.points.fields("x") as x:
            cx, cy, _, _ = self.grid.locate(x)
            owner = self.grid.cell_owner(cx, cy)
        moving = int(np.any(owner != self.grid.comm.getRank()))
        from mpi4py import MPI

        out = np.empty(1 + len(flags), dtype=np.int64)
        self.grid.comm.tompi4py().Allreduce(np.array([moving, *flags], dtype=np.int64), out,
                                            op=MPI.MAX)
        if out[0]:
            self.points.migrate(owner)
        return out[1:]

