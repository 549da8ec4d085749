"""The package's metadata: the licence file matches pyproject's licence, and the console
command ``mpm-geo`` names the function ``python -m solver`` runs, which behaves the same."""

from __future__ import annotations

import importlib
import subprocess

import pytest
from conftest import PYTHON, REPO, clean_env

tomllib = pytest.importorskip("tomllib")


def _project():
    with open(REPO / "pyproject.toml", "rb") as fh:
        return tomllib.load(fh)["project"]


def test_licence_file_matches_pyproject():
    assert _project()["license"] == {"text": "BSD-2-Clause"}
    text = (REPO / "LICENSE").read_text()
    assert text.startswith("BSD 2-Clause License")
    assert "Copyright (c) 2026, The mpm-geo developers" in text
    # The two conditions of the 2-clause licence, and no third (no-endorsement) clause.
    assert "1. Redistributions of source code" in text
    assert "2. Redistributions in binary form" in text and "3." not in text


def test_console_command_names_the_module_entry_point():
    target = _project()["scripts"]["mpm-geo"]
    module, _, name = target.partition(":")
    func = getattr(importlib.import_module(module), name)
    from solver import __main__
    assert func is __main__.main and callable(func)


def test_console_command_behaves_as_python_m_solver(tmp_path):
    """What the installed wrapper does (sys.exit(main()) with the command as argv[0]),
    against ``python -m solver``: the same help and the same one-line error and code."""
    wrapper = ("import sys; from solver.__main__ import main; "
               "sys.argv[0] = 'mpm-geo'; sys.exit(main())")
    runs = {}
    for how, head in (("console", [PYTHON, "-c", wrapper]), ("module", [PYTHON, "-m", "solver"])):
        runs[how] = [subprocess.run(head + args, cwd=REPO, env=clean_env(), capture_output=True,
                                    text=True, timeout=120)
                     for args in (["-help"], ["-options_file", str(tmp_path / "none.opts")])]
    for console, module in zip(runs["console"], runs["module"]):
        assert console.returncode == module.returncode
        assert console.stderr == module.stderr
    assert runs["console"][0].returncode == 0
    assert "Options of the MPM solver" in runs["console"][0].stdout
    assert runs["console"][0].stdout == runs["module"][0].stdout
    assert runs["console"][1].returncode == 2
    assert runs["console"][1].stderr == f"solver: error: -options_file {tmp_path}/none.opts: " \
                                        "no such file\n"
