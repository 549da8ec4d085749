"""Edges a batch user hits: where the results cannot go, a reader of stdout that
goes away, an unexpected failure late in a run, eigen failures, one scene file for both
analyses and a shorter run, the progress lines, and where the study scripts write.

Each failure must be a documented exit code with one ``solver: error:`` line, the summary
written where the README promises it, and no MPI abort where the ranks can agree.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from conftest import (CASES, ONE_AND_TWO_RANKS, PYTHON, REPO, clean_env, mpi_command,
                      option_entries, run_command)

SHORT = ["-mpm_Tv_end", "0.02", "-mpm_progress", "0", "-mpm_figures", "0"]
M1 = CASES / "consolidation-m1-q4.opts"


def _error_lines(stderr):
    return [line for line in stderr.splitlines() if line.startswith("solver: error: ")]


def _summary(folder):
    path = os.path.join(folder, "summary.json")
    with open(path) as fh:
        return json.load(fh)


# -- 1. an output folder that cannot be written -------------------------------------------
def _unwritable(kind, tmp_path):
    """An -mpm_output that cannot take files, as a batch user gets one wrong."""
    if kind == "file":
        path = tmp_path / "taken"
        path.write_text("a file, not a folder\n")
        return path
    if kind == "under-a-file":
        (tmp_path / "taken").write_text("x\n")
        return tmp_path / "taken" / "out"
    if kind == "proc":
        return "/proc/mpm-geo-results"
    # A read-only folder: permissions do not stop root, /sys does.
    if os.geteuid() == 0:
        return "/sys/kernel/mpm-geo-results"
    folder = tmp_path / "read-only"
    folder.mkdir()
    folder.chmod(0o555)
    return folder / "out"


@pytest.mark.parametrize("kind, scene, ranks", [
    ("file", "eigen-q4", 1), ("file", "consolidation-m1-q4", 1),
    ("under-a-file", "consolidation-m1-q4", 1), ("proc", "eigen-q4", 1),
    ("read-only", "consolidation-m1-q4", 1),
    *(pytest.param(*case, marks=pytest.mark.mpi(2)) for case in [
        ("proc", "consolidation-m1-q4", 2), ("read-only", "eigen-q4", 2),
        ("file", "consolidation-m1-q4", 2)])])
def test_unwritable_output_is_refused_before_computing(cli, tmp_path, kind, scene, ranks):
    out = _unwritable(kind, tmp_path)
    res = cli(["-mpm_figures", "0", "-mpm_output", out], options_file=scene, ranks=ranks,
              timeout=120)
    assert res.returncode == 2, res.stderr
    lines = _error_lines(res.stderr)
    assert len(lines) == 1 and lines[0].startswith(f"solver: error: -mpm_output {out}: ")
    assert "Traceback" not in res.stderr and "MPI_ABORT" not in res.stderr
    # Refused at set-up: no analysis printed anything.
    assert "Eigen analysis" not in res.stdout and "Critical time steps" not in res.stdout
    if ranks == 1:
        assert res.stderr.count("\n") == 1


def test_summary_in_a_folder_that_cannot_be_written(cli, tmp_path):
    (tmp_path / "taken").write_text("x\n")
    res = cli(["-mpm_summary", tmp_path / "taken" / "s.json"], options_file="eigen-q4")
    assert res.returncode == 2 and "-mpm_summary" in res.stderr
    res = cli(["-mpm_summary", tmp_path], options_file="eigen-q4")
    assert res.returncode == 2 and "a folder, not a file name" in res.stderr


def test_the_write_probe_leaves_nothing_behind(cli, tmp_path):
    """A new output folder is made and tried at set-up, then removed again: a run refused
    later for another reason still writes nothing."""
    out = tmp_path / "new" / "deep"
    res = cli(["-mpm_nmodes", "999", "-mpm_output", out], options_file="eigen-q4")
    assert res.returncode == 2 and "-mpm_nmodes" in res.stderr
    assert not (tmp_path / "new").exists()


# -- 2. a reader of stdout that goes away ----------------------------------------------------
@pytest.mark.parametrize("scene, args", [
    ("consolidation-m1-q4", ["-mpm_Tv_end", "0.02", "-mpm_progress", "0.001"]),
    ("eigen-q4", [])])
def test_closed_stdout_does_not_stop_the_run(tmp_path, scene, args):
    """``python -m solver ... | head -1``: the reader leaves after one line; the run goes on,
    its later lines go nowhere, and it writes its results and exits 0."""
    out = tmp_path / "out"
    cmd = [PYTHON, "-m", "solver", "-options_file", str(CASES / f"{scene}.opts"), *args,
           "-mpm_figures", "0", "-mpm_output", str(out)]
    proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            env=clean_env())
    first = proc.stdout.readline()
    proc.stdout.close()                      # what head does after its line
    stderr = proc.stderr.read().decode()
    code = proc.wait(timeout=180)
    assert first
    assert code == 0, stderr
    assert "Broken" not in stderr and "Traceback" not in stderr and "PETSC ERROR" not in stderr
    assert _summary(out)["completed"] is True


# -- 3. an unexpected failure late in a run --------------------------------------------------
INJECT = """\
import sys
sys.path.insert(0, {repo!r})
import petsc4py
petsc4py.init(sys.argv)
import importlib
module, name = sys.argv.pop(1).rsplit(".", 1)
def fail(*args, **kwargs):
    raise MemoryError("injected")
