"""The options as PETSc options: -options_left reports only what nobody read,
-help/--help show the values in effect and run nothing, the parameters are frozen once read,
the FE reference solve has its own prefix, and the printed SLEPc label is the solver used."""

import dataclasses
import os

import pytest

from conftest import CASES, PYTHON, REPO, run_command

# PETSc's own -options_left report (PetscOptionsLeft) after the table of options.
LEFT = "Option left: name:"


def _solver(args, cwd, timeout=180):
    """``python -m solver ARGS`` run in ``cwd`` (so a default output folder would land
    there); returns (returncode, stdout, stderr)."""
    cmd = ["env", f"PYTHONPATH={REPO}", PYTHON, "-m", "solver", *map(str, args)]
    return run_command(cmd, timeout=timeout, cwd=cwd)


def _left(stdout):
    """The options PETSc reports unused: ["-name", ...]."""
    return [ln.split(LEFT, 1)[1].split()[0] for ln in stdout.splitlines() if LEFT in ln]


def test_options_left_reports_only_the_typo(tmp_path):
    code, out, err = _solver(["-options_file", CASES / "eigen-q9.opts", "-eps_tpye", "lapack",
                              "-options_left", "-mpm_output", tmp_path / "out",
                              "-mpm_figures", "0"], tmp_path)
    assert code == 0, err[-3000:]
    assert _left(out) == ["-eps_tpye"], out[-3000:]


@pytest.mark.parametrize("scene", ["consolidation-m1-q4", "consolidation-m1-q9"])
def test_options_left_consolidation_has_nothing_left(tmp_path, scene):
    """Every -mpm_ option of the scene is read, as are the ones the program sets itself."""
    code, out, err = _solver(["-options_file", CASES / f"{scene}.opts", "-options_left",
                              "-mpm_output", tmp_path / "out", "-mpm_figures", "0",
                              "-mpm_progress", "0", "-mpm_Tv_end", "0.02",
                              "-mpm_Tv_report", "0.02"], tmp_path, timeout=300)
    assert code == 0, err[-3000:]
    assert _left(out) == [], out[-3000:]
    assert "There are no unused options." in out


def test_options_left_scene_options_of_the_other_analysis_are_not_left(tmp_path):
    """A consolidation scene run as eigen drops its consolidation options with a note: they
    were read (and checked), so -options_left does not list them as typos."""
    code, out, err = _solver(["-options_file", CASES / "consolidation-m1-q4.opts",
                              "-mpm_analysis", "eigen", "-options_left",
                              "-mpm_output", tmp_path / "out", "-mpm_figures", "0"], tmp_path)
    assert code == 0, err[-3000:]
    assert "not used by -mpm_analysis eigen" in out
    assert _left(out) == [], out[-3000:]


@pytest.mark.parametrize("flag", ["-help", "--help"])
def test_help_shows_values_in_effect_and_runs_nothing(tmp_path, flag):
    code, out, err = _solver([flag, "-options_file", CASES / "eigen-q9.opts",
                              "-mpm_nmodes", "3"], tmp_path)
    assert code == 0, err[-3000:]
    assert os.listdir(tmp_path) == [], "help wrote files"
    rows = {ln.split("|")[1].strip(" `"): [c.strip(" `") for c in ln.split("|")[2:-1]]
            for ln in out.splitlines() if ln.startswith("| `-mpm_")}
    assert "| option | value | default |" in out
    assert rows["-mpm_element"][:2] == ["q9", "q4"]         # the file's value
    assert rows["-mpm_nmodes"][:2] == ["3", "5"]            # the command line's
    assert rows["-mpm_output"][:2] == ["output/eigen-q9", "output"]
    assert "Eigen analysis" not in out and "Natural frequencies" not in out


def test_help_shows_our_table_first_and_petscs_only_when_asked(tmp_path):
    """-help starts with the option table (PETSc's 60 lines of generic
    help came first); -help petsc adds PETSc's, and the table still follows."""
    code, out, err = _solver(["-help"], tmp_path)
    assert code == 0, err[-3000:]
    assert out.startswith("Options of the MPM solver") and "Petsc Release" not in out
    assert out.rstrip().endswith("-help petsc")
    code, out, err = _solver(["-help", "petsc"], tmp_path)
    assert code == 0, err[-3000:]
    assert out.index("Petsc Release") < out.index("Options of the MPM solver")
    assert "| `-mpm_element` |" in out and os.listdir(tmp_path) == []


def test_help_with_a_bad_value_still_shows_the_table(tmp_path):
    code, out, err = _solver(["--help", "-mpm_nu", "0.7"], tmp_path)
    assert code == 0, err[-3000:]
    assert "| `-mpm_nu` | `0.7` |" in out
    assert "-mpm_nu 0.7: must lie in [0, 0.5)" in out
    assert os.listdir(tmp_path) == []


# -- in-process ---------------------------------------------------------------------------
def _read(values):
    from petsc4py import PETSc

    from solver.io import options

    db = PETSc.Options()
    for k, v in values.items():
        db.setValue(f"mpm_{k}", v)
    try:
        return options.read(db=db)
    finally:
        for k in values:
            db.delValue(f"mpm_{k}")


def test_params_are_frozen():
    p = _read({"cells": "2,3"})
    with pytest.raises(dataclasses.FrozenInstanceError):
        p.cells = (4, 4)
    with pytest.raises(dataclasses.FrozenInstanceError):
        setattr(p, "output", "elsewhere")
    assert p.cells == (2, 3) and p.given == ("cells",)
    q = dataclasses.replace(p, cells=(4, 4))
    assert q.cells == (4, 4) and p.cells == (2, 3) and q.given == p.given


