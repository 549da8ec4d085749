"""Start-up of the executables in ``scripts/`` and of ``python -m solver``: make sure they run
under a Python with PETSc.

The scripts start with ``#!/usr/bin/env python3``, and the first ``python3`` on PATH (a pyenv
or conda one) often has no petsc4py: Debian gives it only to ``/usr/bin/python3`` and to the
repository's ``.venv`` that ``scripts/install`` creates. :func:`use_petsc_python` runs the
script again under that ``.venv`` in that case; :func:`missing` tells ``python -m solver``
what to say instead (one line: how to activate ``.venv``). It needs only the standard
library, because it runs before numpy is imported (the Python on PATH may lack numpy as well).
"""

from __future__ import annotations

import importlib.util
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
# Another interpreter to run the scripts under (default: the repository's .venv).
PYTHON_VARIABLE = "MPM_GEO_PYTHON"
# Set for the re-executed process: a second failure stops instead of looping.
_GUARD = "MPM_GEO_REEXEC"


def petsc_python() -> str:
    """The interpreter the scripts fall back to: $MPM_GEO_PYTHON, else ROOT/.venv/bin/python."""
    return os.environ.get(PYTHON_VARIABLE) or os.path.join(ROOT, ".venv", "bin", "python")


def use_petsc_python() -> None:
    """Return when this Python can import petsc4py; otherwise replace this process by the
    same script under :func:`petsc_python` (same PID and arguments, so under ``mpirun`` each
    rank does it before MPI starts), or exit 2 with one line saying what to do."""
    if importlib.util.find_spec("petsc4py") is not None:
        os.environ.pop(_GUARD, None)          # children start afresh
        return
    script = os.path.basename(sys.argv[0])
    target = petsc_python()
    if os.environ.get(_GUARD):
        why = f"{target} has no petsc4py either"
    elif not os.access(target, os.X_OK):
        why = f"there is no {target} (scripts/install creates it; or set {PYTHON_VARIABLE})"
    else:
        os.environ[_GUARD] = "1"
        sys.stdout.flush()
        os.execv(target, [target, os.path.abspath(sys.argv[0]), *sys.argv[1:]])
    sys.stderr.write(f"{script}: error: petsc4py cannot be imported by {sys.executable} and "
                     f"{why}\n")
    sys.exit(2)


# What the solver imports beyond the standard library (Debian's packages, or .venv).
NEEDED = ("petsc4py", "slepc4py", "mpi4py", "numpy", "numba", "scipy", "meshio", "h5py",
          "matplotlib")


def missing() -> str:
    """None when this Python can import every module of :data:`NEEDED`; otherwise one line
    naming the first missing and saying which Python has them: the repository's ``.venv``
    (to activate, or to run), or how to make it."""
    absent = [name for name in NEEDED if importlib.util.find_spec(name) is None]
    if not absent:
        return None
    venv = os.path.join(ROOT, ".venv", "bin")
    if os.access(os.path.join(venv, "python"), os.X_OK):
        where = (f"activate the repository's environment (. {venv}/activate), or run "
                 f"{venv}/python -m solver")
    else:
        where = f"there is no {venv}/python: bash {ROOT}/scripts/install creates it"
    return f"{absent[0]} cannot be imported by {sys.executable}: {where}"
