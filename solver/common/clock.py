"""Where a command's wall time goes: its start, and the phases of a run after it.

The command line (:func:`solver.__main__.main`) marks its start with :func:`command`; in a
process of its own that start is the process's (the interpreter's start-up and the imports
of NumPy, PETSc and numba count, as a user's clock counts them). A run measures its phases
from there with :class:`Phases`: the set-up (up to the first step: options, the body, the
critical time steps and the stability analysis, the static references, the kernels), the
stepping, and the reporting (tables, field series, CSV files and figures, up to the
summary), and their total. A run started from Python without the command line (a study)
measures from its own start.
"""

from __future__ import annotations

import contextlib
import os
import time

_origin = None     # perf_counter() of the running command's start; None outside a command


def process_age():
    """Seconds since this process started (Linux: /proc/self/stat against the boot-time
    clock, to 10 ms), or None where that cannot be read."""
    try:
        with open("/proc/self/stat", encoding="ascii") as fh:
            fields = fh.read().rsplit(")", 1)[1].split()   # after "(command name)"
        started = int(fields[19]) / os.sysconf("SC_CLK_TCK")  # field 22: start time
        return max(0.0, time.clock_gettime(time.CLOCK_BOOTTIME) - started)
    except (OSError, ValueError, IndexError, AttributeError):
        return None


@contextlib.contextmanager
def command(fresh: bool):
    """The block is one command: its start is now, or with ``fresh`` (the command is the
    process: ``python -m solver``, ``mpm-geo``) the process's start."""
    global _origin
    now = time.perf_counter()
    before, _origin = _origin, now - ((process_age() or 0.0) if fresh else 0.0)
    try:
        yield
    finally:
        _origin = before


class Phases:
    """Wall seconds of a run's phases, each from the end of the one before (the first from
    the command's start, or from now outside a command)."""

    def __init__(self):
        self.origin = _origin if _origin is not None else time.perf_counter()
        self.marks = []        # (phase, perf_counter at its end)

    def mark(self, phase: str) -> None:
        """The phase ``phase`` ends now."""
        self.marks.append((phase, time.perf_counter()))

    def seconds(self, running: str = "") -> dict:
        """``{phase: s, ..., "total": s}`` of the phases marked so far, and of the phase
        ``running`` (when given) up to now."""
        out, last = {}, self.origin
        marks = self.marks + ([(running, time.perf_counter())] if running else [])
        for phase, at in marks:
            out[phase] = at - last
            last = at
        out["total"] = last - self.origin
        return out

    def line(self) -> str:
        """``Wall time 5.2 s: set-up 2.6 s, stepping 1.0 s, reporting 1.6 s``."""
        s = self.seconds()
        parts = ", ".join(f"{phase} {s[phase]:.1f} s" for phase, _ in self.marks)
        return f"Wall time {s['total']:.1f} s: {parts}"


_EVENTS = {}


def log_event(name: str):
    """PETSc log event ``name`` (what -log_view shows), registered once per process on first
    use (PETSc is then initialised with the command line, which a registration at import
    could precede)."""
    from petsc4py import PETSc

    ev = _EVENTS.get(name)
    if ev is None:
        ev = _EVENTS[name] = PETSc.Log.Event(name)
    return ev
