"""Explicit single-point two-phase (v-w) MPM step (paper Section 2.2, eqs. 6-15).

Sign conventions: stresses are tension positive, the pore pressure p compression positive,
so the total stress is sigma = sigma' - m p (the paper's eq. 15 in compression-positive form).

One step, with every nodal quantity lumped (a diagonal):
1. Points to grid. Porosity and densities are uniform, so every lumped mass is a constant
   times S = sum w V (m3): M_s = (1 - n) rho_s S, M_l = n rho_l S, the liquid "mass"
   M~_l = rho_l S and the drag Q = (n mu_l / kappa_l) S (eq. 12); likewise the momenta are
   (1 - n) rho_s sum w V v_s and n rho_l sum w V v_l. Nine nodal fields are summed: S,
   sum w V v_s (2), sum w V v_l (2), the mixture force f_m = f_ext - sum B^T sigma V (2) and
   the liquid force f_l = sum p grad(N) V (2) (+ gravity), into the ghosted-local nodes and,
   over the ranks, by one localToGlobal(ADD) of a ghosted 9-field DMDA Vec.
2. Nodal accelerations (eqs. 13, 14), node by node: explicit drag a_l = (f_l - Q (v_l -
   v_s)) / M~_l, a_s = (f_m - M_l a_l) / M_s, or implicit drag (backward Euler on the
   relative velocity, a closed-form 2 x 2 solve per node and direction:
       (M~_l M_s / (M_s + M_l) + Q dt) b = f_l - Q w - M~_l f_m / (M_s + M_l),
   b = a_l - a_s, w = v_l - v_s, then a_s = (f_m - M_l b) / (M_s + M_l), a_l = a_s + b; a
   held phase (fixed, or without mass at the node) has a = 0, v = 0 and the other phase's
   equation alone: a_l = (f_l - Q v_l) / (M~_l + Q dt), a_s = f_m / M_s; unconditionally
   stable in the drag); optional local damping of the mixture's unbalanced force; fixed
   DOFs held; then v^{k+1} = v^k + dt a^k (eq. 6). Mass scaling (-mpm_mass_scaling S)
   multiplies every inertia (M_s, M_l, M~_l) by S. globalToLocal sends the owned nodes'
   results to the ghosts.
3. Grid to points: point velocities (FLIP, or a FLIP/PIC blend), strain rate from the nodal
   v_s^{k+1}, effective stress by linear elasticity, pore pressure from eqs. 8-9
   (dp = -K_l / n [(1 - n) div v_s + n div v_l] dt), positions x += dt v_s^{k+1}, the
   volume ratio J; the viscous stress eta div v_s of -mpm_bulk_viscosity (added to the
   mixture's stress in the next points-to-grid) and the fast-part damping of
   -mpm_fast_damping (both phases' velocities lose dt 2 zeta w1 (v_m - v_slow), v_m the
   mixture velocity and v_slow its low-pass over 1/w1: the relative velocity is untouched).
Porosity, volumes and masses stay at their initial values (small strain: the paper neglects
spatial variation of density and porosity, and the analytic references are linear).

Scheme options (:class:`solver.stepping.scheme.Scheme`, docs/method.md): shape
functions at the points' initial positions x0 (small kinematics) or current ones (large);
pore-pressure increments kept per point or projected through the nodes (lumped L2 projection
sum w V dp / S, interpolated back at x0 or at the new positions), or onto the corner nodes'
bilinear field (kernels._to_corners: the flux term in weak form, the liquid force from grad
p); the liquid equation in the element's basis or in the blended basis N_hat = N/2 + N_Q4/2
(Q8), which then also gives its masses and drag (a tenth nodal field S_l = sum N_hat V), its
velocity transfers and the relative motion in the storage equation, dp = -(K_l / n) [div
v_s + n div_hat(v_l - v_s)] dt. Lumping: row sums (w = N) or HRZ (w = N^2 / sum N^2).

Performance (docs/performance.md): the work is done by the compiled kernels of
:mod:`solver.stepping.kernels` (numba), one pass over the points per transfer,
computing each point's shape functions where they are needed (cheaper than storing them:
memory traffic); this class keeps the state, the PETSc objects and the kernels' flat arrays,
all made once (the point-field addresses again after a migration or resize). One kernel call
per phase: on one rank a step makes three calls and no PETSc call besides the log events; on
several ranks it adds the DMDA scatters (and, with the projection, a second pair and two
calls). PETSc log events MPMPointsToGrid, MPMNodalUpdate, MPMGridToPoints and MPMMigrate
show the phases in -log_view; MPMCompile the compilation (first run) or the loading of the
cached machine code, once per process at model set-up.
"""

