"""Where a result came from, for ``summary["provenance"]`` of both analyses: the package's
version and git commit, the versions of the libraries that computed it, the ranks, and every
option of the run, so that a summary alone reproduces the run.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import os
import platform
import subprocess
import sys

from .. import __version__
from .options import PREFIX, SPEC

# Distributions whose versions matter to the numbers (PETSc and SLEPc themselves are asked
# through petsc4py and slepc4py: they are C libraries).
LIBRARIES = ("petsc4py", "slepc4py", "mpi4py", "numpy", "scipy", "numba", "meshio", "h5py",
             "matplotlib")
# Debian ships some under other distribution names.
_ALIASES = {"h5py": ("h5py._debian_h5py_serial", "h5py._debian_h5py_mpi")}
GIT_SECONDS = 10      # a hung git (a network file system) must not hold up the run


def collect(comm, recorded: dict) -> dict:
    """The provenance of a run on the PETSc communicator ``comm`` whose options are
    ``recorded`` (:func:`options`) (collective: rank 0 asks git and the libraries, every
    rank gets the same dict)."""
    info = None
    if comm.getRank() == 0:
        info = {"package": "mpm-geo", "version": __version__, "git": git_state(),
                "python": platform.python_version(), "libraries": libraries(), "cpu": cpu(),
                "ranks": comm.getSize(), "argv": list(sys.argv), "options": recorded}
    return comm.tompi4py().bcast(info, root=0)


def git_state(folder=None):
    """{"commit": HEAD, "dirty": tracked files modified} of the git checkout that holds this
    package, or None: no git, not a checkout, or a checkout that does not track the package
    (an installed copy inside some other repository's tree)."""
    folder = folder or os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def git(*args):
        res = subprocess.run(["git", "-C", folder, *args], capture_output=True, text=True,
                             timeout=GIT_SECONDS, stdin=subprocess.DEVNULL)
        return res.stdout.strip() if res.returncode == 0 else None

    try:
        if git("ls-files", "--error-unmatch", "--", "__init__.py") is None:
            return None
        commit = git("rev-parse", "HEAD")
        status = git("status", "--porcelain", "--untracked-files=no")
    except (OSError, subprocess.SubprocessError):
        return None
    if not commit or status is None:
        return None
    return {"commit": commit, "dirty": bool(status)}


def libraries() -> dict:
    """Versions of PETSc, SLEPc, the MPI library and the Python packages of LIBRARIES
    (None for one that is not installed)."""
    from mpi4py import MPI
    from petsc4py import PETSc
    from slepc4py import SLEPc

    out = {"petsc": ".".join(map(str, PETSc.Sys.getVersion())),
           "slepc": ".".join(map(str, SLEPc.Sys.getVersion())),
           "mpi": MPI.Get_library_version().replace("\0", "").strip().splitlines()[0]}
    for name in LIBRARIES:
        out[name] = _version(name)
    return out


def cpu() -> dict:
    """The processor and the arithmetic NumPy chose on it: the CPU's model name, the
    machine type, and the SIMD features NumPy's dispatched kernels use (its
    ``__cpu_features__`` that are on; ``NPY_DISABLE_CPU_FEATURES`` turns some off). Machines
    with and without AVX-512 take different ``exp``/``sin`` kernels that round differently,
    so the last digits of a result depend on them."""
    return {"model": _cpu_model(), "machine": platform.machine(),
            "numpy_simd": _numpy_simd(),
            "numpy_disabled": os.environ.get("NPY_DISABLE_CPU_FEATURES") or None}


def _cpu_model():
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or None


def _numpy_simd():
    """NumPy's SIMD features in use, in its own order (None where NumPy does not say)."""
    for module in ("numpy._core._multiarray_umath", "numpy.core._multiarray_umath"):
        try:
            features = importlib.import_module(module).__cpu_features__
        except (ImportError, AttributeError):
            continue
        return [name for name, on in features.items() if on]
    return None


def _version(name):
    for dist in (name, *_ALIASES.get(name, ())):
        try:
            return importlib.metadata.version(dist)
        except importlib.metadata.PackageNotFoundError:
            pass
    # A package without metadata: a loaded module still knows.
    return getattr(sys.modules.get(name), "__version__", None)


def options(p) -> dict:
    """Every option of the run: the value in effect of each -mpm_ option that the analysis
    uses (after -mpm_target_error's picks), the names given, and the other PETSc options
    given (PETSc's names without the dash; None for a flag without a value)."""
    from petsc4py import PETSc

    used = {o.name for o in SPEC if p.analysis in o.used_by}
    given = PETSc.Options().getAll()
    return {"mpm": {k: list(v) if isinstance(v, tuple) else v
                    for k, v in sorted(vars(p).items()) if k in used},
            "mpm_given": list(p.given),
            "petsc": {k: v for k, v in sorted(given.items()) if not k.startswith(PREFIX)}}
