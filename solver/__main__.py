"""Command line: ``mpirun -n N python -m solver -options_file cases/<scene>.opts [options]``.

Exit codes: 0 success, 2 bad input, 3 numerical failure, 4 stopped by SIGTERM/SIGINT
after writing a checkpoint. Failures print one line on stderr
(rank 0); ``-mpm_debug`` adds the Python traceback.
"""

from __future__ import annotations

import os
import sys


def _options_files(argv):
    """Paths given to -options_file / -options_file_yaml, checked before PETSc reads them."""
    for flag, value in zip(argv, argv[1:] + [None]):
        if flag in ("-options_file", "-options_file_yaml"):
            yield flag, value


def _rank() -> int:
    """This process's MPI rank before MPI starts (Open MPI, MPICH), 0 when run alone."""
    for var in ("OMPI_COMM_WORLD_RANK", "PMI_RANK", "PMIX_RANK"):
        if os.environ.get(var, "").isdigit():
            return int(os.environ[var])
    return 0


def main(argv=None) -> int:
    argv = list(sys.argv if argv is None else argv)
    origins = {}
    for flag, path in _options_files(argv):
        if path is None or path.startswith("-"):
            return _fail(f"{flag}: needs a file name", 2, _rank())
        if not os.path.isfile(path):
            return _fail(f"{flag} {path}: no such file", 2, _rank())
        if flag == "-options_file":
            from .errors import InputError
            from .options import scan_file

            try:
                origins.update(scan_file(path))
            except InputError as exc:
                return _fail(str(exc), 2, _rank())
    for arg in argv:                # the command line overrides the files
        if arg.startswith("-mpm_"):
            origins.pop(arg[5:], None)

    import petsc4py

    petsc4py.init(argv)
    import slepc4py

    slepc4py.init(argv)
    from petsc4py import PETSc

    from . import options
    from .errors import InputError, Interrupted, NumericalError

    comm = PETSc.COMM_WORLD
    if "-help" in argv or "-h" in argv:
        PETSc.Sys.Print("Options of the MPM solver (SI units):\n" + options.table(), comm=comm)
        return 0
    debug = PETSc.Options().getString("mpm_debug", "false")
    debug = str(debug or "true").strip().lower() not in ("0", "false", "no", "off")
    if not debug:
        # Errors reach us as exceptions and are reported in one line; PETSc's own
        # multi-line dump would only repeat them.
        PETSc.Sys.pushErrorHandler("ignore")
    try:
        params = options.read()
        if params.analysis == "eigen":
            from . import eigen

            eigen.run(params, comm)
        else:
            from . import consolidation

            code = consolidation.run(params, comm)
            if code:
                return code
    except (InputError, NumericalError, Interrupted) as exc:
        if debug:
            raise
        message = str(exc)
        if isinstance(exc, InputError):
            name = message.split(":")[0].split(" ")[0]
            if name.startswith("-mpm_") and name[5:] in origins:
                message += f" (set in {origins[name[5:]]})"
        return _fail(message, exc.exit_code, comm.getRank())
    except PETSc.Error as exc:
        if debug:
            raise
        return _fail(f"PETSc error {exc.ierr}: {exc}", 3, comm.getRank())
    return 0


def _fail(message: str, code: int, rank: int = 0) -> int:
    if rank == 0:
        sys.stderr.write(f"solver: error: {message}\n")
        sys.stderr.flush()
    return code


if __name__ == "__main__":
    sys.exit(main())
