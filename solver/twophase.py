"""Explicit single-point two-phase (v-w) MPM step (paper Section 2.2, eqs. 6-15).

Sign conventions: stresses are tension positive, the pore pressure p compression positive,
so the total stress is sigma = sigma' - m p (the paper's eq. 15 in compression-positive form).

One step, with every nodal quantity lumped (a diagonal):
1. Points to grid. Porosity and densities are uniform, so every lumped mass is a constant
   times S = sum w V (m3): M_s = (1 - n) rho_s S, M_l = n rho_l S, the liquid "mass"
   M~_l = rho_l S and the drag Q = (n mu_l / kappa_l) S (eq. 12); likewise the momenta are
   (1 - n) rho_s sum w V v_s and n rho_l sum w V v_l. Nine nodal fields are summed: S,
   sum w V v_s (2), sum w V v_l (2), the mixture force f_m = f_ext - sum B^T sigma V (2) and
   the liquid force f_l = sum p grad(N) V (2) (+ gravity). Per point and node they are
   w, dN/dx or dN/dy times per-point coefficients, summed over the nodes by one np.bincount
   and, over the ranks, by one localToGlobal(ADD) of a ghosted 9-field Vec.
2. Nodal accelerations (eqs. 13, 14), pointwise: explicit drag a_l = (f_l - Q (v_l - v_s))
   / M~_l, a_s = (f_m - M_l a_l) / M_s, or implicit drag (backward Euler on the relative
   velocity, a closed-form 2 x 2 solve per node and direction, ``_implicit_drag``);
   optional local damping; fixed DOFs held; then v^{k+1} = v^k + dt a^k (eq. 6). Mass
   scaling (-mpm_mass_scaling S) multiplies every inertia (M_s, M_l, M~_l) by S.
3. Grid to points: point velocities (FLIP, or a FLIP/PIC blend), strain rate from the nodal
   v_s^{k+1}, effective stress by linear elasticity, pore pressure from eqs. 8-9
   (dp = -K_l / n [(1 - n) div v_s + n div v_l] dt), positions x += dt v_s^{k+1}.
Porosity, volumes and masses stay at their initial values (small strain: the paper neglects
spatial variation of density and porosity, and the analytic references are linear).

Scheme options (``assembly.step_scheme``, docs/method.md): shape functions at the points'
initial positions x0 (small kinematics) or current ones (large); pore-pressure increments
kept per point or projected through the nodes; the liquid equation in the element's basis or
in the blended basis N_hat = N/2 + N_Q4/2 (Q8), which then also gives its masses and drag
(a tenth nodal field S_l = sum N_hat V), its velocity transfers and the relative motion in
the storage equation, dp = -(K_l / n) [div v_s + n div_hat(v_l - v_s)] dt.

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
from .timestep import drag_coefficient, impermeable, mixture_density, wave_speeds

NF = 9    # nodal fields summed from the points: S, V v_s (2), V v_l (2), f_m (2), f_l (2),
#           and S_l = sum N_hat V (the liquid's own weights) with a blended liquid basis
NG = 8    # fields sent back to the points: a_s(2), a_l(2), v_s(2), v_l(2)
CHUNK = 4096   # points per pass (about 1.5 MB of Q4 work arrays: within a core's L2 cache)

# Material-point fields of the consolidation run (besides x, volume, mass).
POINT_FIELDS = {"vs": 2, "vl": 2, "stress": 3, "p": 1, "x0": 2, "monitor": 1, "id": 1,
                "J": 1}


def point_fields(p) -> dict:
    """The point fields of scene ``p``: POINT_FIELDS, with the viscous stress (Pa) of
    -mpm_bulk_viscosity and the slow mixture velocity (m/s) of -mpm_fast_damping when on."""
    fields = dict(POINT_FIELDS)
    if p.bulk_viscosity > 0:
        fields["visc"] = 1
    if p.fast_damping > 0:
        fields["vslow"] = 2
    return fields

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
    go through ``MaterialPoints`` (it bumps the generation). The reference positions x0 are
    constants of the run: with small kinematics a one-pass model evaluates its shape
    functions once."""

    def __init__(self, grid, points, p, bcs, scheme):
        self.grid, self.points, self.p = grid, points, p
        self.lumping = lumping = scheme["lumping"]
        # Small kinematics: shape functions at the initial positions x0 (a point's cell never
        # changes, so nothing migrates); large: at the current positions.
        self.small = scheme["kinematics"] == "small"
        self.project = scheme["pressure_projection"] == "nodal"
        self.blend = scheme["liquid_basis"] == "blended"
        self.nf = NF + self.blend
        self.D = assembly.elasticity(p.E, p.nu)
        self.gvec = np.array([0.0, -p.gravity])
        n = p.porosity
        self.n = n
        self.drag = drag_coefficient(p)                     # eq. 12 (kg/m3/s)
        self.implicit = scheme["drag"] == "implicit"
        # Lumped quantities per unit S = sum w V (uniform porosity and densities). Mass
        # scaling multiplies the inertia only: the drag and the weight stay physical.
        inertia = scheme["mass_scaling"]
        self.c_s = (1 - n) * p.rho_s * inertia              # M_s / S, kg/m3
        self.c_l = n * p.rho_l * inertia                    # M_l / S
        self.c_t = p.rho_l * inertia                        # M~_l / S
        self.c_q = self.drag                                # Q / S, kg/m3/s
        self._damping_terms(p, inertia)
        # Lumping weights other than N (HRZ) are computed per step from N.
        self.hrz = lumping != "rowsum"
        self.serial = grid.comm.getSize() == 1
        self.mpi = grid.comm.tompi4py()
        self.ng = grid.gxm * grid.gym
        self.nown = (grid.xe - grid.xs) * (grid.ye - grid.ys)
        # One rank: the ghosted local and the global node sets are the same (the grid is not
        # periodic), so the nodal sums need no PETSc scatter.
        assert not self.serial or self.ng == self.nown
        if not self.serial:
            self.da_f = grid.da.duplicate(dof=self.nf)
            self.da_g = grid.da.duplicate(dof=NG)
            self.loc_f, self.glob_f = self.da_f.createLocalVec(), self.da_f.createGlobalVec()
            self.loc_g, self.glob_g = self.da_g.createLocalVec(), self.da_g.createGlobalVec()
            if self.project:
                self.da_p = grid.da.duplicate(dof=1)
                self.loc_p, self.glob_p = self.da_p.createLocalVec(), self.da_p.createGlobalVec()
        self.fixed_s = grid.constrained_mask(bcs).reshape(-1, 2)
        self.fixed_l = grid.constrained_mask(impermeable(p.drained)).reshape(-1, 2)
        # 0 on the fixed DOFs of (a_s, a_l, v_s, v_l), 1 elsewhere: (NG, nown), field-major.
        free = np.vstack([~self.fixed_s.T, ~self.fixed_l.T]).astype(float)
        self._free = np.vstack([free, free])
        self.traction = self._traction(p.load)
        # Nodal accelerations and velocities of the ghosted-local nodes, field-major.
        self._locgT = np.zeros((NG, self.ng))
        # Geometry of the shape-function evaluation and of the node numbering.
        self._h2 = np.array(grid.h).reshape(2, 1)
        self._scale = (2.0 / self._h2).reshape(2, 1)            # d(xi, eta)/d(x, y), 1/m
        self._cmax2 = np.array([[grid.cells[0] - 1.0], [grid.cells[1] - 1.0]])
        # Linear cells: dl/dxi = -+1/2, so dl/dx = -+1/h (exactly, a power-of-2 scaling).
        self._dL = np.array([-0.5, 0.5]) * self._scale
        self._order = grid.p
        off = grid.offsets
        self._nen = len(off)
        # Ghosted-local node of local node a of cell (cx, cy): p cx + p gxm cy + offl[a].
        self._stride = np.array([grid.p, grid.p * grid.gxm], dtype=np.int64)
        self._offl = (off[:, 1] - grid.gys) * grid.gxm + (off[:, 0] - grid.gxs)
        self._offl_min, self._offl_max = int(self._offl.min()), int(self._offl.max())
        self._frow = np.arange(self.nf, dtype=np.int64)[:, None, None]
        self._invS = np.zeros(self.nown)            # 1 / S of the owned nodes, this step
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
    def _damping_terms(self, p, S):
        """Coefficients of the two damping terms beside local damping (0: off): the bulk
        viscosity eta = b1 rho c1 h (Pa s), and the fast-part damping rate 2 zeta w1 and
        low-pass rate w1 (1/s), from the wave with inertia scaled by S."""
        b1 = getattr(p, "bulk_viscosity", 0.0)
        zeta = getattr(p, "fast_damping", 0.0)
        c1 = float(wave_speeds(p, S)["c1"])
        self.eta = b1 * mixture_density(p) * S * c1 * min(self.grid.h)
        w1 = 2 * np.pi * c1 / (4 * p.size[1])
        self.fast_rate, self.slow_rate = 2 * zeta * w1, (w1 if zeta > 0 else 0.0)

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
        (self.x, self.x0, self.V, self.vs, self.vl, self.sig, self.pp,
         self.J) = pts.views("x", "x0", "volume", "vs", "vl", "stress", "p", "J")
        self.visc = pts.views("visc") if self.eta else None
        self.vslow = pts.views("vslow") if self.fast_rate else None
        self.xref = self.x0 if self.small else self.x
        n, nen, k = pts.n_local, self._nen, self._order + 1
        self.n_local = n
        # Work arrays are field-major, (fields, ..., points): every NumPy operation then runs
        # one long loop over the points (broadcasting over short trailing axes is several
        # times slower per element).
        m = max(1, min(n, CHUNK))
        # Rows N, dN/dx, dN/dy (1, 1/m, 1/m) and ghosted-local node numbers of a chunk,
        # (3, nen, m) and (nen, m). Grid-to-points computes them again from the same
        # positions: that is cheaper than keeping them for all points (memory traffic,
        # 128 bytes per Q4 point), except for a one-pass model, which keeps them.
        self.W = np.empty((3, nen, m))
        # Rows N_hat, dN_hat/dx, dN_hat/dy of the blended liquid basis (else those of N).
        self.Wl = np.empty((3, nen, m)) if self.blend else self.W
        self.nodes = np.empty((nen, m), dtype=np.int64)
        self._c = np.empty((2, m))                 # cell indices, as floats
        self._ci = np.empty((2, m), dtype=np.int64)
        self._base = np.empty(m, dtype=np.int64)
        self._Lv = np.empty((2, k, m))             # 1D shape values per direction
        self._Ld = np.empty((2, k, m))             # and their derivatives
        self._s = np.empty((2, m))                 # natural coordinates (quadratic cells)
        self._w = np.empty((nen, m)) if self.hrz else None
        self._Kw = np.empty((4, m))                # V v_s, V v_l
        self._T = np.empty((4, m))                 # -(sigma' - p) V, row-major 2 x 2
        self._C = np.empty(self.nf * nen * m)      # (nf, nen, m) per chunk
        self._C2 = np.empty((2, nen, m))
        self._idx = np.empty(self.nf * nen * m, dtype=np.int64)
        self._idx_cells = None                     # cells the kept index was built for
        self._acc = None if n <= CHUNK else np.empty((self.nf, self.ng))
        # Pressure projection: nodal sums of the points' increments, sum w V dp.
        self._accp = np.empty(self.ng) if self.project else None
        self._H = np.empty(NG * nen * m)           # (NG, nen, m) per chunk
        self._at = np.empty((NG, m))
        self._Ls = np.empty((2, 2, m))
        self._E = np.empty((3, m))
        self._E2 = np.empty((3, m))
        self._t2 = np.empty((2, m))
        self._t1 = np.empty(m)
        self._t1b = np.empty(m)
        self._t1c = np.empty(m)
        # Small kinematics in one pass: the rows at x0 are constants, computed once.
        self._kept = False
        self._gen = pts.generation

    # -- one step --------------------------------------------------------------------------
    def step(self, dt: float, load_factor: float, damping: float, flip: float):
        """Advance the points by one explicit step of dt (s); load_factor scales the surface
        load, damping is the local damping coefficient, flip the FLIP fraction."""
        self._prepare()
        n = self.n_local
        nf = self.nf
        self.ev_p2g.begin()
        if n <= CHUNK:
            # One pass: its bincount spans the whole ghosted node set directly.
            acc = (self._p2g(0, n, True)[2] if n else np.zeros(nf * self.ng)).reshape(nf, -1)
        else:
            acc = self._acc
            acc.fill(0.0)
            for s in range(0, n, CHUNK):
                lo, span, part = self._p2g(s, min(s + CHUNK, n), False)
                acc[:, lo:lo + span] += part.reshape(nf, span)
        if self.serial:
            G, O = acc, self._locgT
        else:
            np.copyto(self.loc_f.getArray().reshape(self.ng, nf), acc.T)
            self.glob_f.zeroEntries()
            self.da_f.localToGlobal(self.loc_f, self.glob_f, addv=PETSc.InsertMode.ADD_VALUES)
            G = self.glob_f.getArray().reshape(-1, nf).T
            O = self.glob_g.getArray().reshape(-1, NG).T
        self.ev_p2g.end()

        self.ev_nodal.begin()
        self._nodal(G, O, dt, load_factor, damping)
        if not self.serial:
            self.da_g.globalToLocal(self.glob_g, self.loc_g)
            np.copyto(self._locgT, self.loc_g.getArray().reshape(-1, NG).T)
        self.ev_nodal.end()

        self.ev_g2p.begin()
        if self.project:
            self._accp.fill(0.0)
        for s in range(0, n, CHUNK):
            self._g2p(s, min(s + CHUNK, n), n <= CHUNK, dt, flip)
        if self.project:
            self._project(n)
        self.ev_g2p.end()

    def _project(self, n):
        """Pore-pressure increments through the nodes: lumped L2 projection of the points'
        increments dp onto the nodal field (sum w V dp / S) and its interpolation back."""
        if self.serial:
            pn = self._accp
            pn *= self._invS
        else:
            np.copyto(self.loc_p.getArray(), self._accp)
            self.glob_p.zeroEntries()
            self.da_p.localToGlobal(self.loc_p, self.glob_p, addv=PETSc.InsertMode.ADD_VALUES)
            self.glob_p.getArray()[:] *= self._invS
            self.da_p.globalToLocal(self.glob_p, self.loc_p)
            pn = self.loc_p.getArray()
        for s in range(0, n, CHUNK):
            e = min(s + CHUNK, n)
            if n <= CHUNK and self.small:
                W, nodes = self.W[:, :, :n], self.nodes[:, :n]     # kept, at x0
            else:
                # Large kinematics: at the points' new positions, whatever the chunking.
                W, nodes = self._interpolate(s, e, False)[:2]
            self.pp[s:e] -= np.einsum("am,am->m", W[0], pn[nodes])

    def _shape_rows(self, t, m, W):
        """Rows N, dN/dx, dN/dy (W, (3, nen, m)) from the local coordinates t = (x - x_cell)
        / h in [0, 1] (2, m) of the points in their cells."""
        k = self._order + 1
        if self.grid.element == "q8" or self.blend:
            s = np.multiply(t, 2.0, out=self._s[:, :m])
            s -= 1.0
            N, dN = shapes.evaluate(self.grid.element, s[0], s[1])
            rows = [(W, N, dN)]
            if self.blend:
                rows.append((self.Wl[:, :, :m],
                             *shapes.blended(self.grid.element, N, dN, s[0], s[1])))
            for Wr, Nr, dNr in rows:
                Wr[0] = Nr.T
                Wr[1:3] = dNr.transpose(2, 1, 0)
                Wr[1:3] *= self._scale[:, :, None]
            return
        # Lagrange cells: N_a = l_i(xi) l_j(eta) for node a = (i, j), a = j (p + 1) + i: each
        # row is an outer product of 1D polynomials (as in shapes.lagrange1d) in x and y.
        Lv, Ld = self._Lv[:, :, :m], self._Ld[:, :, :m]
        Wn, Wx, Wy = (W[r].reshape(k, k, m) for r in range(3))
        if k == 2:
            # (1 - xi) / 2 = 1 - t, (1 + xi) / 2 = t; derivatives -+1/2 in xi, -+1/h in x.
            np.subtract(1.0, Lv[:, 1], out=Lv[:, 0])
            np.multiply(Lv[1][:, None], Lv[0][None, :], out=Wn)
            np.multiply(Lv[1][:, None], self._dL[0][None, :, None], out=Wx)
            np.multiply(self._dL[1][:, None, None], Lv[0][None, :], out=Wy)
            return
        s = np.multiply(t, 2.0, out=self._s[:, :m])
        s -= 1.0
        v0, v1, v2 = Lv[:, 0], Lv[:, 1], Lv[:, 2]
        np.subtract(s, 1.0, out=v0)                   # s (s - 1) / 2
        v0 *= s
        np.multiply(s, s, out=v1)                     # 1 - s^2
        np.subtract(1.0, v1, out=v1)
        np.add(s, 1.0, out=v2)                        # s (s + 1) / 2
        v2 *= s
        Lv[:, 0::2] /= 2
        np.subtract(s, 0.5, out=Ld[:, 0])             # s - 1/2, -2 s, s + 1/2
        np.multiply(s, -2.0, out=Ld[:, 1])
        np.add(s, 0.5, out=Ld[:, 2])
        np.multiply(Lv[1][:, None], Lv[0][None, :], out=Wn)
        np.multiply(Lv[1][:, None], Ld[0][None, :], out=Wx)
        Wx *= self._scale[0, 0]
        np.multiply(Ld[1][:, None], Lv[0][None, :], out=Wy)
        Wy *= self._scale[1, 0]

    def _interpolate(self, s, e, whole):
        """Shape-function rows and node numbers of points s:e (self.W, self.nodes, first
        e - s columns); returns (W, nodes, base, same), ``base`` the cells' first node and
        ``same`` whether the cells are those of the kept bincount index (one-pass model)."""
        m = e - s
        if whole and self._kept:
            return self.W[:, :, :m], self.nodes[:, :m], self._base[:m], True
        self._kept = whole and self.small
        # Cells as Grid.locate finds them (floor(x / h), clipped to the grid; NaN gives cell
        # 0 there and here) and the local coordinates t = x / h - cell in them (the natural
        # coordinates are 2 t - 1).
        c, ci, Lv = self._c[:, :m], self._ci[:, :m], self._Lv[:, :, :m]
        t = Lv[:, -1]
        np.divide(self.xref[s:e].T, self._h2, out=t)
        np.floor(t, out=c)
        np.fmax(c, 0.0, out=c)                  # fmax: NaN -> 0
        np.fmin(c, self._cmax2, out=c)
        t -= c
        np.copyto(ci, c, casting="unsafe")
        W, nodes, base = self.W[:, :, :m], self.nodes[:, :m], self._base[:m]
        self._shape_rows(t, m, W)
        # One pass over all points (a small model): node numbers and the bincount index only
        # change when a point changes cell, which is rare; otherwise keep them.
        same = whole and self._idx_cells is not None and (ci == self._idx_cells).all()
        if not same:
            np.multiply(ci[0], self._stride[0], out=base)
            base += ci[1] * self._stride[1]
            np.add(base, self._offl[:, None], out=nodes)
        return W, nodes, base, same

    def _p2g(self, s, e, whole):
        """Points s:e to grid: (lo, span, sums), sums of the nf fields (field-major) over
        the ghosted-local nodes lo:lo+span (all of them when ``whole``)."""
        m, nen, nf = e - s, self._nen, self.nf
        kept = whole and self._kept
        W, nodes, base, same = self._interpolate(s, e, whole)
        Wl = self.Wl[:, :, :m]

        # Per point and node: w V, w V v_s, w_l V v_l (fields 0-4); the forces
        # -(sigma' - p I) V grad N (fields 5, 6) and p V grad N_l (fields 7, 8); w_l V
        # (field 9) with a blended liquid basis, whose N_hat is then w_l and N_l.
        V, pp, sig = self.V[s:e], self.pp[s:e], self.sig[s:e]
        C = self._C[:nf * nen * m].reshape(nf, nen, m)
        w = self._weights(W, m, kept)
        Kw, T, t1 = self._Kw[:, :m], self._T[:, :m], self._t1[:m]
        np.multiply(self.vs[s:e].T, V, out=Kw[0:2])
        np.multiply(self.vl[s:e].T, V, out=Kw[2:4])
        np.multiply(w, V, out=C[0])
        np.multiply(w, Kw[0:2, None], out=C[1:3])
        np.multiply(Wl[0] if self.blend else w, Kw[2:4, None], out=C[3:5])
        if self.blend:
            np.multiply(Wl[0], V, out=C[9])
        np.subtract(pp, sig[:, 0:2].T, out=self._t2[:, :m])
        if self.eta:
            self._t2[:, :m] -= self.visc[s:e]          # the viscous stress, on the mixture
        np.multiply(self._t2[:, :m], V, out=T[0::3])           # -(s_xx - p) V, -(s_yy - p) V
        np.multiply(sig[:, 2], V, out=t1)
        np.negative(t1, out=T[1:3])                             # -s_xy V
        T = T.reshape(2, 2, m)
        np.multiply(W[1], T[:, 0, None], out=C[5:7])
        C2 = self._C2[:, :, :m]
        np.multiply(W[2], T[:, 1, None], out=C2)
        C[5:7] += C2
        np.multiply(pp, V, out=t1)
        np.multiply(Wl[1:3], t1, out=C[7:9])
        if self.p.gravity:
            # Body forces of the mixture (with N) and of the liquid (with N_l).
            g = self.gvec[1]
            np.multiply(V, ((1 - self.n) * self.p.rho_s + self.n * self.p.rho_l) * g, out=t1)
            C[6] += np.multiply(W[0], t1, out=C2[0])
            np.multiply(V, self.p.rho_l * g, out=t1)
            C[8] += np.multiply(Wl[0], t1, out=C2[0])
        idx = self._idx[:nf * nen * m].reshape(nf, nen, m)
        if whole:
            lo, span = 0, self.ng
            if not same:
                np.add(nodes, self._frow * span, out=idx)
                self._idx_cells = self._ci[:, :m].copy()
        else:
            # Points are mostly sorted by cell (placed so, and they move little): the chunk
            # touches a narrow band of nodes, and the sums need only that band.
            lo = int(base.min()) + self._offl_min
            span = int(base.max()) + self._offl_max - lo + 1
            np.add(nodes, self._frow * span - lo, out=idx)
        return lo, span, np.bincount(idx.ravel(), weights=C.ravel(), minlength=nf * span)

    def _weights(self, W, m, kept=False):
        """Lumping weights w (nen, m) of the chunk's points from its rows W (``kept``: those
        computed last time, for the same rows)."""
        if not self.hrz:
            return W[0]
        w = self._w[:, :m]
        if not kept:
            np.copyto(w, assembly.lumping_weights(W[0].T, self.lumping).T)
        return w

    def _nodal(self, G, O, dt, load_factor, damping):
        """Nodal accelerations and velocities (eqs. 13, 14, 6) of the owned nodes from the
        field-major sums G (nf, nown) into O (NG, nown)."""
        S = G[0]
        invS = self._invS
        invS.fill(0.0)
        np.divide(1.0, S, out=invS, where=S > 0)
        if self.blend:
            # The liquid's masses and drag from its own weights: S_l = sum N_hat V.
            Sl = G[9]
            invSl = np.divide(1.0, Sl, out=np.zeros_like(Sl), where=Sl > 0)
        else:
            Sl, invSl = S, invS
        vn = np.empty((4, len(S)))
        np.multiply(G[1:3], invS, out=vn[0:2])   # v_s
        np.multiply(G[3:5], invSl, out=vn[2:4])  # v_l
        vs_n, vl_n = vn[0:2], vn[2:4]
        fm = G[5:7]                              # G is scratch: changed in place
        fm[1] += load_factor * self.traction
        if damping:
            # Local (Cundall) damping of the mixture's unbalanced force only: it takes
            # the undrained wave out, in which both phases move together, and leaves the
            # drag (which the liquid equation integrates explicitly) untouched. The sign of
            # the mixture momentum M_s v_s + M_l v_l is that of c_s v_s + c_l (S_l / S) v_l.
            v_mix = self.c_s * vs_n
            v_mix += self.c_l * (vl_n * (Sl * invS) if self.blend else vl_n)
            damp = np.abs(fm)
            damp *= np.sign(v_mix)
            damp *= damping
            fm -= damp
        if self.implicit:
            self._implicit_drag(G[7:9], fm, vs_n, vl_n, S, Sl, O, dt)
        else:
            a_s, a_l = O[0:2], O[2:4]
            rel = np.subtract(vl_n, vs_n)
            rel *= self.c_q * Sl                     # Q (v_l - v_s)
            np.subtract(G[7:9], rel, out=a_l)
            a_l *= invSl * (1.0 / self.c_t)          # / M~_l
            np.multiply(a_l, self.c_l * Sl, out=a_s)  # M_l a_l
            np.subtract(fm, a_s, out=a_s)
            a_s *= invS * (1.0 / self.c_s)           # / M_s
        np.multiply(O[0:4], dt, out=O[4:8])
        O[4:8] += vn                             # v^{k+1} = v^k + dt a^k
        O *= self._free                          # fixed DOFs: a = 0 and v = 0

    def _implicit_drag(self, fl, fm, vs_n, vl_n, S, Sl, O, dt):
        """Accelerations a_s, a_l (m/s2, into O[0:4]) with the drag of eq. (14) taken
        implicitly, node by node and direction by direction: with the relative velocity at
        the end of the step in the drag,
            M~_l a_l = f_l - Q (w + dt (a_l - a_s)),   M_s a_s + M_l a_l = f_m,
        w = v_l - v_s. The relative acceleration b = a_l - a_s comes first,
            (M~_l M_s / (M_s + M_l) + Q dt) b = f_l - Q w - M~_l f_m / (M_s + M_l),
        then a_s = (f_m - M_l b) / (M_s + M_l), a_l = a_s + b. Where a phase is held
        (a = 0, v = 0), the other alone: a_l = (f_l - Q v_l) / (M~_l + Q dt) on a held
        solid, a_s = f_m / M_s on a held liquid. Backward Euler on the drag is unconditionally
        stable: no 2/lambda limit."""
        Ms, Ml, Mt, Q = self.c_s * S, self.c_l * Sl, self.c_t * Sl, self.c_q * Sl
        # A node without positive mass of a phase (no points, or negative Q9 row sums of an
        # irregular state) holds that phase, as the explicit step's 1/S = 0 there does.
        held_s = self.fixed_s.T | (S <= 0)                       # (2, nown)
        held_l = self.fixed_l.T | (Sl <= 0)
        vs = np.where(held_s, 0.0, vs_n)
        vl = np.where(held_l, 0.0, vl_n)
        Mm = Ms + Ml
        inv_m = np.divide(1.0, Mm, out=np.zeros_like(Mm), where=Mm > 0)
        r = fl - Q * (vl - vs)                                  # f_l - Q w
        den = Mt * Ms * inv_m + Q * dt
        b = np.divide(r - Mt * inv_m * fm, den, out=np.zeros_like(r), where=den > 0)
        a_s, a_l = O[0:2], O[2:4]
        np.multiply(fm - Ml * b, inv_m, out=a_s)
        np.add(a_s, b, out=a_l)
        alone_l = np.divide(r, Mt + Q * dt, out=np.zeros_like(r), where=Sl > 0)
        alone_s = np.divide(fm, Ms, out=np.zeros_like(fm), where=S > 0)
        a_l[:] = np.where(held_l, 0.0, np.where(held_s, alone_l, a_l))
        a_s[:] = np.where(held_s, 0.0, np.where(held_l, alone_s, a_s))

    def _g2p(self, s, e, whole, dt, flip):
        """Grid to points s:e: velocities, stress, pore pressure, positions, volume ratio."""
        m, nen = e - s, self._nen
        if whole:
            W, nodes = self.W[:, :, :m], self.nodes[:, :m]      # kept from points-to-grid
            base = None
        else:
            W, nodes, base = self._interpolate(s, e, False)[:3]   # positions not moved yet
        Wl = self.Wl[:, :, :m]
        H = self._H[:NG * nen * m].reshape(NG, nen, m)
        np.take(self._locgT, nodes, axis=1, out=H, mode="clip")
        nat = 6 if flip == 1.0 else 8
        at = self._at[:nat, :m]
        np.einsum("am,fam->fm", W[0], H[:nat], out=at)          # N-interpolated fields
        if self.blend:
            # The liquid's fields in its own basis.
            np.einsum("am,fam->fm", Wl[0], H[2:4], out=at[2:4])
            if nat == 8:
                np.einsum("am,fam->fm", Wl[0], H[6:8], out=at[6:8])
        Ls = self._Ls[:, :, :m]
        np.einsum("iam,jam->ijm", H[4:6], W[1:3], out=Ls)       # grad v_s [i, j]
        t1, t1b, t1c, t2 = self._t1[:m], self._t1b[:m], self._t1c[:m], self._t2[:, :m]
        np.einsum("iam,iam->m", H[6:8], Wl[1:3], out=t1b)       # div v_l
        if self.blend:
            # div (v_l - v_s) in the liquid's basis: the storage term is then
            # div v_s + n div(v_l - v_s), whose power the liquid force balances exactly
            # (the scheme conserves energy; docs/method.md).
            np.einsum("iam,iam->m", H[4:6], Wl[1:3], out=t1c)
            t1b -= t1c
        vs, vl, x = self.vs[s:e].T, self.vl[s:e].T, self.x[s:e].T
        if flip == 1.0:
            np.multiply(at[0:2], dt, out=t2)
            np.add(vs, t2, out=vs)
            np.multiply(at[2:4], dt, out=t2)
            np.add(vl, t2, out=vl)
        else:
            vs[:] = flip * (vs + dt * at[0:2]) + (1 - flip) * at[4:6]
            vl[:] = flip * (vl + dt * at[2:4]) + (1 - flip) * at[6:8]
        Lf = Ls.reshape(4, m)
        E = self._E[:, :m]
        np.copyto(E[0:2], Lf[0::3])                  # eps_xx, eps_yy
        np.add(Lf[1], Lf[2], out=E[2])               # gamma_xy
        np.add(Lf[0], Lf[3], out=t1)                 # div v_s
        E *= dt
        sig = self.sig[s:e].T
        np.add(sig, np.matmul(self.D, E, out=self._E2[:, :m]), out=sig)   # D d eps
        t1b *= self.n
        np.multiply(t1, 1.0 if self.blend else 1 - self.n, out=t1c)
        t1c += t1b
        t1c *= dt * self.p.K_l / self.n
        if self.project:
            self._accumulate_dp(s, e, W, nodes, base, t1c)
        else:
            self.pp[s:e] -= t1c                      # eqs. 8-9
        np.multiply(at[4:6], dt, out=t2)
        np.add(x, t2, out=x)
        if self.eta:
            np.multiply(t1, self.eta, out=self.visc[s:e])   # eta div v_s
        if self.fast_rate:
            self._damp_fast(s, e, dt)
        t1 *= dt
        t1 += 1
        J = self.J[s:e]
        J *= t1                  # volume ratio of the solid, to catch inversion

    def _damp_fast(self, s, e, dt):
        """Fast-part damping of points s:e: both phases' velocities lose dt 2 zeta w1
        (v_m - v_slow), v_m the mixture velocity (momentum-weighted) and v_slow its low-pass
        over 1/w1; the slow part of the motion (settlement on the consolidation time scale)
        is left alone, and so is the relative velocity w (Darcy flow)."""
        vs, vl, slow = self.vs[s:e].T, self.vl[s:e].T, self.vslow[s:e].T
        fast = np.multiply(vs, self.c_s / (self.c_s + self.c_l), out=self._t2[:, :e - s])
        fast += vl * (self.c_l / (self.c_s + self.c_l))        # v_m
        slow += (dt * self.slow_rate) * (fast - slow)          # v_slow, low-passed
        fast -= slow
        fast *= dt * self.fast_rate
        vs -= fast
        vl -= fast

    def _accumulate_dp(self, s, e, W, nodes, base, dp):
        """Add the chunk's sum w V dp (pressure increments dp, Pa) to the nodal sums."""
        m = e - s
        # One pass (base None): the weights of points-to-grid, for the same rows, still hold.
        wv = np.multiply(self._weights(W, m, kept=base is None), self.V[s:e],
                         out=self._C2[0, :, :m])
        wv *= dp
        if base is None:
            self._accp += np.bincount(nodes.ravel(), weights=wv.ravel(), minlength=self.ng)
            return
        # The chunk's band of nodes, as in points-to-grid.
        lo = int(base.min()) + self._offl_min
        span = int(base.max()) + self._offl_max - lo + 1
        self._accp[lo:lo + span] += np.bincount((nodes - lo).ravel(), weights=wv.ravel(),
                                                minlength=span)

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
            u = self.xref[:, d] / h
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
            cx, cy, _, _ = self.grid.locate(self.xref)
            self.points.migrate(self.grid.cell_owner(cx, cy))
        self.ev_migrate.end()
        return out[1:]
