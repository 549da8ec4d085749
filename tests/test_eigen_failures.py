"""Where the Jacobi solver cannot work or works poorly: each case ends in one clear line.

Singular or indefinite mass (too few points per cell; for SLEPc too), zero-energy modes
(rigid-body motion the boundary conditions leave free), a loose tolerance
(the achieved accuracy is reported and warned about), too few sweeps (exit 3, with how many
more would do), non-finite matrices. The expected numbers come from independent sources:
numpy's rank and eigenvalues of the dense reference model of test_eigen_reference, a
dense residual, a rerun with the suggested sweep count.
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from conftest import check_ok
from test_eigen_jacobi import gather_vectors, petsc_mat, random_pencil
from test_eigen_reference import dense_model

E, RHO = 10e6, 2190.0
PAPER = ((1, 10), (0.1, 1.0))


def error_line(res):
    """The single 'solver: error:' line of a failed run (and no traceback)."""
    lines = [ln for ln in res.stderr.splitlines() if ln.startswith("solver: error:")]
    assert len(lines) == 1, res.stderr[-3000:]
    assert "Traceback" not in res.stderr
    return lines[0]


def scaled_rank(M):
    """Numerical rank of the unit-diagonal form of M (numpy's SVD)."""
    s = 1 / np.sqrt(np.diag(M))
    return np.linalg.matrix_rank(M * s[:, None] * s[None, :], tol=1e-10 * len(M))


@pytest.mark.parametrize("element, ppc, need", [("q9", 2, 3), ("q8", 2, 3), ("q9", 1, 3),
                                                ("q4", 1, 2)])
def test_too_few_points_singular_mass(cli, ref_shapes, element, ppc, need):
    """Fewer points per cell than nodes: a singular consistent mass, exit 3 with the cause
    (element, points per cell, numerical rank) and the fix (-mpm_ppc)."""
    res = cli(["-mpm_element", element, "-mpm_ppc", ppc, "-mpm_figures", "0"],
              options_file="eigen-q4")
    assert res.returncode == 3, res.stdout + res.stderr[-3000:]
    line = error_line(res)
    points = f"{ppc} x {ppc} point{'s' if ppc > 1 else ''} per cell"
    assert f"{element.upper()} with {points}" in line
    assert "consistent mass is singular" in line and f"-mpm_ppc {need} or more" in line
    rank, n = map(int, re.search(r"numerical rank (\d+) of (\d+)", line).groups())
    _, M, dofs, _ = dense_model(ref_shapes, element, *PAPER, ppc, E, 0.0, RHO)
    # (With one point at a Q9 cell's centre the solver keeps the DOFs whose mass is a
    # rounding residue, about 1e-32 kg, which the reference drops as massless.)
    assert n == len(dofs) or (element, ppc) == ("q9", 1)
    assert rank == scaled_rank(M) < n


@pytest.mark.mpi(2)
def test_singular_mass_under_mpi(cli):
    """The same diagnosis on two ranks: one line, exit 3, no hang."""
    res = cli(["-mpm_element", "q9", "-mpm_ppc", "2", "-mpm_figures", "0"], ranks=2,
              options_file="eigen-q4", timeout=60)
    assert res.returncode == 3, res.stdout + res.stderr[-3000:]
    assert "Q9 with 2 x 2 points per cell" in error_line(res)


@pytest.mark.parametrize("element, ppc", [("q9", 2), ("q4", 1)])
def test_singular_mass_slepc_only_is_an_error(cli, ref_shapes, element, ppc):
    """SLEPc needs a positive definite M as much as Jacobi: the same diagnosis, exit 3.
    (With one point per Q4 cell SLEPc alone would print four modes at 0 Hz although the
    reference stiffness is regular: no eigenpairs at all.)"""
    res = cli(["-mpm_element", element, "-mpm_ppc", ppc, "-mpm_eigen_solver", "slepc",
               "-mpm_figures", "0"], options_file="eigen-q4")
    assert res.returncode == 3, res.stdout + res.stderr[-3000:]
    line = error_line(res)
    assert "consistent mass is singular" in line and "-mpm_ppc" in line
    assert not line.startswith("solver: error: Jacobi")
    K, M, dofs, _ = dense_model(ref_shapes, element, *PAPER, ppc, E, 0.0, RHO)
    assert np.linalg.matrix_rank(K) == len(dofs)         # the stiffness itself is regular
    assert scaled_rank(M) < len(dofs)


def test_rigid_body_mode_warns(cli):
    """No base support and only one roller side: the column can move up and down as a
    whole (one rigid-body mode at 0 Hz): a warning, the other modes still right."""
    res = cli(["-mpm_bc_bottom", "none", "-mpm_bc_left", "none", "-mpm_nmodes", "3",
               "-mpm_figures", "0"], options_file="eigen-q4")
    s = check_ok(res)
    assert any("1 of the lowest 3 modes at about 0 Hz" in w for w in s["eigen"]["warnings"])
    for solver in ("jacobi", "slepc"):
        f = s["eigen"]["frequencies_hz"][solver]
        assert f[0] < 1e-3 and f[1] > 1.0
    assert max(s["eigen"]["cross_check"]["relative_eigenvalue_difference"][1:]) < 1e-8
    assert not any("residual" in w for w in s["eigen"]["warnings"])


def test_loose_tolerance_reports_accuracy(cli):
    """-mpm_jacobi_tol 0.1: converged by the loose test, with residuals far above the
    default's; the run warns and the frequencies differ from SLEPc's by about what the
    residuals say (Rayleigh quotients: eigenvalue error of the order of the residual
    squared, never more than the residual)."""
    loose = check_ok(cli(["-mpm_jacobi_tol", "0.1", "-mpm_figures", "0"],
                         options_file="eigen-q9"))
    r = np.array(loose["eigen"]["jacobi"]["residual"])
    assert r.max() > 1e-6
    assert any("relative residuals up to" in w for w in loose["eigen"]["warnings"])
    diff = np.array(loose["eigen"]["cross_check"]["relative_eigenvalue_difference"])
    assert diff.max() > 1e-8                       # the loose run is visibly off ...
    assert np.all(diff <= 2 * r)                   # ... by no more than its residuals say
    tight = check_ok(cli(["-mpm_figures", "0"], options_file="eigen-q9"))
    assert max(tight["eigen"]["jacobi"]["residual"]) < 1e-10
    assert not tight["eigen"]["warnings"]


def test_residual_is_the_dense_residual():
    """JacobiResult.residual equals ||K phi - lambda M phi|| / (||K phi|| + |lambda| ||M phi||)
    computed densely from the returned modes, for a loosely converged random pencil."""
    from solver.modal import jacobi

    Kd, Md = random_pencil(30, 41)
    res = jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 4, tol=0.3)
    Phi = gather_vectors(res.vectors).T
    lam = res.eigenvalues[:4]
    R = Kd @ Phi - (Md @ Phi) * lam
    want = np.linalg.norm(R, axis=0) / (np.linalg.norm(Kd @ Phi, axis=0)
                                        + np.abs(lam) * np.linalg.norm(Md @ Phi, axis=0))
    np.testing.assert_allclose(res.residual, want, rtol=1e-8)
    assert want.max() > 1e-8


