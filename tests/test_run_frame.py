"""One run frame for every analysis: the same life for each, as a batch user meets it.

Explicit and implicit consolidation, the dynamic analysis with one and two phases, each
(a) run to the end, (b) stopped by SIGTERM in the middle of its steps and restarted on the
other rank count, (c) failing in its set-up, (d) failing in its steps, (e) failing in its
reporting (a function of the run replaced by one that raises MemoryError: the suite's fault
injection); the eigen analysis (a), (c) and (e). Each writes a summary with the same head
(``completed``, ``steps``, ``wall`` with its phases, ``provenance.git`` and
``provenance.ranks``, on failure ``error.kind`` and ``error.stage``) and exits with the
documented code (0, 4 for a signal, 5 for an internal error); a restart ends where the
uninterrupted run does.
"""

from __future__ import annotations

import csv
import os
import signal

import numpy as np
import pytest
from conftest import CASES, PYTHON, REPO, mpi_command, run_command

QUIET = ["-mpm_progress", "0", "-mpm_figures", "0"]


def _quiet(scene: str) -> list:
    """The scene's options without progress lines or figures (eigen prints no progress)."""
    return SCENES[scene] + (QUIET if scene in STEPPING else ["-mpm_figures", "0"])
# The smallest runs that take enough steps to be stopped in the middle of them.
SCENES = {
    "explicit": ["-options_file", CASES / "consolidation-m1-q4.opts", "-mpm_Tv_end", "0.05",
                 "-mpm_Tv_report", "0.02,0.05", "-mpm_scheme", "explicit"],
    "implicit": ["-options_file", CASES / "consolidation-m1-q4.opts", "-mpm_Tv_end", "0.05",
                 "-mpm_Tv_report", "0.02,0.05", "-mpm_scheme", "implicit"],
    "dynamic-1": ["-options_file", CASES / "dynamic-uniform.opts", "-mpm_t_end", "0.4",
                  "-mpm_cells", "1,20"],
    "dynamic-2": ["-options_file", CASES / "dynamic-saturated.opts", "-mpm_t_end", "0.002",
                  "-mpm_cells", "1,20", "-mpm_record_dt", "1e-4"],
    "eigen": ["-options_file", CASES / "eigen-q4.opts"],
}
STEPPING = ("explicit", "implicit", "dynamic-1", "dynamic-2")
# Where the fault is injected: a function each run calls once the record has begun, in its
# set-up; one it calls in every step (the samples); one of its reporting.
SET_UP = {"explicit": "solver.consolidation.schedules.limits_and_schedule",
          "implicit": "solver.consolidation.schedules.limits_and_schedule",
          "dynamic-1": "solver.dynamic.plan.lowest",
          "dynamic-2": "solver.dynamic.saturated.SaturatedColumn._rows",
          "eigen": "solver.eigen.driver.build"}
STEPS = {"explicit": "solver.consolidation.model.Consolidation.sample",
         "implicit": "solver.consolidation.model.Consolidation.sample",
         "dynamic-1": "solver.dynamic.driver.Shaken.sample",
         "dynamic-2": "solver.dynamic.driver.Shaken.sample"}
REPORTING = {"explicit": "solver.consolidation.reporting.write_files",
             "implicit": "solver.consolidation.reporting.write_files",
             "dynamic-1": "solver.dynamic.histories.write_histories",
             "dynamic-2": "solver.dynamic.histories.write_histories",
             "eigen": "solver.eigen.plots.mode_figure"}


def _head(s: dict, completed: bool) -> None:
    """The head every summary shares."""
    assert s["completed"] is completed
    assert "steps" in s and isinstance(s["provenance"]["git"], (dict, type(None)))
    assert "git" in s["provenance"] and s["provenance"]["ranks"] >= 1
    # The phases it went through: all three when it finished.
    assert {"setup_s", "total_s"} | ({"reporting_s"} if completed else set()) <= set(s["wall"])
    assert sum(v for k, v in s["wall"].items() if k != "total_s") == pytest.approx(
        s["wall"]["total_s"], abs=1e-9)
    assert s["files"]["summary"].endswith("summary.json")


def _failed(res, code: int, kind: str, phase: str) -> dict:
    """A run that stopped: its exit code, one error line, and the summary's error."""
    assert res.returncode == code, res.stderr
    lines = [line for line in res.stderr.splitlines() if line.startswith("solver: error: ")]
    assert len(lines) == 1 and "Traceback" not in res.stderr, res.stderr
    s = res.summary
    _head(s, completed=False)
    assert s["error"]["kind"] == kind and s["error"]["exit_code"] == code
    assert s["error"]["stage"].startswith(phase), s["error"]
    return s


def _fail(*args, **kwargs):
    raise MemoryError("injected")


def _final(folder, scene: str):
    """What a finished run ends with, to compare two runs: the monitor's pressures and the
    settlement (consolidation), the recorded histories (dynamic)."""
    if scene.startswith("dynamic"):
        with open(folder / "histories.csv") as fh:
            rows = [row for row in csv.reader(fh) if row and not row[0].startswith("#")]
        return np.array([[float(v) for v in row] for row in rows[1:]])
    with open(folder / "settlement.csv") as fh:
        rows = [row for row in csv.reader(fh) if row and not row[0].startswith("#")]
    return np.array([[float(v) for v in row] for row in rows[1:]])


@pytest.mark.parametrize("scene", list(SCENES))
def test_to_the_end(cli, tmp_path, scene):
    res = cli(_quiet(scene), out_dir=tmp_path)
    assert res.returncode == 0, res.stderr
    s = res.summary
    _head(s, completed=True)
    assert "error" not in s and s["analysis"] == scene.split("-")[0].replace(
        "explicit", "consolidation").replace("implicit", "consolidation")
    if scene in STEPPING:
        assert s["steps"] > 10 and s["wall"]["stepping_s"] > 0
    else:
        assert s["steps"] is None and s["wall"]["solving_s"] > 0