from __future__ import annotations

import time

import numpy as np
from petsc4py import PETSc

from ..common.clock import log_event
from ..common.errors import NumericalError
from ..materials import history
from ..materials.model import Elastic
from ..model import shapes
from ..model.scene import top_forces, water_forces
from . import kernels
from .kernels import NB, NF, NLS
from .scheme import Scheme
from . import darcy

# Material-point fields of the consolidation run (besides x, volume, mass).
POINT_FIELDS = {"vs": 2, "vl": 2, "stress": 3, "p": 1, "x0": 2, "monitor": 1, "id": 1,
                "J": 1}


def point_fields(scheme, layered: bool = False) -> dict:
    """The point fields of a run with ``scheme``: POINT_FIELDS, with the viscous stress (Pa)
    of -mpm_bulk_viscosity and the slow mixture velocity (m/s) of -mpm_fast_damping when
    on, in layered ground the point's layer (its index from the surface down), and with
    the corner pressure projection the gradient of the pore pressure (Pa/m), which the
    liquid force takes (kernels.points_to_grid)."""
    fields = dict(POINT_FIELDS)
    if scheme.pressure_projection == "corner":
        fields["gradp"] = 2
    if layered:
        fields["layer"] = 1
    if scheme.bulk_viscosity > 0:
        fields["visc"] = 1
    if scheme.fast_damping > 0:
        fields["vslow"] = 2
    return fields


def kernel_variant(element: str, scheme, layered: bool = False) -> tuple:
    """The compiled variant of the step's kernels for a cell type, scheme and material: the
    number of the cell's nodes, and the lumping, liquid basis and material as None (row
    sums or the blended basis, the element's basis, one material) or True (HRZ, blended,
    per-point layers):
    their types select the machine code (one material pays nothing for layers)."""
    return (len(shapes.OFFSETS[element]), True if scheme.lumping == "hrz" else None,
            True if scheme.liquid_basis == "blended" else None, True if layered else None)


def compile_kernels(element: str, scheme, layered: bool = False) -> dict:
    """Compile (first run on a machine) or load from the disk cache the step's kernels for
    a cell type, scheme and material, once per process, timed by the MPMCompile log event;
    returns :func:`solver.stepping.kernels.warm_up`'s record (seconds,
    compiled, loaded)."""
    with log_event("MPMCompile"):
        return kernels.warm_up(*kernel_variant(element, scheme, layered))


def compile_defaults() -> None:
    """Fill numba's disk cache with the kernels of every cell type's default scheme, so
    that a machine's first runs compile nothing (``scripts/install`` calls this)."""
    t = time.perf_counter()
    for element in shapes.OFFSETS:
        for layered in (False, True):
            record = compile_kernels(element, Scheme.resolve(element, {}), layered)
    PETSc.Sys.Print(f"Step kernels of {', '.join(shapes.OFFSETS).upper()} ready in "
                    f"{time.perf_counter() - t:.1f} s ({record['compiled']} compiled, "
                    f"{record['loaded']} loaded from numba's cache)")


