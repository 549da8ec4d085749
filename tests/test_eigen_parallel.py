"""One rank against several: the same model, the same frequencies (both solvers) to 1e-10."""

import numpy as np
import pytest

from conftest import check_ok

ELEMENTS = ("q4", "q8", "q9")
RTOL = 1e-10
WIDE = ["-mpm_cells", "4,6", "-mpm_size", "0.4,0.6", "-mpm_nu", "0.3", "-mpm_element", "q9",
        "-mpm_figures", "0"]


def assert_same_model(s1, sn, ranks):
    assert sn["provenance"]["ranks"] == ranks and s1["provenance"]["ranks"] == 1
    assert sn["eigen"]["ndof"] == s1["eigen"]["ndof"]
    assert sn["eigen"]["n_points"] == s1["eigen"]["n_points"]
    for solver in ("jacobi", "slepc"):
        f1 = np.array(s1["eigen"]["frequencies_hz"][solver])
        fn = np.array(sn["eigen"]["frequencies_hz"][solver])
        assert f1.shape == fn.shape
        np.testing.assert_allclose(fn, f1, rtol=RTOL, atol=0, err_msg=solver)
    np.testing.assert_allclose(
        sn["eigen"]["references"]["fe_gauss_hz"],
        s1["eigen"]["references"]["fe_gauss_hz"],
        rtol=RTOL,
    )
    assert max(sn["eigen"]["cross_check"]["relative_eigenvalue_difference"]) <= 1e-8
    assert min(sn["eigen"]["cross_check"]["mac"]) > 0.999999


@pytest.mark.mpi(2)
@pytest.mark.parametrize("element", ELEMENTS)
def test_paper_scene_two_ranks(paper_run, element):
    s1 = check_ok(paper_run(element, 1)[0])
    res2 = paper_run(element, 2)[0]
    s2 = check_ok(res2)
    assert_same_model(s1, s2, 2)
    assert "2 rank(s)" in res2.stdout
    assert res2.stderr.count("solver: error") == 0


@pytest.mark.mpi(2)
def test_wide_grid_two_ranks(cli, tmp_path):
    """4 x 6 Q9 cells, nu = 0.3 (modes with lateral motion), on 1 and 2 ranks."""
    s1 = check_ok(cli(WIDE, options_file="eigen-q9", out_dir=tmp_path / "n1"))
    assert s1["eigen"]["ndof"] == 192 and s1["eigen"]["n_points"] == 216
    s2 = check_ok(cli(WIDE, ranks=2, options_file="eigen-q9", out_dir=tmp_path / "n2"))
    assert_same_model(s1, s2, 2)


@pytest.mark.mpi(4)
def test_four_ranks_cut_in_both_directions(cli, tmp_path):
    """4 x 4 Q4 cells on 4 ranks: a 2 x 2 process grid, every rank owns 2 x 2 cells."""
    args = ["-mpm_cells", "4,4", "-mpm_size", "0.4,0.4", "-mpm_nu", "0.25",
            "-mpm_nmodes", "6", "-mpm_figures", "0"]
    s1 = check_ok(cli(args, options_file="eigen-q4", out_dir=tmp_path / "n1"))
    s4 = check_ok(cli(args, ranks=4, options_file="eigen-q4", out_dir=tmp_path / "n4"))
    assert_same_model(s1, s4, 4)


@pytest.mark.mpi(3)
@pytest.mark.parametrize("element, cells, size", [
    ("q8", "3,2", "0.3,0.2"),     # 3 ranks: one column of 2 cells each
    ("q4", "1,10", "0.1,1.0"),    # 3 ranks: 4, 3, 3 cells
])
def test_three_ranks_with_few_cells_each(cli, tmp_path, element, cells, size):
    args = ["-mpm_element", element, "-mpm_cells", cells, "-mpm_size", size,
            "-mpm_ppc", "2" if element == "q4" else "3", "-mpm_nu", "0.2", "-mpm_figures", "0"]
    s1 = check_ok(cli(args, options_file=f"eigen-{element}", out_dir=tmp_path / "n1"))
    s3 = check_ok(cli(args, ranks=3, options_file=f"eigen-{element}", out_dir=tmp_path / "n3"))
    assert_same_model(s1, s3, 3)


@pytest.mark.mpi(3)
def test_more_ranks_than_cells_is_input_error(cli, tmp_path):
    out = tmp_path / "out"
    res = cli(["-mpm_cells", "1,2"], ranks=3, options_file="eigen-q4", out_dir=out)
    assert res.returncode == 2, res.stderr[-3000:]
    errors = [ln for ln in res.stderr.splitlines() if ln.startswith("solver: error:")]
    assert len(errors) == 1 and "-mpm_cells" in errors[0], res.stderr
    assert "Traceback" not in res.stderr
    assert not out.exists()


@pytest.mark.mpi(2)
def test_tiny_model_on_two_ranks(cli, tmp_path):
    """A model with 2 free DOFs (1 x 2 Q4 cells, top fixed too) on 2 ranks: each rank owns a
    cell, but the Jacobi solver's single pair leaves one rank without rows. Must give the
    same answer as one rank (the rod fixed at both ends, discretised), not hang."""
    args = ["-mpm_cells", "1,2", "-mpm_size", "0.1,0.2", "-mpm_bc_top", "xy",
            "-mpm_nmodes", "1", "-mpm_figures", "0"]
    s1 = check_ok(cli(args, options_file="eigen-q4", out_dir=tmp_path / "n1"))
    assert s1["eigen"]["ndof"] == 2
    res = cli(args, ranks=2, options_file="eigen-q4", out_dir=tmp_path / "n2", timeout=10)
    s2 = check_ok(res)
    assert_same_model(s1, s2, 2)


@pytest.mark.mpi(2)
def test_blocked_model_two_ranks(cli, tmp_path):
    """A model in the blocked range (2 x 40 Q9 cells, nu = 0.3: 640 DOFs, 10 blocks of 64):
    one rank (pair problems swept in a worker thread) and two (block pairs split between the
    ranks) give the same frequencies; Jacobi agrees with SLEPc."""
    args = ["-mpm_cells", "2,40", "-mpm_nu", "0.3", "-mpm_figures", "0"]
    s1 = check_ok(cli(args, options_file="eigen-q9", out_dir=tmp_path / "n1"))
    assert s1["eigen"]["ndof"] == 640 and s1["eigen"]["jacobi"]["block_sizes"][0] > 1
    s2 = check_ok(cli(args, ranks=2, options_file="eigen-q9", out_dir=tmp_path / "n2"))
    assert s2["eigen"]["jacobi"]["block_sizes"] == s1["eigen"]["jacobi"]["block_sizes"]
    assert_same_model(s1, s2, 2)
    assert max(s1["eigen"]["jacobi"]["residual"]) < 1e-9
