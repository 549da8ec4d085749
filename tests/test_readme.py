"""The README against the code: its sections in the order a newcomer reads them, the two
set-up commands that CI runs, the main job's output as the solver prints it, the scenes
table against cases/, the outputs table against the files a run writes and their CSV
headers, the exit codes against solver/common/errors.py, every link resolving, and the module map
of docs/code.md against solver/. (The option table: tests/test_options.py; the files of a
scene without a closed form: tests/test_fe_reference.py.)"""

from __future__ import annotations

import re
import struct

import pytest
from conftest import (CASES, REPO, check_ok, check_readme_outputs, readme_outputs,
                      readme_section, readme_table, run_cli, typed)

README = REPO / "README.md"
SECTIONS = ["Set-up", "The main job", "Scenes", "Outputs", "Options", "Exit codes",
            "Documentation", "Licence"]
MAIN_JOB = ".venv/bin/python -m solver -options_file cases/eigen-q9.opts"


def _code_lines(section: str) -> list:
    """The commands of a section: its lines indented by four spaces."""
    return [line[4:] for line in section.splitlines() if line.startswith("    ")]


def _scene(name: str):
    """The -mpm_ options of cases/NAME.opts as the solver reads them (solver.io.options.Params)."""
    from solver.io import options, scenefile

    given = {k[len(scenefile.PREFIX):]: v for k, v in scenefile.pairs(CASES / f"{name}.opts")
             if k.startswith(scenefile.PREFIX)}
    return options.from_mapping(given)


# -- the order and the set-up --------------------------------------------------------------
def test_the_sections_come_in_the_order_a_newcomer_reads():
    """What it is (above the first section, at most four lines), set-up, the main job, scenes,
    outputs, options, exit codes, documentation."""
    text = README.read_text()
    headings = re.findall(r"^## (.*)$", text, flags=re.M)
    assert [next((s for s in SECTIONS if h.startswith(s)), h) for h in headings] == SECTIONS
    intro = text[:text.index("\n## ")].strip().splitlines()
    assert intro[0].startswith("# ") and 1 <= len([l for l in intro[1:] if l.strip()]) <= 4


def test_the_set_up_is_two_commands_that_ci_runs():
    """Exactly the two commands for a fresh Debian 12, and .ci/run runs the same."""
    commands = _code_lines(readme_section("Set-up"))
    assert commands == ["bash scripts/install", ".venv/bin/python -m pytest -q"]
    ci = [line.strip() for line in (REPO / ".ci" / "run").read_text().splitlines()
          if line.strip() and not line.startswith(("#", "set ", "cd "))]
    assert ci == commands


# -- the main job ----------------------------------------------------------------------------
def _normalised(text: str) -> list:
    """Printed lines with what differs between runs and machines masked: timings (0.43 s),
    round-off-sized numbers (1.8e-13) and the output folder (its results and summary)."""
    text = re.sub(r"\b\d+\.\d+ s\b", "T s", text)
    text = re.sub(r"\b\d\.\de[-+]\d\d\b", "R", text)
    text = re.sub(r"^Results in \S+:", "Results in OUT:", text, flags=re.M)
    text = re.sub(r"; summary \S+$", "; summary OUT", text, flags=re.M)
    return [line.rstrip() for line in text.strip().splitlines()]


def _png_size(path) -> tuple:
    """(width, height) in pixels of a PNG file, from its IHDR chunk."""
    head = path.read_bytes()[:24]
    assert head[:8] == b"\x89PNG\r\n\x1a\n", f"{path}: not a PNG"
    return struct.unpack(">II", head[16:24])


def test_the_main_job_prints_what_the_readme_shows(paper_run):
    """The main job is one command; the README's printed block is its output (timings and
    round-off masked), and its figure is the job's modes.png (a PNG of the same size)."""
    section = readme_section("The main job")
    commands = _code_lines(section)
    assert commands[0] == MAIN_JOB
    res, out = paper_run("q9")
    check_ok(res)
    assert _normalised("\n".join(commands[1:])) == _normalised(res.stdout)
    figures = re.findall(r"!\[[^\]]*\]\(([^)]+)\)", section)
    assert len(figures) == 1
    assert _png_size(REPO / figures[0]) == _png_size(out / "modes.png")


