"""Batches of solver runs for the study scripts (reproduction, convergence, stability map).

Each run is a separate ``mpirun -n R python -m solver ...`` process that writes its own
``summary.json``; a run whose summary already exists with the same arguments is not repeated,
so a study that was killed continues where it stopped. Runs are spread over the cores: with
C cores and R ranks per run, C // R run at once.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field


ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
PUBLISHED = os.path.join(ROOT, "docs", "results")     # the tracked results the docs show
STUDIES = os.path.join(ROOT, "output", "studies")      # everything else, untracked


def add_destination(ap, name: str, what: str) -> None:
    """``--out`` and ``--publish`` of a study script: its results ``what`` go to
    output/studies/``name``/ unless ``--publish`` sends them to docs/results/ (the tracked
    copy the docs show) or ``--out`` elsewhere; :func:`destination` reads them."""
    ap.set_defaults(_study_name=name)
    ap.add_argument("--out", default=None,
                    help=f"folder for {what} (default "
                         f"{os.path.relpath(os.path.join(STUDIES, name), ROOT)})")
    ap.add_argument("--publish", action="store_true",
                    help=f"write {what} into {os.path.relpath(PUBLISHED, ROOT)}, the tracked "
                         "results the docs show, instead of the default folder")


def destination(ap, args) -> str:
    """The folder chosen by the options of :func:`add_destination` (argparse error when
    both are given)."""
    if args.publish and args.out:
        ap.error("--publish writes docs/results; leave out --out (or --publish)")
    return args.out or (PUBLISHED if args.publish else os.path.join(STUDIES, args._study_name))


@dataclass
class Run:
    name: str
    args: list                 # solver options, e.g. ["-options_file", "cases/x.opts", ...]
    folder: str                # its -mpm_output folder
    ranks: int = 1
    result: dict = field(default=None)
    code: int = None
    seconds: float = 0.0
    stderr: str = ""
    reused: bool = False

    @property
    def summary_path(self):
        return os.path.join(self.folder, "summary.json")

    def command(self):
        cmd = [sys.executable, "-m", "solver", *self.args, "-mpm_output", self.folder]
        if self.ranks > 1:
            cmd = [shutil.which("mpirun") or "mpirun", "-n", str(self.ranks), *cmd]
        return cmd


def environment():
    """The children's environment: Open MPI refuses root without these two variables, and
    each child runs on one core (its BLAS too: two threads per child on a core each would
    contend with the other children)."""
    env = dict(os.environ)
    for var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS"):
        env.setdefault(var, "1")
    if hasattr(os, "geteuid") and os.geteuid() == 0:
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
        env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    return env


def _done(run: Run):
    """The stored summary of an identical earlier run, or None."""
    try:
        with open(run.summary_path) as fh:
            summary = json.load(fh)
        with open(os.path.join(run.folder, "args.json")) as fh:
            args = json.load(fh)
    except (OSError, ValueError):
        return None
    if args.get("args") != run.args or args.get("ranks") != run.ranks:
        return None
    if not (summary.get("stable") is False or "monitor" in summary
            or summary.get("analysis") == "eigen"):
        return None        # an interrupted run: do it again
    if summary.get("completed") is False and (summary.get("error") or {}).get("kind") not in (
            "numerical",):
        return None        # stopped or failed for a reason that may not come again
    return summary, args.get("code"), args.get("seconds", 0.0)


def execute(run: Run, log=print, fresh=False) -> Run:
    """Run one job (or reuse its stored result) and load its summary into ``run.result``."""
    cached = None if fresh else _done(run)
    if cached:
        run.result, run.code, run.seconds = cached
        run.reused = True
        log(f"  {run.name}: stored result (exit {run.code})")
        return run
    os.makedirs(run.folder, exist_ok=True)
    t0 = time.perf_counter()
    proc = subprocess.run(run.command(), env=environment(), capture_output=True, text=True)
    run.seconds = time.perf_counter() - t0
    run.code, run.stderr = proc.returncode, proc.stderr.strip()
    try:
        with open(run.summary_path) as fh:
            run.result = json.load(fh)
    except (OSError, ValueError):
        run.result = None
    with open(os.path.join(run.folder, "stdout.txt"), "w") as fh:
        fh.write(proc.stdout + proc.stderr)
    if run.result is not None:
        with open(os.path.join(run.folder, "args.json"), "w") as fh:
            json.dump({"args": run.args, "ranks": run.ranks, "code": run.code,
                       "seconds": run.seconds}, fh)
    last = run.stderr.splitlines()[-1] if run.stderr else ""
    log(f"  {run.name}: exit {run.code}, {run.seconds:.1f} s" + (f" ({last})" if last else ""))
    return run


def execute_all(runs, cores: int = 2, log=print, fresh=False):
    """Run every job, ``cores // ranks`` at a time, longest first as given; returns ``runs``."""
    width = max(1, cores // max(r.ranks for r in runs)) if runs else 1
    with ThreadPoolExecutor(max_workers=width) as pool:
        list(pool.map(lambda r: execute(r, log, fresh), runs))
    return runs


def cores() -> int:
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()


def read_scene(path: str, extra=()):
    """The options of scene file ``path`` with ``extra`` (``["-mpm_k", "1e-9", ...]``) on
    top, read and checked as the solver reads them (for a study that derives its runs'
    settings from the scene, e.g. the mass-scaling factor or the wave period)."""
    from ..io import options, scenefile

    pairs = scenefile.pairs(path) + options._pairs(list(extra))
    return options.from_mapping({name[len(options.PREFIX):]: value for name, value in pairs
                                 if name.startswith(options.PREFIX)})
