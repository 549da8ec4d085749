"""Command line: ``mpirun -n N python -m solver -options_file cases/<scene>.opts [options]``.

Exit codes:

- 0 success;
- 2 bad input: an option, a scene file, an output folder that cannot be written (nothing
  computed, nothing written);
- 3 numerical failure (Jacobi, a KSP or an EPS not converged, a mass that is not positive definite,
  a blown-up run): the summary says what was computed and where it failed;
- 4 stopped by SIGTERM/SIGINT at any point: one line naming the stage, the summary
  (``"completed": false``, the ``error`` with its ``stage``) once the output folder is
  known, and a checkpoint once the steps have begun. A parallel run stopped where its
  ranks cannot agree (before the steps) aborts MPI after rank 0's summary;
- 5 internal error: an exception the solver did not foresee (a bug, or the machine out of
  memory or disk). The summary is still written (``"completed": false``, the ``error``),
  with a checkpoint when the points held a whole step. In a parallel run a failure that
  only some ranks meet inside the stepping aborts MPI (the others wait in a collective).

Failures print one line on stderr (rank 0; the failing rank for an unshared internal
error); ``-mpm_debug`` adds the Python traceback. Options a scene file sets that the chosen
analysis does not use, and its report times after ``-mpm_Tv_end``, are dropped with a note;
given on the command line they are errors. A reader of stdout that goes away (``| head``)
does not stop the run. ``-help`` (``--help``, ``-h``) prints the option table with the values
in effect and runs nothing (exit 0); PETSc's generic help (its own options: ``-log_view``,
``-on_error_abort``, ...) comes before it only with ``-help petsc``.
"""

from __future__ import annotations

import contextlib
import os
import signal
import sys
import tempfile
import traceback


HELP = ("-help", "--help", "-h")


def _petsc_argv(argv) -> list:
    """The command line as PETSc's start sees it: without -help, unless it asks for PETSc's
    own help too (``-help petsc``: PETSc sees a plain ``-help``)."""
    ours = [i for i, a in enumerate(argv) if a in HELP]
    asked = [i for i in ours if argv[i + 1:i + 2] == ["petsc"]]
    drop = {i + 1 for i in asked} if asked else set(ours)
    return _files_first([a for i, a in enumerate(argv) if i not in drop])


def _files_first(argv) -> list:
    """``argv`` with its ``-options_file`` / ``-options_file_yaml`` pairs moved to the front
    (after the program name), in their order. PETSc reads a file where it stands on the
    command line, so a file after an option would override it; the command line wins over
    the scene wherever it stands (as :func:`options.command_line` does for a hosted run)."""
    files, rest, i = [], [], 1
    while i < len(argv):
        if argv[i] in ("-options_file", "-options_file_yaml") and i + 1 < len(argv):
            files += argv[i:i + 2]
            i += 2
        else:
            rest.append(argv[i])
            i += 1
    return argv[:1] + files + rest


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


def _scan_options_files(argv) -> tuple:
    """(where each option of the -options_file files is set, None), the files checked
    before PETSc reads them; (the options so far, exit code 2) after the error line for a
    missing name or file, or a malformed file."""
    origins = {}
    for flag, path in _options_files(argv):
        if path is None or path.startswith("-"):
            return origins, _fail(f"{flag}: needs a file name", 2, _rank())
        if not os.path.isfile(path):
            return origins, _fail(f"{flag} {path}: no such file", 2, _rank())
        if flag == "-options_file":
            from .common.errors import InputError
            from .io.scenefile import scan_file

            try:
                origins.update(scan_file(path))
            except InputError as exc:
                return origins, _fail(str(exc), 2, _rank())
    return origins, None


def main(argv=None, comm=None) -> int:
    """Run the command line ``argv`` (program name first; ``sys.argv`` when None) and return
    its exit code.

    Called from Python where PETSc already runs (a test, a notebook, one process running
    several scenes), the options of ``argv`` hold for this call only and ``comm`` (default
    ``PETSc.COMM_WORLD``) runs the analysis; ``-options_left`` and ``-log_view`` then belong
    to the host process, which prints them when it finalises PETSc.

    SIGTERM and SIGINT stop it at any point with one line and exit code 4
    (:mod:`solver.common.signals`), from the start, before PETSc runs, on.
    """
    if "petsc4py.PETSc" not in sys.modules:
        from .io.launch import missing

        problem = missing()       # a Python without PETSc (a pyenv's): one line, not a trace
        if problem:
            return _fail(problem, 2, _rank())
    from .common import clock, signals
    from .common.errors import Interrupted

    # A process of its own (PETSc not yet started) counts its wall time from its own start.
    with signals.watched(), clock.command(fresh="petsc4py.PETSc" not in sys.modules):
        signals.stage("start-up")
        try:
            return _main(list(sys.argv if argv is None else argv), comm)
        except Interrupted as exc:     # before the analysis began (it reports its own)
            return _fail(str(exc), exc.exit_code, _rank())