# -- scenes ----------------------------------------------------------------------------------
def _reference_words(p) -> set:
    """What a scene's reference cell must name, from its options: the eigen analysis is
    cross-checked by SLEPc against the rod (layered or not); a consolidation scene without
    a closed form has the FE, a layered column the layered column's solution, a load alone
    Terzaghi."""
    from solver.consolidation import plan

    if p.analysis == "eigen":
        return {"SLEPc", "layered rod" if len(p.layers) > 1 else "analytic rod"}
    if p.analysis == "static":
        return {"Prandtl"} if p.material == "tresca" else {"Prandtl-Reissner"}
    if p.analysis == "soiltest":
        # One point against its test's closed form: Cam Clay's at the critical state.
        return {"critical state"} if p.material == "mcc" else {"closed form"}
    if p.analysis == "dynamic" and p.kinematics == "large":
        # A flowing body: a Tresca footing's Prandtl at small settlement, the experiment it
        # names, or none.
        if p.footing:
            return {"Prandtl", "small settlement"} if p.material == "tresca" else {"none"}
        return {"none"} if p.experiment == "none" else {"experiment", "Bui"}
    if p.analysis == "dynamic":
        # Two phases: the saturated column's waves, then Terzaghi; one phase: the exact
        # response of the column on rock, unless Rayleigh damping's mass part rules it out.
        if p.phases == 2:
            return {"solver/references/waves.py", "Terzaghi"}
        if p.material == "hyperbolic":     # no reference of its own: its linear twin beside
            return {"none", "linear twin"}
        return {"Jacobi", "layered rod"} if p.rayleigh else \
            {"solver/references/site.py", "Jacobi"}
    if p.kinematics == "large" and p.scheme == "implicit":
        # The large-strain column: Xie and Leo's closed form, and the small strain's beside.
        return {"Xie and Leo", "small-strain"}
    if set(p.material if isinstance(p.material, tuple) else (p.material,)) != {"elastic"}:
        # Every reference of a consolidation scene is linear elastic: none for soil that
        # yields (solver/consolidation/setup.py).
        return {"none"}
    t = typed(p)
    if plan.no_reference(t.body, t.loading):
        return {"FE", "solver/references/biot.py", "static"}
    if len(p.layers) > 1:
        return {"layered column"}
    return {"own solution"} if t.loading.self_weight else {"Terzaghi"}


def test_the_scenes_table_is_cases():
    """One row per file of cases/, in the file's analysis, scheme, element, cells and points
    per cell, with a description, the reference its options give it and a measured wall time."""
    rows = readme_table("Scenes")
    names = [re.fullmatch(r"`([\w-]+)`", row[0]).group(1) for row in rows]
    assert sorted(names) == sorted(p.stem for p in CASES.glob("*.opts"))
    for name, (_, analysis, scheme, what, mesh, reference, wall) in zip(names, rows):
        p = _scene(name)
        assert analysis == p.analysis, name
        # A scene names its scheme, or auto picks the implicit one (test_implicit.py); the
        # dynamic analysis steps explicitly.
        assert scheme == ("-" if p.analysis in ("eigen", "soiltest", "static") else "explicit"
                          if p.analysis == "dynamic" else
                          "implicit" if p.scheme == "auto" else p.scheme), name
        nx, ny = p.cells
        assert mesh == ("one point" if p.analysis == "soiltest" else
                        f"{p.shape} {nx} x {ny} on the body, {p.ppc} x {p.ppc}"
                        if p.kinematics == "large" and p.analysis == "dynamic" else
                        f"{p.element.upper()} {nx} x {ny}, {p.ppc} x {p.ppc}"), name
        assert len(what.split()) >= 4, name
        for word in _reference_words(p):
            assert word in reference, f"{name}: the reference should name {word!r}"
        assert float(wall) > 0, name


def test_the_reference_rule_tells_scenes_apart():
    """The rule above gives the strip the FE, the layered column its own, the paper's
    column Terzaghi (so the scenes test can fail)."""
    assert "FE" in _reference_words(_scene("consolidation-strip"))
    assert _reference_words(_scene("consolidation-layered")) == {"layered column"}
    assert _reference_words(_scene("consolidation-m1-q4")) == {"Terzaghi"}
    assert _reference_words(_scene("consolidation-self-weight")) == {"own solution"}


