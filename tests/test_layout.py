"""The module layout: the analyses are leaves that nothing else in solver/ builds on.

Scene set-up lives in :mod:`solver.scene`; a module other than the command line and the
analyses that imported :mod:`solver.eigen` for it would make one analysis depend on another
(and pull SLEPc into every consolidation import)."""

from __future__ import annotations

import ast
from pathlib import Path

SOLVER = Path(__file__).resolve().parents[1] / "solver"
# Modules that may import the eigen driver: the command line and the analyses.
ALLOWED = {"__main__", "eigen", "consolidation"}


def _imports_eigen(tree) -> list:
    """Line numbers of imports of solver.eigen (absolute or relative, whole or by name)."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            if any(a.name in ("solver.eigen",) or a.name.startswith("solver.eigen.")
                   for a in node.names):
                lines.append(node.lineno)
        elif isinstance(node, ast.ImportFrom):
            module = node.module or ""
            relative = node.level == 1
            if (relative and module == "eigen") or (not relative and module == "solver.eigen"):
                lines.append(node.lineno)
            elif (relative and module == "") or (not relative and module == "solver"):
                if any(a.name == "eigen" for a in node.names):
                    lines.append(node.lineno)
    return lines


def test_only_cli_and_analyses_import_eigen():
    offenders = {}
    for path in sorted(SOLVER.glob("*.py")):
        if path.stem in ALLOWED:
            continue
        lines = _imports_eigen(ast.parse(path.read_text(), filename=str(path)))
        if lines:
            offenders[path.name] = lines
    assert not offenders, f"import solver.scene instead of solver.eigen: {offenders}"


def test_the_check_sees_each_form_of_import():
    for source in ("from . import eigen", "from .eigen import build", "import solver.eigen",
                   "from solver import assembly, eigen", "from solver.eigen import x",
                   "def f():\n    from . import eigen\n"):
        assert _imports_eigen(ast.parse(source)), source
    for source in ("from . import scene", "from .scene import build", "import eigenvalues"):
        assert not _imports_eigen(ast.parse(source)), source