@pytest.mark.parametrize("scene", ["eigen-q4", "eigen-q9"])
def test_too_few_sweeps_say_how_many_more(cli, scene):
    """Stopped after 5 sweeps (the paper needs 7 to 9): exit 3 with the estimate of the
    sweeps still needed, and that many more sweeps do converge."""
    res = cli(["-mpm_jacobi_max_sweeps", "5", "-mpm_figures", "0"], options_file=scene)
    assert res.returncode == 3, res.stdout + res.stderr[-3000:]
    line = error_line(res)
    assert "did not converge in 5 sweeps" in line and "-mpm_jacobi_max_sweeps" in line
    more = int(re.search(r"about (\d+) more sweep", line).group(1))
    s = check_ok(cli(["-mpm_jacobi_max_sweeps", 5 + more, "-mpm_figures", "0"],
                     options_file=scene))
    assert s["eigen"]["jacobi"]["sweeps"] == 5 + more or s["eigen"]["jacobi"]["sweeps"] <= 5 + more


def test_two_sweeps_far_from_converged(cli):
    res = cli(["-mpm_jacobi_max_sweeps", "2", "-mpm_figures", "0"], options_file="eigen-q4")
    assert res.returncode == 3
    line = error_line(res)
    assert "did not converge in 2 sweeps" in line and "7 to 12 sweeps" in line


@pytest.mark.parametrize("kind", ["singular", "indefinite", "diagonal"])
def test_check_mass_kinds_and_rank(kind):
    """jacobi.check_mass against numpy: the kind of failure and the numerical rank."""
    from solver.modal import jacobi

    rng = np.random.default_rng(5)
    n = 12
    if kind == "singular":
        B = rng.standard_normal((n, 7))
        M = B @ B.T                              # rank 7, positive diagonal
    elif kind == "indefinite":
        M = np.eye(n)
        M[2:4, 2:4] = [[1.0, 3.0], [3.0, 1.0]]   # eigenvalues 4 and -2
    else:
        M = np.eye(n)
        M[5, 5] = 0.0
    with pytest.raises(jacobi.MassError) as info:
        jacobi.check_mass(petsc_mat(M))
    err = info.value
    assert err.kind == kind and err.n == n
    if kind == "singular":
        assert err.rank == np.linalg.matrix_rank(M) == 7 and err.negative == 0
        assert "numerical rank 7 of 12" in str(err)
    if kind == "indefinite":
        assert err.negative == int(np.sum(np.linalg.eigvalsh(M) < 0)) == 1
    jacobi.check_mass(petsc_mat(random_pencil(n, 6)[1]))     # positive definite: silent