@pytest.mark.parametrize("scene", STEPPING)
def test_stopped_in_its_steps_then_restarted_on_two_ranks(cli, tmp_path, monkeypatch, scene):
    """SIGTERM in the middle of the steps (sent by the run itself at its 8th sample): the
    loop stops after that step with a checkpoint (exit 4); the restart on two ranks ends
    where the run without a stop does, on one."""
    target = STEPS[scene]
    module, cls, name = target.rsplit(".", 2)
    import importlib

    real = getattr(getattr(importlib.import_module(module), cls), name)
    calls = []

    def signalled(self, k):
        calls.append(k)
        if len(calls) == 8:
            os.kill(os.getpid(), signal.SIGTERM)
        return real(self, k)

    stopped = tmp_path / "stopped"
    with monkeypatch.context() as patch:
        patch.setattr(target, signalled)
        res = cli(_quiet(scene), out_dir=stopped)
    s = _failed(res, 4, "interrupted", "stepping")
    assert 0 < s["steps"] == s["error"]["step"] and (stopped / "checkpoint.npz").is_file()
    assert "-mpm_restart" in res.stderr
    again = cli(["-mpm_restart", stopped / "checkpoint.npz"], ranks=2, process=True,
                out_dir=stopped)
    assert again.returncode == 0, again.stderr
    _head(again.summary, completed=True)
    assert again.summary["provenance"]["ranks"] == 2 and again.summary["run_id"] == s["run_id"]
    whole = tmp_path / "whole"
    res = cli(_quiet(scene), out_dir=whole)
    assert res.returncode == 0, res.stderr
    assert again.summary["steps"] == res.summary["steps"]
    a, b = _final(stopped, scene), _final(whole, scene)
    assert a.shape == b.shape
    np.testing.assert_allclose(a, b, rtol=1e-7, atol=1e-9 * np.max(np.abs(b)))


@pytest.mark.parametrize("scene", list(SCENES))
def test_failing_in_the_set_up(cli, tmp_path, monkeypatch, scene):
    monkeypatch.setattr(SET_UP[scene], _fail)
    res = cli(_quiet(scene), out_dir=tmp_path)
    s = _failed(res, 5, "internal", "set-up")
    assert "MemoryError: injected" in s["error"]["message"]
    assert not (tmp_path / "checkpoint.npz").exists()


@pytest.mark.parametrize("scene", STEPPING)
def test_failing_in_the_steps(cli, tmp_path, monkeypatch, scene):
    monkeypatch.setattr(STEPS[scene], _fail)
    res = cli(_quiet(scene), out_dir=tmp_path)
    s = _failed(res, 5, "internal", "stepping")
    assert s["steps"] == s["error"]["step"] >= 0
    assert not (tmp_path / "checkpoint.npz").exists()     # mid-step: no whole state


@pytest.mark.parametrize("scene", list(SCENES))
def test_failing_in_the_reporting(cli, tmp_path, monkeypatch, scene):
    """A failure after the last step: the summary says so, and a stepping run keeps its
    whole state in a checkpoint, from which a restart reports again."""
    monkeypatch.setattr(REPORTING[scene], _fail)
    args = SCENES[scene] + (QUIET if scene in STEPPING else [])
    res = cli(args, out_dir=tmp_path)
    s = _failed(res, 5, "internal", "reporting")
    if scene in STEPPING:
        assert (tmp_path / "checkpoint.npz").is_file() and s["steps"] > 10
        assert s["files"]["checkpoint"] == str(tmp_path / "checkpoint.npz")
        monkeypatch.undo()
        again = cli(["-mpm_restart", tmp_path / "checkpoint.npz"], out_dir=tmp_path)
        assert again.returncode == 0, again.stderr
        _head(again.summary, completed=True)
        assert again.summary["steps"] == s["steps"] and again.summary["wall"]["stepping_s"] < 1
    else:
        assert s["eigen"]["frequencies_hz"]["jacobi"] and s["steps"] is None


def test_ranks_whose_clocks_differ_agree_on_the_progress_lines(tmp_path):
    """The progress line of the flowing body takes a collective sum (its toe): every rank
    must print it at the same steps. Rank 1's clock here runs 50 times fast; were each rank
    to read its own, rank 1 would enter that sum at steps where rank 0 does not, and the
    ranks' collectives would part ways (a hang or an MPI error)."""
    wrapper = tmp_path / "skewed.py"
    wrapper.write_text(
        "import runpy, sys, time\n"
        "from mpi4py import MPI\n"
        "if MPI.COMM_WORLD.Get_rank() == 1:\n"
        "    real = time.perf_counter\n"
        "    time.perf_counter = lambda: 50.0 * real()\n"
        "sys.argv = ['solver'] + sys.argv[1:]\n"
        "runpy.run_module('solver', run_name='__main__')\n")
    out = tmp_path / "out"
    args = ["-options_file", CASES / "collapse-bui.opts", "-mpm_cells", "20,10",
            "-mpm_t_end", "0.15", "-mpm_progress", "0.02", "-mpm_figures", "0",
            "-mpm_output", out]
    code, stdout, stderr = run_command(mpi_command(2, [PYTHON, wrapper, *args]), timeout=60,
                                       env={"PYTHONPATH": str(REPO)})
    assert code == 0, stderr[-2000:]
    assert stdout.count("  step ") >= 1
    assert (out / "summary.json").exists()
