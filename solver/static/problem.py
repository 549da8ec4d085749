"""The static problem on the material points: f_int(u) = sum_p V B^T sigma_p = f_ext, small
strain, every point's stress from the materials room (path-dependent: each load step
updates the stresses of the last converged step by the step's strain increment).

Newton on PETSc SNES (``-mpm_snes_*``; line search, KSP preonly with MUMPS LU by default,
``-mpm_ksp_*``, ``-mpm_pc_*``) over the free DOFs: the held ones (the supports, the rigid
footing's nodes and the nodes no point supports) carry their prescribed displacements. The
Jacobian is sum V B^T D_alg B with the material's algorithmic tangent; with ``bbar`` the
volumetric strain of each point is its cell's projection (B-bar, Hughes 1980: the in-plane
volumetric rows replaced by their projection over the cell's points, the mean on Q4 cells,
a linear field on the quadratic ones, split equally between xx and yy so that eps_zz
stays 0), which keeps near-incompressible and isochoric plastic flow from locking.
"""

from __future__ import annotations

import math

import numpy as np
from petsc4py import PETSc

from ..materials.history import in_plane
from ..materials.model import tangent
from ..model import assembly
from ..model.scene import Loading, geostatic_fields, top_forces

PLANE = [0, 1, 3]          # the (xx, yy, xy) rows of the materials' four components


def strain_operator(interp, x, volume, bbar: bool) -> np.ndarray:
    """B (np, 3, 2 nen) mapping a point's cell DOFs to (xx, yy, 2 xy), B-bar when asked:
    the volumetric rows replaced by their L2 projection over the cell's points (weights
    the volumes) onto the constants on Q4 cells (the mean), onto 1, x, y on the quadratic
    ones (whose P0 projection is too soft: -15 % under Prandtl on the Tresca footing)."""
    B = assembly.strain_matrix(interp.dNdx)
    if not bbar or not len(volume):
        return B
    cx, cy = interp.cells
    _, cell = np.unique(np.stack([cx, cy], axis=1), axis=0, return_inverse=True)
    cell = cell.ravel()
    ncell = cell.max() + 1
    vol = B[:, 0] + B[:, 1]
    if B.shape[2] == 8:
        P = np.ones((len(volume), 1))
    else:
        centre = np.zeros((ncell, 2))
        np.add.at(centre, cell, x * volume[:, None])
        centre /= np.bincount(cell, weights=volume)[:, None]
        P = np.column_stack([np.ones(len(volume)), x - centre[cell]])
    k = P.shape[1]
    A = np.zeros((ncell, k, k))
    np.add.at(A, cell, volume[:, None, None] * P[:, :, None] * P[:, None, :])
    b = np.zeros((ncell, k, B.shape[2]))
    np.add.at(b, cell, volume[:, None, None] * P[:, :, None] * vol[:, None, :])
    coef = np.linalg.solve(A, b)                       # (ncell, k, 2 nen)
    shift = (np.einsum("pk,pkj->pj", P, coef[cell]) - vol) / 2
    B[:, 0] += shift
    B[:, 1] += shift
    return B


