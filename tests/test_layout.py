"""The module layout: the analyses are leaves that nothing else in solver/ builds on, the
package has no import cycle, and the options object stays at the edge (issue 20).

Scene set-up lives in :mod:`solver.scene` and f1 in :mod:`solver.frequency`; a module other
than the command line that imported :mod:`solver.eigen` would make one analysis depend on
the other. After the set-up the run works on typed values (:mod:`solver.plan`): only the
command line and the set-up read the options object."""

from __future__ import annotations

import ast
from pathlib import Path

SOLVER = Path(__file__).resolve().parents[1] / "solver"
# Modules that may import the eigen driver: the command line (and the driver itself).
ALLOWED = {"__main__", "eigen"}
# Modules allowed beyond MAX_LINES: the compiled kernels and the Jacobi solver.
LONG = {"kernels", "jacobi"}
MAX_LINES, MAX_FUNCTION_LINES, MAX_TAKING_OPTIONS = 600, 80, 20


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
    assert not offenders, f"import solver.frequency or solver.scene, not solver.eigen: " \
        f"{offenders}"


def test_the_check_sees_each_form_of_import():
    for source in ("from . import eigen", "from .eigen import build", "import solver.eigen",
                   "from solver import assembly, eigen", "from solver.eigen import x",
                   "def f():\n    from . import eigen\n"):
        assert _imports_eigen(ast.parse(source)), source
    for source in ("from . import scene", "from .scene import build", "import eigenvalues"):
        assert not _imports_eigen(ast.parse(source)), source


def _modules() -> dict:
    return {path.stem: ast.parse(path.read_text(), filename=str(path))
            for path in sorted(SOLVER.glob("*.py"))}


def _solver_imports(tree, names) -> set:
    """The solver modules a module imports, anywhere in it (inside functions too)."""
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            module = node.module or ""
            if node.level == 1 or module == "solver" or module.startswith("solver."):
                head = module.split(".")[-1] if module.startswith("solver.") else module
                if node.level == 1 and module:
                    head = module.split(".")[0]
                if head and head != "solver":
                    found.add(head)
                else:
                    found.update(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            found.update(a.name.split(".")[1] for a in node.names
                         if a.name.startswith("solver."))
    return found & set(names)


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
    modules = _modules()
    graph = {name: _solver_imports(tree, modules) - {name} for name, tree in modules.items()}
    assert _cycle(graph) is None, " -> ".join(_cycle(graph))


def test_the_cycle_check_finds_a_cycle():
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set(), "c": {"a", "b"}}) is None


def _option_names() -> set:
    from solver.options import EXTRA_FIELDS, SPEC

    return {o.name for o in SPEC} | set(EXTRA_FIELDS)


def _takes_options(fn, names) -> bool:
    """Whether function ``fn`` takes the options object: a parameter ``p`` or ``params``
    whose options it reads (``p.E``) or that it hands on whole (``f(p)``)."""
    args = {a.arg for a in fn.args.args + fn.args.kwonlyargs} & {"p", "params"}
    for node in ast.walk(fn):
        if isinstance(node, ast.Attribute) and isinstance(node.value, ast.Name) \
                and node.value.id in args and node.attr in names:
            return True
        if isinstance(node, ast.Call) and any(isinstance(a, ast.Name) and a.id in args
                                              for a in node.args):
            return True
    return False


def _functions(tree):
    return [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]


def test_few_functions_take_the_options():
    names = _option_names()
    taking = [f"{mod}.{fn.name}" for mod, tree in _modules().items()
              for fn in _functions(tree) if _takes_options(fn, names)]
    assert len(taking) <= MAX_TAKING_OPTIONS, taking


def test_the_options_check_sees_reads_and_hand_ons():
    names = _option_names()
    fn = ast.parse("def f(p, comm):\n    return g(p)\n").body[0]
    assert _takes_options(fn, names)
    fn = ast.parse("def f(p):\n    return p.element\n").body[0]
    assert _takes_options(fn, names)
    fn = ast.parse("def f(p, s):\n    return range(p + 1)\n").body[0]   # an order
    assert not _takes_options(fn, names)


def test_modules_and_functions_stay_small():
    long_modules = {path.stem: n for path in SOLVER.glob("*.py")
                    if (n := len(path.read_text().splitlines())) > MAX_LINES
                    and path.stem not in LONG}
    assert not long_modules, long_modules
    long_functions = {f"{mod}.{fn.name}": fn.end_lineno - fn.lineno + 1
                      for mod, tree in _modules().items() for fn in _functions(tree)
                      if fn.end_lineno - fn.lineno + 1 > MAX_FUNCTION_LINES}
    assert not long_functions, long_functions
