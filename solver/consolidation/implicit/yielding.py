"""Yielding soil in the implicit scheme: each stage's equations with the points' effective
stresses from the materials room, solved by Newton on PETSc SNES.

A stage of :mod:`.quasistatic` solves J(c) y = r, whose displacement rows hold K u + f_0,
the internal force of sigma' = sigma'_0 + D eps. With a material the internal force is
f(u) = sum V B^T sigma'(u), sigma' the material's update of the last committed stress by
the strain increment since the last committed state (path-dependent: each stage commits
its converged state). The stage's residual and Jacobian are then

    G(y) = J(c) y - r + (f(u) - f_0 - K u),     J(c) + sum V B^T (D_alg - D) B,

with D_alg the material's algorithmic tangent (:func:`solver.materials.model.tangent`).
For an elastic material the bracket vanishes: the linear stage is Newton's first step.
Newton runs on the scheme's scaled unknowns z = y / d (both blocks O(1)), options under
``-mpm_snes_*`` (newtonls with its line search; the KSP and its MUMPS LU under
``-mpm_ksp_*``, ``-mpm_pc_*`` as the linear scheme takes them); it stops when the scaled
residual is below 1e-10 of the scaled load's (relative, not in newtons) or 1e-9 of its
first. Effective stress throughout: Tresca's strength bounds the deviator, the same for
total and effective stress, so an undrained load past it finds no equilibrium.

The history (the committed stress's zz component and the material's state variables) lives
in point fields (:func:`solver.materials.history.fields`), so a checkpoint stores it and a restart takes it up.
"""

from __future__ import annotations

import numpy as np
from petsc4py import PETSc

from ...common.errors import NumericalError
from ...common.linalg import newton_solver
from ...materials import history
from ...materials.history import PLANE

RTOL, LOAD_TOL, MAX_IT = 1e-9, 1e-10, 30
OUTSIDE = 1e6       # the residual (times the load's) of a state the material cannot take


