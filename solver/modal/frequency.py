"""The modal solvers both analyses use: SLEPc's generalized eigensolve and the fundamental
frequency f1 of a body.

The eigen analysis (:mod:`solver.eigen.driver`) reports the modes; the consolidation run
(:mod:`solver.consolidation.driver`) needs f1 for its oscillator criterion (dt_crit,3). Both come
here, so that neither analysis depends on the other.
"""

from __future__ import annotations

import time
from dataclasses import replace
from typing import NamedTuple

import numpy as np
from petsc4py import PETSc
from slepc4py import SLEPc

from ..common.errors import NumericalError, check_converged
from ..materials.history import elasticity_of
from ..model import shapes
from ..model.scene import build, destroy
from . import jacobi


class SlepcResult(NamedTuple):
    """What :func:`slepc_solve` found, and with which solver."""
    values: np.ndarray     # eigenvalues (rad2/s2), ascending ('largest': descending)
    vectors: list          # their eigenvectors (PETSc Vecs)
    seconds: float         # wall time of set-up and solve
    eps_type: str          # the EPS type that solved (e.g. "krylovschur", "lapack")
    st_type: str           # its spectral transformation (e.g. "sinvert", "shift")

    @property
    def label(self) -> str:
        """The solver as printed: "SLEPc krylovschur, ST sinvert"."""
        return f"SLEPc {self.eps_type}, ST {self.st_type}"


def slepc_solve(K, M, nmodes: int, which: str = "smallest", prefix: str = ""):
    """Eigenpairs of K x = lambda M x by SLEPc (GHEP, Krylov-Schur by default).

    ``which='smallest'``: shift-and-invert about 0 with a MUMPS LU (works in parallel);
    ``'largest'``: plain Krylov-Schur for the largest eigenvalues. Any option
    ``-{prefix}eps_*``/``-{prefix}st_*`` overrides these defaults: the prefix keeps a
    secondary solve (the FE reference's ``fe_``) apart from the main one's ``-eps_*``.
    Returns a :class:`SlepcResult` with the solver types actually used.
    """
    t0 = time.perf_counter()
    eps = SLEPc.EPS().create(K.getComm())
    vectors = []
    try:
        _configure(eps, K, M, nmodes, which, prefix)
        inner = (eps.getST().getKSP(), "SLEPc's eigensolve's linear solves (options "
                 f"-{prefix}st_ksp_*, -{prefix}st_pc_*)")
        try:
            eps.solve()
        except PETSc.Error:
            check_converged(*inner)    # SLEPc's own stop (error 91), named
            raise
        # Checked here too: PETSc raises on a nested solve's iteration limit only until a
        # first error has left its nesting count behind, then returns its iterate as is.
        check_converged(*inner)
        check_converged(eps, f"SLEPc's eigensolve (options -{prefix}eps_*, -{prefix}st_*)")
        nconv = eps.getConverged()
        if nconv < nmodes:
            raise NumericalError(f"SLEPc converged {nconv} of {nmodes} eigenpairs "
                                 f"(reason {eps.getConvergedReason()})")
        values = []
        for k in range(nconv):
            vectors.append(K.createVecRight())
            values.append(eps.getEigenpair(k, vectors[-1]).real)
        order = np.argsort(values)
        if which == "largest":
            order = order[::-1]
        keep = order[:nmodes]
        result = SlepcResult(np.array(values)[keep], [vectors[k] for k in keep],
                             time.perf_counter() - t0, eps.getType(), eps.getST().getType())
        for k in order[nmodes:]:
            vectors[k].destroy()
        return result
    except BaseException:
        for v in vectors:
            v.destroy()
        raise
    finally:
        eps.destroy()


