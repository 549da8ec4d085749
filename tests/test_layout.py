"""The module layout: no module over MAX_LINES lines but the compiled kernels and the
Jacobi solver, no analysis driver over MAX_DRIVER_LINES, no function over
MAX_FUNCTION_LINES, and the options object at the edge: at most MAX_TAKING_OPTIONS functions
take it. After the set-up the run works on typed values (the plans). The rooms of solver/
and the direction of their imports (no cycle, the analyses' drivers run by the command line
alone) are tests/test_rooms.py's."""

from __future__ import annotations

import ast
from pathlib import Path

SOLVER = Path(__file__).resolve().parents[1] / "solver"
# Modules allowed beyond MAX_LINES: the compiled kernels and the Jacobi solver.
LONG = {"kernels", "jacobi"}
# At most MAX_TAKING_OPTIONS functions read the options: each analysis's edge (its run and
# plan) and the few that check them against each other (20 with three analyses; the soil
# test's and the static analysis's run and plan made 24; the material's recipe, which three
# analyses share, 25; the plan of the flowing body, the dynamic analysis's second edge, 26;
# the large-strain column's plan, the consolidation analysis's second edge, 27).
MAX_LINES, MAX_FUNCTION_LINES, MAX_TAKING_OPTIONS = 600, 80, 27
MAX_DRIVER_LINES = 300


def _modules() -> dict:
    """{dotted name under solver/: syntax tree} of every module, in every room."""
    return {".".join(path.relative_to(SOLVER).with_suffix("").parts):
            ast.parse(path.read_text(), filename=str(path))
            for path in sorted(SOLVER.rglob("*.py"))}


def _option_names() -> set:
    from solver.io.options import EXTRA_FIELDS, SPEC

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
    long_modules = {str(path.relative_to(SOLVER)): n for path in SOLVER.rglob("*.py")
                    if (n := len(path.read_text().splitlines())) > MAX_LINES
                    and path.stem not in LONG}
    assert not long_modules, long_modules
    long_functions = {f"{mod}.{fn.name}": fn.end_lineno - fn.lineno + 1
                      for mod, tree in _modules().items() for fn in _functions(tree)
                      if fn.end_lineno - fn.lineno + 1 > MAX_FUNCTION_LINES}
    assert not long_functions, long_functions


def test_the_drivers_are_thin():
    """Each analysis's driver builds its plan and model, hands them to the loop and reports:
    under MAX_DRIVER_LINES lines."""
    drivers = sorted(SOLVER.glob("*/driver.py"))
    assert len(drivers) == 5, drivers
    long = {str(p.relative_to(SOLVER)): n for p in drivers
            if (n := len(p.read_text().splitlines())) > MAX_DRIVER_LINES}
    assert not long, long
