"""What the command line promises and the run keeps (issue 28, section 3): each check runs
the command and asserts its exit code, its one-line message and the files it writes."""

from __future__ import annotations

import json
import os
import sys

from conftest import CASES, REPO, run_command


def _solver(args, cwd, **kw):
    """``python -m solver ARGS`` in a fresh process started in ``cwd`` (this worktree's
    solver first on the path): (exit code, stdout, stderr)."""
    return run_command([sys.executable, "-m", "solver", *args], cwd=cwd,
                       env={"PYTHONPATH": str(REPO)}, **kw)


def test_command_line_wins_before_the_scene_file(tmp_path):
    """Options before -options_file win over the scene's: the run goes to the folder the
    command line names, with its number of modes; the scene's folder is not written."""
    code, out, err = _solver(["-mpm_nmodes", "2", "-mpm_output", "mine",
                              "-mpm_eigen_solver", "jacobi", "-mpm_figures", "0",
                              "-options_file", CASES / "eigen-q4.opts"], tmp_path)
    assert code == 0, err
    assert not (tmp_path / "output").exists()
    with open(tmp_path / "mine" / "summary.json") as fh:
        summary = json.load(fh)
    assert len(summary["frequencies_hz"]["jacobi"]) == 2
