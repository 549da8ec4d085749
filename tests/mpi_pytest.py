"""Tests that run in-process on every rank of ``mpirun -n N``: the marker ``mpi(N)``.

A plain ``pytest`` runs the serial tests itself. The tests marked ``@pytest.mark.mpi(N)``
(``N`` ranks, 2 when not given) run together: one ``mpirun -n N python -m pytest <their
ids>`` per rank count, started in the background when collection ends, so that the ranks
work while this process runs the serial tests; the marked tests are moved to the end, where
this process waits for the ranks and reports what they found. Every rank runs each test
in-process on ``PETSc.COMM_WORLD``; a test passes when it passes on every rank, and a
failure names its rank. The ranks send pytest's own reports back (a JSON line each, one
file per rank, written as each test ends, so that a run killed by its timeout still tells
which tests finished and which one hung).

Run under ``mpirun -n N python -m pytest`` by hand, only the tests marked ``mpi(N)`` run.
Temporary folders (``tmp_path``, ``tmp_path_factory.mktemp``) are made by rank 0 and shared
by all ranks, so that a test's ranks write and read the same files.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import pytest

RESULTS = "MPM_TEST_MPI_RESULTS"        # where the ranks of a child run write their reports
TIMEOUT = float(os.environ.get("MPM_TEST_MPI_TIMEOUT", 1800))   # s, per rank count


def ranks_of(item) -> int:
    """The rank count an ``mpi`` item asks for; 0 for a serial one."""
    mark = item.get_closest_marker("mpi")
    if mark is None:
        return 0
    return int(mark.args[0] if mark.args else mark.kwargs.get("ranks", 2))


def world():
    from mpi4py import MPI

    return MPI.COMM_WORLD


def pytest_configure(config):
    config.addinivalue_line(
        "markers", "mpi(ranks=2): runs in-process on every rank of mpirun -n ranks")
    if world().Get_size() > 1:
        config.pluginmanager.register(_Rank(config), "mpi-rank")
    elif not config.option.collectonly:
        config.pluginmanager.register(_Launcher(config), "mpi-launcher")


class _Rank:
    """The plugin on each rank of a child run: only the tests for this many ranks; every
    report appended, as a JSON line, to this rank's file."""

    def __init__(self, config):
        self.config = config
        self.size, self.rank = world().Get_size(), world().Get_rank()
        folder = os.environ.get(RESULTS)
        self.file = open(Path(folder) / f"rank{self.rank}.jsonl", "w") if folder else None

    def pytest_collection_modifyitems(self, config, items):
        keep = [item for item in items if ranks_of(item) == self.size]
        dropped = [item for item in items if ranks_of(item) != self.size]
        if dropped:
            config.hook.pytest_deselected(items=dropped)
        items[:] = keep

    def _write(self, record):
        if self.file:
            self.file.write(json.dumps(record) + "\n")
            self.file.flush()

    def pytest_runtest_logstart(self, nodeid, location):
        self._write({"start": nodeid})

    def pytest_runtest_logreport(self, report):
        self._write({"report": self.config.hook.pytest_report_to_serializable(
            config=self.config, report=report)})

    def pytest_unconfigure(self, config):
        if self.file:
            self.file.close()


