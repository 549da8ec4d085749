"""Failures the command line reports with a one-line message and a fixed exit code
(0 success, 2 bad input, 3 numerical failure, 4 stopped by a signal, 5 internal error)."""


class InputError(Exception):
    """Bad input: an option with a wrong type, range or spelling. Exit code 2."""

    exit_code = 2


class NumericalError(Exception):
    """A numerical failure: a solver that does not converge, a run that blows up. Exit code 3."""

    exit_code = 3


class NotConverged(NumericalError):
    """A PETSc KSP or SLEPc EPS that stopped without converging (:func:`check_converged`):
    its solver is the options' (``-static_ksp_*``, ``-eps_*``), so the run stops on it even
    where another numerical failure only drops what it would have given. Exit code 3."""


class Interrupted(BaseException):
    """A run stopped by SIGTERM or SIGINT (:mod:`solver.common.signals`), after writing the summary
    and, once stepping has begun, a checkpoint. Exit code 4. ``stage``: where it stopped.
    ``agreed``: every rank stopped at the same point (between two steps), so the ranks can
    go on together; otherwise a parallel run aborts MPI after the summary.

    A BaseException, as KeyboardInterrupt is: raised by a signal's handler wherever the run
    is, it must pass through the ``except Exception`` of code that handles its own
    failures."""

    exit_code = 4

    def __init__(self, message="", stage="", agreed=False):
        super().__init__(message)
        self.stage, self.agreed = stage, agreed


class InternalError(Exception):
    """An unexpected failure (a bug, or the machine: memory, disk) that every rank has
    agreed on, after the summary (and a checkpoint when the state was whole) was written.
    Exit code 5."""

    exit_code = 5


def check_converged(solver, what: str) -> None:
    """:class:`NotConverged` when the PETSc KSP or SLEPc EPS ``solver`` stopped without converging
    (its converged reason below 0: the iteration limit, a breakdown, a failed
    factorization), naming ``what`` was solved, the solver type, the reason and the
    iterations. A KSP or EPS run by options (``-static_ksp_type cg``) may stop anywhere,
    and its last iterate is no result."""
    reason = solver.getConvergedReason()
    if reason >= 0:
        return
    names = {v: k for k, v in vars(type(solver).ConvergedReason).items()
             if k.startswith(("CONVERGED_", "DIVERGED_"))}
    raise NotConverged(f"{what}: {type(solver).__name__} {solver.getType()} did not "
                         f"converge ({names.get(reason, reason)} after "
                         f"{solver.getIterationNumber()} iterations)")


def describe(exc: BaseException) -> str:
    """``Type: message`` of an exception on one line (``Type`` alone without a message)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def agree(comm, failure) -> str:
    """The first failure of any rank as one line, or None on every rank if there is none.
    Collective over the PETSc communicator ``comm``: every rank calls it, failed or not."""
    return agree_code(comm, failure)[0]


def agree_code(comm, failure) -> tuple:
    """(:func:`agree`'s line, the exit code of that failure: 4 for a signal, else 5), or
    (None, 0). A signal's line is its own message, without the type's name."""
    mine = None
    if failure is not None:
        mine = (str(failure), 4) if isinstance(failure, Interrupted) else (describe(failure), 5)
    if comm.getSize() == 1:
        return mine or (None, 0)
    every = comm.tompi4py().allgather(mine)
    where = [(rank, got) for rank, got in enumerate(every) if got is not None]
    if not where:
        return None, 0
    rank, (text, code) = where[0]
    return f"{text} (on rank {rank})", code


KINDS = {2: "input", 3: "numerical", 4: "interrupted", 5: "internal"}


def entry(message: str, code: int, stage: str = "") -> dict:
    """The ``error`` entry of the summary of a failed run: the one-line message, the exit
    code and its kind, and the stage of the run where it happened when known."""
    out = {"kind": KINDS[code], "exit_code": code, "message": " ".join(message.split())}
    if stage:
        out["stage"] = stage
    return out
