"""The run frame of the study scripts in scripts/: their start-up, where their results go,
and batches of solver runs.

- :func:`start`: a script run as a command goes on under a Python with PETSc;
- :func:`add_destination` / :func:`destination`: ``--out`` and ``--publish``;
- :class:`Run`, :func:`execute`, :func:`execute_all`: solver runs, each a separate ``mpirun -n
  R python -m solver ...`` process that writes its own ``summary.json``. A run whose stored
  summary says it completed (or blew up: a numerical failure comes again) with the same
  arguments is not repeated, so a study that was killed continues where it stopped; a timed
  run asks for ``fresh``. Runs are spread over the cores: with C cores and R ranks per run,
  C // R run at once.

This module needs only the standard library: a script imports it before it knows that its
Python has PETSc and NumPy.
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


def start() -> None:
    """The start-up of a study script run as a command (``scripts/<name>``, ``python
    scripts/<name>.py``, or each rank of ``mpirun -n R python scripts/<name>.py``), called
    under ``if __name__ == "__main__"`` once the script has put the repository first on
    ``sys.path`` (the one thing it must do itself: it finds this module there), before it
    imports NumPy or PETSc. When this Python has no petsc4py (the first ``python3`` on PATH
    often has none), the script starts again under the repository's ``.venv`` or
    ``$MPM_GEO_PYTHON``, or exits 2 with one line saying what to do
    (:func:`solver.io.launch.use_petsc_python`). A script that is imported runs nothing of
    this."""
    from ..io.launch import use_petsc_python

    use_petsc_python()


def add_destination(ap, name: str, what: str, published: str = "") -> None:
    """``--out`` and ``--publish`` of a study script: its results ``what`` go to
    output/studies/``name``/ unless ``--publish`` sends them to docs/results/ (the tracked
    copy the docs show) or ``--out`` elsewhere; :func:`destination` reads them.
    ``published``: what else ``--publish`` writes, said in its help."""
    ap.set_defaults(_study_name=name)
    ap.add_argument("--out", default=None,
                    help=f"folder for {what} (default "
                         f"{os.path.relpath(os.path.join(STUDIES, name), ROOT)})")
    ap.add_argument("--publish", action="store_true",
                    help=f"write {what} into {os.path.relpath(PUBLISHED, ROOT)}, the tracked "
                         "results the docs show, instead of the default folder"
                         + (f"; {published}" if published else ""))


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
    cwd: str = None            # the folder it runs in (default: this process's)

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


def reusable(summary: dict) -> bool:
    """Whether a stored ``summary.json`` is a result to keep, whatever the analysis: a run
    that completed, or one that stopped on a numerical failure (a blow-up comes again with
    the same arguments: it is the result). A run stopped by a signal, by its input or by an
    internal error, or a summary without ``completed`` (written before every analysis said
    it), is done again."""
    if summary.get("completed") is True:
        return True
    return summary.get("completed") is False and \
        (summary.get("error") or {}).get("kind") == "numerical"


def stable(summary: dict) -> bool:
    """Whether a finished run's summary says it ran to its end without blowing up (a
    summary of before the common record says ``stable``; one of after, ``completed``)."""
    if "stable" in summary:
        return bool(summary["stable"])
    return summary.get("completed") is True


def wall_seconds(summary: dict) -> float:
    """The run's own wall time (s) its summary records: the record's ``wall.total_s``, or a
    summary of before the common record's ``wall_seconds``."""
    total = (summary.get("wall") or {}).get("total_s")
    return summary["wall_seconds"] if total is None else total


def results(summary: dict) -> dict:
    """A run's summary as a study reads it: one flat dict of the record's head (``steps``,
    ``wall``, ``completed``, ...) and the keys of its analysis's block
    (``summary[summary["analysis"]]``: ``monitor``, ``frequencies_hz``, ...). A summary of
    before the blocks is already flat."""
    block = summary.get(summary.get("analysis"))
    if not isinstance(block, dict):
        return summary
    return {**{k: v for k, v in summary.items() if k != summary["analysis"]}, **block}


def _done(run: Run):
    """The stored (summary, exit code, seconds) of an identical earlier run that is
    :func:`reusable`, or None."""
    try:
        with open(run.summary_path) as fh:
            summary = json.load(fh)
        with open(os.path.join(run.folder, "args.json")) as fh:
            args = json.load(fh)
    except (OSError, ValueError):
        return None
    if not isinstance(summary, dict) or not isinstance(args, dict):
        return None
    if args.get("args") != run.args or args.get("ranks") != run.ranks:
        return None
    if not reusable(summary):
        return None
    return results(summary), args.get("code"), args.get("seconds", 0.0)


