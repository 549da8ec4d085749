"""The rooms of solver/ and the one direction of their imports.

solver/ is the command line (``__main__``) and its rooms, lowest first (ROOMS): ``common``
(errors, signals, clock), ``model``, ``references``, ``io``, ``run`` (the frame every analysis
runs in: its record and the loop), ``modal`` (the eigensolvers), ``stepping`` (the engines
that step a body in time), then the analyses ``eigen``, ``consolidation`` (with its implicit
scheme's room) and ``dynamic``, and ``studies``. A module imports modules of its own room and
of rooms before it, never one after it; the package itself (its version) is open to all. So
the model never builds on a reference that checks it, the writers know nothing of the
analyses they write for, and the engines nothing of the run around them. No analysis's room
imports another's (what two share lives before them), the analyses' drivers are imported by
the command line alone, no import cycle between modules, and each room's ``__init__``
docstring names what it holds and the rooms it may import.

Imports are read from the syntax tree, anywhere in a module (inside functions too),
relative or absolute."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
SOLVER = REPO / "solver"
ROOMS = ("common", "model", "materials", "references", "io", "run", "modal", "stepping", "eigen",
         "consolidation.implicit", "consolidation", "dynamic", "soiltest", "static",
         "studies")
CLI = "__main__"
DRIVERS = ("eigen.driver", "consolidation.driver", "dynamic.driver", "soiltest.driver",
           "static.driver")
# The analyses' rooms: none imports another's (what two of them share lives in a room before
# them: the modal solvers, the engines that step, the run's frame).
ANALYSES = ("eigen", "consolidation", "dynamic", "soiltest", "static")


def _name(path: Path) -> str:
    """Dotted name under solver/ ('' for the package, 'io' for solver/io/__init__.py)."""
    parts = path.relative_to(SOLVER).with_suffix("").parts
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _modules() -> dict:
    """{dotted name: (path, syntax tree)} of every module of the package."""
    return {_name(path): (path, ast.parse(path.read_text(), filename=str(path)))
            for path in sorted(SOLVER.rglob("*.py"))}


def _room(name: str):
    """The room of module ``name`` (the longest room that holds it), CLI for the command
    line, '' for the package itself, None for a module outside every room."""
    if name == CLI:
        return CLI
    if name == "":
        return ""
    held = [room for room in ROOMS if name == room or name.startswith(room + ".")]
    return max(held, key=len) if held else None


def _rank(room) -> int:
    return -1 if room == "" else len(ROOMS) if room == CLI else ROOMS.index(room)


def _imports(name: str, tree, package: bool, known) -> list:
    """[(line, imported module)] of module ``name``: the modules of ``known`` it imports,
    by the longest known name (``from .io import output`` is io.output, ``from ..common.errors
    import InputError`` is common.errors)."""
    own = name.split(".") if name else []
    own = own if package else own[:-1]
    found = []

    def longest(parts):
        for n in range(len(parts), -1, -1):
            if ".".join(parts[:n]) in known:
                return ".".join(parts[:n])
        return None

    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level:
                if node.level - 1 > len(own):
                    continue
                base = own[:len(own) - (node.level - 1)]
            elif node.module == "solver" or (node.module or "").startswith("solver."):
                base = []
            else:
                continue
            module = (node.module or "") if node.level else (node.module or "")[len("solver"):]
            parts = base + [p for p in module.split(".") if p]
            for alias in node.names:
                target = longest(parts + [alias.name])
                if target is not None:
                    found.append((node.lineno, target))
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("solver."):
                    target = longest(alias.name.split(".")[1:])
                    if target is not None:
                        found.append((node.lineno, target))
    return found


def _graph() -> dict:
    modules = _modules()
    return {name: _imports(name, tree, path.name == "__init__.py", modules)
            for name, (path, tree) in modules.items()}


def _offences(graph) -> list:
    """Imports that run up the rooms: a module importing a room after its own."""
    bad = []
    for name, imports in graph.items():
        for line, target in imports:
            if None in (_room(name), _room(target)):
                continue                        # test_every_module_is_in_a_room says so
            if _rank(_room(target)) > _rank(_room(name)):
                bad.append(f"{name}:{line} imports {target} ({_room(target)} comes after "
                           f"{_room(name) or 'the package'})")
    return bad


def test_every_module_is_in_a_room():
    homeless = [name for name in _modules() if _room(name) is None]
    assert not homeless, f"give them a room (one of {ROOMS}): {homeless}"
    for room in ROOMS:
        assert (SOLVER / room.replace(".", "/") / "__init__.py").is_file(), room


@pytest.mark.parametrize("name", sorted(_modules()))
def test_every_module_imports(name):
    """Every module imports by its dotted name (a relative import that missed its room
    fails here, not in the middle of a run)."""
    importlib.import_module("solver" + (f".{name}" if name else ""))


def test_imports_run_down_the_rooms():
    bad = _offences(_graph())
    assert not bad, "\n".join(bad)


def test_only_the_command_line_runs_an_analysis():
    bad = [f"{name}:{line} imports {target}" for name, imports in _graph().items()
           for line, target in imports if target in DRIVERS and name != CLI]
    assert not bad, bad


def _analysis(room):
    """The analysis whose room holds ``room`` (consolidation for consolidation.implicit), or
    None for a room that serves every analysis."""
    return next((a for a in ANALYSES if room == a or (room or "").startswith(a + ".")), None)


def test_no_analysis_imports_another():
    bad = [f"{name}:{line} imports {target}" for name, imports in _graph().items()
           for line, target in imports
           if None not in (_analysis(_room(name)), _analysis(_room(target)))
           and _analysis(_room(name)) != _analysis(_room(target))]
    assert not bad, bad


def _cycle(graph):
    """One import cycle of ``graph`` ({module: imported modules}) as a list, or None."""
    state = {}

    def visit(node, path):
        state[node] = "open"
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                return path[path.index(nxt):] + [nxt]
            if nxt not in state:
                found = visit(nxt, path + [nxt])
                if found:
                    return found
        state[node] = "done"
        return None

    for start in sorted(graph):
        if start not in state:
            found = visit(start, [start])
            if found:
                return found
    return None


def test_no_import_cycle():
    graph = {name: {t for _, t in imports} - {name} for name, imports in _graph().items()}
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


@pytest.mark.parametrize("room", ROOMS)
def test_each_room_says_what_it_holds_and_what_it_may_import(room):
    folder = SOLVER / room.replace(".", "/")
    doc = ast.get_docstring(ast.parse((folder / "__init__.py").read_text())) or ""
    held = [p.stem for p in folder.glob("*.py") if p.stem != "__init__"]
    held += [p.name + "/" for p in folder.iterdir() if (p / "__init__.py").is_file()]
    missing = [name for name in held if f"``{name}``" not in doc]
    assert not missing, f"solver/{folder.relative_to(SOLVER)}/__init__.py names no {missing}"
    before = ROOMS[:ROOMS.index(room)][::-1]
    rule = ("May import: " + ", ".join(before) + ".") if before else \
        "May import: nothing of the package."
    assert rule in " ".join(doc.split()), f"{room}: its docstring should say '{rule}'"


def test_setuptools_installs_every_room():
    tomllib = pytest.importorskip("tomllib")
    setuptools = pytest.importorskip("setuptools")
    with open(REPO / "pyproject.toml", "rb") as fh:
        config = tomllib.load(fh)["tool"]["setuptools"]
    rooms = {".".join(("solver",) + p.parent.relative_to(SOLVER).parts)
             for p in SOLVER.rglob("__init__.py")}
    found = config.get("packages")
    if isinstance(found, dict) or found is None:
        find = (found or {}).get("find", {})
        found = setuptools.find_packages(str(REPO), include=find.get("include", ("*",)),
                                         exclude=find.get("exclude", ()))
    assert rooms <= set(found), sorted(rooms - set(found))


def test_the_checks_see_each_form_of_import():
    known = {"", CLI, "io", "io.output", "model", "model.scene", "common", "common.errors",
             "eigen", "eigen.driver", "consolidation", "consolidation.implicit",
             "consolidation.implicit.operators"}
    for source, name, target in [
            ("from ..io import output", "model.scene", "io.output"),
            ("from ...model.scene import Body", "consolidation.implicit.operators",
             "model.scene"),
            ("from . import scene", "model.grid", "model.scene"),
            ("from solver.io import output", "model.scene", "io.output"),
            ("from solver import io", "model.scene", "io"),
            ("import solver.io.output", "model.scene", "io.output"),
            ("def f():\n    from ..eigen import driver\n", "io.output", "eigen.driver"),
            ("from .. import __version__", "io.output", "")]:
        got = [t for _, t in _imports(name, ast.parse(source), False, known)]
        assert got == [target], (source, got)
    assert _offences({"model.scene": [(1, "io.output")]})          # up: refused
    assert _offences({"stepping.twophase": [(1, "consolidation.plan")]})
    assert _offences({"consolidation.implicit.operators": [(1, "consolidation.plan")]})
    assert not _offences({"io.output": [(1, "model.scene")], CLI: [(1, "eigen.driver")],
                          "consolidation.plan": [(1, "stepping.twophase")],
                          "io.provenance": [(1, "")]})
    assert _analysis("consolidation.implicit") == "consolidation"
    assert _analysis("stepping") is None and _analysis("dynamic") == "dynamic"
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None