def _configure(eps, K, M, nmodes, which, prefix):
    """The defaults of :func:`slepc_solve`, then the options database's word."""
    eps.setOptionsPrefix(prefix)
    eps.setOperators(K, M)
    eps.setProblemType(SLEPc.EPS.ProblemType.GHEP)
    eps.setType(SLEPc.EPS.Type.KRYLOVSCHUR)
    eps.setDimensions(nev=nmodes)
    eps.setTolerances(tol=1e-13, max_it=1000)
    if which == "smallest":
        eps.setWhichEigenpairs(SLEPc.EPS.Which.TARGET_MAGNITUDE)
        eps.setTarget(0.0)
        st = eps.getST()
        st.setType(SLEPc.ST.Type.SINVERT)
        ksp = st.getKSP()
        ksp.setType(PETSc.KSP.Type.PREONLY)
        pc = ksp.getPC()
        pc.setType(PETSc.PC.Type.LU)
        pc.setFactorSolverType("mumps")
    else:
        eps.setWhichEigenpairs(SLEPc.EPS.Which.LARGEST_MAGNITUDE)
    eps.setFromOptions()


def frequencies(eigenvalues) -> np.ndarray:
    """omega^2 (rad2/s2) -> f (Hz)."""
    return np.sqrt(np.maximum(np.asarray(eigenvalues), 0.0)) / (2 * np.pi)



# f1 by SLEPc above this: Jacobi's dense sweeps grow as n^3 (M3-Q4's 320 DOFs 1 s, Q4
# 8 x 80's 1,280 DOFs 22 s, SLEPc 0.1 s); the paper's scenes up to M3-Q4 keep Jacobi's f1.
JACOBI_MAX_DOFS = 400


F1_MAX_DOFS = 20000   # f1 on a coarser grid above this: the shift-invert LU grows fast


def f1_cells(element: str, cells) -> tuple:
    """The cells of the eigen model that gives f1: ``cells``, or coarsened by a whole
    factor in both directions to at most F1_MAX_DOFS DOFs. f1 of the column converges fast
    (M1-Q4 column: 16.89343 Hz on 25 x 625 cells, 16.89343 on 100 x 2500, whose solve
    needs 2.2 GB and 21 s for that sixth digit)."""
    factor = 1
    while 2 * shapes.lattice_nodes(element, [c // factor for c in cells]) > F1_MAX_DOFS \
            and min(cells) // (factor + 1) >= 1:
        factor += 1
    return tuple(max(1, c // factor) for c in cells)


def fundamental_frequency(comm, body, soil, solver: str = "jacobi", tol: float = 1e-15,
                          max_sweeps: int = 50) -> float:
    """f1 (Hz) of ``body`` (scene.Body) made of ``soil`` (saturated density), on
    :func:`f1_cells`: :func:`lowest` with SLEPc's options under the prefix ``f1_``
    (``-f1_eps_view``), apart from an eigen analysis's ``-eps_*``."""
    body = replace(body, cells=f1_cells(body.element, body.cells))
    return float(lowest(comm, body, soil, 1, solver, tol, max_sweeps, "f1_")[0][0])


def lowest(comm, body, soil, count: int, solver: str = "jacobi", tol: float = 1e-15,
           max_sweeps: int = 50, prefix: str = "", largest: int = JACOBI_MAX_DOFS) -> tuple:
    """(the ``count`` lowest natural frequencies (Hz) of ``body`` made of ``soil``, the
    solver that found them): our Jacobi solver (``solver`` 'jacobi', tolerance ``tol``, at
    most ``max_sweeps``) up to ``largest`` DOFs, a dense method, else SLEPc (its options
    under ``prefix``)."""
    made = build(comm, body, soil, D=elasticity_of(soil))
    _, _, K, M, _ = made
    try:
        if solver == "jacobi" and K.getSize()[0] <= largest:
            res = jacobi.solve(K, M, count, tol, max_sweeps)
            lam, vectors, used = res.eigenvalues[:count], res.vectors, "jacobi"
        else:
            res = slepc_solve(K, M, count, prefix=prefix)
            lam, vectors, used = res.values[:count], res.vectors, "slepc"
        destroy(*vectors)
    finally:
        destroy(*reversed(made))
    return frequencies(lam), used
