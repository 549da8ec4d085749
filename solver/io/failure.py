"""What a run that stops early writes, for both analyses: the summary so far
(``"completed": false``, the ``error`` with the stage it stopped in) and, for a
consolidation run once the points hold a whole step after the stepping began, a checkpoint
to continue from."""

from __future__ import annotations

import sys
import time

from ..common import signals
from ..common.errors import InternalError, Interrupted, describe, entry
from . import output


class RunFailure:
    """What the failure handlers of :func:`consolidation.driver.run` and
    :func:`eigen.driver.run` need, set as the run gets there."""

    def __init__(self, comm, analysis="consolidation"):
        self.phase = "set-up"        # then "stepping", "reporting" (eigen: "writing")
        self.summary = None          # the summary so far, and where it goes (once the
        self.summary_path = ""       # output folder is known to be this run's)
        self.analysis = analysis
        self.early = {"analysis": analysis}   # the summary before there is one
        self.save = None             # save(step) writes a checkpoint (collective)
        self.ckpt_path = ""
        self.start = None            # the step the run started from (0, or a restart's)
        self.whole = None            # the last step whose points and records all agree
        self.t_wall = time.perf_counter()
        self.cleanup = []            # calls that undo the run's settings (FP)
        self.owned = []              # PETSc objects (and their owners), destroyed by run()

    def begin(self, summary_path, run_id, recorded):
        """Where the summary goes, the run's id and its options as provenance records
        them (``recorded``), for a summary written before the full one (no collective);
        from here on a stopped run writes its summary."""
        self.summary_path = summary_path
        self.early = {"analysis": self.analysis, **({"run_id": run_id} if run_id else {}),
                      "provenance": {"argv": list(sys.argv), "options": recorded}}

    def record(self, comm, message, exc=None, code=5, stage="", agreed=True):
        """Write what a stopped run can (a checkpoint when the state is whole, the stepping
        has begun and ``agreed``: every rank takes part; the summary on rank 0); return the
        exception to raise: InternalError (``code`` 5) or Interrupted (4) of ``message``
        (None: write the summary of ``exc`` only)."""
        for undo in self.cleanup:
            undo()
        stage = stage or signals.current() or self.phase
        text = message if code == 4 else f"internal error: {message or describe(exc)}"
        said = []
        ckpt = None
        if message is not None and agreed and self.whole is not None \
                and self.whole > self.start:
            try:
                self.save(self.whole)
                ckpt = self.ckpt_path
                said.append(f"checkpoint {ckpt} at step {self.whole} (continue with "
                            f"-mpm_restart {ckpt})")
            except Exception as err:   # noqa: BLE001  (the disk may be what failed)
                said.append(f"no checkpoint ({describe(err)})")
        if comm.getRank() == 0 and self.summary_path:
            said.append(self.write_summary(text, code, stage, ckpt))
        if message is None:
            return None
        said = f"; {', '.join(said)}" if said else ""
        if code == 4:
            return Interrupted(text + said, stage=stage, agreed=agreed)
        return InternalError(text + said)

    def write_summary(self, text, code, stage, ckpt=None, extra=None) -> str:
        """The summary of the stopped run (rank 0), with ``extra`` entries; what the error
        line says of it."""
        summary = dict(self.summary or self.early, **(extra or {}))
        files = {"summary": self.summary_path}
        if ckpt:
            files["checkpoint"] = ckpt
        summary.update(completed=False, error=entry(text, code, stage), files=files,
                       wall_seconds=time.perf_counter() - self.t_wall)
        if code == 4:
            summary["interrupted"] = True
        if self.whole is not None:
            summary["steps"] = self.whole
        try:
            output.write_json(self.summary_path, summary)
        except Exception as err:   # noqa: BLE001
            return f"no summary ({describe(err)})"
        return f"summary {self.summary_path}"
