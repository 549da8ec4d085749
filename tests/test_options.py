"""Bad input: exit code 2, one line ``solver: error: ...`` naming the option, nothing written.
Plus the option reader (solver.io.options.read) in-process on a PETSc options database."""

from contextlib import contextmanager

import pytest

from conftest import REPO

# (extra arguments after -options_file cases/eigen-q4.opts, text the message must contain)
BAD = [
    (["-mpm_element", "q5"], "-mpm_element"),
    (["-mpm_E", "0"], "-mpm_E"),
    (["-mpm_E", "-1e6"], "-mpm_E"),
    (["-mpm_nu", "0.5"], "-mpm_nu"),
    (["-mpm_nu", "-0.1"], "-mpm_nu"),
    (["-mpm_porosity", "0"], "-mpm_porosity"),
    (["-mpm_porosity", "1"], "-mpm_porosity"),
    (["-mpm_ppc", "0"], "-mpm_ppc"),
    (["-mpm_cells", "0,10"], "-mpm_cells"),
    (["-mpm_cells", "1,,10"], "-mpm_cells"),
    (["-mpm_cells", "1"], "-mpm_cells"),
    (["-mpm_cells", "a,b"], "-mpm_cells"),
    (["-mpm_elemnt", "q4"], "-mpm_element"),       # the suggestion
    (["-mpm_E", "nan"], "-mpm_E"),
    (["-mpm_nmodes", "21"], "-mpm_nmodes"),        # the Q4 scene has 20 free DOFs
]


def _ids(case):
    return " ".join(case[0])


def assert_input_error(res, must_contain, out_dir):
    err_lines = res.stderr.strip().splitlines()
    assert res.returncode == 2, f"exit {res.returncode}\n{res.stdout}\n{res.stderr[-3000:]}"
    assert len(err_lines) == 1, res.stderr
    assert err_lines[0].startswith("solver: error:"), err_lines[0]
    assert must_contain in err_lines[0], err_lines[0]
    assert "Traceback" not in res.stderr + res.stdout
    assert not out_dir.exists(), "output folder created for bad input"
    assert res.summary is None
    return err_lines[0]


@pytest.mark.parametrize("args, must_contain", BAD, ids=[_ids(c) for c in BAD])
def test_bad_option_cli(cli, tmp_path, args, must_contain):
    out = tmp_path / "out"
    res = cli(args, options_file="eigen-q4", out_dir=out)
    line = assert_input_error(res, must_contain, out)
    if args[0] == "-mpm_elemnt":
        assert "did you mean -mpm_element" in line


def test_nmodes_message_gives_dof_count(cli, tmp_path):
    out = tmp_path / "out"
    res = cli(["-mpm_nmodes", "21"], options_file="eigen-q4", out_dir=out)
    line = assert_input_error(res, "-mpm_nmodes", out)
    assert "20" in line


def test_nmodes_equal_to_dofs_is_accepted(cli):
    """nmodes = ndof (20 on the Q4 grid) is allowed by the check, so it must work: every
    eigenvalue, both solvers (nu = 0.1, so not the paper scene)."""
    res = cli(["-mpm_nmodes", "20", "-mpm_nu", "0.1", "-mpm_figures", "0"],
              options_file="eigen-q4")
    assert res.returncode == 0, res.stderr[-3000:]
    for solver in ("jacobi", "slepc"):
        assert len(res.summary["eigen"]["frequencies_hz"][solver]) == 20
    assert max(res.summary["eigen"]["cross_check"]["relative_eigenvalue_difference"]) <= 1e-8


@pytest.mark.parametrize("args, name", [
    (["-mpm_E"], "-mpm_E"),                          # last on the line, no value
    (["-mpm_nu", "-mpm_E", "5e6"], "-mpm_nu"),       # followed by another option
])
def test_option_without_value_cli(cli, tmp_path, args, name):
    """An option given without its value is an input error, not silently the default."""
    out = tmp_path / "out"
    res = cli(["-mpm_output", str(out), "-options_file", str(REPO / "cases/eigen-q4.opts"),
               "-mpm_figures", "0", *args], out_dir=out)
    assert_input_error(res, name, out)


