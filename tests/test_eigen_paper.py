"""The paper scenes (cases/eigen-q4/q8/q9.opts) against the paper's published numbers, the
analytic rod and the plain FE model.

Every expected number here is the paper's (Table 3, the Q4 FE column, Abaqus CPE8) or a closed
form computed in the test; none is the solver's own output.
"""

import math

import numpy as np
import pytest

from conftest import check_ok

ELEMENTS = ("q4", "q8", "q9")

# Paper Table 3 (Hz): MP models of the 0.1 m x 1 m column on 1 x 10 cells.
PAPER_TABLE3 = {"q4": [16.92, 51.27, 87.24, 126.03, 168.95],
                "q8": [16.89, 50.62, 84.20, 117.62, 150.94],
                "q9": [16.89, 50.62, 84.20, 117.62, 150.94]}
# Paper: the plain Q4 FE model (2 x 2 Gauss points) and Abaqus CPE8 (3 x 3 Gauss points).
PAPER_FE_Q4 = [16.91, 51.15, 86.65, 124.26, 164.77]
PAPER_ABAQUS_CPE8 = [16.89, 50.68, 84.49, 118.37, 152.42]
# Jacobi sweeps to xi = 1e-15 reported in the paper.
PAPER_SWEEPS = {"q4": 7, "q8": 9, "q9": 9}

# The scene: E = 10 MPa, nu = 0, rho = (1 - 0.3) 2700 + 0.3 1000 = 2190 kg/m3, H = 1 m.
E, NU, RHO, H, W = 10e6, 0.0, (1 - 0.3) * 2700 + 0.3 * 1000, 1.0, 0.1
PPC = {"q4": 2, "q8": 3, "q9": 3}


def rod_hz(E_c, rho, height, n):
    """f_k = (2k - 1) c / (4 H), c = sqrt(E_c / rho): rod fixed at the base, free on top."""
    c = math.sqrt(E_c / rho)
    return np.array([(2 * k - 1) * c / (4 * height) for k in range(1, n + 1)])


def constrained_modulus(E_, nu):
    return E_ * (1 - nu) / ((1 + nu) * (1 - 2 * nu))


def expected_free_dofs(element, nx, ny):
    """Lattice nodes (Q8 without cell centres), two DOFs each, minus lateral ux and base."""
    p = 1 if element == "q4" else 2
    ni, nj = p * nx + 1, p * ny + 1
    nodes = ni * nj - (nx * ny if element == "q8" else 0)
    fixed = 2 * nj            # ux on x = 0 and x = W (every lattice row has both ends)
    fixed += 2 * ni - 2       # ux and uy on y = 0, minus the two corner ux already counted
    return 2 * nodes - fixed


def rounded(values):
    return [round(float(v), 2) for v in values]


