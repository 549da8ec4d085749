"""A scene file: a plain PETSc options file (``cases/*.opts``), checked line by line before
PETSc reads it, and read as (name, value) pairs in order (the studies vary scenes with it)."""

from __future__ import annotations

from ..common.errors import InputError

PREFIX = "mpm_"    # the solver's own options: -mpm_...


def _option_lines(text: str):
    """(line number, line, words) of each line of an options file that is not empty or a
    comment."""
    for number, line in enumerate(text.splitlines(), start=1):
        words = line.split("#", 1)[0].split()
        if words:
            yield number, line, words


def pairs(path: str) -> list:
    """``[(name, value or None)]`` of a plain options file (checked by scan_file), in order."""
    with open(path, encoding="utf-8") as fh:
        return [(w[0][1:], w[1] if len(w) > 1 else None)
                for _, _, w in _option_lines(fh.read())]


def scan_file(path: str) -> dict:
    """Check a plain PETSc options file line by line before PETSc reads it.

    Returns where each ``-mpm_`` option is set, ``{name: "path:line"}``. A line must be empty,
    a comment (``#``) or ``-option [value]``; anything else is an InputError naming the file
    and line (PETSc itself would stop with a multi-line error dump).
    """
    try:
        with open(path, "rb") as fh:
            raw = fh.read()
        text = raw.decode("utf-8")
    except UnicodeDecodeError:
        raise InputError(f"{path}: not a text file") from None
    except OSError as exc:
        raise InputError(f"{path}: cannot be read ({exc.strerror})") from None
    if "\0" in text:
        raise InputError(f"{path}: not a text file")
    where = {}
    for number, line, tokens in _option_lines(text):
        if not tokens[0].startswith("-") or len(tokens[0]) < 2 or len(tokens) > 2:
            raise InputError(f"{path}:{number}: expected '-option [value]', found "
                             f"'{line.strip()[:60]}'")
        name = tokens[0][1:]
        if name.startswith(PREFIX):
            where[name[len(PREFIX):]] = f"{path}:{number}"
    return where