def test_missing_options_file(cli, tmp_path):
    out = tmp_path / "out"
    res = cli(["-options_file", str(tmp_path / "no-such.opts")], out_dir=out)
    assert_input_error(res, "-options_file", out)


def test_options_file_without_name(cli, tmp_path):
    out = tmp_path / "out"
    res = cli(["-mpm_output", str(out), "-options_file"], out_dir=out)
    assert_input_error(res, "-options_file", out)


def _consolidation_only():
    from solver.io import options

    return [o for o in options.SPEC
            if options.EIGEN not in o.used_by and options.CONSOLIDATION in o.used_by]


def test_consolidation_option_rejected_in_eigen_run(cli, tmp_path):
    only = _consolidation_only()
    if not only:
        pytest.skip("no consolidation-only options")
    opt = next((o for o in only if o.kind == "float" and o.default == o.default), only[0])
    out = tmp_path / "out"
    res = cli([f"-mpm_{opt.name}", str(opt.default)], options_file="eigen-q4", out_dir=out)
    line = assert_input_error(res, f"-mpm_{opt.name}", out)
    assert "eigen" in line


@pytest.mark.mpi(2)
def test_bad_input_under_mpi_prints_one_line(cli, tmp_path):
    out = tmp_path / "out"
    res = cli(["-mpm_nu", "0.5"], ranks=2, options_file="eigen-q4", out_dir=out)
    assert res.returncode == 2, res.stderr[-3000:]
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("solver: error:")]
    assert len(lines) == 1 and "-mpm_nu" in lines[0]
    assert "Traceback" not in res.stderr
    assert not out.exists()


def test_numerical_failure_exit_code_3(cli, tmp_path):
    """Jacobi stopped after one sweep: exit 3, one line, no traceback."""
    res = cli(["-mpm_jacobi_max_sweeps", "1", "-mpm_figures", "0"], options_file="eigen-q4")
    assert res.returncode == 3, res.stderr[-3000:]
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("solver: error:")
    assert "-mpm_jacobi_max_sweeps" in lines[0]
    assert "Traceback" not in res.stderr


def test_help_lists_the_options(cli):
    res = cli(["-help"])
    assert res.returncode == 0
    for name in ("-mpm_element", "-mpm_cells", "-mpm_nu", "-mpm_nmodes", "-mpm_jacobi_tol"):
        assert name in res.stdout


# -- in-process: solver.io.options.read on the PETSc options database -----------------------
@contextmanager
def petsc_options(values):
    from petsc4py import PETSc

    db = PETSc.Options()
    before = {k for k in db.getAll() if k.startswith("mpm_")}
    assert not before, f"stale options {before}"
    for k, v in values.items():
        db.setValue(f"mpm_{k}", v)
    try:
        yield db
    finally:
        for k in values:
            db.delValue(f"mpm_{k}")


def read(values):
    from solver.io import options

    with petsc_options(values) as db:
        return options.read(db=db)


def test_defaults_are_the_paper_q4_scene():
    p = read({})
    assert p.analysis == "eigen" and p.element == "q4"
    assert p.cells == (1, 10) and p.size == (0.1, 1.0) and p.ppc == 2
    assert p.E == 10e6 and p.nu == 0.0 and p.porosity == 0.3
    assert (p.rho_s, p.rho_l) == (2700.0, 1000.0)
    assert (p.bc_left, p.bc_right, p.bc_bottom, p.bc_top) == ("x", "x", "xy", "none")
    assert p.eigen_solver == ("jacobi", "slepc") and p.jacobi_tol == 1e-15
    assert p.given == ()


