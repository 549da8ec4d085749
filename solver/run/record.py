"""The run record: what ``summary.json`` holds, the same keys in every analysis, and the one
path by which a run that fails writes it.

The head of every summary:

- ``analysis``, ``run_id`` (None for an eigen run: it has no checkpoint to continue);
- ``completed``: true only when the run wrote everything it was asked for;
- ``steps``: the last step done (a stepping run; None for the eigen analysis, which takes
  none);
- ``wall``: wall seconds by phase, ``setup_s``, ``stepping_s`` (``solving_s`` for the eigen
  analysis), ``reporting_s`` and ``total_s``, from the command's start;
- ``provenance``: the package's version and git commit, the libraries, the CPU, the ranks,
  the command line and every option in effect (:mod:`solver.io.provenance`);
- ``error`` (a failed run only): ``kind`` (numerical, interrupted, internal: bad input
  stops a run before it writes anything),
  ``exit_code``, ``message``, ``stage`` (the phase and what it was doing) and ``step`` (the
  last step done, where there is one);
- ``files``: what the run wrote, the summary itself among them;
- the analysis's own block, named for it (``eigen``, ``consolidation``, ``dynamic``): its
  set-up and results.
 :func:`guarded` runs an analysis
and, whatever stops it, writes the summary once with what the run holds by then, and a
checkpoint where the run's state was whole after its last step.
"""

from __future__ import annotations

import contextlib

from petsc4py import PETSc

from ..common import clock, signals
from ..common.errors import (InputError, InternalError, Interrupted, NumericalError,
                             agree_code, describe, entry)
from ..io import checkpoint, output, provenance

#: The middle phase of each analysis: the steps, or the eigen analysis's solves.
MIDDLE = {"eigen": "solving"}


class Record:
    """The record of one run of ``analysis`` on ``comm`` (see the module's docstring).

    ``results`` holds the analysis's block, ``files`` what it wrote; the loop sets
    ``steps`` and ``whole`` (the last step whose state and records agree, None mid-step) and
    ``saving`` (how to write a checkpoint, :meth:`save`)."""

    def __init__(self, analysis: str, comm):
        self.analysis, self.comm = analysis, comm
        self.path = ""               # summary.json, once the run knows it is its own
        self.folder = "."            # the output folder
        self.run_id = None
        self.provenance = None
        self.results = {}
        self.files = {}
        self.clock = clock.Phases()
        self.phase = "set-up"
        self.done = False            # the last phase's clock stopped (finish)
        self.middle = MIDDLE.get(analysis, "stepping")
        self.steps = None if analysis == "eigen" else 0
        self.start = 0               # the step the run started from (a restart's)
        self.whole = None
        self.saving = None           # (write(step), path) of the checkpoints, once stepping

    def begin(self, outputs: output.Outputs, run_id, options: dict) -> None:
        """From here on a failure writes the summary (``outputs.summary``): the run's id and
        its provenance (collective: rank 0 asks git and the libraries) with ``options``
        (:func:`provenance.options`)."""
        self.path, self.folder, self.run_id = outputs.summary, outputs.folder, run_id
        self.provenance = provenance.collect(self.comm, options)

    def enter(self, phase: str) -> None:
        """The phase before ends now and ``phase`` begins (the stage a signal names)."""
        self.clock.mark(self.phase)
        self.phase = phase
        signals.stage(phase)

    def wall(self) -> dict:
        """``{"setup_s": ..., "stepping_s": ..., "reporting_s": ..., "total_s": ...}``: the
        phases so far, the current one up to now."""
        seconds = self.clock.seconds("" if self.done else self.phase)
        return {f"{name.replace('-', '')}_s": s for name, s in seconds.items()}

    def summary(self, completed: bool, error: dict | None = None) -> dict:
        """The summary as it stands: the head (with the error and the files), then the
        analysis's block."""
        head = {"analysis": self.analysis, "run_id": self.run_id, "completed": completed,
                "steps": self.steps, "wall": self.wall(), "provenance": self.provenance}
        if error is not None:
            head["error"] = error
        head["files"] = {"summary": self.path, **self.files}
        head[self.analysis] = self.results
        return head

    def write(self, completed: bool = True, error: dict | None = None) -> str:
        """Write the summary (rank 0; atomic); what the error line says of it."""
        if self.comm.getRank() != 0 or not self.path:
            return ""
        try:
            output.write_json(self.path, self.summary(completed, error))
        except Exception as err:   # noqa: BLE001  (the disk may be what failed)
            return f"no summary ({describe(err)})"
        return f"summary {self.path}"

    def finish(self) -> None:
        """The run's end: the reporting phase closed, the summary written (rank 0) and the
        wall time printed."""
        self.clock.mark(self.phase)
        self.done = True
        self.write(True)
        PETSc.Sys.Print(output.results_line(self.folder,
                                            self.summary(True)["files"]), comm=self.comm)
        PETSc.Sys.Print(f"{self.clock.line()}; summary {self.path}", comm=self.comm)

    def save(self, step: int) -> str:
        """Write the checkpoint after step ``step`` (collective) and list it among the
        files; returns its path."""
        write, path = self.saving
        write(step)
        self.files["checkpoint"] = path
        return path

    def stage(self) -> str:
        """Where the run is: its phase, and what it does there when the signals' stage
        says more ("set-up: the body")."""
        stage = signals.current() or self.phase
        return stage if stage.startswith(self.phase) else f"{self.phase}: {stage}"

    def error(self, message: str, code: int) -> dict:
        """The ``error`` entry of a failure now (:func:`entry`, with the step)."""
        out = entry(message, code, self.stage())
        if self.steps is not None and self.phase != "set-up":
            out["step"] = self.steps
        return out

    def fail(self, message: str, code: int, checkpoint: bool = False) -> str:
        """Write what a stopped run can: a checkpoint when ``checkpoint`` (every rank takes
        part) and the state is whole after a step of this run, then the summary (rank 0);
        returns what the error line adds ("; checkpoint ..., summary ...")."""
        said = []
        if checkpoint and self.saving is not None and self.whole is not None \
                and self.whole > self.start:
            try:
                path = self.save(self.whole)
                said.append(f"checkpoint {path} at step {self.whole} (continue with "
                            f"-mpm_restart {path})")
            except Exception as err:   # noqa: BLE001  (the disk may be what failed)
                said.append(f"no checkpoint ({describe(err)})")
        wrote = self.write(False, self.error(message, code))
        if wrote:
            said.append(wrote)
        return f"; {', '.join(said)}" if said else ""