def execute(run: Run, log=print, fresh=False) -> Run:
    """Run one job (or reuse its stored result, unless ``fresh``) and load its summary into
    ``run.result`` (:func:`results`: head and block in one dict; None when the run wrote
    none)."""
    cached = None if fresh else _done(run)
    if cached:
        run.result, run.code, run.seconds = cached
        run.reused = True
        log(f"  {run.name}: stored result (exit {run.code})")
        return run
    os.makedirs(run.folder, exist_ok=True)
    for stale in (run.summary_path, os.path.join(run.folder, "args.json")):
        if os.path.exists(stale):      # a run that wrote none must not pass for its own
            os.remove(stale)
    t0 = time.perf_counter()
    proc = subprocess.run(run.command(), env=environment(), capture_output=True, text=True,
                          cwd=run.cwd)
    run.seconds = time.perf_counter() - t0
    run.code, run.stderr = proc.returncode, proc.stderr.strip()
    try:
        with open(run.summary_path) as fh:
            run.result = results(json.load(fh))
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


def run_afresh(name: str, args, folder: str, ranks: int = 1, log=None) -> Run:
    """One solver run with the options ``args`` on ``ranks`` ranks into ``folder``, made
    afresh (never a stored result: a timed run, or one into a temporary folder) from the
    repository's root (where the scene files, and the records they name, are found) and
    timed whole: the finished :class:`Run` (``seconds``, ``result``, the summary). SystemExit
    naming the run, its exit code and the end of its stderr when it failed or wrote no
    summary. ``log``: where its line goes (default nowhere)."""
    run = execute(Run(name, list(args), os.path.abspath(folder), ranks, cwd=ROOT),
                  log=log or (lambda message: None), fresh=True)
    if run.code != 0 or run.result is None:
        raise SystemExit(f"{name}: the solver failed (exit {run.code}):\n{run.stderr[-2000:]}")
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


# -- what the benchmark commands share ----------------------------------------------------
class Transcript:
    """A command's report: each line printed as it comes (a long measurement shows where
    it is) and kept in ``lines`` for its .txt file."""

    def __init__(self):
        self.lines = []

    def __call__(self, text: str = "") -> None:
        print(text, flush=True)
        self.lines.append(text)


def load_average():
    """The load average (1, 5, 15 minutes) now, or None where the system has none."""
    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return None


def machine() -> dict:
    """The machine a measurement runs on: its cores, its CPU (the model and NumPy's SIMD
    features, :func:`solver.io.provenance.cpu`), the Python, NumPy and petsc4py versions,
    the platform, the load average now (``load_before``) and the date."""
    import platform

    from ..io import provenance

    cpu = provenance.cpu()
    out = {"nproc": os.cpu_count(), "cpu": cpu["model"] or cpu["machine"],
           "numpy_simd": cpu["numpy_simd"], "python": platform.python_version(),
           "platform": platform.platform(), "load_before": load_average(),
           "date": time.strftime("%Y-%m-%d %H:%M:%S")}
    for name in ("numpy", "petsc4py"):
        try:
            out[name] = __import__(name).__version__
        except ImportError:
            pass
    return out


def run_script(name: str, args, timeout: float) -> dict:
    """Run the command scripts/``name`` with ``args`` under this Python, at most ``timeout``
    s: its status ("ok", "exit N", "timed out ..." or "missing"), command, wall seconds,
    output and the end of its stderr."""
    path = os.path.join(ROOT, "scripts", name)
    command = "scripts/" + " ".join([name, *args])
    if not os.path.exists(path):
        return {"status": "missing", "command": command}
    t = time.perf_counter()
    try:
        res = subprocess.run([sys.executable, path, *args], capture_output=True, text=True,
                             timeout=timeout, cwd=ROOT)
    except subprocess.TimeoutExpired:
        return {"status": f"timed out after {timeout:.0f} s", "command": command}
    return {"status": "ok" if res.returncode == 0 else f"exit {res.returncode}",
            "command": command, "wall_seconds": time.perf_counter() - t,
            "stdout": res.stdout, "stderr_tail": res.stderr[-2000:]}


def write_results(prefix: str, result: dict, lines) -> list:
    """``prefix``.json (``result``) and ``prefix``.txt (the report's ``lines``), each written
    whole; returns their paths."""
    from ..io import output

    paths = [prefix + ".json", prefix + ".txt"]
    output.write_json(paths[0], result)
    output.write_text(paths[1], "\n".join(lines))
    return paths
