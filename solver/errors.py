"""Failures the command line reports with a one-line message and a fixed exit code
(0 success, 2 bad input, 3 numerical failure, 4 stopped by a signal, 5 internal error)."""


class InputError(Exception):
    """Bad input: an option with a wrong type, range or spelling. Exit code 2."""

    exit_code = 2


class NumericalError(Exception):
    """A numerical failure: a solver that does not converge, a run that blows up. Exit code 3."""

    exit_code = 3


class Interrupted(Exception):
    """A run stopped by SIGTERM or SIGINT after writing a checkpoint. Exit code 4."""

    exit_code = 4


class InternalError(Exception):
    """An unexpected failure (a bug, or the machine: memory, disk) that every rank has
    agreed on, after the summary (and a checkpoint when the state was whole) was written.
    Exit code 5."""

    exit_code = 5


def describe(exc: BaseException) -> str:
    """``Type: message`` of an exception on one line (``Type`` alone without a message)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def agree(comm, failure) -> str:
    """The first failure of any rank as one line, or None on every rank if there is none.
    Collective over the PETSc communicator ``comm``: every rank calls it, failed or not."""
    mine = None if failure is None else describe(failure)
    if comm.getSize() == 1:
        return mine
    every = comm.tompi4py().allgather(mine)
    where = [(rank, text) for rank, text in enumerate(every) if text is not None]
    return None if not where else f"{where[0][1]} (on rank {where[0][0]})"


KINDS = {2: "input", 3: "numerical", 4: "interrupted", 5: "internal"}


def entry(message: str, code: int) -> dict:
    """The ``error`` entry of the summary of a failed run: the one-line message, the exit
    code and its kind."""
    return {"kind": KINDS[code], "exit_code": code, "message": " ".join(message.split())}