def test_workprecision_apply_returns_a_new_value():
    from solver.consolidation import workprecision

    p = _read({"analysis": "consolidation"})
    choice = {"element": "q9", "cells": [1, 20], "ppc": 3, "dt_safety": 0.25}
    q = workprecision.apply(p, choice)
    assert (q.element, q.cells, q.ppc, q.dt_safety) == ("q9", (1, 20), 3, 0.25)
    assert (p.element, p.cells, p.ppc, p.dt_safety) == ("q4", (1, 10), 2, 0.5)
    assert all(getattr(q, k) == getattr(p, k) for k in ("E", "k", "load", "output", "given"))


def test_table_value_column():
    from solver.io import options

    p = _read({"element": "q8", "cells": "2,20"})
    text = options.table(values=p)
    assert "| `-mpm_element` | `q8` | `q4` |" in text
    assert "| `-mpm_cells` | `2,20` | `1,10` |" in text
    assert "| option | default |" in options.table()        # the README's, unchanged


# -- SLEPc: the FE reference's prefix and the label of the solver used -------------------
def _eigen(tmp_path, args):
    tmp_path.mkdir(parents=True, exist_ok=True)
    out = tmp_path / "out"
    code, stdout, err = _solver(["-options_file", CASES / "eigen-q4.opts", "-mpm_output", out,
                                 "-mpm_figures", "0", *args], tmp_path)
    assert code == 0, err[-3000:]
    import json

    with open(out / "summary.json") as fh:
        return stdout, json.load(fh)


def test_slepc_label_is_the_solver_used(tmp_path):
    stdout, s = _eigen(tmp_path, [])
    assert "SLEPc krylovschur, ST sinvert:" in stdout
    assert (s["eigen"]["slepc"]["type"], s["eigen"]["slepc"]["st"]) == ("krylovschur", "sinvert")


def test_eps_options_reach_the_main_solve_only(tmp_path):
    """-eps_type lapack changes the main solve (label, summary), -eps_view prints once (the
    FE reference reads -fe_eps_*), and the frequencies agree with Krylov-Schur's."""
    base, s0 = _eigen(tmp_path / "a", [])
    stdout, s = _eigen(tmp_path / "b", ["-eps_type", "lapack", "-eps_view"])
    assert "SLEPc lapack, ST sinvert:" in stdout and s["eigen"]["slepc"]["type"] == "lapack"
    assert stdout.count("EPS Object") == 1, stdout
    for a, b in zip(s["eigen"]["frequencies_hz"]["slepc"], s0["eigen"]["frequencies_hz"]["slepc"]):
        assert abs(a - b) <= 1e-8 * b
    assert s["eigen"]["references"]["fe_gauss_hz"] == pytest.approx(
        s0["eigen"]["references"]["fe_gauss_hz"], rel=1e-10
    )


def test_fe_prefix_reaches_the_reference_solve(tmp_path):
    stdout, s = _eigen(tmp_path, ["-fe_eps_view", "-fe_eps_type", "lapack"])
    assert stdout.count("EPS Object") == 1 and "(fe_)" in stdout, stdout
    assert "SLEPc krylovschur, ST sinvert:" in stdout
    assert s["eigen"]["slepc"]["type"] == "krylovschur"


def test_command_line_in_process_holds_for_the_call_only(tmp_path):
    """options.command_line: the files first, the rest of the line over them, negative
    numbers as values, flags without one; the database as it was afterwards."""
    from petsc4py import PETSc

    from solver.io import options

    db = PETSc.Options()
    db.setValue("mpm_test_kept", "1")
    before = db.getAll()
    scene = tmp_path / "s.opts"
    scene.write_text("-mpm_nu 0.25  # a comment\n\n-mpm_k 1e-4\n-mpm_debug\n")
    try:
        with options.command_line(["solver", "-mpm_k", "-2.5e-5", "-options_file", str(scene),
                                   "-mpm_test_kept", "2", "-help"]) as inside:
            assert inside.getAll() == {**before, "mpm_nu": "0.25", "mpm_k": "-2.5e-5",
                                       "mpm_debug": None, "mpm_test_kept": "2"}
        assert db.getAll() == before
        with pytest.raises(options.InputError, match="'stray'"):
            with options.command_line(["solver", "stray"]):
                pass
        assert db.getAll() == before
    finally:
        db.delValue("mpm_test_kept")


def test_main_in_process_twice_gives_the_same_run(cli, tmp_path):
    """Two calls of the command line in one process: the second sees none of the first's
    options, and gives the same summary as a subprocess."""
    args = ["-mpm_Tv_end", "0.002", "-mpm_Tv_report", "0.002", "-mpm_figures", "0"]
    first = cli(args + ["-mpm_k", "1e-4"], options_file="consolidation-m1-q4",
                out_dir=tmp_path / "a")
    second = cli(args, options_file="consolidation-m1-q4", out_dir=tmp_path / "b")
    apart = cli(args, options_file="consolidation-m1-q4", out_dir=tmp_path / "c", process=True)
    assert first.summary["provenance"]["options"]["mpm"]["k"] == 1e-4
    for key in ("dt", "steps", "monitor", "profile_l2"):
        block = "consolidation" if key != "steps" else None
        assert (second.summary[block][key] if block else second.summary[key]) == \
            (apart.summary[block][key] if block else apart.summary[key]), key
    assert second.summary["provenance"]["options"]["mpm"]["k"] == 2.5e-4