class TwoPhase:
    """State and operators of the explicit v-w scheme on one grid.

    Material-point fields are used in place through ``MaterialPoints.views`` (the kernels
    get their addresses); they are fetched again when the swarm changed (its
    ``generation``). Code that changes the points' fields or volumes between steps needs no
    notice (they are read every step); code that resizes or migrates the swarm must go
    through ``MaterialPoints`` (it bumps the generation). The reference positions x0 are
    constants of the run."""

    def __init__(self, grid, points, soil, body, loading, scheme, materials=None):
        """The model of ``body`` (scene.Body: supports, drainage) on ``grid`` and
        ``points``, made of ``soil`` (soil.Soil, or soil.Ground of several layers: the
        points then carry their ``layer``), under ``loading`` (scene.Loading), stepped
        with ``scheme`` (scheme.Scheme); ``materials``: one yielding material per layer
        (None: linear elastic), whose update corrects the kernels' elastic stress
        (:meth:`_yield`)."""
        self.grid, self.points, self.soil, self.loading = grid, points, soil, loading
        self.materials = materials
        # The strain increment from the kernels' elastic stress increment: D^-1 per layer.
        self._compliance = None if materials is None else \
            np.linalg.inv(np.stack([Elastic(s.E, s.nu).plane() for s in soil.soils]))
        self.lumping = scheme.lumping
        # Small kinematics: shape functions at the initial positions x0 (a point's cell never
        # changes, so nothing migrates); large: at the current positions.
        self.small = scheme.kinematics == "small"
        # Pressure projection: 0 none, kernels.PNODAL or PCORNER (two fields per node).
        self.project = {"none": 0, "nodal": kernels.PNODAL,
                        "corner": kernels.PCORNER}[scheme.pressure_projection]
        self.pfields = 2 if self.project == kernels.PCORNER else 1
        # The compact Darcy stencil (kernels._compact), capped.
        self.compact = darcy.applies(grid.element, scheme.pressure_projection,
                                     scheme.liquid_basis, len(soil.soils))
        self.compact_cap = darcy.cap(grid.h) if self.compact else 0.0
        self.blend = scheme.liquid_basis == "blended"
        self.implicit = scheme.drag == "implicit"
        # -mpm_lumping blended: the solid's transfer (weights and interpolation) in N_hat.
        self.solid_blended = self.lumping == "blended"
        # Layers: per-point material (kernels.NL reals per layer), more nodal sums/results.
        self.layers = soil.soils
        self.layered = len(self.layers) > 1
        self.nf = NF + self.blend + NLS * self.layered
        self.ngf = kernels.result_fields(self.layered, self.compact)
        first = self.layers[0]
        self.D = Elastic(first.E, first.nu).plane()     # the materials room's elastic law
        n = first.porosity
        self.n = n
        self.drag = first.drag_coefficient                  # eq. 12 (kg/m3/s)
        # Lumped quantities per unit S = sum w V (uniform porosity and densities). Mass
        # scaling multiplies the inertia only: the drag and the weight stay physical.
        inertia = self.inertia = scheme.mass_scaling
        self.c_s, self.c_l, self.c_q = self._lumped(first)  # M_s / S, M_l / S, Q / S
        self.c_t = first.rho_l * inertia                    # M~_l / S (one fluid)
        self._damping_terms(soil, body.height, scheme)
        self.serial = grid.comm.getSize() == 1
        self.mpi = grid.comm.tompi4py()
        self.ng = grid.gxm * grid.gym
        self.nown = (grid.xe - grid.xs) * (grid.ye - grid.ys)
        # One rank: the ghosted local and the global node sets are the same (the grid is not
        # periodic), so the nodal sums need no PETSc scatter.
        assert not self.serial or self.ng == self.nown
        self.fixed_s = grid.constrained_mask(body.supports).reshape(-1, 2)
        self.fixed_l = grid.constrained_mask(body.impermeable).reshape(-1, 2)
        self.drained = grid.constrained_mask({s: "x" for s in body.drained})[::2]
        self.traction = self._traction(loading)
        self.water = self._water(body, loading)
        self._R, self._B = self._reals(), self._node_data()
        # Ghosted-local offsets of a cell's nodes from its node (0, 0); a tuple, whose
        # length selects the kernels' machine code for the cell type.
        off = grid.offsets
        self._off = tuple(int(o) for o in (off[:, 1] - grid.gys) * grid.gxm
                          + (off[:, 0] - grid.gxs))
        self._nodal_arrays()
        # The kernels' context: integers, and the addresses of the arrays they work on
        # (kernels module docstring); the point fields' in _prepare.
        K = kernels
        self._C = K.context({K.AR: self._R, K.AB: self._B, K.AGL: self._Gl, K.AGO: self._G,
                             K.AOO: self._Og, K.AOL: self._O, K.APL: self._pn,
                             K.APO: self._pg})
        self._integers(self._C)
        self._gen = None
        _, self._hrz, self._blend, self._layered = kernel_variant(grid.element, scheme,
                                                                 self.layered)
        self.compiled = compile_kernels(grid.element, scheme, self.layered)
        self.ev_p2g = log_event("MPMPointsToGrid")
        self.ev_nodal = log_event("MPMNodalUpdate")
        self.ev_g2p = log_event("MPMGridToPoints")
        self.ev_migrate = log_event("MPMMigrate")

    # -- set-up ----------------------------------------------------------------------------
    def _lumped(self, soil):
        """M_s, M_l per unit S (kg/m3, inertia scaled) and Q per unit S (kg/m3/s) of
        ``soil``."""
        n = soil.porosity
        return ((1 - n) * soil.rho_s * self.inertia, n * soil.rho_l * self.inertia,
                soil.drag_coefficient)

    def _damping_terms(self, soil, H, scheme):
        """Coefficients of the two damping terms beside local damping (0: off): the bulk
        viscosity eta = b1 rho c1 h (Pa s), and the fast-part damping rate 2 zeta w1 and
        low-pass rate w1 (1/s), from the wave with inertia scaled by S, in a column of
        height H (m)."""
        b1, zeta, S = scheme.bulk_viscosity, scheme.fast_damping, scheme.mass_scaling
        c1 = float(soil.wave_speeds(S)["c1"])
        self.eta = b1 * soil.density * S * c1 * min(self.grid.h)
        w1 = 2 * np.pi * c1 / (4 * H)
        if not np.isnan(scheme.wave_period):      # a body's slowest mode, not the column's
            w1 = 2 * np.pi / (scheme.wave_period * np.sqrt(S))
        self.fast_rate, self.slow_rate = 2 * zeta * w1, (w1 if zeta > 0 else 0.0)

    def _traction(self, loading):
        """Owned nodal forces (N per m depth) of the downward load on the top edge
        (:func:`scene.top_forces`)."""
        g = self.grid
        force = np.zeros(((g.ye - g.ys), (g.xe - g.xs)))
        if g.ye == g.nodes[1]:
            force[-1] = -top_forces(g, loading)[g.xs:g.xe]
        return force.ravel()

    def _water(self, body, loading):
        """Owned nodal forces (N per m; nodes x 2 for the mixture, then 2 for the liquid in
        its basis) of the water outside the drained sides at its hydrostatic pressure
        under gravity (:func:`scene.water_forces`); zeros without gravity."""
        g = self.grid
        out = np.zeros((self.nown, 4))
        gamma_w = self.layers[0].rho_l * loading.gravity
        if gamma_w > 0:
            own = np.s_[g.ys:g.ye, g.xs:g.xe]
            out[:, :2] = water_forces(g, body.drained, gamma_w)[own].reshape(-1, 2)
            # The liquid's own basis where it is blended; else the element's, the same forces.
            # The corner projection's liquid force is in gradient form, -N_l V grad p, with
            # no boundary term: it holds the drained sides' pressures instead (at their
            # hydrostatic start), so the outside water adds nothing to the liquid there.
            if self.project == kernels.PCORNER:
                out[:, 2:] = 0.0
            else:
                out[:, 2:] = (water_forces(g, body.drained, gamma_w, shapes.BLEND)[own]
                              .reshape(-1, 2) if self.blend else out[:, :2])
        return out

    def _integers(self, I):
        """The kernels' integers (kernels.I*, into the context I): scheme flags and grid
        numbering."""
        g, K = self.grid, kernels
        I[K.INF] = self.nf
        I[K.IBLEND], I[K.ISOLIDB], I[K.IPROJ], I[K.IIMPL] = (
            self.blend, self.solid_blended, self.project, self.implicit)
        I[K.ICMX], I[K.ICMY] = g.cells[0] - 1, g.cells[1] - 1
        # Ghosted-local node of local node a of cell (cx, cy): order (cx + gxm cy) + off[a].
        I[K.ISTX], I[K.ISTY] = g.order, g.order * g.gxm
        I[K.INOWN] = self.nown
        I[K.ILAYERS] = len(self.layers) if self.layered else 0
        I[K.IWATER] = int(self._B.reshape(-1, NB)[:, 6:].any())
        I[K.ICOMPACT] = self.compact

    def _reals(self):
        """The kernels' real data (kernels.R*, SI units)."""
        g, K, n, soil = self.grid, kernels, self.n, self.layers[0]
        R = np.zeros(K.NR + K.NL * len(self.layers) * self.layered)
        R[K.RHX], R[K.RHY] = g.h
        R[K.RSX], R[K.RSY] = 2.0 / g.h[0], 2.0 / g.h[1]
        R[K.RCS], R[K.RCL], R[K.RCT], R[K.RCQ] = self.c_s, self.c_l, self.c_t, self.c_q
        R[K.RN], R[K.RKL] = n, soil.K_l
        # Body forces of the mixture (with N) and of the liquid (with N_l), per unit volume.
        gy = -self.loading.gravity
        R[K.RGM] = ((1 - n) * soil.rho_s + n * soil.rho_l) * gy
        R[K.RGL] = soil.rho_l * gy
        R[K.RETA], R[K.RFAST], R[K.RSLOW] = self.eta, self.fast_rate, self.slow_rate
        R[K.RBLEND] = shapes.BLEND
        R[K.RCAP] = self.compact_cap
        R[K.RD:K.RD + 9] = self.D.ravel()
        # Partitioned directions and this rank's box of cells in cell units (+-inf at the
        # ends of the grid, where locate clips), for the cheap "does any point leave" test.
        (x0, x1), (y0, y1) = g.owned_cell_range()
        procs = g.da.getProcSizes()
        for d, (lo, hi) in enumerate(((x0, x1), (y0, y1))):
            if procs[d] > 1:
                R[K.RBOX + 4 * d:K.RBOX + 4 * d + 4] = (
                    1.0, g.h[d], -np.inf if lo == 0 else float(lo),
                    np.inf if hi == g.cells[d] else float(hi))
        if self.layered:
            rows = R[K.NR:].reshape(-1, K.NL)
            for row, layer in zip(rows, self.layers):
                row[[K.LCS, K.LCL, K.LCQ]] = self._lumped(layer)
                row[K.LGM] = layer.density * gy
                row[K.LN] = layer.porosity
                row[K.LCK] = layer.drag_coefficient / layer.porosity
                row[K.LD:] = Elastic(layer.E, layer.nu).plane().ravel()
        return R

    def _node_data(self):
        """Per owned node (kernels.NB values): the load's force for a load factor of 1 (N
        per m), then 1 on the free and 0 on the fixed DOFs of v_s (x, y) and v_l (x, y),
        then 0 on a drained side (the corner projection holds the pressure there), else 1,
        then the water's force on the mixture and on the liquid (x, y each, N per m)."""
        B = np.empty((self.nown, NB))
        B[:, 0] = self.traction
        B[:, 1:3] = ~self.fixed_s
        B[:, 3:5] = ~self.fixed_l
        B[:, 5] = ~self.drained
        B[:, 6:] = self.water
        return B.ravel()

    def _nodal_arrays(self):
        """Nodal arrays, node-major (node * fields + field): sums _Gl (ghosted-local, the
        points add into it) and _G (owned, the nodal update reads it), results _Og (owned,
        written) and _O (ghosted-local, read by the points), projected pressure increments
        _pn (ghosted-local) and _pg (owned). On one rank each pair is one array; on several,
        the arrays of ghosted DMDA Vecs (dof = fields), whose storage does not move, so they
        are fetched once."""
        if self.serial:
            self._Gl = self._G = np.zeros(self.ng * self.nf)
            self._O = self._Og = np.zeros(self.ng * self.ngf)
            self._pn = self._pg = np.zeros(self.ng * self.pfields if self.project else 0)
            return
        da = self.grid.da
        self.da_f, self.da_g = da.duplicate(dof=self.nf), da.duplicate(dof=self.ngf)
        self.loc_f, self.glob_f = self.da_f.createLocalVec(), self.da_f.createGlobalVec()
        self.loc_g, self.glob_g = self.da_g.createLocalVec(), self.da_g.createGlobalVec()
        self._Gl, self._G = self.loc_f.getArray(), self.glob_f.getArray()
        self._O, self._Og = self.loc_g.getArray(), self.glob_g.getArray()
        self._pn = self._pg = np.zeros(0)
        if self.project:
            self.da_p = da.duplicate(dof=self.pfields)
            self.loc_p, self.glob_p = self.da_p.createLocalVec(), self.da_p.createGlobalVec()
            self._pn, self._pg = self.loc_p.getArray(), self.glob_p.getArray()

    # -- lifetime ---------------------------------------------------------------------------
    def destroy(self):
        """Destroy the PETSc objects this model made (on several ranks the nodal DMDAs and
        their Vecs; on one rank there are none) and drop the kernels' addresses into them.
        The grid and the points are the caller's: it destroys them after this."""
        for name in ("loc_f", "glob_f", "loc_g", "glob_g", "loc_p", "glob_p",
                     "da_f", "da_g", "da_p"):
            obj = self.__dict__.pop(name, None)
            if obj is not None:
                obj.destroy()
        # The arrays were views of the Vecs' storage; the context held their addresses.
        self._Gl = self._G = self._O = self._Og = self._pn = self._pg = None
        self._C = None
        self._gen = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.destroy()

    def _prepare(self):
        """The point fields' addresses for the kernels (after creation, a migration or a
        resize); nothing when the swarm is unchanged."""
        if self._gen == self.points.generation:
            return
        pts, K = self.points, kernels
        (self.x, self.x0, self.V, self.vs, self.vl, self.sig, self.pp, self.J,
         self.ids) = pts.views("x", "x0", "volume", "vs", "vl", "stress", "p", "J", "id")
        self.visc = pts.views("visc") if self.eta else None
        self.vslow = pts.views("vslow") if self.fast_rate else None
        self.layer = pts.views("layer") if self.layered else None
        self.gradp = pts.views("gradp") if self.project == kernels.PCORNER else None
        self.xref = self.x0 if self.small else self.x
        self.n_local = pts.n_local
        slots = {K.PX: self.x, K.PXREF: self.xref, K.PV: self.V, K.PVS: self.vs,
                 K.PVL: self.vl, K.PSIG: self.sig, K.PP: self.pp, K.PJ: self.J,
                 K.PVISC: self.visc, K.PVSLOW: self.vslow, K.PLAYER: self.layer,
                 K.PGRADP: self.gradp}
        C = self._C
        C[K.PN:K.PGRADP + 1] = 0
        C[K.PN] = self.n_local
        for slot, a in slots.items():
            if a is not None:
                # The kernels view the storage as contiguous (n, bs) float64; the arrays are
                # kept (above), and the swarm does not move them until the next generation.
                assert a.dtype == np.float64 and a.flags.c_contiguous and len(a) == self.n_local
                C[slot] = a.ctypes.data
        self._gen = pts.generation

    @property
    def _locgT(self):
        """The nodal results of the last step, field-major (kernels.result_fields,
        ghosted-local nodes): a_s, a_l, v_s^{k+1}, v_l^{k+1} (and in layers the Darcy flux
        q, with the compact stencil the nodes' quasi-static Darcy flux), x and y each (m/s2,
        m/s; tests read them)."""
        return self._O.reshape(self.ng, self.ngf).T

    # -- one step --------------------------------------------------------------------------
    def step(self, dt: float, load_factor: float, damping: float, flip: float,
             base=None):
        """Advance the points by one explicit step of dt (s); load_factor scales the surface
        load, damping is the local damping coefficient, flip the FLIP fraction; ``base``
        (m/s2, x and y), the acceleration of a rigid base in whose frame the step runs (the
        dynamic analysis; None: at rest)."""
        if base is not None:
            self._R[kernels.RBASE:kernels.RBASE + 2] = base
        if self._gen != self.points.generation:
            self._prepare()
        # Floats: a kernel called with an int would compile a variant inside the step.
        dt, load_factor, damping, flip = float(dt), float(load_factor), float(damping), \
            float(flip)
        off, C = self._off, self._C
        # Events as with blocks: ended also when a PETSc call raises (as cheap as
        # begin/end: one method call each way).
        with self.ev_p2g:
            kernels.points_to_grid(off, C, self._hrz, self._blend, self._layered)
            if not self.serial:
                self.glob_f.zeroEntries()
                self.da_f.localToGlobal(self.loc_f, self.glob_f,
                                        addv=PETSc.InsertMode.ADD_VALUES)

        with self.ev_nodal:
            kernels.nodal_update(C, dt, load_factor, damping)
            if not self.serial:
                self.da_g.globalToLocal(self.glob_g, self.loc_g)

        with self.ev_g2p:
            before = None if self.materials is None else self.points.get("stress")
            if self.serial:
                kernels.grid_to_points_serial(off, C, self._hrz, self._blend, self._layered,
                                               dt, flip)
            else:
                kernels.grid_to_points(off, C, self._hrz, self._blend, self._layered, dt,
                                        flip)
                if self.project:
                    self._project()
            if before is not None:
                self._yield(before)

    def _yield(self, before):
        """The points' stresses from their materials: the step's strain increment is what
        the kernels' elastic increment D d eps (from ``before``, (np, 3), Pa) says, and each
        material updates the last stress and history by it (vectorised over the points of
        each layer)."""
        points = self.points
        layer = history.layer_of(points)
        layered = history.Layered(self.materials, layer)
        d = np.zeros((len(layer), 4))
        d[:, history.PLANE] = np.einsum("pij,pj->pi", self._compliance[layer],
                                        points.get("stress") - before)
        stress, state = history.read(points, before)
        history.write(points, *layered.update(stress, d, state))

    def _project(self):
        """Several ranks: the pressure projection's nodal sums over the ranks, the division
        by S at the owned nodes, the result to the ghosts, and back to the points."""
        self.glob_p.zeroEntries()
        self.da_p.localToGlobal(self.loc_p, self.glob_p, addv=PETSc.InsertMode.ADD_VALUES)
        kernels.project_nodes(self._C)
        self.da_p.globalToLocal(self.glob_p, self.loc_p)
        kernels.project_back(self._off, self._C)

    def check(self, step: int, t: float, scale: float):
        """Stop (NumericalError, on every rank) on non-finite values, unbounded pore pressure,
        an inverted material point or one that left the grid; name the point and the step."""
        self._prepare()
        W, H = self.grid.size
        local = kernels.problems(self._C, 1e3 * scale, W, H, 1e-9 * max(W, H))
        first = [int(self.ids[i]) if i >= 0 else -1 for i in local]
        if self.serial:
            if max(first) < 0:
                return
            kind = next(k for k, f in enumerate(first) if f >= 0)
            pid, info = first[kind], self._detail(local[kind])
        else:
            from mpi4py import MPI

            mpi = self.mpi
            found = np.zeros(len(first), dtype=np.int64)
            mpi.Allreduce((np.array(first) >= 0).astype(np.int64), found, op=MPI.MAX)
            if not found.any():
                return
            kind = int(np.flatnonzero(found)[0])
            owner = mpi.allreduce(self.grid.comm.getRank() if first[kind] >= 0 else -1,
                                  op=MPI.MAX)
            mine = (first[kind], self._detail(local[kind])) if first[kind] >= 0 else None
            pid, info = mpi.bcast(mine, root=owner)
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

    def _detail(self, i):
        """Pore pressure (Pa), volume ratio and position (m) of local point i."""
        return float(self.pp[i]), float(self.J[i]), self.x[i].tolist()

    def migrate(self):
        """Send points that entered another rank's cells there (collective on more than one
        rank with large kinematics; points that keep their reference positions never
        leave their cells)."""
        if self.serial or self.small:
            return
        with self.ev_migrate:
            self._prepare()
            # A point stays when its cell, floor(x / h) clipped to the grid as Grid.locate
            # computes it, is in this rank's box (kernels.leaving).
            from mpi4py import MPI

            if self.mpi.allreduce(int(kernels.leaving(self._C)), op=MPI.MAX):
                cx, cy, _, _ = self.grid.locate(self.xref)
                self.points.migrate(self.grid.cell_owner(cx, cy))

if __name__ == "__main__":
    compile_defaults()