def begun(record: Record, plan, comm) -> tuple:
    """(the checkpoint or None, the run id) of a plan that holds its ``restart``,
    ``overwrite``, ``signature``, ``outputs``, ``provenance`` and ``run``: the restart's
    checkpoint taken up (the output folder checked), ``record`` begun, the id in the
    plan's run."""
    ckpt, run_id = checkpoint.take_up(plan.restart, plan.overwrite, plan.signature,
                                      plan.outputs, comm)
    record.begin(plan.outputs, run_id, plan.provenance)
    plan.run["id"] = run_id
    return ckpt, run_id


def guarded(record: Record, work):
    """``work()`` (the analysis past its options' checks), its failures written into the
    record once, as they arise, and raised on:

    - InputError: nothing written (bad input stops a run before it computes);
    - a signal the loop has agreed on (every rank between two steps, the checkpoint
      written), a NumericalError or a PETSc error (every rank alike): the summary;
    - a signal elsewhere: in the reporting the ranks agree on it as on any failure there;
      before, rank 0 writes the summary and the ranks cannot agree (the command line
      aborts MPI in parallel);
    - any other exception (a bug, the machine): on one rank, or in the reporting where
      every rank gets to the same point, the ranks agree on it, a checkpoint keeps the
      whole state after the last step, and it becomes an InternalError (exit 5); inside
      the set-up or the steps of a parallel run the others may wait in a collective: the
      summary is written where rank 0 is the one that failed, and the exception goes to
      the command line as it is (to abort MPI)."""
    comm = record.comm
    failure = result = None
    try:
        result = work()
    except InputError:
        raise
    except Interrupted as exc:
        if exc.agreed:      # the loop's: its line names the checkpoint and the restart
            record.fail(str(exc), 4)
            raise
        if record.phase != "reporting":
            said = record.fail(str(exc), 4)
            raise Interrupted(str(exc) + said, stage=record.stage()) from None
        failure = exc
    except NumericalError as exc:
        record.fail(str(exc), exc.exit_code)
        raise
    except PETSc.Error as exc:
        record.fail(f"PETSc error {exc.ierr}: {exc}", 3)
        raise
    except Exception as exc:   # noqa: BLE001  (what the solver did not foresee)
        failure = exc
    if failure is None and record.phase != "reporting":
        return result
    if record.phase == "reporting" or comm.getSize() == 1:
        message, code = agree_code(comm, failure)     # every rank gets here, failed or not
        if message is None:
            return result
        if code == 4:
            said = record.fail(message, 4, checkpoint=True)
            raise Interrupted(message + said, stage=record.stage(), agreed=True) \
                from failure
        text = f"internal error: {message}"
        raise InternalError(text + record.fail(text, 5, checkpoint=True)) from failure
    record.fail(f"internal error: {describe(failure)}", 5)
    raise failure


@contextlib.contextmanager
def owned(comm):
    """An ExitStack for the PETSc objects a run makes (last made, first destroyed), unwound
    on the way out, after the failure handling (a checkpoint needs the points); not after a
    failure that some ranks of a parallel run may not know of (a raw exception, a signal
    the ranks did not agree on): the others wait in a collective that a destroy, collective
    too, would join, and the command line aborts MPI."""
    stack = contextlib.ExitStack()
    try:
        yield stack
    except (InputError, NumericalError, InternalError, PETSc.Error):
        stack.close()
        raise
    except BaseException as exc:
        agreed = isinstance(exc, Interrupted) and exc.agreed
        if agreed or comm.getSize() == 1:
            stack.close()
        else:
            stack.pop_all()
        raise
    stack.close()
