"""Direct solvers: a PETSc KSP that applies an LU factorization, its options under a prefix,
for the static ends, the FE reference and the implicit scheme alike; and Newton on SNES
over such a KSP, for the static analysis and the implicit scheme's yielding soil; the
reciprocal of lumped masses that may be empty."""

from __future__ import annotations

import numpy as np


def direct_solver(comm, A, prefix: str, package: str = "mumps"):
    """A KSP (preonly) that solves with ``A`` by LU of ``package`` (mumps; petsc, serial), its
    options read last under ``prefix`` (``-PREFIX_ksp_type``,
    ``-PREFIX_pc_factor_mat_solver_type``, ...), so that the command line wins. Nothing is
    factored until its set-up or first solve. The caller destroys it."""
    from petsc4py import PETSc

    ksp = PETSc.KSP().create(comm)
    ksp.setOptionsPrefix(prefix)
    ksp.setOperators(A)
    ksp.setType(PETSc.KSP.Type.PREONLY)
    pc = ksp.getPC()
    pc.setType(PETSc.PC.Type.LU)
    pc.setFactorSolverType(package)
    ksp.setFromOptions()
    return ksp


def newton_solver(comm, prefix: str, rtol: float, atol: float, max_it: int):
    """SNES newtonls (its line search) whose KSP is preonly with MUMPS LU, the tolerances
    given and the residual history kept, its options read last under ``prefix``
    (``-PREFIX_snes_*``, ``-PREFIX_ksp_*``, ...), so that the command line wins. The caller
    sets its function and Jacobian, and destroys it."""
    from petsc4py import PETSc

    snes = PETSc.SNES().create(comm)
    snes.setOptionsPrefix(prefix)
    snes.setType("newtonls")
    snes.setTolerances(rtol=rtol, atol=atol, max_it=max_it)
    snes.setConvergenceHistory(reset=True)
    ksp = snes.getKSP()
    ksp.setType("preonly")
    pc = ksp.getPC()
    pc.setType("lu")
    pc.setFactorSolverType("mumps")
    snes.setFromOptions()
    return snes


def reciprocal(a):
    """1 / a where a > 0, else 0 (the lumped masses and drags of nodes without points)."""
    return np.divide(1.0, a, out=np.zeros_like(a), where=a > 0)
