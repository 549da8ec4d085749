"""The ``-mpm_`` options: read once from the PETSc options database, checked, returned as data.

Every parameter of a run is a PETSc option with the prefix ``-mpm_``, so a scene file passed
with ``-options_file`` sets them and the command line overrides any of them. Each option is
declared once in :data:`SPEC` with its type, default, range check, the analyses that use it
and a help line; the README's option table is generated from the same list
(``python -m solver -help`` prints it with the values in effect).

Every ``-mpm_`` value is fetched from the database by name (``getString``), which marks it
used: ``-options_left`` then lists only options nobody read, such as a misspelt
``-eps_tpye``. The result of :func:`read` is frozen; a changed set of parameters is a new
value (``dataclasses.replace``), so what the run uses is what was read and checked, plus
changes that are visible where they are made. :func:`from_mapping` gives the same value
from ``{name: value}`` without the database (a study's or a test's scenes), through the
same parsing and checks.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import math

from ..common.errors import InputError
from . import checks
from .scenefile import PREFIX, pairs as file_pairs
from .spec import (ANALYSES, BC_CHOICES, BOTH, CONSOLIDATION, DYNAMIC,  # noqa: F401
                   EIGEN, MATERIAL, MOVING, SOILTEST, SPEC, STATIC, Option)

_BY_NAME = {o.name: o for o in SPEC}
# PETSc's own options of the implicit scheme's linear solver (KSP prefix mpm_): PETSc reads
# them (-mpm_ksp_type, -mpm_pc_factor_mat_solver_type, -mpm_mat_mumps_icntl_14, ...).
LINEAR_SOLVER = ("ksp_", "pc_", "mat_", "snes_")
# The options that only the explicit step reads, and those only the implicit scheme reads.
EXPLICIT_ONLY = ("dt", "dt_safety", "stability_analysis", "target_error", "work_precision",
                 "allow_unstable", "damping", "bulk_viscosity", "fast_damping", "flip",
                 "lumping", "kinematics", "pressure_projection", "liquid_basis", "drag",
                 "mass_scaling")
IMPLICIT_ONLY = ("implicit_steps", "pressure_stabilization")
# Why a value that is not per layer is one: the pore fluid is the same in every layer.
_FLUID = ("one value: the pore water is one fluid, the same in every layer (per layer: "
          + ", ".join(f"-{PREFIX}{o.name}" for o in SPEC if o.kind == "float_or_floats")
          + ")")
ONE_VALUE = {"rho_l": _FLUID, "K_l": _FLUID, "mu_l": _FLUID}
# Besides the options, what :func:`read` found out about where they came from.
EXTRA_FIELDS = ("given", "from_file", "notes")


def params_class(spec):
    """A frozen dataclass with a field per option of ``spec`` and :data:`EXTRA_FIELDS`
    (assigning a field raises ``dataclasses.FrozenInstanceError``)."""
    fields = [(o.name, object) for o in spec] + [(f, object) for f in EXTRA_FIELDS]
    cls = dataclasses.make_dataclass("Params", fields, frozen=True)
    cls.__module__ = __name__
    return cls


Params = params_class(SPEC)    # module level, so that the default parameters pickle


def _parse_int(text):
    value = float(text)
    if not math.isfinite(value) or value != int(value):
        raise ValueError("not an integer")
    if abs(value) > 2**31 - 1:
        raise ValueError("outside the 32-bit integer range")
    return int(value)


def _parse(opt: Option, text: str):
    scalar = {"int": _parse_int, "ints": _parse_int,
              "float": checks.parse_float, "floats": checks.parse_float}.get(opt.kind, str.strip)
    if opt.kind in ("ints", "floats", "strs", "float_or_floats", "str_or_strs"):
        parts = [p.strip() for p in text.split(",")]
        if any(p == "" for p in parts):
            raise ValueError("malformed list (empty entry)")
        if opt.kind in ("float_or_floats", "str_or_strs"):  # one value stays a scalar
            values = tuple(checks.parse_float(p) if opt.kind == "float_or_floats" else p
                           for p in parts)
            return values[0] if len(values) == 1 else values
        value = tuple(scalar(p) for p in parts)
        if opt.length and len(value) != opt.length:
            raise ValueError(f"needs {opt.length} comma-separated values")
        if opt.kind == "strs" and len(set(value)) != len(value):
            raise ValueError("repeated entry")
        return value
    return scalar(text)


def _check_value(opt: Option, value):
    values = value if isinstance(value, tuple) else (value,)
    if opt.choices:
        bad = [v for v in values if v not in opt.choices]
        if bad:
            return f"unknown value '{bad[0]}' (choose from {', '.join(opt.choices)})"
    if opt.kind == "float_or_floats" and isinstance(value, tuple) and opt.check:
        return next((f"layer {i + 1}: {problem}" for i, v in enumerate(value)
                     if (problem := opt.check(v))), None)
    return opt.check(value) if opt.check else None


def _describe(opt: Option, value) -> str:
    return ",".join(map(str, value)) if isinstance(value, tuple) else str(value)


def _from_json(opt: Option, value):
    """A value as JSON holds it (a checkpoint's options): lists as tuples, null as NaN."""
    if value is None and opt.kind in ("float", "float_or_floats"):
        return math.nan
    return tuple(value) if isinstance(value, list) else value


def text(name: str, value) -> str:
    """Option ``name``'s value as the command line writes it (a list comma-separated)."""
    opt = _BY_NAME[name]
    return _describe(opt, _from_json(opt, value))


def read(spec=None, db=None, origins=None, base=None):
    """Read, parse and check every ``-mpm_`` option; raise :class:`InputError` on the first fault.

    ``db`` is a ``PETSc.Options`` (the global database when None). Options that no analysis
    knows are errors with a suggestion of the nearest valid name. ``origins`` maps the
    options a scene file set (and the command line did not) to their ``FILE:LINE``
    (:func:`scan_file`): such an option that the chosen analysis does not use is dropped with
    a note, so one scene serves both analyses; given anywhere else it is an error.

    The result, a frozen :data:`Params` (``dataclasses.replace`` makes a changed copy),
    holds every option's value, ``given`` (the names set), ``from_file`` (those of them a
    scene file set: ``{name: "FILE:LINE"}``) and ``notes`` (lines to print before the run).
    Every option given is fetched by name, which marks it used for ``-options_left``.
    ``base`` ({name: value as JSON holds it}, a checkpoint's options) gives the values of
    the options not given, in place of the defaults.
    """
    from petsc4py import PETSc

    db = PETSc.Options() if db is None else db
    # getString marks the option used (getAll does not): -options_left then reports only
    # the options nobody read. PETSc returns "" for an option given without a value.
    given = {k[len(PREFIX):]: db.getString(k, "") for k in db.getAll() if k.startswith(PREFIX)
             and not k[len(PREFIX):].startswith(LINEAR_SOLVER)}
    return _assemble(SPEC if spec is None else spec, given, origins or {}, base or {})


def from_mapping(values, base=None):
    """The :data:`Params` that :func:`read` returns for a command line giving ``values``.

    ``values`` is ``{name: value}``, names without ``mpm_``; a value is either the text the
    command line would give (``"1,10"``) or a Python value of the option's kind (a float,
    an int, a tuple for a list, a bool, a str; None for an option given without a value).
    It is parsed and checked as that text, with the same :class:`InputError` texts; ``base``
    is :func:`read`'s. PETSc's options database is neither read nor written, so a study or
    a test can build the parameters of many scenes in one process.
    """
    return _assemble(SPEC, {name: _as_text(value) for name, value in values.items()}, {},
                     base or {})


def _as_text(value):
    """A Python value as the command line writes it (None stays None: no value given)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (tuple, list)):
        return ",".join(map(str, value))
    return None if value is None else str(value)


def _value(opt: Option, text):
    """Option ``opt`` given as ``text`` (None or "" when given without a value), parsed and
    checked."""
    text = "" if text is None else str(text)
    if opt.kind == "bool":
        low = text.strip().lower()
        if low in ("", "1", "true", "yes", "on"):
            return True
        if low in ("0", "false", "no", "off"):
            return False
        raise InputError(f"-{PREFIX}{opt.name}: '{text}' is not a boolean")
    if text.strip() == "":
        raise InputError(f"-{PREFIX}{opt.name}: needs a value")
    if opt.kind in ("float", "int") and "," in text:
        raise InputError(f"-{PREFIX}{opt.name} {text.strip()}: "
                         + ONE_VALUE.get(opt.name, "takes one value, not a list"))
    try:
        value = _parse(opt, text)
    except ValueError as exc:
        raise InputError(f"-{PREFIX}{opt.name}: '{text}': {exc}") from None
    problem = _check_value(opt, value)
    if problem:
        raise InputError(f"-{PREFIX}{opt.name} {_describe(opt, value)}: {problem}")
    return value


def _assemble(spec, given: dict, origins: dict, base: dict):
    """The Params of the options ``given`` ({name: text}) over ``base`` or the defaults:
    :func:`read` after the database is read, shared with :func:`from_mapping`."""
    by_name = {o.name: o for o in spec}
    given = dict(given)
    for name in given:
        if name not in by_name:
            near = difflib.get_close_matches(name, list(by_name), n=1)
            hint = f" (did you mean -{PREFIX}{near[0]}?)" if near else ""
            raise InputError(f"-{PREFIX}{name}: unknown option{hint}")

    values = {}
    for opt in spec:
        if opt.name in given:
            values[opt.name] = _value(opt, given[opt.name])
        elif opt.name in base:
            values[opt.name] = _from_json(opt, base[opt.name])
        else:
            values[opt.name] = opt.default

    analysis = values["analysis"]
    unused = [name for name in given if analysis not in by_name[name].used_by]
    for name in unused:
        if name not in origins:
            raise InputError(f"-{PREFIX}{name}: not used by -{PREFIX}analysis {analysis}")
    notes = []
    if unused:
        # The values are parsed and checked above (a broken scene file stays an error) but
        # left at their defaults: the analysis does not read them.
        for name in unused:
            values[name] = by_name[name].default
            del given[name]
        files = sorted({origins[n].rsplit(":", 1)[0] for n in unused})
        notes.append(f"{len(unused)} option(s) of {', '.join(files)} not used by "
                     f"-{PREFIX}analysis {analysis}, ignored: "
                     + " ".join(f"-{PREFIX}{n}" for n in sorted(unused)))
    cls = Params if spec is SPEC else params_class(spec)
    return cls(**values, given=tuple(sorted(given)),
               from_file={n: origins[n] for n in given if n in origins}, notes=tuple(notes))


def table(spec=None, values=None) -> str:
    """The option table as Markdown (the README's). ``values`` (a :func:`read` result, or
    ``{name: text}``) adds a column "value" with the values in effect (``-help``)."""
    spec = SPEC if spec is None else spec
    if values is not None and not isinstance(values, dict):
        values = {o.name: _describe(o, getattr(values, o.name)) for o in spec}
    value_head, value_rule = ("value | ", "---|") if values is not None else ("", "")
    rows = [f"| option | {value_head}default | used by | meaning |",
            f"|---|{value_rule}---|---|---|"]
    for o in spec:
        value = f"`{values[o.name]}` | " if values is not None else ""
        rows.append(f"| `-{PREFIX}{o.name}` | {value}`{_describe(o, o.default)}` | "
                    f"{', '.join(o.used_by)} | {o.help} |")
    return "\n".join(rows)


def given_text(spec=None, db=None) -> dict:
    """``{name: text}`` of every option of ``spec`` as the database holds it (the default
    for those not given), unparsed: ``-help`` shows these when :func:`read` refuses them.
    Fetching marks the options used."""
    from petsc4py import PETSc

    spec = SPEC if spec is None else spec
    db = PETSc.Options() if db is None else db
    return {o.name: db.getString(PREFIX + o.name, "") if db.hasName(PREFIX + o.name)
            else _describe(o, o.default) for o in spec}


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _pairs(args) -> list:
    """``[(name, value or None)]`` of command-line arguments, split as PETSc splits them: a
    word that starts with ``-`` and is not a number names an option; the word after it is
    its value unless it names another."""
    pairs = []
    for word in args:
        if word.startswith("-") and not _is_number(word):
            pairs.append((word[1:], None))
        elif pairs and pairs[-1][1] is None:
            pairs[-1] = (pairs[-1][0], word)
        else:
            raise InputError(f"'{word}': expected an option (-name [value])")
    return pairs


@contextlib.contextmanager
def command_line(argv, db=None):
    """PETSc's database holding the options of ``argv`` (a command line, program name
    first) for the duration of the block, then the database as it was.

    For a process where PETSc already runs (a test, a notebook, a study calling
    ``solver.__main__.main`` once per scene), where ``petsc4py.init`` can no longer take
    them. As at PETSc's start, the ``-options_file`` files are read first and the rest of
    the command line wins over them.
    """
    from petsc4py import PETSc

    db = PETSc.Options() if db is None else db
    before = db.getAll()
    try:
        pairs = _pairs(argv[1:])
        # PETSc reads an -options_file on rank 0 of COMM_WORLD and broadcasts it, which a
        # run on fewer ranks would leave half done; the files are plain (scan_file checked
        # them), so they are read here. -help is the caller's to act on: in the database it
        # would change how PETSc finalises.
        for name, value in pairs:
            if name == "options_file_yaml":
                raise InputError("-options_file_yaml: only on a command line; from Python "
                                 "give -options_file")
            if name == "options_file":
                for option, text in file_pairs(value):
                    db.setValue(option, text)
        for name, value in pairs:
            if name not in ("options_file", "help", "-help", "h"):
                db.setValue(name, value)
        yield db
    finally:
        after = db.getAll()
        for name, value in after.items():
            if name not in before:
                db.delValue(name)
            elif before[name] != value:
                db.setValue(name, before[name])