setattr(importlib.import_module(module), name, fail)
from solver.__main__ import main
sys.exit(main(sys.argv))
"""


def _inject(tmp_path, target, args, ranks=1, timeout=180):
    """Run the solver in a subprocess with ``target`` ("module.function") replaced by one
    that raises MemoryError; returns (code, stdout, stderr). For failures that end the
    process (an MPI abort); :func:`inject` does the rest in-process."""
    wrapper = tmp_path / "inject.py"
    wrapper.write_text(INJECT.format(repo=str(REPO)))
    cmd = mpi_command(ranks, [PYTHON, wrapper, target, *args])
    return run_command(cmd, timeout=timeout)


def _fail(*args, **kwargs):
    raise MemoryError("injected")


@pytest.fixture
def inject(cli, monkeypatch):
    """``inject(target, args, ranks=1)``: the command line ``args`` run in-process with
    ``target`` ("module.function") replaced by one that raises MemoryError; a CliResult."""
    def run(target, args, ranks=1):
        with monkeypatch.context() as patch:
            patch.setattr(target, _fail)
            return cli(args, ranks=ranks)
    return run


@ONE_AND_TWO_RANKS
def test_failure_in_the_final_reporting_writes_summary_and_checkpoint(inject, cli, tmp_path,
                                                                       ranks):
    out = tmp_path / "out"
    args = ["-options_file", M1, *SHORT, "-mpm_output", out]
    code, stdout, stderr, _ = inject("solver.consolidation.reporting.write_files", args, ranks)
    assert code == 5, stderr
    lines = _error_lines(stderr)
    assert len(lines) == 1 and "internal error: MemoryError: injected" in lines[0]
    assert "Traceback" not in stderr and "MPI_ABORT" not in stderr
    s = _summary(out)
    assert s["completed"] is False and s["error"]["kind"] == "internal"
    assert s["error"]["exit_code"] == 5 and "MemoryError: injected" in s["error"]["message"]
    assert (out / "checkpoint.npz").exists() and s["files"]["checkpoint"] == str(
        out / "checkpoint.npz")
    # The checkpoint holds the whole run: a restart only does the reporting again.
    res = cli([*args, "-mpm_restart", out / "checkpoint.npz"], ranks=ranks)
    assert res.returncode == 0, res.stderr
    again = _summary(out)
    assert again["completed"] is True and again["steps"] == s["steps"]
    assert again["consolidation"]["monitor"]["Tv"] == [0.02]


def test_failure_inside_the_stepping_writes_the_summary_without_a_checkpoint(inject, tmp_path):
    """A failure between the step and its reports leaves no state whose records agree:
    the summary says so, no checkpoint is written."""
    out = tmp_path / "out"
    code, _, stderr, _ = inject("solver.consolidation.reporting.report",
                                ["-options_file", M1, *SHORT, "-mpm_output", out])
    assert code == 5 and stderr.count("\n") == 1, stderr
    assert "internal error: MemoryError: injected" in stderr
    s = _summary(out)
    assert s["completed"] is False and s["error"]["kind"] == "internal"
    assert not (out / "checkpoint.npz").exists()


def test_failure_on_some_ranks_inside_the_stepping_aborts_rather_than_hangs(tmp_path):
    out = tmp_path / "out"
    code, _, stderr = _inject(tmp_path, "solver.consolidation.reporting.report",
                              ["-options_file", M1, *SHORT, "-mpm_output", out], ranks=2,
                              timeout=120)
    assert code not in (0, 124), stderr
    assert "internal error on rank" in stderr and "MemoryError: injected" in stderr


def test_internal_error_traceback_only_with_debug(inject, tmp_path):
    out = tmp_path / "out"
    args = ["-options_file", CASES / "eigen-q4.opts", "-mpm_figures", "0", "-mpm_output", out]
    code, _, stderr, _ = inject("solver.eigen.compare.print_table", args + ["-mpm_debug"])
    assert code == 5 and "Traceback" in stderr and "MemoryError: injected" in stderr
    code, _, stderr, _ = inject("solver.eigen.compare.print_table", args)
    assert code == 5 and stderr.count("\n") == 1 and "Traceback" not in stderr
    s = _summary(out)
    assert s["completed"] is False and s["error"]["kind"] == "internal"
    # What was computed before the failure is in the summary.
    assert len(s["eigen"]["frequencies_hz"]["jacobi"]) == 5 and "references" in s["eigen"]


@ONE_AND_TWO_RANKS
def test_eigen_failure_in_the_writing_is_agreed_by_every_rank(inject, tmp_path, ranks):
    out = tmp_path / "out"
    args = ["-options_file", CASES / "eigen-q4.opts", "-mpm_output", out]
    code, _, stderr, _ = inject("solver.eigen.plots.mode_figure", args, ranks)
    assert code == 5 and "MPI_ABORT" not in stderr, stderr
    assert len(_error_lines(stderr)) == 1
    assert _summary(out)["error"]["exit_code"] == 5


# -- 4. eigen failures write the summary -----------------------------------------------------
@pytest.mark.parametrize("args, ranks, says", [
    (["-mpm_jacobi_max_sweeps", "2"], 1, "Jacobi did not converge in 2 sweeps"),
    pytest.param(["-mpm_jacobi_max_sweeps", "2"], 2, "Jacobi did not converge in 2 sweeps",
                 marks=pytest.mark.mpi(2)),
    (["-mpm_element", "q9", "-mpm_eigen_solver", "slepc"], 1, "consistent mass is singular")])
def test_eigen_failure_writes_the_summary(cli, tmp_path, args, ranks, says):
    res = cli(args + ["-mpm_figures", "0"], options_file="eigen-q4", ranks=ranks)
    assert res.returncode == 3 and len(_error_lines(res.stderr)) == 1, res.stderr
    s = res.summary
    assert s is not None and s["completed"] is False
    assert s["error"]["kind"] == "numerical" and says in s["error"]["message"]
    assert s["analysis"] == "eigen" and s["eigen"]["ndof"] > 0


def test_successful_runs_say_completed(cli):
    res = cli(["-mpm_figures", "0"], options_file="eigen-q4")
    assert res.returncode == 0 and res.summary["completed"] is True


# -- 5. report times after -mpm_Tv_end -------------------------------------------------------
def test_scene_report_times_after_the_end_are_dropped_with_a_note(cli):
    res = cli(SHORT, options_file="consolidation-m1-q4")
    assert res.returncode == 0, res.stderr
    notes = [line for line in res.stdout.splitlines() if "-mpm_Tv_report" in line]
    assert len(notes) == 1 and notes[0].startswith("Note: -mpm_Tv_report (")
    assert "consolidation-m1-q4.opts:" in notes[0] and "0.5,1 after -mpm_Tv_end 0.02" in notes[0]
    assert res.summary["consolidation"]["monitor"]["Tv"] == [0.02]


def test_report_times_all_after_the_end_report_at_the_end(cli):
    res = cli(SHORT[2:] + ["-mpm_Tv_end", "0.01"], options_file="consolidation-m1-q4")
    assert res.returncode == 0, res.stderr
    assert res.summary["consolidation"]["monitor"]["Tv"] == [0.01]


def test_report_times_on_the_command_line_after_the_end_stay_an_error(cli):
    res = cli(SHORT + ["-mpm_Tv_report", "0.02,0.5"], options_file="consolidation-m1-q4")
    assert res.returncode == 2 and res.stderr.count("\n") == 1
    assert "-mpm_Tv_report 0.5: after -mpm_Tv_end 0.02" in res.stderr


# -- 6. one scene file for both analyses -----------------------------------------------------
def test_consolidation_scene_runs_as_eigen(cli):
    res = cli(["-mpm_analysis", "eigen", "-mpm_figures", "0"],
              options_file="consolidation-m1-q4")
    assert res.returncode == 0, res.stderr
    notes = [line for line in res.stdout.splitlines() if line.startswith("Note:")]
    assert len(notes) == 1 and "not used by -mpm_analysis eigen, ignored" in notes[0]
    assert "-mpm_K_l" in notes[0] and "-mpm_Tv_end" in notes[0]
    assert res.summary["eigen"]["frequencies_hz"]["jacobi"][0] == pytest.approx(16.92, abs=0.005)


def test_other_analysis_options_on_the_command_line_stay_errors(cli):
    res = cli(["-mpm_analysis", "eigen", "-mpm_K_l", "1e9"], options_file="consolidation-m1-q4")
    assert res.returncode == 2 and res.stderr.count("\n") == 1
    assert "-mpm_K_l: not used by -mpm_analysis eigen" in res.stderr


def test_scene_of_another_analysis_writes_into_its_own_folder(tmp_path):
    """The scene's -mpm_output holds its own analysis's results: the other analysis writes
    into a sub-folder named after it, and leaves them alone."""
    scene = tmp_path / "scene.opts"
    scene.write_text(M1.read_text().replace("-mpm_output output/consolidation-m1-q4",
                                            f"-mpm_output {tmp_path / 'res'}"))
    code, out, err = run_command([PYTHON, "-m", "solver", "-options_file", scene,
                                  "-mpm_analysis", "eigen", "-mpm_figures", "0"])
    assert code == 0, err
    assert f"results in {tmp_path / 'res' / 'eigen'}" in out
    assert _summary(tmp_path / "res" / "eigen")["analysis"] == "eigen"
    assert not (tmp_path / "res" / "summary.json").exists()


def test_options_read_drops_scene_options_of_the_other_analysis():
    from petsc4py import PETSc

    from solver.common.errors import InputError
    from solver.io import options

    db = PETSc.Options()
    for key in list(db.getAll()):
        db.delValue(key)
    for key, value in (("mpm_analysis", "eigen"), ("mpm_k", "1e-6"), ("mpm_E", "2e7")):
        db.setValue(key, value)
    try:
        p = options.read(db=db, origins={"k": "s.opts:3", "E": "s.opts:4"})
        assert p.k == options._BY_NAME["k"].default and p.E == 2e7
        assert p.given == ("E", "analysis") and p.from_file == {"E": "s.opts:4"}
        assert len(p.notes) == 1 and "-mpm_k" in p.notes[0] and "s.opts" in p.notes[0]
        with pytest.raises(InputError, match="-mpm_k: not used by"):
            options.read(db=db, origins={"E": "s.opts:4"})
    finally:
        for key in list(db.getAll()):
            db.delValue(key)


# -- 7. progress lines -----------------------------------------------------------------------
def test_stability_analysis_is_announced_and_timed(cli):
    res = cli(["-mpm_Tv_end", "0.02", "-mpm_progress", "0.001", "-mpm_figures", "0"],
              options_file="consolidation-m1-q4")
    assert res.returncode == 0, res.stderr
    lines = res.stdout.splitlines()
    start = lines.index("Stability analysis of the step on 1 x 10 cells ...")
    assert lines[start + 1].startswith("Stability analysis took ")
    assert lines[start + 1].endswith(" s")
    progress = [line for line in lines if line.startswith("  step ")]
    assert progress and all("s elapsed, about" in line and line.endswith("s left")
                            for line in progress)


# -- 8. where the study scripts write --------------------------------------------------------
STUDY_SCRIPTS = ("stability-map", "damping-figure", "benchmark", "damping-study",
                 "permeability-map")


@pytest.mark.parametrize("name", STUDY_SCRIPTS)
def test_study_scripts_write_under_output_and_document_every_option(name):
    res = subprocess.run([sys.executable, str(REPO / "scripts" / name), "--help"],
                         cwd=REPO, env=clean_env(), capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0, res.stderr
    text = " ".join(res.stdout.split())
    assert f"(default output/studies/{name})" in text
    entries = option_entries(res.stdout)
    assert {"--out OUT", "--publish"} <= {head for head, _ in entries}
    for head, help_text in entries:
        assert len(help_text) > 10, f"{name}: {head} has no help text"


def test_study_destination():
    import argparse

    from solver.studies import study

    ap = argparse.ArgumentParser()
    study.add_destination(ap, "x", "x.json")
    assert study.destination(ap, ap.parse_args([])) == os.path.join(
        str(REPO), "output", "studies", "x")
    assert study.destination(ap, ap.parse_args(["--publish"])) == os.path.join(
        str(REPO), "docs", "results")
    assert study.destination(ap, ap.parse_args(["--out", "/tmp/y"])) == "/tmp/y"
    with pytest.raises(SystemExit):
        study.destination(ap, ap.parse_args(["--out", "/tmp/y", "--publish"]))


# The commands (scripts/NAME, a symlink to scripts/NAME.py for the Python ones).
ALL_SCRIPTS = sorted(p.name for p in (REPO / "scripts").iterdir()
                     if p.is_file() and not p.suffix
                     and p.read_text().startswith("#!/usr/bin/env python3"))


@pytest.mark.parametrize("name", ALL_SCRIPTS)
def test_every_help_line_is_whole(name):
    """--help's description is the docstring's whole first paragraph
    (damping-study and permeability-map stopped mid-sentence) and no option's help ends
    on a dangling word."""
    res = subprocess.run([sys.executable, str(REPO / "scripts" / name), "--help"],
                         cwd=REPO, env=clean_env(), capture_output=True, text=True,
                         timeout=60)
    assert res.returncode == 0, res.stderr
    description = " ".join(res.stdout.split("\n\n")[1].split())
    assert description[-1] in ".:)", (name, description)
    for head, help_text in option_entries(res.stdout):
        words = help_text.rstrip(" ,").split() or ["(none)"]
        assert words[-1].lower() not in {"the", "and", "of", "a", "to", "with", "against",
                                         "from", "or"}, (name, head, help_text)