class Yielding:
    """The points' committed effective stress and history, the stage's Newton, and the
    nodal state they belong to. ``materials`` one per layer, ``layer`` (np,) the points'
    layers, ``sigma0`` (np, 3) the initial effective stress (xx, yy, xy; its zz taken as
    xx: K0 in both horizontal directions)."""

    def __init__(self, ops, materials, layer, sigma0, volume, comm):
        self.ops, self.comm, self.volume = ops, comm, volume
        self.layered = history.Layered(materials, layer)
        self.sigma0 = sigma0
        self.start_stress = history.in_plane(sigma0, sigma0[:, 0])
        self.begin(self.start_stress)
        self.y_n = ops.da.createGlobalVec()
        self.loc = ops.da.createLocalVec()
        self.y_n.set(0.0)
        self._committed(self.y_n)
        self.corr = ops.da.createGlobalVec()
        self.Kd = ops.J0.duplicate()
        self.snes = self.Jac = self.F = None
        self.iterations = []

    def begin(self, stress, state=None):
        """Start from ``stress`` (np, 4) (Pa) and ``state`` (None: each material's initial)."""
        self.stress = stress
        self.state = self.layered.initial(stress) if state is None else state
        self.trial = (self.stress, self.state)

    # -- the points ------------------------------------------------------------------------
    def _increment(self, y):
        """(each point's strain increment (np, 4) since the committed state, its total
        displacement's cell DOFs (np, 2 nen))."""
        ops = self.ops
        n2 = 2 * ops.u.N.shape[1]
        ops.da.globalToLocal(y, self.loc)
        u = self.loc.getArray()[ops.dofs[:, :n2]]
        d = np.zeros((len(u), 4))
        d[:, PLANE] = np.einsum("pij,pj->pi", ops.B, u - self.u_n)
        return d, u

    def _committed(self, y):
        """y is the committed nodal state: its displacement at the points' DOFs kept."""
        y.copy(self.y_n)
        self.ops.da.globalToLocal(self.y_n, self.loc)
        self.u_n = self.loc.getArray()[self.ops.dofs[:, :2 * self.ops.u.N.shape[1]]]

    def correction(self, y):
        """f(u) - f_0 - K u (global Vec, N per m depth) of the nodal state y, the points'
        trial stresses kept for :meth:`commit`."""
        ops = self.ops
        d, u = self._increment(y)
        self.trial = self.layered.update(self.stress, d, self.state)
        eps = np.einsum("pij,pj->pi", ops.B, u)
        D = ops.D
        linear = np.einsum("kl,pl->pk" if np.ndim(D) == 2 else "pkl,pl->pk", D, eps)
        s = (self.trial[0][:, PLANE] - self.sigma0 - linear) * self.volume[:, None]
        f = np.einsum("pij,pi->pj", ops.B, s)
        n2 = f.shape[1]
        arr = self.loc.getArray()
        arr[:] = np.bincount(ops.dofs[:, :n2].ravel(), weights=f.ravel(), minlength=arr.size)
        self.corr.set(0.0)
        ops.da.localToGlobal(self.loc, self.corr, addv=PETSc.InsertMode.ADD_VALUES)
        return self.corr

    def softening(self, y):
        """sum V B^T (D_alg - D) B (a Mat over the three-DOF lattice) at the nodal state y."""
        ops = self.ops
        d, _ = self._increment(y)
        D_alg = self.layered.tangent(self.stress, d, self.state)
        D_alg -= ops.D
        B = ops.B
        blocks = np.matmul(B.transpose(0, 2, 1), np.matmul(D_alg, B))
        blocks *= self.volume[:, None, None]
        n2 = B.shape[2]
        full = np.zeros((len(d), ops.dofs.shape[1], ops.dofs.shape[1]))
        full[:, :n2, :n2] = blocks
        self.Kd.zeroEntries()
        if len(full):
            self.Kd.setValuesLocalRCV(ops.dofs, ops.dofs, full,
                                      addv=PETSc.InsertMode.ADD_VALUES)
        self.Kd.assemble()
        return self.Kd

    def commit(self, y):
        """The converged stage: its stresses and history the new start, y its nodal state."""
        self.stress, self.state = self.trial
        self._committed(y)

    def reset(self, y):
        """Back to the start of :meth:`begin`'s stress (the undrained start retried in more
        increments), y the nodal state there."""
        self.begin(self.start_stress)
        self._committed(y)

    def to_fields(self, points):
        """The committed stress and history into the point fields."""
        history.write(points, self.stress, self.state)

    def from_fields(self, points, y):
        """A restart's committed state: the points' stresses and history, the nodal y."""
        self.begin(*history.read(points))
        self._committed(y)

    # -- Newton ----------------------------------------------------------------------------
    def solve(self, scheme, c, held, rhs, y, when: str):
        """y (in place) with G(y) = 0 on the free rows, 0 on ``held``, from y's values
        (``scheme`` the QuasiStatic: its J0, H, scaling d; ``when`` names the stage in a
        failure). Commits the converged state; NumericalError where Newton does not
        converge."""
        ops, d = self.ops, scheme.d
        J0 = ops.J0.duplicate(copy=True)
        if c:
            J0.axpy(-c, ops.H, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        work = y.duplicate()

        def residual(snes, z, F):
            z.copy(work)
            work.pointwiseMult(work, d)
            work.setValues(held, np.zeros(len(held)))
            work.assemble()
            try:
                corr = self.correction(work)
            except ArithmeticError:
                # A return that found no stress (a strain far outside the soil's range):
                # a residual too large for the line search to accept, which then shortens
                # the step (petsc4py has no SNESSetFunctionDomainError).
                F.set(OUTSIDE * scale)
                return
            J0.mult(work, F)
            F.axpy(-1.0, rhs)
            F.axpy(1.0, corr)
            F.pointwiseMult(F, d)
            F.setValues(held, z.getValues(held))
            F.assemble()

        def jacobian(snes, z, A, P):
            z.copy(work)
            work.pointwiseMult(work, d)
            J0.copy(A, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
            A.axpy(1.0, self.softening(work),
                   structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            A.diagonalScale(d, d)
            A.zeroRowsColumns(held, diag=1.0)

        scale = scheme.load_scale()
        snes = self._snes(J0, scale)
        snes.setFunction(residual, self.F)
        z = y.duplicate()
        y.copy(z)
        z.pointwiseDivide(z, d)
        z.setValues(held, np.zeros(len(held)))
        z.assemble()
        snes.setJacobian(jacobian, self.Jac)
        snes.solve(None, z)
        reason, its = snes.getConvergedReason(), snes.getIterationNumber()
        history = snes.getConvergenceHistory()[0]
        for obj in (J0, work):
            obj.destroy()
        if reason <= 0:
            z.destroy()
            raise NumericalError(
                f"implicit scheme: Newton found no equilibrium {when} ({its} iterations, "
                f"residual {history[-1] / scale if len(history) else float('nan'):.2g} of "
                "the load's): the soil fails under the load there (or the steps are too "
                "long: -mpm_implicit_steps, -mpm_snes_*)")
        z.pointwiseMult(z, d)
        z.setValues(held, np.zeros(len(held)))
        z.assemble()
        z.copy(y)
        z.destroy()
        self.correction(y)                   # the trial state of the converged y
        self.iterations.append(its)
        self.commit(y)
        return y

    def _snes(self, J0, scale: float):
        """The Newton solver, made at the first stage (``scale``: the scaled load's size)."""
        if self.snes is None:
            self.snes = newton_solver(self.comm, "mpm_", rtol=RTOL, atol=LOAD_TOL * scale,
                                      max_it=MAX_IT)
            self.Jac = J0.duplicate(copy=True)
            self.F = self.y_n.duplicate()
        return self.snes

    def destroy(self):
        for obj in (self.y_n, self.loc, self.corr, self.Kd, self.snes, self.Jac, self.F):
            if obj is not None:
                obj.destroy()
