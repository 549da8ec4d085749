"""Direct linear solvers: a PETSc KSP that applies an LU factorization, its options under a
prefix, for the static ends, the FE reference and the implicit scheme alike."""

from __future__ import annotations


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