class _Launcher:
    """The plugin of a plain pytest: starts the child runs, then reports their results in
    place of running the marked tests."""

    def __init__(self, config):
        self.config = config
        self.groups = {}           # ranks: [nodeid]
        self.thread = None
        self.folder = None
        self.failures = {}         # ranks: why the child run did not finish
        self.read = {}             # ranks: {rank: [record]}

    @pytest.hookimpl(trylast=True)
    def pytest_collection_modifyitems(self, items):
        items.sort(key=lambda item: ranks_of(item) > 0)       # stable: serial ones first

    def pytest_collection_finish(self, session):
        for item in session.items:
            if ranks_of(item):
                self.groups.setdefault(ranks_of(item), []).append(item.nodeid)
        from conftest import MPIRUN

        if not self.groups or MPIRUN is None:
            return
        self.folder = Path(tempfile.mkdtemp(prefix="mpm-test-mpi-"))
        self.thread = threading.Thread(target=self._run_all, daemon=True)
        self.thread.start()

    def _run_all(self):
        for ranks, ids in sorted(self.groups.items()):
            self._run(ranks, ids)

    def _run(self, ranks, ids):
        from conftest import PYTHON, mpi_command, run_command

        folder = self.folder / f"n{ranks}"
        folder.mkdir()
        root = self.config.rootpath
        cmd = mpi_command(ranks, [PYTHON, "-m", "pytest", "-q", "--color=no", "-p",
                                  "no:cacheprovider", "--rootdir", root, *ids])
        # Ranks that wait for another (rank 0 alone running a serial reference) yield the
        # core to this process's serial tests rather than spinning.
        code, out, err = run_command(cmd, timeout=TIMEOUT, cwd=root, env={
            RESULTS: str(folder), "OMPI_MCA_mpi_yield_when_idle": "1"})
        (folder / "output.txt").write_text(out + err)
        if code == 124:
            code = f"killed after its timeout of {TIMEOUT:.0f} s"
        if code not in (0, 1):     # 1: some test failed, which its report says
            self.failures[ranks] = f"mpirun -n {ranks} python -m pytest: exit {code}"

    def pytest_unconfigure(self, config):
        if self.thread is not None:
            self.thread.join()
            shutil.rmtree(self.folder, ignore_errors=True)

    def _records(self, ranks):
        """{rank: [record]} of a finished child run (read once)."""
        if ranks in self.read:
            return self.read[ranks]
        out = self.read[ranks] = {}
        for path in sorted((self.folder / f"n{ranks}").glob("rank*.jsonl")):
            with open(path) as fh:
                out[int(path.stem[4:])] = [json.loads(line) for line in fh if line.strip()]
        return out

    @pytest.hookimpl(tryfirst=True)
    def pytest_runtest_protocol(self, item, nextitem):
        ranks = ranks_of(item)
        if not ranks:
            return None
        ihook = item.ihook
        ihook.pytest_runtest_logstart(nodeid=item.nodeid, location=item.location)
        for report in self._reports(item, ranks):
            ihook.pytest_runtest_logreport(report=report)
        ihook.pytest_runtest_logfinish(nodeid=item.nodeid, location=item.location)
        return True

    def _reports(self, item, ranks):
        if self.thread is None:
            return [pytest.TestReport(item.nodeid, item.location, {}, "skipped",
                                      (__file__, 0, "Skipped: mpirun not found"), "setup")]
        started = time.time()
        self.thread.join()
        by_rank = {}
        for rank, records in self._records(ranks).items():
            by_rank[rank] = [self.config.hook.pytest_report_from_serializable(
                config=self.config, data=r["report"]) for r in records
                if r.get("report", {}).get("nodeid") == item.nodeid]
        merged = []
        for when in ("setup", "call", "teardown"):
            found = [(rank, r) for rank in sorted(by_rank) for r in by_rank[rank]
                     if r.when == when]
            failed = [(rank, r) for rank, r in found if r.failed]
            if failed:
                rank, report = failed[0]
                report.sections.append(("mpi", f"failed on rank {rank} of {ranks}"))
                merged.append(report)
            elif found:
                merged.append(found[0][1])
        ended = [any(r.when == "teardown" for r in by_rank.get(rank, ()))
                 for rank in range(ranks)]
        if not all(ended):
            return [pytest.TestReport(item.nodeid, item.location, {}, "failed",
                                      self._lost(item, ranks), "call",
                                      duration=time.time() - started)]
        return merged

    def _lost(self, item, ranks) -> str:
        """Why a test has no reports: the child run's end and the tail of its output."""
        why = self.failures.get(ranks, "no report from every rank")
        hung = [r.get("start") for records in self._records(ranks).values()
                for r in records if "start" in r]
        last = f"; the last test started: {hung[-1]}" if hung else ""
        with open(self.folder / f"n{ranks}" / "output.txt") as fh:
            tail = fh.read()[-3000:]
        return f"{item.nodeid}: not run to the end under mpirun -n {ranks} ({why}{last})\n{tail}"