# -- outputs ---------------------------------------------------------------------------------
def _solver_sources() -> str:
    return "\n".join(p.read_text() for p in (REPO / "solver").rglob("*.py"))


def test_every_file_of_the_outputs_table_is_one_the_code_writes():
    """Each file the table names is named in solver/ (a figure by its name, the series'
    HDF5 files by the index they belong to), with content, units and sign convention."""
    source = _solver_sources()
    for name, cells in readme_outputs().items():
        literal = name.rsplit(".", 1)[0] if name.endswith(".png") else name
        literal = {"points_<step>.h5": "points.xdmf",
                   "nodes_<step>.h5": "nodes.xdmf"}.get(name, literal)
        assert f'"{literal}"' in source, f"{name}: no solver module writes it"
        assert all(c.strip() for c in cells.split(" | ")), name


def test_every_file_the_main_job_writes_is_in_the_outputs_table(paper_run):
    res, out = paper_run("q9")
    check_ok(res)
    check_readme_outputs(out)


def test_every_file_a_column_run_writes_is_in_the_outputs_table(tmp_path):
    """The paper's consolidation column, shortened, with a checkpoint: every file it writes,
    its CSV headers column by column."""
    out = tmp_path / "out"
    res = run_cli(["-mpm_Tv_end", "0.02", "-mpm_Tv_report", "0.01,0.02", "-mpm_progress", "0",
                   "-mpm_checkpoint_every", "200"], out, options_file="consolidation-m1-q4")
    check_ok(res)
    assert (out / "checkpoint.npz").is_file()
    check_readme_outputs(out)


# -- exit codes ------------------------------------------------------------------------------
def test_the_exit_code_table_is_solver_errors():
    """The codes are 0 and errors.KINDS, each with its kind and the classes that raise it;
    every failure class of solver/common/errors.py is in its code's row."""
    from solver.common import errors

    rows = readme_table("Exit codes")
    codes = [int(row[0]) for row in rows]
    assert codes == [0, *sorted(errors.KINDS)]
    named = set()
    for code, row in zip(codes, rows):
        if code == 0:
            continue
        assert row[1] == f"`{errors.KINDS[code]}`"
        classes = re.findall(r"`(\w+)`", row[2])
        assert classes
        for cls in classes:
            assert getattr(errors, cls).exit_code == code, cls
        named.update(classes)
    raised = {name for name, obj in vars(errors).items()
              if isinstance(obj, type) and issubclass(obj, BaseException)
              and hasattr(obj, "exit_code")}
    assert named == raised


# -- links and the module map ----------------------------------------------------------------
def _slug(heading: str) -> str:
    """GitHub's anchor of a heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def _anchors(path) -> set:
    return {_slug(h) for h in re.findall(r"^#+ (.*)$", path.read_text(), flags=re.M)}


@pytest.mark.parametrize("page", ["README.md", *sorted(
    str(p.relative_to(REPO)) for p in (REPO / "docs").glob("*.md"))])
def test_every_relative_link_resolves(page):
    """Every relative link of the README and docs/ names a file that is there, and an
    anchor a heading of it."""
    path = REPO / page
    for target in re.findall(r"\]\(([^)\s]+)\)", path.read_text()):
        if re.match(r"[a-z]+:", target):
            continue
        file, _, anchor = target.partition("#")
        dest = (path.parent / file) if file else path
        assert dest.exists(), f"{page}: {target}"
        if anchor:
            assert anchor in _anchors(dest), f"{page}: {target}: no such heading"


def test_the_readme_links_every_page_of_docs():
    links = set(re.findall(r"\]\((docs/[^)#\s]+)", README.read_text()))
    assert {f"docs/{p.name}" for p in (REPO / "docs").glob("*.md")} <= links


def test_the_module_map_names_every_module():
    """docs/code.md's map names each module of solver/ (package __init__ files aside) once,
    and nothing that is not there."""
    text = (REPO / "docs" / "code.md").read_text()
    mapped = re.findall(r"^\| `(solver/[\w/]+\.py)` \|", text, flags=re.M)
    modules = sorted(str(p.relative_to(REPO)) for p in (REPO / "solver").rglob("*.py")
                     if p.name != "__init__.py")
    assert sorted(mapped) == modules
