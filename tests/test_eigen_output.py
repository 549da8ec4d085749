"""What an eigen run writes: summary.json, modes.vtu, modes.png."""

import json
import math

import meshio
import numpy as np
import pytest

from conftest import check_ok

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
TABLE3_Q4 = [16.92, 51.27, 87.24, 126.03, 168.95]
LATTICE = {"q4": (2, 11), "q8": (3, 21), "q9": (3, 21)}   # paper scene, nodes per direction
VTK_CELL = {"q4": "quad", "q8": "quad8", "q9": "quad9"}


@pytest.mark.parametrize("element", ["q4", "q8", "q9"])
def test_summary_keys(paper_run, element):
    res, out = paper_run(element)
    s = check_ok(res)
    for key in ("analysis", "provenance", "completed", "steps", "wall", "files", "eigen"):
        assert key in s, key
    for key in ("ndof", "n_points", "frequencies_hz", "jacobi", "slepc", "cross_check",
                "references"):
        assert key in s["eigen"], key
    assert set(s["eigen"]["frequencies_hz"]) == {"jacobi", "slepc"}
    for key in ("sweeps", "seconds"):
        assert key in s["eigen"]["jacobi"]
    assert s["eigen"]["jacobi"]["seconds"] >= 0 and s["eigen"]["slepc"]["seconds"] >= 0
    assert set(s["eigen"]["cross_check"]) >= {"relative_eigenvalue_difference", "mac"}
    assert set(s["eigen"]["references"]) >= {"rod_hz", "fe_gauss_hz", "paper_table3_hz"}
    files = s["files"]
    assert {"summary", "modes_vtu", "modes_png"} <= set(files)
    assert files["summary"] == str(out / "summary.json")
    for name in ("modes_vtu", "modes_png"):
        assert files[name].startswith(str(out))
    # Strict JSON: no NaN / Infinity tokens.
    text = (out / "summary.json").read_text()
    json.loads(text, parse_constant=lambda c: pytest.fail(f"non-finite {c} in summary"))
    # Nothing half-written left behind.
    assert not [p for p in out.iterdir() if p.name.startswith(".partial-")]


@pytest.mark.parametrize("element", ["q4", "q8", "q9"])
def test_vtu_modes(paper_run, element):
    res, out = paper_run(element)
    s = check_ok(res)
    mesh = meshio.read(out / "modes.vtu")
    ni, nj = LATTICE[element]
    assert mesh.points.shape == (ni * nj, 3)
    assert [c.type for c in mesh.cells] == [VTK_CELL[element]]
    assert len(mesh.cells[0].data) == 10
    names = sorted(mesh.point_data)
    assert names == [f"mode_{k}" for k in range(1, 6)]
    x, y = mesh.points[:, 0], mesh.points[:, 1]
    assert np.allclose(mesh.points[:, 2], 0)
    assert x.min() == pytest.approx(0) and x.max() == pytest.approx(0.1)
    assert y.min() == pytest.approx(0) and y.max() == pytest.approx(1.0)
    for k in range(1, 6):
        u = mesh.point_data[f"mode_{k}"]
        assert u.shape == (ni * nj, 3)
        assert np.all(np.isfinite(u)) and np.abs(u).max() > 0
        assert np.all(u[:, 2] == 0)
        assert np.all(u[np.isclose(x, 0) | np.isclose(x, 0.1), 0] == 0)   # rollers
        assert np.all(u[np.isclose(y, 0)] == 0)                             # fixed base
        if element == "q8":                     # Q8 cell centres are no model nodes
            centre = np.isclose(x, 0.05) & np.isclose((y / 0.05) % 2, 1)
            assert centre.sum() == 10 and np.all(u[centre] == 0)
        # The common sign: the largest component points up / right (positive).
        assert u.ravel()[np.argmax(np.abs(u).ravel())] > 0
        # Shape of the k-th rod mode along the column (nu = 0: a 1D problem).
        col = np.isclose(x, 0.05) if element == "q9" else np.isclose(x, 0.0)
        rod = np.sin((2 * k - 1) * math.pi * y[col] / 2)
        uy = u[col, 1]
        assert (uy @ rod) ** 2 / ((uy @ uy) * (rod @ rod)) > 0.99
    assert s["files"]["modes_vtu"] == str(out / "modes.vtu")


@pytest.mark.mpi(2)
@pytest.mark.parametrize("element", ["q4", "q9"])
def test_vtu_same_on_two_ranks(paper_run, element):
    """The modes gathered from 2 ranks equal the 1-rank modes (same normalisation, sign)."""
    _, out1 = paper_run(element, 1)
    res2, out2 = paper_run(element, 2)
    check_ok(res2)
    m1 = meshio.read(out1 / "modes.vtu")
    m2 = meshio.read(out2 / "modes.vtu")
    np.testing.assert_array_equal(m1.points, m2.points)
    np.testing.assert_array_equal(m1.cells[0].data, m2.cells[0].data)
    for name, u1 in m1.point_data.items():
        u2 = m2.point_data[name]
        np.testing.assert_allclose(u2, u1, rtol=0, atol=1e-7 * np.abs(u1).max(), err_msg=name)


def test_png(paper_run):
    res, out = paper_run("q9")
    check_ok(res)
    png = out / "modes.png"
    data = png.read_bytes()
    assert data[:8] == PNG_MAGIC
    assert len(data) > 10_000
    import matplotlib.image

    img = matplotlib.image.imread(str(png))
    assert img.ndim == 3 and img.shape[0] > 200 and img.shape[1] > 200


def test_summary_option_and_no_figures(cli, tmp_path):
    out = tmp_path / "out"
    summary = tmp_path / "elsewhere" / "run.json"
    res = cli(["-mpm_summary", summary, "-mpm_figures", "0"], options_file="eigen-q4",
              out_dir=out)
    s = check_ok(res)
    assert summary.is_file()
    assert not (out / "summary.json").exists()
    assert not (out / "modes.png").exists()
    assert (out / "modes.vtu").is_file()
    assert s["files"]["summary"] == str(summary)
    assert "modes_png" not in s["files"]
    assert [round(f, 2) for f in s["eigen"]["frequencies_hz"]["jacobi"]] == pytest.approx(TABLE3_Q4)


@pytest.mark.parametrize("solver", ["jacobi", "slepc"])
def test_single_solver(cli, solver):
    s = check_ok(cli(["-mpm_eigen_solver", solver, "-mpm_figures", "0"],
                     options_file="eigen-q4"))
    assert set(s["eigen"]["frequencies_hz"]) == {solver}
    assert "cross_check" not in s["eigen"]
    other = {"jacobi": "slepc", "slepc": "jacobi"}[solver]
    assert other not in s
    assert [round(f, 2) for f in s["eigen"]["frequencies_hz"][solver]] == pytest.approx(TABLE3_Q4)


def test_deep_output_folder_is_created(cli, tmp_path):
    """-mpm_output names a folder that does not exist yet, several levels deep."""
    out = tmp_path / "abs" / "deep" / "folder"
    s = check_ok(cli(["-mpm_figures", "0"], options_file="eigen-q8", out_dir=out))
    assert (out / "summary.json").is_file() and (out / "modes.vtu").is_file()
    assert s["files"]["modes_vtu"] == str(out / "modes.vtu")
