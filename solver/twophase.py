"""Explicit single-point two-phase (v-w) MPM step (paper Section 2.2, eqs. 6-15).

Sign conventions: stresses are tension positive, the pore pressure p compression positive,
so the total stress is sigma = sigma' - m p (the paper's eq. 15 in compression-positive form).

One step, with every nodal quantity lumped (a diagonal):
1. Points to grid. Porosity and densities are uniform, so every lumped mass is a constant
   times S = sum w V (m3): M_s = (1 - n) rho_s S, M_l = n rho_l S, the liquid "mass"
   M~_l = rho_l S and the drag Q = (n mu_l / kappa_l) S (eq. 12); likewise the momenta are
   (1 - n) rho_s sum w V v_s and n rho_l sum w V v_l. Nine nodal fields are summed: S,
   sum w V v_s (2), sum w V v_l (2), the mixture force f_m = f_ext - sum B^T sigma V (2) and
   the liquid force f_l = sum p grad(N) V (2) (+ gravity). Per point they are one small
   product [w, dN/dx, dN/dy] x (coefficients), summed over the nodes by one np.bincount and,
   over the ranks, by one localToGlobal(ADD) of a ghosted 9-field Vec.
2. Nodal accelerations (eqs. 13, 14), pointwise: a_l = (f_l - Q (v_l - v_s)) / M~_l,
   a_s = (f_m - M_l a_l) / M_s; optional local damping; fixed DOFs held; then
   v^{k+1} = v^k + dt a^k (eq. 6).
3. Grid to points: point velocities (FLIP, or a FLIP/PIC blend), strain rate from the nodal
   v_s^{k+1}, effective stress by linear elasticity, pore pressure from eqs. 8-9
   (dp = -K_l / n [(1 - n) div v_s + n div v_l] dt), positions x += dt v_s^{k+1}.
Porosity, volumes and masses stay at their initial values (small strain: the paper neglects
spatial variation of density and porosity, and the analytic references are linear).

Performance (docs/performance.md): points are processed in chunks of CHUNK, so that the
work arrays of a pass stay in cache and the memory is bounded whatever the model size; all
work arrays are allocated once and reused (re-allocated only when the swarm changed, after a
migration); shape functions and node numbers of a step are computed once and used by both
transfers. PETSc log events MPMPointsToGrid, MPMNodalUpdate, MPMGridToPoints and MPMMigrate
show the phases in -log_view.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from . import assembly, shapes
from .errors import NumericalError
from .timestep import drag_coefficient, impermeable

NF = 9    # nodal fields summed from the points: S, V v_s (2), V v_l (2), f_m (2), f_l (2)
NG = 8    # fields sent back to the points: a_s(2), a_l(2), v_s(2), v_l(2)
CHUNK = 4096   # points per pass (about 1.5 MB of Q4 work arrays: within a core's L2 cache)

# Material-point fields of the consolidation run (besides x, volume, mass).
POINT_FIELDS = {"vs": 2, "vl": 2, "stress": 3, "p": 1, "y0": 1, "monitor": 1, "id": 1,
                "J": 1}

_EVENTS = {}


def _event(name: str):
    """PETSc log event ``name``, registered once per process on first use (PETSc is then
    initialised with the command line, which a registration at import could precede)."""
    ev = _EVENTS.get(name)
    if ev is None:
        ev = _EVENTS[name] = PETSc.Log.Event(name)
    return ev


class TwoPhase:
    """State and operators of the explicit v-w scheme on one grid.

    Material-point fields are used in place through ``MaterialPoints.views``; shape
    functions, node numbers and work arrays are kept between steps and rebuilt when the
    swarm changed (its ``generation``). Code that changes the points' volumes between steps
    needs no notice (they are read every step); code that resizes or migrates the swarm must
    go through ``MaterialPoints`` (it bumps the generation)."""

    def __init__(self, grid, points, p, bcs, lumping):
        self.grid, self.points, self.p = grid, points, p
        self.lumping = lumping
        self.D = assembly.elasticity(p.E, p.nu)
        self.DT = np.ascontiguousarray(self.D.T)
        self.gvec = np.array([0.0, -p.gravity])
        n = p.porosity
        self.n = n
        self.drag = drag_coefficient(p)                     # eq. 12 (kg/m3/s)
        # Lumped quantities per unit S = sum w V (uniform porosity and densities).
        self.c_s = (1 - n) * p.rho_s                        # M_s / S, kg/m3
        self.c_l = n * p.rho_l                              # M_l / S
        self.c_t = p.rho_l                                  # M~_l / S
        self.c_q = self.drag                                # Q / S, kg/m3/s
        # Weight rows of the points-to-grid product: w, dN/dx, dN/dy, and N where the
        # lumping weights differ from N and gravity needs N (HRZ).
        self.hrz = lumping != "rowsum"
        self.nr = 4 if (self.hrz and p.gravity) else 3
        self.serial = grid.comm.getSize() == 1
        self.mpi = grid.comm.tompi4py()
        self.ng = grid.gxm * grid.gym
        self.nown = (grid.xe - grid.xs) * (grid.ye - grid.ys)
        if self.serial:
            # One rank: the ghosted local and the global node sets are the same (the grid is
            # not periodic), so the nodal sums need no PETSc scatter.
            assert self.ng == self.nown
            self._locg = np.zeros((self.ng, NG))
        else:
            self.da_f = grid.da.duplicate(dof=NF)
            self.da_g = grid.da.duplicate(dof=NG)
            self.loc_f, self.glob_f = self.da_f.createLocalVec(), self.da_f.createGlobalVec()
            self.loc_g, self.glob_g = self.da_g.createLocalVec(), self.da_g.createGlobalVec()
        self.fixed_s = grid.constrained_mask(bcs).reshape(-1, 2)
        self.fixed_l = grid.constrained_mask(impermeable(p.drained)).reshape(-1, 2)
        self._fix_s = np.ascontiguousarray(self.fixed_s.T)      # (2, nown), field-major
        self._fix_l = np.ascontiguousarray(self.fixed_l.T)
        self.traction = self._traction(p.load)
        # Geometry of the shape-function evaluation and of the node numbering.
        self._h = np.array(grid.h)
        self._scale = (2.0 / self._h).reshape(2, 1)             # d(xi, eta)/d(x, y), 1/m
        self._cmax = np.array([grid.cells[0] - 1, grid.cells[1] - 1])
        self._order = grid.p
        off = grid.offsets
        self._nen = len(off)
        # Ghosted-local node of local node a of cell (cx, cy): p cx + p gxm cy + offl[a].
        self._stride = np.array([grid.p, grid.p * grid.gxm], dtype=np.int64)
        self._offl = (off[:, 1] - grid.gys) * grid.gxm + (off[:, 0] - grid.gxs)
        self._frow = np.arange(NF, dtype=np.int64)[:, None]
        # Partitioned directions and this rank's box of cells in cell units (+-inf at the
        # ends of the grid, where locate clips), for the cheap "does any point leave" test.
        (x0, x1), (y0, y1) = grid.owned_cell_range()
        procs = grid.da.getProcSizes()
        self._box = [(d, np.array(grid.h[d]),
                      -np.inf if lo == 0 else float(lo),
                      np.inf if hi == grid.cells[d] else float(hi))
                     for d, (lo, hi) in enumerate(((x0, x1), (y0, y1))) if procs[d] > 1]
        self._flags = None
        self._gen = None
        self.ev_p2g = _event("MPMPointsToGrid")
        self.ev_nodal = _event("MPMNodalUpdate")
        self.ev_g2p = _event("MPMGridToPoints")
        self.ev_migrate = _event("MPMMigrate")

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

    def _prepare(self):
        """Field views and work arrays for the current swarm (after creation, a migration
        or a resize); nothing when the swarm is unchanged."""
        if self._gen == self.points.generation:
            return
        pts = self.points
        (self.x, self.V, self.vs, self.vl, self.sig, self.pp,
         self.J) = pts.views("x", "volume", "vs", "vl", "stress", "p", "J")
        n, nen, k = pts.n_local, self._nen, self._order + 1
        self.n_local = n
        # Per point, kept from points-to-grid for grid-to-points: rows N, dN/dx, dN/dy
        # (1, 1/m, 1/m) and ghosted-local node numbers.
        self.W = np.empty((n, 3, nen))
        self.nodes = np.empty((n, nen), dtype=np.int64)
        m = max(1, min(n, CHUNK))
        self._u = np.empty((m, 2))
        self._ci = np.empty((m, 2), dtype=np.int64)
        self._s = np.empty((m, 2))
        self._Lv = np.empty((m, 2, k))        # 1D shape values per direction
        self._Ld = np.empty((m, 2, k))        # and derivatives
        self._A = np.empty((m, 3, k))         # rows (N, dN/dxi, dN/deta) = A_j B_i
        self._B = np.empty((m, 3, k))
        if k == 2:                            # linear: constant derivatives
            self._Ld[:] = [-0.5, 0.5]
            self._A[:, 2] = self._Ld[:, 1]
            self._B[:, 1] = self._Ld[:, 0]
        # Coefficients (NF x nr per point) of the points-to-grid product; the entries that
        # are always zero stay zero.
        self._K = np.zeros((m, NF, self.nr))
        self._Wp = np.empty((m, self.nr, nen)) if self.hrz else None
        self._C = np.empty(NF * m * nen)
        self._idx = np.empty(NF * m * nen, dtype=np.int64)
        self._acc = None if n <= CHUNK else np.empty((NF, self.ng))
        self._H = np.empty((m, nen, NG))
        self._R = np.empty((m, 3, NG))
        self._t3 = np.empty((m, 3))
        self._t3b = np.empty((m, 3))
        self._t2 = np.empty((m, 2))
        self._t1 = np.empty(m)
        self._t1b = np.empty(m)
        self._t1c = np.empty(m)
        self._gen = pts.generation

    # -- one step --------------------------------------------------------------------------
    def step(self, dt: float, load_factor: float, damping: float, flip: float):
        """Advance the points by one explicit step of dt (s); load_factor scales the surface
        load, damping is the local damping coefficient, flip the FLIP fraction."""
        self._prepare()
        n = self.n_local
        self.ev_p2g.begin()
        if n <= CHUNK:
            # One pass: its bincount spans the whole ghosted node set directly.
            acc = (self._p2g(0, n, True)[2] if n else np.zeros(NF * self.ng)).reshape(NF, -1)
        else:
            acc = self._acc
            acc.fill(0.0)
            for s in range(0, n, CHUNK):
                lo, span, part = self._p2g(s, min(s + CHUNK, n), False)
                acc[:, lo:lo + span] += part.reshape(NF, span)
        if self.serial:
            G, locg = acc, self._locg
            O = locg.T
        else:
            np.copyto(self.loc_f.getArray().reshape(self.ng, NF), acc.T)
            self.glob_f.zeroEntries()
            self.da_f.localToGlobal(self.loc_f, self.glob_f, addv=PETSc.InsertMode.ADD_VALUES)
            G = self.glob_f.getArray().reshape(-1, NF).T
            O = self.glob_g.getArray().reshape(-1, NG).T
        self.ev_p2g.end()

        self.ev_nodal.begin()
        self._nodal(G, O, dt, load_factor, damping)
        if not self.serial:
            self.da_g.globalToLocal(self.glob_g, self.loc_g)
            locg = self.loc_g.getArray().reshape(-1, NG)
        self.ev_nodal.end()

        self.ev_g2p.begin()
        for s in range(0, n, CHUNK):
            self._g2p(s, min(s + CHUNK, n), locg, dt, flip)
        self.ev_g2p.end()

    def _shape_rows(self, sn, W):
        """Rows N, dN/dx, dN/dy (W, (m, 3, nen)) at natural coordinates sn (m, 2)."""
        m = len(sn)
        if self.grid.element == "q8":
            N, dN = shapes.evaluate("q8", sn[:, 0], sn[:, 1])
            W[:, 0] = N
            W[:, 1:3] = dN.transpose(0, 2, 1)
        else:
            # Lagrange cells: N_a = l_i(xi) l_j(eta) for node a = (i, j), a = j (p + 1) + i,
            # so each row is the outer product of a row of A (eta) and one of B (xi); the
            # 1D polynomials as in shapes.lagrange1d.
            Lv, Ld, A, B = self._Lv[:m], self._Ld[:m], self._A[:m], self._B[:m]
            if self._order == 1:
                np.subtract(1.0, sn, out=Lv[:, :, 0])          # (1 - s) / 2
                np.add(1.0, sn, out=Lv[:, :, 1])               # (1 + s) / 2
                Lv /= 2
            else:
                v0, v1, v2 = Lv[:, :, 0], Lv[:, :, 1], Lv[:, :, 2]
                np.subtract(sn, 1.0, out=v0)                   # s (s - 1) / 2
                v0 *= sn
                np.multiply(sn, sn, out=v1)                    # 1 - s^2
                np.subtract(1.0, v1, out=v1)
                np.add(sn, 1.0, out=v2)                        # s (s + 1) / 2
                v2 *= sn
                Lv[:, :, 0::2] /= 2
                np.subtract(sn, 0.5, out=Ld[:, :, 0])          # s - 1/2, -2 s, s + 1/2
                np.multiply(sn, -2.0, out=Ld[:, :, 1])
                np.add(sn, 0.5, out=Ld[:, :, 2])
                np.copyto(A[:, 2], Ld[:, 1])
                np.copyto(B[:, 1], Ld[:, 0])
            np.copyto(A[:, 0:2], Lv[:, None, 1])
            np.copyto(B[:, 0::2], Lv[:, None, 0])
            k = self._order + 1
            np.multiply(A[:, :, :, None], B[:, :, None, :], out=W.reshape(m, 3, k, k))
        W[:, 1:3] *= self._scale

    def _p2g(self, s, e, whole):
        """Points s:e to grid: (lo, span, sums), sums of the NF fields (field-major) over
        the ghosted-local nodes lo:lo+span (all of them when ``whole``)."""
        m, nen, nr = e - s, self._nen, self.nr
        x = self.x[s:e]
        # Cells and natural coordinates, as Grid.locate (same operations, in place).
        u, ci, sn = self._u[:m], self._ci[:m], self._s[:m]
        np.divide(x, self._h, out=u)
        np.floor(u, out=u)
        np.copyto(ci, u, casting="unsafe")
        np.clip(ci, 0, self._cmax, out=ci)
        np.multiply(ci, self._h, out=sn)
        np.subtract(x, sn, out=sn)
        sn *= 2
        sn /= self._h
        sn -= 1
        W, nodes = self.W[s:e], self.nodes[s:e]
        self._shape_rows(sn, W)
        np.add(np.dot(ci, self._stride)[:, None], self._offl, out=nodes)

        # Coefficients: row w -> V, V v_s, V v_l (fields 0-4); rows dN/dx, dN/dy -> the
        # forces -sigma_total V (fields 5, 6) and p V (fields 7, 8).
        V, vs, vl, sig, pp = self.V[s:e], self.vs[s:e], self.vl[s:e], self.sig[s:e], \
            self.pp[s:e]
        K = self._K[:m]
        Kf = K.reshape(m, NF * nr)
        t1, t2 = self._t1[:m], self._t2[:m]
        np.copyto(K[:, 0, 0], V)
        np.multiply(vs, V[:, None], out=K[:, 1:3, 0])
        np.multiply(vl, V[:, None], out=K[:, 3:5, 0])
        np.subtract(pp[:, None], sig[:, 0:2], out=t2)                  # -(sigma' - p)
        np.multiply(t2, V[:, None], out=Kf[:, 5 * nr + 1:6 * nr + 3:nr + 1])   # K[5,1], K[6,2]
        np.multiply(sig[:, 2], V, out=t1)
        np.negative(t1[:, None], out=Kf[:, 5 * nr + 2:6 * nr + 2:nr - 1])       # K[5,2], K[6,1]
        np.multiply(pp, V, out=t1)
        np.copyto(Kf[:, 7 * nr + 1:8 * nr + 3:nr + 1], t1[:, None])            # K[7,1], K[8,2]
        if self.p.gravity:
            # Body force of the mixture and of the liquid, distributed with N.
            col = 3 if self.hrz else 0
            g = self.gvec[1]
            np.multiply(V, ((1 - self.n) * self.p.rho_s + self.n * self.p.rho_l) * g,
                        out=K[:, 6, col])
            np.multiply(V, self.p.rho_l * g, out=K[:, 8, col])
        if self.hrz:
            Wp = self._Wp[:m]
            Wp[:, 0] = assembly.lumping_weights(W[:, 0], self.lumping)
            Wp[:, 1:3] = W[:, 1:3]
            if nr == 4:
                Wp[:, 3] = W[:, 0]
        else:
            Wp = W
        C = self._C[:NF * m * nen].reshape(NF, m, nen)
        np.matmul(K, Wp, out=C.transpose(1, 0, 2))
        if whole:
            lo, span = 0, self.ng
        else:
            # Points are mostly sorted by cell (placed so, and they move little): the chunk
            # touches a narrow band of nodes, and the sums need only that band.
            lo = int(nodes.min())
            span = int(nodes.max()) - lo + 1
        idx = self._idx[:NF * m * nen].reshape(NF, m * nen)
        np.add(nodes.reshape(1, -1), self._frow * span - lo, out=idx)
        return lo, span, np.bincount(idx.ravel(), weights=C.ravel(), minlength=NF * span)

    def _nodal(self, G, O, dt, load_factor, damping):
        """Nodal accelerations and velocities (eqs. 13, 14, 6) of the owned nodes from the
        field-major sums G (NF, nown) into O (NG, nown)."""
        S = G[0]
        has = S > 0
        invS = np.zeros_like(S)
        np.divide(1.0, S, out=invS, where=has)
        vn = G[1:5] * invS                       # v_s (rows 0, 1) and v_l (rows 2, 3)
        vs_n, vl_n = vn[0:2], vn[2:4]
        fm = G[5:7]                              # G is scratch: changed in place
        fm[1] += load_factor * self.traction
        if damping:
            # Local (Cundall) damping of the mixture's unbalanced force only: it takes
            # the undrained wave out, in which both phases move together, and leaves the
            # drag (which the liquid equation integrates explicitly) untouched. The sign of
            # the mixture momentum M_s v_s + M_l v_l is that of c_s v_s + c_l v_l (S > 0).
            v_mix = self.c_s * vs_n
            v_mix += self.c_l * vl_n
            damp = np.abs(fm)
            damp *= np.sign(v_mix)
            damp *= damping
            fm -= damp
        a_s, a_l = O[0:2], O[2:4]
        rel = np.subtract(vl_n, vs_n)
        rel *= self.c_q * S                      # Q (v_l - v_s)
        np.subtract(G[7:9], rel, out=a_l)
        a_l *= invS * (1.0 / self.c_t)           # / M~_l
        np.multiply(a_l, self.c_l * S, out=a_s)  # M_l a_l
        np.subtract(fm, a_s, out=a_s)
        a_s *= invS * (1.0 / self.c_s)           # / M_s
        np.copyto(a_s, 0.0, where=self._fix_s)
        np.copyto(vs_n, 0.0, where=self._fix_s)
        np.copyto(a_l, 0.0, where=self._fix_l)
        np.copyto(vl_n, 0.0, where=self._fix_l)
        np.multiply(a_s, dt, out=O[4:6])
        O[4:6] += vs_n
        np.multiply(a_l, dt, out=O[6:8])
        O[6:8] += vl_n

    def _g2p(self, s, e, locg, dt, flip):
        """Grid to points s:e: velocities, stress, pore pressure, positions, volume ratio."""
        m = e - s
        H, R = self._H[:m], self._R[:m]
        locg.take(self.nodes[s:e], axis=0, out=H, mode="clip")   # (m, nen, NG)
        np.matmul(self.W[s:e], H, out=R)          # rows N, dN/dx, dN/dy times the fields
        Rf = R.reshape(m, 3 * NG)
        vs, vl, x = self.vs[s:e], self.vl[s:e], self.x[s:e]
        t1, t1b, t1c = self._t1[:m], self._t1b[:m], self._t1c[:m]
        t2, t3 = self._t2[:m], self._t3[:m]
        if flip == 1.0:
            np.multiply(R[:, 0, 0:2], dt, out=t2)
            vs += t2
            np.multiply(R[:, 0, 2:4], dt, out=t2)
            vl += t2
        else:
            vs[:] = flip * (vs + dt * R[:, 0, 0:2]) + (1 - flip) * R[:, 0, 4:6]
            vl[:] = flip * (vl + dt * R[:, 0, 2:4]) + (1 - flip) * R[:, 0, 6:8]
        # grad v_s [i, j] = R[:, 1 + j, 4 + i]; div v_l = R[:, 1, 6] + R[:, 2, 7].
        np.add(Rf[:, 12], Rf[:, 21], out=t1)                  # div v_s
        np.copyto(t3[:, 0:2], Rf[:, 12:22:9])                 # eps_xx, eps_yy
        np.add(Rf[:, 20], Rf[:, 13], out=t3[:, 2])            # gamma_xy
        t3 *= dt
        sig = self.sig[s:e]
        sig += np.matmul(t3, self.DT, out=self._t3b[:m])      # d sigma' = D d eps
        np.add(Rf[:, 14], Rf[:, 23], out=t1b)                 # div v_l
        t1b *= self.n
        np.multiply(t1, 1 - self.n, out=t1c)
        t1c += t1b
        t1c *= dt * self.p.K_l / self.n
        self.pp[s:e] -= t1c                                    # eqs. 8-9
        np.multiply(R[:, 0, 4:6], dt, out=t2)
        x += t2
        t1 *= dt
        t1 += 1
        self.J[s:e] *= t1          # volume ratio of the solid, to catch inversion

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
        self.ev_migrate.begin()
        if self.serial:
            self.ev_migrate.end()
            return np.array(flags, dtype=np.int64)
        self._prepare()
        # A point stays when its cell, floor(x / h) clipped to the grid as Grid.locate
        # computes it, is in this rank's box: lo <= x / h < hi in the partitioned
        # directions. A non-finite position fails the test and takes the general path.
        moving = 0
        for d, h, lo, hi in self._box:
            u = self.x[:, d] / h
            if not ((u >= lo) & (u < hi)).all():
                moving = 1
        if self._flags is None or len(self._flags) != 1 + len(flags):
            self._flags = np.empty(1 + len(flags), dtype=np.int64)
            self._flags_out = np.empty(1 + len(flags), dtype=np.int64)
        self._flags[0] = moving
        self._flags[1:] = flags
        from mpi4py import MPI

        self.mpi.Allreduce(self._flags, self._flags_out, op=MPI.MAX)
        out = self._flags_out.copy()
        if out[0]:
            cx, cy, _, _ = self.grid.locate(self.x)
            self.points.migrate(self.grid.cell_owner(cx, cy))
        self.ev_migrate.end()
        return out[1:]