def test_values_are_parsed():
    p = read({"cells": "4,6", "size": "0.4,6e-1", "E": "2.5e7", "nu": "0.3", "ppc": "3",
              "element": "q9", "eigen_solver": "slepc", "figures": "0", "nmodes": "1e1"})
    assert p.cells == (4, 6) and p.size == (0.4, 0.6) and p.E == 2.5e7 and p.nu == 0.3
    assert p.ppc == 3 and p.element == "q9" and p.eigen_solver == ("slepc",)
    assert p.figures is False and p.nmodes == 10
    assert set(p.given) == {"cells", "size", "E", "nu", "ppc", "element", "eigen_solver",
                            "figures", "nmodes"}


@pytest.mark.parametrize("values, name", [
    ({"element": "q5"}, "element"),
    ({"E": "0"}, "E"), ({"E": "inf"}, "E"), ({"E": "nan"}, "E"), ({"E": "ten"}, "E"),
    ({"nu": "0.5"}, "nu"), ({"nu": "-0.1"}, "nu"), ({"nu": ""}, "nu"),
    ({"porosity": "0"}, "porosity"), ({"porosity": "1"}, "porosity"),
    ({"ppc": "0"}, "ppc"), ({"ppc": "2.5"}, "ppc"),
    ({"cells": "0,10"}, "cells"), ({"cells": "1,,10"}, "cells"), ({"cells": "1"}, "cells"),
    ({"cells": "a,b"}, "cells"), ({"cells": "1.5,10"}, "cells"), ({"cells": "1,2,3"}, "cells"),
    ({"size": "0,1"}, "size"), ({"size": "0.1,-1"}, "size"),
    ({"rho_s": "0"}, "rho_s"), ({"rho_l": "-1"}, "rho_l"),
    ({"bc_top": "z"}, "bc_top"), ({"points": "random"}, "points"),
    ({"nmodes": "0"}, "nmodes"),
    ({"eigen_solver": "arpack"}, "eigen_solver"),
    ({"eigen_solver": "jacobi,jacobi"}, "eigen_solver"),
    ({"jacobi_tol": "0"}, "jacobi_tol"), ({"jacobi_tol": "1"}, "jacobi_tol"),
    ({"jacobi_max_sweeps": "0"}, "jacobi_max_sweeps"),
    ({"figures": "maybe"}, "figures"),
    ({"analysis": "modal"}, "analysis"),
    ({"elemnt": "q4"}, "element"),
    ({"nodes": "3"}, "nodes"),
])
def test_read_rejects(values, name):
    from solver.common.errors import InputError

    with pytest.raises(InputError) as info:
        read(values)
    assert f"-mpm_{name}" in str(info.value)
    assert "\n" not in str(info.value)
    assert info.value.exit_code == 2


def test_every_consolidation_option_rejected_for_eigen():
    from solver.common.errors import InputError

    only = _consolidation_only()
    if not only:
        pytest.skip("no consolidation-only options")
    from solver.io import options

    for opt in only:
        value = options._describe(opt, opt.default)
        if opt.default != opt.default:      # NaN default (automatic): give a valid value
            value = "1"
        if value == "":                     # empty default: a file name, or a list
            value = {"floats": "0,0.05", "ints": "4,2"}.get(opt.kind, "some-file")
        with pytest.raises(InputError, match=f"-mpm_{opt.name}"):
            read({opt.name: value})
        # ... and accepted with -mpm_analysis consolidation.
        p = read({opt.name: value, "analysis": "consolidation"})
        assert opt.name in p.given


def test_cases_files_parse():
    """The shipped eigen scenes are valid option files for the reader."""
    for element in ("q4", "q8", "q9"):
        text = (REPO / "cases" / f"eigen-{element}.opts").read_text()
        values = {}
        for line in text.splitlines():
            line = line.split("#")[0].strip()
            if line:
                key, _, value = line.partition(" ")
                values[key.lstrip("-")[len("mpm_"):]] = value.strip()
        p = read(values)
        assert p.element == element and p.cells == (1, 10)
        assert p.ppc == (2 if element == "q4" else 3)