def test_non_finite_matrices():
    from solver.common.errors import NumericalError
    from solver.modal import jacobi

    Kd, Md = random_pencil(8, 9)
    Kbad = Kd.copy()
    Kbad[3, 3] = np.nan
    with pytest.raises(NumericalError, match="stiffness matrix has non-finite"):
        jacobi.solve(petsc_mat(Kbad), petsc_mat(Md), 2)
    Mbad = Md.copy()
    Mbad[1, 2] = Mbad[2, 1] = np.inf
    with pytest.raises(NumericalError, match="mass matrix has 2 non-finite"):
        jacobi.solve(petsc_mat(Kd), petsc_mat(Mbad), 2)


def _table(stdout):
    lines = stdout.splitlines()
    start = lines.index("Natural frequencies (Hz)")
    rows = []
    for ln in lines[start + 2:]:
        if not ln.split() or not ln.split()[0].isdigit():
            break
        rows.append(ln.split())
    return lines[start + 1].split(), rows


def test_free_body_names_its_rigid_modes(cli):
    """No support at all: a plane body has exactly three rigid-body
    motions (two translations, one rotation), reported as such, without NumPy's warnings;
    the fixed-base rod is no reference for it, and the flexible modes still agree."""
    res = cli(["-mpm_bc_bottom", "none", "-mpm_bc_left", "none", "-mpm_bc_right", "none"],
              options_file="eigen-q9")
    s = check_ok(res)
    assert "Warning" not in res.stderr and "RuntimeWarning" not in res.stdout, res.stderr
    assert s["eigen"]["rigid_modes"] == {"jacobi": [1, 2, 3], "slepc": [1, 2, 3]}
    assert s["eigen"]["references"]["rod_hz"] is None
    head, rows = _table(res.stdout)
    assert "rod" not in head and len(rows) == 5
    assert all(r[1:4] == ["rigid"] * 3 for r in rows[:3])
    cross = s["eigen"]["cross_check"]
    assert cross["mac"][:3] == [None] * 3 and None not in cross["mac"][3:]
    fj, fs = (np.array(s["eigen"]["frequencies_hz"][k][3:]) for k in ("jacobi", "slepc"))
    np.testing.assert_allclose(fj, fs, rtol=1e-8)
    assert f"Results in {s['files']['summary'].rsplit('/', 1)[0]}: summary.json" in res.stdout


def test_tall_column_prints_four_digits(cli):
    """The paper's column scaled 500 times (50 m x 500 m): every frequency 500 times
    smaller, printed with four significant digits (0.03378 Hz, not 0.03), the rod's too."""
    from solver.references.analytic import rod_frequencies

    res = cli(["-mpm_size", "50,500", "-mpm_figures", "0"], options_file="eigen-q9")
    s = check_ok(res)
    rod = rod_frequencies(E, RHO, 500.0, 5)
    np.testing.assert_allclose(s["eigen"]["references"]["rod_hz"], rod, rtol=1e-12)
    head, rows = _table(res.stdout)
    assert head[1:5] == ["Jacobi", "SLEPc", "1D", "rod"]
    col = {"Jacobi": 1, "SLEPc": 2, "rod": 3}
    for k, row in enumerate(rows):
        for name, value in (("Jacobi", s["eigen"]["frequencies_hz"]["jacobi"][k]),
                            ("SLEPc", s["eigen"]["frequencies_hz"]["slepc"][k]), ("rod", rod[k])):
            txt = row[col[name]]
            digits = len(txt.replace(".", "").lstrip("0"))
            assert digits >= 4 and float(txt) == pytest.approx(value, rel=5e-4), (name, txt)


def test_mode_figure_has_a_colour_bar_and_the_rod_only_where_it_applies(cli, monkeypatch):
    """modes.png colours the grid by |u| over the mode's largest, with a
    colour bar from 0 to 1; the rod's dashed shape is drawn on a fixed-base column only."""
    from solver.eigen import plots as eigen

    figs = []
    real = eigen.mode_figure

    def keep(*args, **kwargs):
        figs.append(real(*args, **kwargs))
        return figs[-1]
    monkeypatch.setattr(eigen, "mode_figure", keep)
    check_ok(cli(["-mpm_nmodes", "3"], options_file="eigen-q9"))
    check_ok(cli(["-mpm_nmodes", "4", "-mpm_bc_bottom", "none", "-mpm_bc_left", "none",
                  "-mpm_bc_right", "none"], options_file="eigen-q9"))
    fixed, free = figs
    for fig, rods in ((fixed, 3), (free, 0)):
        bars = [ax for ax in fig.axes if ax.get_label() == "<colorbar>"]
        assert len(bars) == 1 and bars[0].get_ylabel() == "|u| / largest |u| of the mode"
        assert bars[0].get_ylim() == (0.0, 1.0)
        labels = [ln.get_label() for ax in fig.axes for ln in ax.get_lines()]
        assert sum(lab.startswith("rod") for lab in labels) == rods
    titles = [ax.get_title() for ax in free.axes]
    assert titles.count("mode 1\nrigid") == 1 and any("Hz" in t for t in titles)