def _main(argv, comm) -> int:
    """:func:`main` with the signals watched."""
    origins, code = _scan_options_files(argv)
    if code is not None:
        return code
    scene_analysis = _value_at(origins["analysis"]) if "analysis" in origins else None
    for arg in argv:                # the command line overrides the files
        if arg.startswith("-mpm_"):
            origins.pop(arg[5:], None)

    hosted = "petsc4py.PETSc" in sys.modules
    if not hosted:
        # (Called again where PETSc runs, init would register a second finalisation.)
        import petsc4py
        import slepc4py

        # -help is ours (the option table); PETSc's generic help only when asked for by
        # name, -help petsc (printed by PETSc's start, before the table).
        petsc_argv = _petsc_argv(argv)
        petsc4py.init(petsc_argv)
        slepc4py.init(petsc_argv)
    from petsc4py import PETSc
    from slepc4py import SLEPc  # noqa: F401  (initialised here, before the signals are set)

    from .common.errors import InputError
    from .io import options

    comm = PETSc.COMM_WORLD if comm is None else comm
    try:
        with options.command_line(argv) if hosted else contextlib.nullcontext():
            return _run(argv, origins, scene_analysis, comm)
    except InputError as exc:    # a command line that is not options
        return _fail(str(exc), 2, comm.getRank())


def _run(argv, origins, scene_analysis, comm) -> int:
    """The analysis the options in PETSc's database ask for; the exit code (see above)."""
    from petsc4py import PETSc

    from .common import signals
    from .common.errors import InputError, InternalError, Interrupted, NumericalError, describe
    from .io import options, restart

    _survive_closed_stdout()
    if set(HELP) & set(argv):
        return _help(options, origins, comm)
    debug = PETSc.Options().getString("mpm_debug", "false")
    debug = str(debug or "true").strip().lower() not in ("0", "false", "no", "off")
    if not debug:
        # Errors reach us as exceptions and are reported in one line; PETSc's own
        # multi-line dump would only repeat them.
        PETSc.Sys.pushErrorHandler("ignore")
    try:
        signals.stage("set-up")
        params = restart.read_options(origins)
        params, moved = _own_folder(params, scene_analysis)
        for note in params.notes + moved:
            PETSc.Sys.Print(f"Note: {note}", comm=comm)
        check_output(params.output, params.summary, comm)
        # Each analysis's driver: run(options, comm) -> 0, or a failure raised after its
        # record has written the summary (solver.run.record).
        import importlib

        driver = importlib.import_module(f".{params.analysis}.driver", __package__)
        return driver.run(params, comm)
    except Interrupted as exc:
        if debug:
            traceback.print_exc()
        code = _fail(str(exc), exc.exit_code, comm.getRank())
        if comm.getSize() > 1 and not exc.agreed:
            _abort(comm, code)
        return code
    except (InputError, NumericalError, InternalError) as exc:
        if debug:
            traceback.print_exc()
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
    except Exception as exc:   # noqa: BLE001  (a failure this rank alone may know of)
        if debug:
            traceback.print_exc()
        if comm.getSize() == 1:
            return _fail(f"internal error: {describe(exc)}", 5)
        # The other ranks may wait in a collective that this one will never join.
        _fail(f"internal error on rank {comm.getRank()}: {describe(exc)}; aborting MPI", 5)
        comm.tompi4py().Abort(5)
    finally:
        if not debug:
            PETSc.Sys.popErrorHandler()
        _release_stdout()
    return 0


def _help(options, origins, comm) -> int:
    """Print the option table with the values in effect (defaults, then the scene files,
    then the command line; with -mpm_restart, the checkpoint's in place of the defaults)
    and run nothing. Values that :func:`options.read` refuses are shown as given, with the
    reason below the table."""
    from petsc4py import PETSc

    from .common.errors import InputError
    from .io import restart

    problem = ""
    try:
        values = restart.read_options(origins)
    except InputError as exc:
        values, problem = options.given_text(), f"\nNote: {exc}; this command would stop there"
    text = ("Options of the MPM solver (SI units), with the values this command would use "
            "(an option on the command line wins over the -options_file scenes, before or "
            "after them):\n"
            + options.table(values=values) + problem
            + "\nPETSc's and SLEPc's own options (-log_view, -eps_type, ...): -help petsc")
    # Line by line: PETSc formats one print in an 8 KiB buffer, and the table is longer.
    for line in text.splitlines():
        PETSc.Sys.Print(line, comm=comm)
    return 0


