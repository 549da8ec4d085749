"""The study scripts as modules and as commands: ``scripts/<name>.py`` holds a script's code
and imports without running anything; the command ``scripts/<name with hyphens>`` is a
relative symlink to it, so the commands in the README and docs stay as they were."""

import importlib
import os
import sys

import pytest

from conftest import REPO

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