class StaticProblem:
    """The points' stresses and history at the last converged step, the displacement
    there, and the residual and Jacobian of a step (as SNES calls them). ``held`` (owned
    DOFs) are prescribed; ``loaded`` (owned y DOFs of the footing, or of the top under the
    load) carry the footing's settlement, whose reaction :meth:`reaction` sums.
    ``sigma0`` (np, 3) (Pa; xx, yy, xy, its zz taken as xx) the stress at the start, in
    equilibrium with the constant external forces :meth:`loads` sets (gravity, a
    surcharge); under load control (``load_control``) the prescribed value of a step is
    the share of the load vector that :meth:`loads` sets too."""

    def __init__(self, grid, points, material, held, loaded, bbar: bool, sigma0=None,
                 load_control: bool = False):
        self.grid, self.material, self.comm = grid, material, grid.comm
        x, self.volume = points.get("x", "volume")
        self.it = assembly.interpolation(grid, x)
        self.B = strain_operator(self.it, x, self.volume, bbar)
        self.dofs = np.ascontiguousarray(self.it.dofs, dtype=PETSc.IntType)
        sigma0 = np.zeros((len(self.volume), 3)) if sigma0 is None else sigma0
        self.stress = in_plane(sigma0, sigma0[:, 0])
        self.state = material.initial_state(self.stress)
        self.trial = (self.stress, self.state)
        da = grid.da
        # u, the last converged u_n, the internal forces f (what the reaction sums), the last
        # step's increment du (the predictor) and the step's increment u - u_n so far; the
        # constant external forces and the load's (at its full value).
        self.u, self.u_n, self.f, self.du, self.delta, self.f_const, self.f_load = (
            da.createGlobalVec() for _ in range(7))
        for v in (self.du, self.f_const, self.f_load):
            v.set(0.0)
        self.load_control, self.factor = load_control, 0.0
        self.loc = da.createLocalVec()
        self.K = da.createMat()
        self.K.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        held = held | ~self._supported()
        self.held, self.loaded = held, loaded
        start = self.u.getOwnershipRange()[0]
        self.free = PETSc.IS().createGeneral(
            (start + np.flatnonzero(~held)).astype(PETSc.IntType), comm=self.comm)
        self.J = None

    def _supported(self) -> np.ndarray:
        """Owned DOFs some point's shape functions reach (a Q8 cell's centre node not)."""
        self.loc.set(0.0)
        arr = self.loc.getArray()
        np.add.at(arr, self.dofs.ravel(), 1.0)
        self.f.set(0.0)
        self.grid.da.localToGlobal(self.loc, self.f, addv=PETSc.InsertMode.ADD_VALUES)
        return self.f.getArray() > 0

    # -- a step ---------------------------------------------------------------------------
    def loads(self, constant, load):
        """The external forces (owned DOFs, N per m depth): ``constant`` always on (the
        weight, a surcharge), ``load`` scaled by the step's share under load control."""
        self.f_const.getArray()[:] = constant
        self.f_load.getArray()[:] = load

    def prescribe(self, value: float):
        """A step's target: the footing's settlement (m, downwards; its y DOFs at -value),
        or under load control the load's share; the supports at 0."""
        arr = self.u.getArray()
        arr[self.held] = 0.0
        if self.load_control:
            self.factor = value
        else:
            arr[self.loaded] = -value

    def _increment(self):
        """Each point's strain increment (np, 4) from u - u_n."""
        self.u.copy(self.delta)
        self.delta.axpy(-1.0, self.u_n)
        self.grid.da.globalToLocal(self.delta, self.loc)
        du = self.loc.getArray()[self.dofs]
        d = np.zeros((len(du), 4))
        d[:, PLANE] = np.einsum("pij,pj->pi", self.B, du)
        return d

    def point_forces(self, fy) -> np.ndarray:
        """Forces fy (np,) (N per m depth, upwards) at the points spread by their shape
        functions onto the y DOFs: the owned DOFs' values."""
        arr = self.loc.getArray()
        arr[:] = 0.0
        np.add.at(arr, self.dofs[:, 1::2].ravel(), (fy[:, None] * self.it.N).ravel())
        self.delta.set(0.0)
        self.grid.da.localToGlobal(self.loc, self.delta, addv=PETSc.InsertMode.ADD_VALUES)
        return self.delta.getArray().copy()

    def _set_free(self, x):
        sub = self.u.getSubVector(self.free)
        x.copy(sub)
        self.u.restoreSubVector(self.free, sub)

    def residual(self, snes, x, F):
        """F(x) = f_int over the free DOFs, the held ones at their prescribed values."""
        self._set_free(x)
        d = self._increment()
        stress, state = self.material.update(self.stress, d, self.state)
        self.trial = (stress, state)
        forces = np.einsum("pij,pi->pj", self.B, stress[:, PLANE] * self.volume[:, None])
        arr = self.loc.getArray()
        arr[:] = np.bincount(self.dofs.ravel(), weights=forces.ravel(), minlength=arr.size)
        self.f.set(0.0)
        self.grid.da.localToGlobal(self.loc, self.f, addv=PETSc.InsertMode.ADD_VALUES)
        sub = self.f.getSubVector(self.free)
        sub.copy(F)
        self.f.restoreSubVector(self.free, sub)
        for vec, scale in ((self.f_const, 1.0), (self.f_load, self.factor)):
            if scale:
                sub = vec.getSubVector(self.free)
                F.axpy(-scale, sub)
                vec.restoreSubVector(self.free, sub)

    def jacobian(self, snes, x, J, P):
        """sum V B^T D_alg B over the free DOFs."""
        self._set_free(x)
        d = self._increment()
        D = tangent(self.material, self.stress, d, self.state)[:, PLANE][:, :, PLANE]
        # B^T (D B) V as two batched matrix products (BLAS; a three-operand einsum took
        # most of a Jacobian's time).
        blocks = np.matmul(self.B.transpose(0, 2, 1), np.matmul(D, self.B))
        blocks *= self.volume[:, None, None]
        self.K.zeroEntries()
        if len(blocks):
            self.K.setValuesLocalRCV(self.dofs, self.dofs, np.ascontiguousarray(blocks),
                                     addv=PETSc.InsertMode.ADD_VALUES)
        self.K.assemble()
        self.K.createSubMatrix(self.free, self.free, submat=J)

    def commit(self):
        """The step converged: its stresses, history and displacement are the new start,
        and its displacement increment the next step's predictor."""
        self.stress, self.state = self.trial
        self.u.copy(self.du)
        self.du.axpy(-1.0, self.u_n)
        self.u.copy(self.u_n)

    def predict(self, ratio: float):
        """u = u_n + ratio du (the last step's increment, scaled to this step's length)."""
        self.u_n.copy(self.u)
        self.u.axpy(ratio, self.du)

    def displacement_at_points(self) -> np.ndarray:
        """The converged nodal displacement at the points, (np, 2) (m)."""
        self.grid.da.globalToLocal(self.u_n, self.loc)
        u = self.loc.getArray()[self.dofs]
        return np.stack([np.sum(self.it.N * u[:, 0::2], axis=1),
                         np.sum(self.it.N * u[:, 1::2], axis=1)], axis=1)

    def reaction(self) -> float:
        """The footing's downward force (N per m depth): minus the y components of the
        internal forces less the constant external ones (the weight, a surcharge's share
        on the footing's edge nodes) summed over its nodes (collective)."""
        net = self.f.getArray()[self.loaded] - self.f_const.getArray()[self.loaded]
        local = -float(np.sum(net))
        return self.comm.tompi4py().allreduce(local)

    def settlement(self) -> float:
        """The mean settlement (m, downwards) of the loaded top nodes (collective)."""
        mpi = self.comm.tompi4py()
        values = self.u_n.getArray()[self.loaded]
        return -mpi.allreduce(float(np.sum(values))) / max(mpi.allreduce(len(values)), 1)

    def destroy(self):
        for obj in (self.u, self.u_n, self.f, self.du, self.delta, self.f_const, self.f_load,
                    self.loc, self.K, self.free, self.J):
            if obj is not None:
                obj.destroy()