# -- options.from_mapping: the same Params without PETSc's database -------------------------
def _from_command_line(argv):
    from solver.io import options

    with options.command_line(["solver", *argv]):
        return options.read()


@pytest.mark.parametrize("scene", ["consolidation-m1-q4", "consolidation-m2-q4",
                                   "consolidation-m1-q9", "eigen-q8"])
def test_from_mapping_equals_read_over_a_command_line(scene):
    """A scene file's words as a mapping, and the values read back as Python values, give
    the Params the command line gives (the command line with an override on top)."""
    from petsc4py import PETSc

    from solver.io import options, scenefile

    path = str(REPO / "cases" / f"{scene}.opts")
    argv = ["-options_file", path, "-mpm_cells", "2,20", "-mpm_figures", "0"]
    expected = _from_command_line(argv)
    words = {name[len("mpm_"):]: value for name, value in scenefile.pairs(path)}
    before = PETSc.Options().getAll()
    got = options.from_mapping({**words, "cells": "2,20", "figures": "0"})
    assert PETSc.Options().getAll() == before
    assert got == expected and got.cells == (2, 20) and got.figures is False
    assert got.given == expected.given and "cells" in got.given
    assert (got.from_file, got.notes) == ({}, ())
    # Python values of each option's kind: floats, ints, tuples, bools, strs.
    typed = {name: getattr(expected, name) for name in expected.given}
    assert options.from_mapping(typed) == expected
    assert PETSc.Options().getAll() == before


def test_from_mapping_keeps_the_base_and_the_defaults():
    from solver.io import options

    base = {"E": 2e7, "Tv_report": [0.1, 0.2], "dt": None}
    p = options.from_mapping({"analysis": "consolidation", "nu": 0.25}, base=base)
    assert (p.E, p.Tv_report, p.nu) == (2e7, (0.1, 0.2), 0.25) and p.dt != p.dt
    assert p.given == ("analysis", "nu") and p.ppc == 2       # the default
    assert options.from_mapping({}) == read({})


@pytest.mark.parametrize("values", [
    {"E": "-1e6"}, {"E": "nan"}, {"cells": "1,,10"}, {"cells": "1.5,10"}, {"nu": ""},
    {"figures": "maybe"}, {"elemnt": "q4"}, {"k": "1e-4"}, {"eigen_solver": "jacobi,jacobi"},
])
def test_from_mapping_rejects_with_reads_message(values):
    from petsc4py import PETSc

    from solver.common.errors import InputError
    from solver.io import options

    with pytest.raises(InputError) as by_read:
        read(values)
    before = PETSc.Options().getAll()
    with pytest.raises(InputError) as by_mapping:
        options.from_mapping(values)
    assert str(by_mapping.value) == str(by_read.value)
    assert by_mapping.value.exit_code == 2
    assert PETSc.Options().getAll() == before


@pytest.mark.parametrize("values, text", [
    ({"E": -1e6}, "-mpm_E -1000000.0: must be > 0"),
    ({"cells": (0, 10)}, "-mpm_cells 0,10: every entry must be >= 1"),
    ({"ppc": 2.5}, "-mpm_ppc: '2.5': not an integer"),
    ({"E": float("inf")}, "-mpm_E: 'inf': not a finite number"),
    ({"element": "q5"}, "-mpm_element q5: unknown value 'q5' (choose from q4, q8, q9)"),
])
def test_from_mapping_checks_python_values(values, text):
    from solver.common.errors import InputError
    from solver.io import options

    with pytest.raises(InputError) as info:
        options.from_mapping(values)
    assert str(info.value) == text


def test_readme_option_table_is_the_generated_one():
    """README's option table is options.table() as it is (regenerate it when SPEC changes)."""
    from solver.io import options

    assert options.table() in (REPO / "README.md").read_text()
