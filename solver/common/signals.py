"""SIGTERM and SIGINT (what batch schedulers and Ctrl-C send) at any point of a run.

While a command runs (:func:`watched`), either signal raises :class:`Interrupted` at once,
naming the stage the run was in (:func:`stage`): the set-up, the stability analysis, an
eigen solve, the reporting. While the loop steps (:func:`deferred`) a signal is only
marked; the time loop looks at the mark after each step, where the ranks agree on it and the
points hold a whole state for the checkpoint.

Python runs a signal's handler between two bytecodes of the main thread: a long call into
C (a LAPACK or SLEPc solve, an MPI collective) ends first, then the run stops.
"""

from __future__ import annotations

import contextlib
import signal

from .errors import Interrupted

SIGNALS = (signal.SIGTERM, signal.SIGINT)


class _Watch:
    """The handlers' state: the stage, and while stepping the signal seen (0 or 1)."""

    def __init__(self):
        self.stage = "set-up"
        self.deferring = False
        self.seen, self.name = 0, ""

    def catch(self, signum, frame):
        name = signal.Signals(signum).name
        if self.deferring:
            self.seen, self.name = 1, name
            return
        raise Interrupted(f"stopped by {name} during {self.stage}", stage=self.stage)


_watch = None      # the installed handlers' state, None when none are installed


@contextlib.contextmanager
def watched():
    """SIGTERM and SIGINT raise Interrupted within the block (nested: the outer one holds),
    and get their former handlers back after it; yields the handlers' state. Outside the
    main thread, where Python cannot set handlers, the block runs without them (None)."""
    global _watch
    if _watch is not None:
        yield _watch
        return
    watch, old = _Watch(), {}
    try:
        for sig in SIGNALS:
            old[sig] = signal.signal(sig, watch.catch)
    except ValueError:       # not the main thread
        pass
    _watch = watch if old else None
    try:
        yield _watch
    finally:
        _watch = None
        for sig, handler in old.items():
            signal.signal(sig, handler)


def stage(name: str) -> None:
    """Say what the run does now (the stage an interruption names)."""
    if _watch is not None:
        _watch.stage = name


def current() -> str:
    """The stage the run is in ("" when no handlers are installed)."""
    return _watch.stage if _watch is not None else ""


@contextlib.contextmanager
def deferred(name: str):
    """Within the block (stage ``name``) a signal only marks the yielded state (``seen``:
    1, ``name``: the signal's name); the caller stops where it can. After the block a
    signal raises again; one seen within it is the caller's to act on."""
    with watched() as watch:
        if watch is None:                # not the main thread: nothing is ever seen
            yield _Watch()
            return
        before = watch.stage
        watch.stage, watch.deferring = name, True
        try:
            yield watch
        finally:
            watch.deferring = False
            watch.stage = before
