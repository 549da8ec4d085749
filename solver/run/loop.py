"""The one time loop: it drives every model that steps (the consolidation's explicit and
implicit schemes, the dynamic analysis with one or two phases) and owns the order of what a
step does, the blow-up check, the agreement of the ranks, checkpoints, signals, progress and
the end.

A model offers (the protocol :class:`Model`):

- ``advance(k)``: take step k (from the state of step k - 1 to that of step k);
- ``check(k)``: NumericalError on every rank for a state that blew up;
- ``sample(k)``: record the samples of step k (histories, reports);
- ``write_fields(k)``: the fields of step k into the output series (collective);
- ``state()``: what a checkpoint stores besides the points (a dict of JSON values);
- ``time(k)``: the time (s) that step k's samples and fields are of: the step's end, or
  its start for a model whose cadence counts from an offset of 1 (the one-phase dynamic
  step computes the acceleration at its start);
- ``progress(k)``: what the progress line says of step k ("t = 1.2 s, ...");
- ``points`` (the DMSwarm a checkpoint gathers) and ``log_stage`` (the PETSc log stage
  of its steps);
- optionally ``finished(k)``: true, on every rank alike, when the run ends after step k
  before the last (a flow come to rest); its fields are written then.

Step k is the k-th step of the run, counted from 1; a checkpoint's ``step`` is the last
step done, and a restart goes on with the next one. Every step the ranks agree (one
collective, on more than one rank) on whether a signal came (SIGTERM, SIGINT: the loop
stops after the step, with a checkpoint) and whether a checkpoint is due by the clock
(rank 0's), so that they stop and save at the same step.
"""

from __future__ import annotations

import dataclasses
import time
from typing import Protocol

import numpy as np
from petsc4py import PETSc

from ..common import signals
from ..common.errors import Interrupted
from ..io import checkpoint


class Model(Protocol):
    points: object
    log_stage: str

    def advance(self, k: int) -> None: ...
    def check(self, k: int) -> None: ...
    def sample(self, k: int) -> None: ...
    def write_fields(self, k: int) -> None: ...
    def state(self) -> dict: ...
    def time(self, k: int) -> float: ...
    def progress(self, k: int) -> str: ...


@dataclasses.dataclass(frozen=True)
class Cadence:
    """When the loop does what, in steps (``*_every`` 0: never by count) and seconds.

    Samples are taken every ``sample_every`` steps and at ``sample_steps``; fields written
    every ``output_every`` steps, at ``output_steps`` and at the last step; the state checked
    every ``check_every`` steps, at ``check_steps`` and at the last; a checkpoint written
    every ``checkpoint_every`` steps and ``checkpoint_seconds`` after the last one; a
    progress line printed every ``progress_seconds``. ``offset``: the samples' and fields'
    counts start at step ``offset`` (a model whose step k records the state at the start of
    the step, time k - 1, takes 1)."""

    nsteps: int
    sample_every: int = 1
    output_every: int = 0
    check_every: int = 50
    checkpoint_every: int = 0
    checkpoint_seconds: float = 0.0
    progress_seconds: float = 0.0
    offset: int = 0
    sample_steps: frozenset = frozenset()
    output_steps: frozenset = frozenset()
    check_steps: frozenset = frozenset()

    def samples(self, k: int) -> bool:
        return (k - self.offset) % self.sample_every == 0 or k in self.sample_steps

    def outputs(self, k: int) -> bool:
        return (bool(self.output_every) and (k - self.offset) % self.output_every == 0) \
            or k in self.output_steps or k == self.nsteps

    def checks(self, k: int) -> bool:
        return k % self.check_every == 0 or k == self.nsteps or k in self.check_steps

    def checkpoints(self, k: int) -> bool:
        return bool(self.checkpoint_every) and k % self.checkpoint_every == 0


@dataclasses.dataclass(frozen=True)
class Saving:
    """Where and how the loop writes checkpoints: the file, the signature of the run's
    physics and the run (:func:`checkpoint.write`'s ``sig`` and ``run``)."""

    path: str
    signature: str
    run: dict

    def write(self, comm, model, step: int) -> None:
        """The checkpoint of ``model`` after step ``step`` (collective)."""
        checkpoint.write(self.path, comm, model.points, dict(model.state(), step=step),
                         self.signature, self.run)


def drive(model: Model, cadence: Cadence, record, saving: Saving, first: int = 1) -> None:
    """Take steps ``first`` to ``cadence.nsteps`` of ``model``; ``record`` (a
    :class:`solver.run.record.Record`) enters the stepping phase, follows the steps
    (``steps``, ``whole``) and can write a checkpoint after a failure that follows them.
    A signal stops the run after its step with a checkpoint: Interrupted, agreed by every
    rank."""
    comm = record.comm
    mpi = comm.tompi4py() if comm.getSize() > 1 else None
    record.start = record.steps = first - 1
    record.saving = (lambda step: saving.write(comm, model, step), saving.path)
    record.enter(record.middle)
    t0 = last_print = last_save = time.perf_counter()
    # A blow-up overflows before the periodic check names it in one line; NumPy's warnings
    # would only precede that line on stderr.
    with np.errstate(over="ignore", invalid="ignore"), \
            signals.deferred(record.middle) as stop, PETSc.Log.Stage(model.log_stage):
        for k in range(first, cadence.nsteps + 1):
            record.whole = None          # mid-step: the state and the records disagree
            model.advance(k)
            if cadence.checks(k):
                model.check(k)
            if cadence.samples(k):
                model.sample(k)
            if cadence.outputs(k):
                model.write_fields(k)
            record.steps = k
            # Rank 0's clock decides what is due, for every rank: a model's progress may
            # take collective sums, and ranks that read their own clocks part ways.
            now = time.perf_counter()
            due = cadence.checkpoint_seconds > 0 and now - last_save > cadence.checkpoint_seconds
            show = cadence.progress_seconds and now - last_print > cadence.progress_seconds
            flags = 2 * stop.seen + (int(due) + 4 * int(bool(show)) if comm.getRank() == 0
                                     else 0)
            if mpi is not None:
                flags = mpi.allreduce(flags, op=_bor())
            if flags & 3 or cadence.checkpoints(k):
                record.save(k)
                last_save = time.perf_counter()
            if flags & 2:
                raise Interrupted(f"stopped by {stop.name or 'a signal'} at step {k} "
                                  f"(t = {model.time(k):.6g} s); checkpoint {saving.path}; "
                                  f"continue with -mpm_restart {saving.path}",
                                  stage=record.middle, agreed=True)
            record.whole = k
            if hasattr(model, "finished") and model.finished(k):
                if not cadence.outputs(k):
                    model.write_fields(k)
                break
            if flags & 4:
                last_print = now
                PETSc.Sys.Print(_progress(model, k, cadence.nsteps, now - t0, first),
                                comm=comm)
    record.enter("reporting")


def _progress(model, k: int, nsteps: int, elapsed: float, first: int) -> str:
    """``  step K/N (P %), <the model's words>, E s elapsed, about L s left``; the time
    left from the pace of the steps taken by this command."""
    left = elapsed / (k - first + 1) * (nsteps - k)
    return (f"  step {k}/{nsteps} ({100 * k / max(nsteps, 1):.0f} %), {model.progress(k)}, "
            f"{elapsed:.0f} s elapsed, about {left:.0f} s left")


def _bor():
    from mpi4py import MPI

    return MPI.BOR
