"""Failures the command line reports with a one-line message and a fixed exit code."""


class InputError(Exception):
    """Bad input: an option with a wrong type, range or spelling. Exit code 2."""

    exit_code = 2


class NumericalError(Exception):
    """A numerical failure: a solver that does not converge, a run that blows up. Exit code 3."""

    exit_code = 3


class Interrupted(Exception):
    """A run stopped by SIGTERM or SIGINT after writing a checkpoint. Exit code 4."""

    exit_code = 4