def at_rest(grid, points, body, soil, loading, q0: float, loaded: tuple) -> tuple:
    """(the points' stress at the start (np, 3), Pa: at rest under gravity and the
    surcharge q0 (Pa); the function of a StaticProblem that gives the constant external
    forces and the load's, over the owned DOFs, N per m depth: the soil's weight (buoyant
    under the water table at the surface, dry with rho_l 0), the surcharge on the top
    outside the footing or load (``loaded``: x0, x1 in m), the load q on its extent)."""
    x0 = points.get("x")
    sigma0 = geostatic_fields(x0, body, soil, loading)[1] if loading.gravity > 0 \
        else np.zeros((len(x0), 3))
    K0 = loading.K0[0] if isinstance(loading.K0, tuple) else loading.K0
    K0 = soil.soils[0].nu / (1 - soil.soils[0].nu) if math.isnan(K0) else K0
    sigma0[:, 1] -= q0
    sigma0[:, 0] -= K0 * q0
    I, J = grid.owned_lattice()
    top = J == grid.nodes[1] - 1

    def forces(problem):
        constant, load = np.zeros(2 * len(I)), np.zeros(2 * len(I))
        if loading.gravity > 0:
            layers = soil.soils
            layer = soil.layer_of(x0[:, 1]) if len(layers) > 1 else np.zeros(len(x0), int)
            gamma = np.array([(1 - s.porosity) * (s.rho_s - s.rho_l) * loading.gravity
                              for s in layers])[layer]
            constant += problem.point_forces(-points.get("volume") * gamma)
        if q0:
            sides = top_forces(grid, Loading(load=q0)) - \
                top_forces(grid, Loading(load=q0, extent=loaded))
            constant[2 * np.flatnonzero(top) + 1] -= sides[I[top]]
        if loading.load > 0:
            load[2 * np.flatnonzero(top) + 1] -= top_forces(grid, loading)[I[top]]
        return constant, load

    return sigma0, forces