def _table_rows(stdout):
    """Rows of the printed frequency table: {header name: [strings]}."""
    lines = stdout.splitlines()
    start = lines.index("Natural frequencies (Hz)")
    head = lines[start + 1]
    names = ["mode"] + [h.strip() for h in
                        [head[5 + 11 * k: 5 + 11 * (k + 1)] for k in range((len(head) - 5) // 11)]]
    rows = []
    for ln in lines[start + 2:]:
        parts = ln.split()
        if not parts or not parts[0].isdigit():
            break
        rows.append(parts)
    return names, rows


@pytest.mark.parametrize("element", ELEMENTS)
def test_table3_both_solvers(paper_run, element):
    s = check_ok(paper_run(element)[0])
    for solver in ("jacobi", "slepc"):
        f = s["eigen"]["frequencies_hz"][solver]
        assert len(f) == 5
        assert rounded(f) == pytest.approx(PAPER_TABLE3[element], abs=1e-9), solver


@pytest.mark.parametrize("element", ELEMENTS)
def test_printed_table_shows_table3(paper_run, element):
    res = paper_run(element)[0]
    check_ok(res)
    names, rows = _table_rows(res.stdout)
    assert names[:3] == ["mode", "Jacobi", "SLEPc"]
    assert "paper" in names
    assert len(rows) == 5
    for k, row in enumerate(rows):
        assert int(row[0]) == k + 1
        want = f"{PAPER_TABLE3[element][k]:.2f}"
        assert row[1] == want and row[2] == want, row
        assert row[names.index("paper")] == want


@pytest.mark.parametrize("element", ELEMENTS)
def test_jacobi_and_slepc_agree(paper_run, element):
    s = check_ok(paper_run(element)[0])
    fj = np.array(s["eigen"]["frequencies_hz"]["jacobi"])
    fs = np.array(s["eigen"]["frequencies_hz"]["slepc"])
    rel = np.abs(fj ** 2 - fs ** 2) / fs ** 2
    assert np.all(rel <= 1e-8), rel
    cross = s["eigen"]["cross_check"]
    assert len(cross["relative_eigenvalue_difference"]) == 5 and len(cross["mac"]) == 5
    assert max(cross["relative_eigenvalue_difference"]) <= 1e-8
    np.testing.assert_allclose(cross["relative_eigenvalue_difference"], rel, rtol=0, atol=1e-12)
    assert min(cross["mac"]) > 0.999999
    assert max(cross["mac"]) < 1 + 1e-9


@pytest.mark.parametrize("element", ELEMENTS)
def test_jacobi_sweeps_within_paper_count(paper_run, element):
    s = check_ok(paper_run(element)[0])
    assert s["eigen"]["jacobi"]["tol"] == 1e-15
    assert 1 <= s["eigen"]["jacobi"]["sweeps"] <= PAPER_SWEEPS[element]
    assert s["eigen"]["jacobi"]["coupling"] <= 1e-15
    assert s["eigen"]["jacobi"]["eigenvalue_change"] <= 1e-15
    assert f"Jacobi: {s['eigen']['jacobi']['sweeps']} sweeps" in paper_run(element)[0].stdout


@pytest.mark.parametrize("element", ELEMENTS)
def test_scene_size(paper_run, element):
    s = check_ok(paper_run(element)[0])
    assert s["analysis"] == "eigen"
    assert s["provenance"]["ranks"] == 1
    assert s["eigen"]["ndof"] == expected_free_dofs(element, 1, 10)
    assert s["eigen"]["ndof"] == {"q4": 20, "q8": 60, "q9": 80}[element]
    assert s["eigen"]["n_points"] == 10 * PPC[element] ** 2
    assert s["eigen"]["density_kg_m3"] == pytest.approx(2190.0, rel=1e-14)


@pytest.mark.parametrize("element", ELEMENTS)
def test_references_in_summary(paper_run, element):
    s = check_ok(paper_run(element)[0])
    refs = s["eigen"]["references"]
    assert refs["paper_table3_hz"] == pytest.approx(PAPER_TABLE3[element], abs=1e-12)
    np.testing.assert_allclose(refs["rod_hz"], rod_hz(E, RHO, H, 5), rtol=1e-12)
    assert len(refs["fe_gauss_hz"]) == 5


def test_fe_gauss_q4_equals_paper(paper_run):
    s = check_ok(paper_run("q4")[0])
    assert rounded(s["eigen"]["references"]["fe_gauss_hz"]) == pytest.approx(PAPER_FE_Q4, abs=1e-9)


@pytest.mark.parametrize("element", ["q8", "q9"])
def test_fe_gauss_quadratic_equals_abaqus_cpe8(paper_run, element):
    """3 x 3 Gauss points integrate the quadratic cells' K and M exactly: Abaqus CPE8."""
    s = check_ok(paper_run(element)[0])
    assert rounded(s["eigen"]["references"]["fe_gauss_hz"]) == pytest.approx(PAPER_ABAQUS_CPE8,
                                                                    abs=1e-9)


@pytest.mark.mpi(2)
def test_fine_q9_column_approaches_rod(cli, paper_run):
    """1 x 40 Q9 cells (nu = 0.3: the rod uses the constrained modulus): both solvers within
    0.5 % of the rod, and closer than the 1 x 10 grid of the paper."""
    nu = 0.3
    res = cli(["-mpm_cells", "1,40", "-mpm_nu", nu, "-mpm_figures", "0"], ranks=2,
              options_file="eigen-q9")
    s = check_ok(res)
    rod = rod_hz(constrained_modulus(E, nu), RHO, H, 5)
    np.testing.assert_allclose(s["eigen"]["references"]["rod_hz"], rod, rtol=1e-12)
    coarse = check_ok(paper_run("q9")[0])
    err10 = np.abs(np.array(coarse["eigen"]["frequencies_hz"]["slepc"]) / rod_hz(E, RHO, H, 5) - 1)
    for solver in ("jacobi", "slepc"):
        f = np.array(s["eigen"]["frequencies_hz"][solver])
        err = np.abs(f / rod - 1)
        assert np.all(err <= 0.005), (solver, err)
        assert np.all(err < err10), (solver, err, err10)
    # The FE model of the fine grid too.
    assert np.all(np.abs(np.array(s["eigen"]["references"]["fe_gauss_hz"]) / rod - 1) <= 0.005)
    assert s["eigen"]["ndof"] == expected_free_dofs("q9", 1, 40)


def test_paper_scene_with_more_modes(cli):
    """Asking for more modes than Table 3 lists (8 > 5) on a paper scene still works: the
    first five keep the Table 3 values."""
    res = cli(["-mpm_nmodes", "8", "-mpm_figures", "0"], options_file="eigen-q9")
    assert res.returncode == 0, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
    s = check_ok(res)
    for solver in ("jacobi", "slepc"):
        f = s["eigen"]["frequencies_hz"][solver]
        assert len(f) == 8
        assert rounded(f[:5]) == pytest.approx(PAPER_TABLE3["q9"], abs=1e-9)
        assert np.all(np.diff(f) > 0)