def _value_at(where: str) -> str:
    """The value on line ``FILE:LINE`` of a scene file (checked by scan_file already)."""
    path, number = where.rsplit(":", 1)
    with open(path, encoding="utf-8") as fh:
        line = fh.read().splitlines()[int(number) - 1]
    tokens = line.split("#", 1)[0].split()
    return tokens[1] if len(tokens) > 1 else ""


def _own_folder(p, scene_analysis) -> tuple:
    """A scene of one analysis run as the other (``-mpm_analysis`` on the command line)
    writes into a sub-folder of the scene's ``-mpm_output``, named after the analysis, so
    that it leaves the scene's own summary alone; returns the parameters (frozen: a copy
    when the folder changes) and the note that says so."""
    if scene_analysis in (None, p.analysis) or "output" not in p.from_file:
        return p, ()
    import dataclasses

    p = dataclasses.replace(p, output=os.path.join(p.output, p.analysis))
    return p, (f"a {scene_analysis} scene run as -mpm_analysis {p.analysis}: results in "
               f"{p.output}",)


def check_output(folder, summary, comm) -> None:
    """InputError on every rank, before anything is computed, when the results cannot be
    written where ``-mpm_output`` (``folder``) and ``-mpm_summary`` (``summary``, '' for
    the default) send them. Rank 0, the one that writes, tries and tells the others."""
    problem = None
    if comm.getRank() == 0:
        problem = _unwritable(folder, "-mpm_output")
        if problem is None and summary:
            if os.path.isdir(summary):
                problem = f"-mpm_summary {summary}: a folder, not a file name"
            else:
                problem = _unwritable(os.path.dirname(summary) or ".", "-mpm_summary",
                                      summary)
    problem = comm.tompi4py().bcast(problem, root=0)
    if problem:
        from .common.errors import InputError

        raise InputError(problem)


def _unwritable(folder: str, flag: str, given: str = None):
    """Why ``folder`` cannot take result files, or None. Missing folders are made, a
    temporary file is created and removed in it, then the folders made are removed again:
    a run refused later for another reason leaves nothing behind."""
    given = given or folder
    path = os.path.abspath(folder)
    missing = []
    while not os.path.lexists(path):
        missing.append(path)
        path = os.path.dirname(path)
    if not os.path.isdir(path):
        what = "exists and is not a folder" if not missing else f"{path} is not a folder"
        return f"{flag} {given}: {what}"
    made = []
    try:
        for d in reversed(missing):
            os.mkdir(d)
            made.append(d)
        fd, tmp = tempfile.mkstemp(prefix=".probe-", dir=os.path.abspath(folder))
        os.close(fd)
        os.remove(tmp)
    except OSError as exc:
        where = missing[len(made)] if len(made) < len(missing) else os.path.abspath(folder)
        verb = "create the folder" if len(made) < len(missing) else "write in"
        return f"{flag} {given}: cannot {verb} {where} ({exc.strerror})"
    finally:
        for d in reversed(made):
            try:
                os.rmdir(d)
            except OSError:
                pass
    return None


def _survive_closed_stdout() -> None:
    """A reader of stdout that goes away (``| head``) must not stop the run. PETSc catches
    SIGPIPE and aborts MPI; with the signal ignored a write to the closed pipe fails with
    EPIPE, which PETSc's printing passes over, and the run goes on to write its results."""
    if hasattr(signal, "SIGPIPE"):
        signal.signal(signal.SIGPIPE, signal.SIG_IGN)


def _release_stdout() -> None:
    """Flush Python's stdout; on a closed pipe point it at /dev/null, so that the flush at
    exit does not fail again (which would turn the exit code into 120)."""
    try:
        sys.stdout.flush()
    except (BrokenPipeError, ValueError):
        try:
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        except (OSError, ValueError):
            pass


def _abort(comm, code: int) -> None:
    """End a parallel run that a signal stopped where its ranks cannot agree (in a
    collective some of them may never join): rank 0, which has written the summary and
    the error line, aborts MPI; the others give it a moment to do so first."""
    import time

    if comm.getRank() != 0:
        time.sleep(2.0)
    comm.tompi4py().Abort(code)


def _fail(message: str, code: int, rank: int = 0) -> int:
    """Print ``message`` as the one error line (on rank 0) and return ``code``."""
    if rank == 0:
        try:
            sys.stderr.write(f"solver: error: {message}\n")
            sys.stderr.flush()
        except (OSError, ValueError):      # stderr closed too: the exit code still tells
            pass
    return code


if __name__ == "__main__":
    sys.exit(main())
