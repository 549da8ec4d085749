"""The study scripts as modules and as commands: ``scripts/<name>.py`` holds a script's code
and imports without running anything; the command ``scripts/<name with hyphens>`` is a
relative symlink to it, so the commands in the README and docs stay as they were. Every
script runs in the study harness's frame (solver/studies/study.py): its start-up, its
``--out``/``--publish`` and its solver runs are the harness's, and each benchmark is a
command of its own."""

import importlib
import os
import sys

import pytest

from conftest import REPO, script_module

SCRIPTS = REPO / "scripts"
MODULES = sorted(p.stem for p in SCRIPTS.glob("*.py"))


def test_every_command_is_a_relative_symlink_to_its_module():
    assert len(MODULES) >= 10
    commands = sorted(p.name for p in SCRIPTS.iterdir() if not p.suffix and p.name != "install")
    assert commands == sorted(m.replace("_", "-") for m in MODULES)
    for name in MODULES:
        command, module = SCRIPTS / name.replace("_", "-"), SCRIPTS / f"{name}.py"
        # Relative, so that it holds in any checkout and through any path to it.
        assert command.is_symlink() and os.readlink(command) == module.name
        assert command.resolve() == module.resolve()
        assert os.access(module, os.X_OK) and not module.is_symlink()
        assert module.read_text().startswith("#!/usr/bin/env python3\n")
    assert not (SCRIPTS / "install").is_symlink()     # bash, a command of its own


@pytest.mark.parametrize("name", MODULES)
def test_importing_a_script_runs_nothing(name, monkeypatch, capfd):
    """Import alone neither re-launches under another Python, nor touches sys.path, nor
    runs main(), which with ``--help`` in argv would print its usage and exit."""
    import solver.io.launch

    def launched():
        raise AssertionError(f"importing {name} launched it")

    monkeypatch.setattr(solver.io.launch, "use_petsc_python", launched)
    monkeypatch.setattr(sys, "argv", [name, "--help"])
    monkeypatch.syspath_prepend(str(SCRIPTS))
    monkeypatch.delitem(sys.modules, name, raising=False)
    path = list(sys.path)
    module = importlib.import_module(name)
    assert sys.path == path
    assert os.path.realpath(module.__file__) == str((SCRIPTS / f"{name}.py").resolve())
    assert callable(module.main)
    assert capfd.readouterr() == ("", "")


# -- one run frame: the study harness (solver/studies/study.py) -----------------------------
START = ('if __name__ == "__main__":      # a command, not an import: see '
         'solver.studies.study.start\n')
MAX_LINES = 600      # as solver/'s modules (tests/test_layout.py)


def _text(name):
    return (SCRIPTS / f"{name}.py").read_text()


@pytest.mark.parametrize("name", MODULES)
def test_every_script_starts_through_the_harness(name):
    """One start-up, the harness's (``study.start``): the script puts the repository on the
    path and calls it under ``__main__``, before NumPy, PETSc or the solver is imported;
    nothing of solver.io.launch is its own."""
    text = _text(name)
    assert "use_petsc_python" not in text and "solver.io.launch" not in text
    head, sep, rest = text.partition(START)
    assert sep, f"{name}: no start-up block"
    block = rest.split("\n\n", 2)
    assert block[0].startswith("    sys.path") and block[0].endswith(
        "\n    from solver.studies.study import start") and block[1] == "    start()"
    for heavy in ("import numpy", "from petsc4py", "import petsc4py", "from solver",
                  "import solver"):
        assert not any(line.startswith(heavy) for line in head.splitlines()), (name, heavy)


@pytest.mark.parametrize("name", MODULES)
def test_every_script_takes_its_destination_and_runs_from_the_harness(name):
    """``--out``/``--publish`` come from study.add_destination, the solver runs from
    study.execute (no script starts ``python -m solver`` itself), and no script is over
    MAX_LINES lines."""
    text = _text(name)
    for flag in ("--out", "--publish"):
        assert f'add_argument("{flag}"' not in text, (name, flag)
    if '"--publish"' in text or "add_destination" in text:
        assert "add_destination(ap, " in text and "destination(ap, args)" in text
    assert '"-m", "solver"' not in text and "subprocess.run([sys.executable, \"-m\"" \
        not in text, name
    assert len(text.splitlines()) <= MAX_LINES, name


def test_each_benchmark_is_a_command_of_its_own():
    """scripts/benchmark dispatches to no sibling script (footing-benchmark and
    site-benchmark are commands), times each size by scripts/step-benchmark, and takes the
    CPU's model from solver.io.provenance."""
    text = _text("benchmark")
    for gone in ("--footing", "--dynamic", "footing_benchmark", "site_benchmark",
                 "/proc/cpuinfo", "sys.path.insert(0, str(REPO / \"scripts\"))"):
        assert gone not in text, gone
    for name in ("footing_benchmark", "site_benchmark", "step_benchmark"):
        assert name in MODULES
    step = script_module("step_benchmark")
    cfg = {"element": "q9", "cells": [3, 30], "size": [0.1, 1.0], "ppc": 3, "steps": 7,
           "warmup": 2, "repeats": 1}
    assert step.arguments(step.command(cfg)) == cfg
    assert step.arguments(["--element", "q4", "--cells", "2,20"])["size"] == [0.1, 1.0]
