"""What users look at: settlement and the degree of consolidation, the XDMF + HDF5 point
series, the modes file's frequencies, provenance, -mpm_output_every 0, -mpm_figure_format.

References are independent of the solver: Terzaghi's pressure series written again here and
integrated over the depth by Gauss-Legendre quadrature, the settlements q H / E_c and
q H / (E_c + K_l / n) from the scene's parameters, git run here.
"""

from __future__ import annotations

import csv
import json
import math
import shutil
import subprocess

import meshio
import numpy as np
import pytest
from conftest import ONE_AND_TWO_RANKS, REPO, check_ok, run_cli

# The scene of cases/consolidation-m1-q4.opts (paper Table 2), SI units.
H, Q, E_C, K_L, N_POR, K, GAMMA_W = 1.0, 10e3, 10e6, 120e6, 0.3, 2.5e-4, 1000 * 9.81
CV = K * E_C / GAMMA_W
C2 = K / (GAMMA_W * (1 / E_C + N_POR / K_L))
S_INF = Q * H / E_C                       # drained: the constrained modulus
S_0 = Q * H / (E_C + K_L / N_POR)         # undrained: the water's stiffness K_l / n too
REPORTS = (0.1, 0.5)


def terzaghi_mean(Tv, nodes=400):
    """1 - U: the depth average of Terzaghi's p / p0, its series summed here and integrated
    over z / H in [0, 1] by Gauss-Legendre quadrature."""
    z, w = np.polynomial.legendre.leggauss(nodes)
    z, w = (z + 1) / 2, w / 2
    M = np.pi * (2 * np.arange(400) + 1) / 2
    p = (2 / M * np.exp(-M * M * Tv)) @ np.sin(np.outer(M, z))
    return float(w @ p)


# -- the analytic degree of consolidation -------------------------------------------------
@pytest.mark.parametrize("Tv", [0.01, 0.03, 0.1, 0.2, 0.5, 1.0, 2.0])
def test_degree_of_consolidation_is_the_mean_of_the_pressure(Tv):
    from solver.references import analytic

    assert analytic.degree_of_consolidation(Tv) == pytest.approx(1 - terzaghi_mean(Tv),
                                                                 abs=1e-12)


@pytest.mark.parametrize("Tv", [1e-9, 1e-6, 1e-4, 1e-3, 0.005])
def test_degree_of_consolidation_early(Tv):
    """Before the base is felt (images below 1e-25 at these times) U = 2 sqrt(T_v / pi)."""
    from solver.references import analytic

    assert analytic.degree_of_consolidation(Tv) == pytest.approx(
        2 * math.sqrt(Tv / math.pi), rel=1e-12, abs=1e-15)


def test_degree_of_consolidation_arrays_and_switch():
    from solver.references import analytic

    T = np.array([[-1.0, 0.0], [0.00699999999, 0.007]])
    U = analytic.degree_of_consolidation(T)
    assert U.shape == (2, 2) and U[0, 0] == 0 and U[0, 1] == 0
    # Both forms meet at the switch from images to series.
    assert U[1, 1] - U[1, 0] == pytest.approx(
        (1 / math.sqrt(math.pi * 0.007)) * 1e-11, rel=1e-2, abs=1e-13)
    assert analytic.degree_of_consolidation(0.3, terms=5000) == pytest.approx(
        analytic.degree_of_consolidation(0.3), abs=1e-13)
    assert np.ndim(analytic.degree_of_consolidation(0.3)) == 0


# -- one consolidation run per rank count --------------------------------------------------
@pytest.fixture(scope="module")
def m1_run(tmp_path_factory):
    """``m1_run(ranks)``: consolidation-m1-q4 to T_v = 0.5, reports at 0.1 and 0.5, figures
    as PNG and PDF, run once per rank count: (summary, out folder, CliResult)."""
    cache = {}

    def get(ranks):
        if ranks not in cache:
            out = tmp_path_factory.mktemp(f"m1-n{ranks}") / "out"
            res = run_cli(["-mpm_Tv_end", "0.5", "-mpm_Tv_report",
                           ",".join(map(str, REPORTS)), "-mpm_progress", "0",
                           "-mpm_figure_format", "png,pdf", "-options_left", "0"],
                          out, ranks=ranks, options_file="consolidation-m1-q4")
            cache[ranks] = (check_ok(res), out, res)
        return cache[ranks]

    return get


@pytest.fixture(params=[1, pytest.param(2, marks=pytest.mark.mpi(2))], ids=["1rank", "2ranks"])
def m1(request, m1_run):
    return m1_run(request.param)


def test_settlement_and_degree_against_terzaghi(m1):
    """Measured (1 and 2 ranks alike) against compressible-water Terzaghi: U_s -0.81 % at
    T_v = 0.1, -0.18 % at 0.5; against classic Terzaghi -2.03 % and -1.12 %; U from the
    settlement equals U from the pore pressure to 1e-4 (equilibrium)."""
    s, _, res = m1
    d = s["consolidation"]["consolidation_degree"]
    assert d["Tv"] == list(REPORTS)
    assert d["s_inf_m"] == pytest.approx(S_INF, rel=1e-12)
    assert d["s0_m"] == pytest.approx(S_0, rel=1e-12)
    for k, Tv in enumerate(REPORTS):
        classic = 1 - terzaghi_mean(Tv)
        water = 1 - terzaghi_mean(Tv * C2 / CV)
        assert d["terzaghi"][k] == pytest.approx(classic, abs=1e-12)
        assert d["consistent"][k] == pytest.approx(water, abs=1e-12)
        Us, Up = d["U_settlement"][k], d["U_pressure"][k]
        assert Us == pytest.approx((d["settlement_m"][k] - S_0) / (S_INF - S_0), rel=1e-12)
        assert abs(Us - Up) < 1e-4
        # The settlement itself: s0 + (s_inf - s0) U with compressible water.
        assert abs(d["settlement_m"][k] - (S_0 + (S_INF - S_0) * water)) < 3e-3 * S_INF
    err = dict(zip(REPORTS, d["error_settlement_consistent_pct"]))
    assert abs(err[0.1]) < 1.5 and abs(err[0.5]) < 0.5, err
    err = dict(zip(REPORTS, d["error_settlement_pct"]))
    assert abs(err[0.1]) < 3.0 and abs(err[0.5]) < 1.5, err
    assert "Degree of consolidation" in res.stdout


def test_files_names_every_file_written(m1):
    """The summary's files name every file in the output folder, the
    field series' HDF5 files included, and nothing that is not there."""
    s, out, res = m1
    line = next(ln for ln in res.stdout.splitlines() if ln.startswith("Results in "))
    assert line.startswith(f"Results in {out}: ") and "points.xdmf" in line
    assert f"{len(s['files']['fields_h5'])} files points_" in line
    named = []
    for value in s["files"].values():
        named += value if isinstance(value, list) else [value]
    assert sorted(named) == sorted(str(p) for p in out.iterdir())
    assert len(s["files"]["fields_h5"]) == len(list(out.glob("points_*.h5"))) > 0


def test_settlement_csv(m1):
    s, out, _ = m1
    assert s["files"]["settlement_csv"] == str(out / "settlement.csv")
    with open(out / "settlement.csv") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["t_s", "Tv", "settlement_m_downwards_positive", "U_settlement",
                       "U_pressure", "U_terzaghi", "U_consistent"]
    table = np.array(rows[1:], dtype=float)
    assert np.all(np.diff(table[:, 0]) > 0)
    assert np.allclose(table[:, 1], CV * table[:, 0] / H ** 2, rtol=1e-12)
    # One row every 10 steps (and at the report times).
    assert len(table) >= s["steps"] // 10
    d = s["consolidation"]["consolidation_degree"]
    last = table[-1]
    assert last[1] == pytest.approx(0.5, rel=1e-3)
    assert last[2] == pytest.approx(d["settlement_m"][-1], rel=1e-12)
    assert last[3] == pytest.approx(d["U_settlement"][-1], rel=1e-12)
    for row in table[:: max(1, len(table) // 7)]:
        assert row[5] == pytest.approx(1 - terzaghi_mean(row[1]), abs=1e-10)
        assert row[6] == pytest.approx(1 - terzaghi_mean(row[1] * C2 / CV), abs=1e-10)


def _series(path):
    """(points, cells, steps (t, point data, cell data), each step's geometry (N, 3)) of the
    XDMF file ``path``: meshio's reader, and the steps' own geometry read here."""
    import xml.etree.ElementTree as ET

    import h5py

    with meshio.xdmf.TimeSeriesReader(path) as series:
        points, cells = series.read_points_cells()
        steps = [series.read_data(k) for k in range(series.num_steps)]
    geometry = []
    for item in ET.parse(path).getroot().iter("Geometry"):
        name, where = item.find("DataItem").text.strip().split(":")
        with h5py.File(path.parent / name, "r") as h5:
            geometry.append(h5[where][()])
    return points, cells, steps, geometry


def test_xdmf_series_at_the_report_times(m1):
    """-mpm_output_every 0 (the scene's default): one step per report time, no more."""
    s, out, _ = m1
    assert s["files"]["fields_xdmf"] == str(out / "points.xdmf")
    assert not list(out.glob("*.pvd")) and not list(out.glob("*.vtu"))
    points, cells, steps, geometry = _series(out / "points.xdmf")
    n = s["consolidation"]["n_points"]
    assert points.shape == (n, 3) and [c.type for c in cells] == ["vertex"]
    assert len(cells[0].data) == n
    want = [
        round(Tv * H**2 / (CV * s["consolidation"]["dt"])) * s["consolidation"]["dt"]
        for Tv in REPORTS
    ]
    assert [t for t, _, _ in steps] == pytest.approx(want, rel=1e-12)
    assert len(list(out.glob("points_*.h5"))) == len(REPORTS)
    ppc, h = 2, 0.1
    for (t, data, _), xyz in zip(steps, geometry):
        assert set(data) == {"pore_pressure", "effective_stress_xx", "effective_stress_yy",
                             "effective_stress_xy", "displacement", "velocity_solid",
                             "velocity_liquid"}
        for name in ("displacement", "velocity_solid", "velocity_liquid"):
            assert data[name].shape == (n, 3) and np.all(data[name][:, 2] == 0)
        # Reference positions: the sub-cell centres of 2 x 2 points in 0.1 m cells,
        # in the same order at every step.
        x0 = xyz - data["displacement"]
        assert np.allclose(np.sort(x0[:, 1]), np.repeat(h / ppc * (np.arange(20) + 0.5), 2),
                           atol=1e-12)
        np.testing.assert_allclose(x0, geometry[0] - steps[0][1]["displacement"], atol=1e-12)
        # Rollers, 1D compression: no horizontal displacement; the surface settlement of
        # the summary from the top cell's two rows, extrapolated linearly to y = H.
        assert np.abs(data["displacement"][:, 0]).max() < 1e-12
        uy = {y: -data["displacement"][np.isclose(x0[:, 1], y, atol=1e-9), 1].mean()
              for y in (0.925, 0.975)}
        settled = uy[0.975] + (uy[0.975] - uy[0.925]) / 2
        k = [round(w, 9) for w in want].index(round(t, 9))
        assert settled == pytest.approx(
            s["consolidation"]["consolidation_degree"]["settlement_m"][k], rel=1e-9
        )
        assert np.all(np.isfinite(data["pore_pressure"]))


@pytest.mark.mpi(2)
def test_xdmf_same_on_two_ranks(m1_run):
    """The 2-rank series equals the 1-rank one, point by point (matched by position)."""
    _, _, steps1, geo1 = _series(m1_run(1)[1] / "points.xdmf")
    _, _, steps2, geo2 = _series(m1_run(2)[1] / "points.xdmf")
    assert len(steps1) == len(steps2)
    for (t1, d1, _), (t2, d2, _), g1, g2 in zip(steps1, steps2, geo1, geo2):
        assert t1 == t2
        o1 = np.lexsort((g1 - d1["displacement"]).T[:2])
        o2 = np.lexsort((g2 - d2["displacement"]).T[:2])
        for name in d1:
            a, b = d1[name][o1], d2[name][o2]
            # Round-off of sums in another order, against the field's scale (stresses: q;
            # the shear stress itself is round-off).
            scale = Q if name.startswith(("effective", "pore")) else np.abs(a).max()
            np.testing.assert_allclose(b, a, rtol=0, atol=1e-9 * scale, err_msg=name)


def test_figures_in_every_format(m1):
    s, out, _ = m1
    files = s["files"]
    for name in ("settlement", "isochrones", "pressure_field", "monitor"):
        assert files[f"{name}_png"] == str(out / f"{name}.png")
        assert files[f"{name}_pdf"] == str(out / f"{name}.pdf")
        assert (out / f"{name}.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert (out / f"{name}.pdf").read_bytes()[:5] == b"%PDF-"
    assert not [f for f in out.iterdir() if f.name.startswith(".partial")]


def _git_head():
    if shutil.which("git") is None:
        return None
    res = subprocess.run(["git", "-C", str(REPO), "rev-parse", "HEAD"], capture_output=True,
                         text=True)
    return res.stdout.strip() if res.returncode == 0 else None


def check_provenance(s, given: dict):
    """The provenance of summary ``s``: versions, ranks, git, and the options ``given``
    ({name without -mpm_: value as given}) recorded as given and in effect."""
    prov = s["provenance"]
    from solver import __version__

    assert prov["version"] == __version__
    assert prov["ranks"] >= 1
    for lib in ("petsc", "slepc", "petsc4py", "slepc4py", "mpi4py", "numpy", "scipy",
                "numba", "meshio", "h5py", "mpi"):
        assert isinstance(prov["libraries"][lib], str) and prov["libraries"][lib], lib
    # The arithmetic: this machine's CPU and the SIMD features NumPy uses on it (SSE2 is in
    # every x86-64 baseline).
    import platform

    cpu = prov["cpu"]
    assert cpu["machine"] == platform.machine() and cpu["model"]
    if platform.machine() in ("x86_64", "AMD64"):
        assert "SSE2" in cpu["numpy_simd"]
    assert prov["libraries"]["petsc"].split(".")[:2] == \
        prov["libraries"]["petsc4py"].split(".")[:2]
    head = _git_head()
    if head:
        assert prov["git"]["commit"] == head and isinstance(prov["git"]["dirty"], bool)
    opts = prov["options"]
    for name, value in given.items():
        assert name in opts["mpm_given"]
        recorded = opts["mpm"][name]
        if isinstance(recorded, list):
            assert ",".join(str(v) for v in recorded) == value
        elif isinstance(recorded, float):
            assert recorded == float(value)
        else:
            assert str(recorded) == value
    # Options only the other analysis uses are not in effect, hence not recorded.
    if s["analysis"] == "eigen":
        assert "K_l" not in opts["mpm"] and "Tv_end" not in opts["mpm"]
    return prov


def test_provenance_consolidation(m1):
    s, out, _ = m1
    prov = check_provenance(s, {"Tv_end": "0.5", "Tv_report": "0.1,0.5", "element": "q4",
                                "cells": "1,10", "figure_format": "png,pdf",
                                "drag": "explicit", "output": str(out)})
    assert prov["options"]["petsc"]["options_left"] == "0"
    # Every option the run used is there, defaults included.
    assert prov["options"]["mpm"]["output_every"] == 0
    assert prov["options"]["mpm"]["kinematics"] == "auto"


# -- eigen: the modes file's frequencies, provenance, formats -------------------------------
@ONE_AND_TWO_RANKS
def test_modes_file_carries_frequencies(paper_run, ranks):
    res, out = paper_run("q4", ranks)
    s = check_ok(res)
    mesh = meshio.read(out / "modes.vtu")
    freq = mesh.field_data["frequency_hz"]
    np.testing.assert_allclose(freq, s["eigen"]["frequencies_hz"]["jacobi"], rtol=1e-15)
    assert [round(f, 2) for f in freq] == [16.92, 51.27, 87.24, 126.03, 168.95]
    assert sorted(mesh.point_data) == [f"mode_{k}" for k in range(1, 6)]
    check_provenance(s, {"element": "q4", "cells": "1,10"})


def test_eigen_figure_format_svg_only(cli, tmp_path):
    out = tmp_path / "svg"
    s = check_ok(cli(["-mpm_figure_format", "svg"], options_file="eigen-q4", out_dir=out))
    assert (out / "modes.svg").is_file() and not (out / "modes.png").exists()
    assert s["files"]["modes_svg"] == str(out / "modes.svg") and "modes_png" not in s["files"]
    assert (out / "modes.svg").read_text().lstrip().startswith("<?xml")


@pytest.mark.parametrize("value", ["jpg", "png,gif", ",,"])
def test_bad_figure_format_is_an_input_error(cli, tmp_path, value):
    out = tmp_path / "never"
    res = cli(["-mpm_figure_format", value], options_file="eigen-q4", out_dir=out)
    assert res.returncode == 2
    line = res.stderr.strip()
    assert "\n" not in line and line.startswith("solver: error: -mpm_figure_format")
    assert not out.exists()


# -- the XDMF writer on its own --------------------------------------------------------------
def test_xdmf_index_is_whole_after_every_step(tmp_path):
    """A job killed between two steps keeps every step written: after each write the index
    on disk lists them all and reads back; nothing half-written stays behind."""
    from solver.io import output

    series = output.XdmfSeries(str(tmp_path / "pts.xdmf"))
    xy = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 1.0]])
    for k in range(3):
        series.write(10 * k, 0.25 * k, xy + k, {"p": np.arange(3.0) * k,
                                                "u": np.full((3, 3), float(k))})
        points, cells, steps, geometry = _series(tmp_path / "pts.xdmf")
        assert [t for t, _, _ in steps] == [0.25 * j for j in range(k + 1)]
        for j, (t, data, _) in enumerate(steps):
            np.testing.assert_array_equal(data["p"], np.arange(3.0) * j)
            np.testing.assert_array_equal(data["u"], np.full((3, 3), float(j)))
            np.testing.assert_array_equal(geometry[j][:, :2], xy + j)
        assert [c.type for c in cells] == ["vertex"] and len(cells[0].data) == 3
    assert sorted(f.name for f in tmp_path.iterdir()) == [
        "pts.xdmf", "pts_0000000.h5", "pts_0000010.h5", "pts_0000020.h5"]
    # A step written again (a restart redoing it) replaces its entry.
    series.write(20, 0.5, xy, {"p": np.ones(3), "u": np.zeros((3, 3))})
    assert len(_series(tmp_path / "pts.xdmf")[2]) == 3
    # The entries survive a checkpoint as JSON.
    again = output.XdmfSeries(str(tmp_path / "pts.xdmf"), json.loads(json.dumps(series.entries)))
    assert again.index() == series.index()


def test_xdmf_series_appends_in_constant_work_per_output(tmp_path):
    """10^4 outputs of a small body: after the first, each output adds its grid to the
    index in place (the file is never replaced: same inode) and the index grows by the
    same number of bytes per output (its Time value aside); the index on disk is the whole
    series, which meshio reads back, first and last step included. Whole rewrites made
    the cost grow with the outputs (1,181 outputs once took 100 s)."""
    from solver.io import output

    path = tmp_path / "pts.xdmf"
    series = output.XdmfSeries(str(path), run_id="run-a")
    xy = np.array([[0.0, 0.0], [1.0, 0.5], [2.0, 1.0]])
    growth, inode = [], None
    for k in range(10_000):
        before = path.stat().st_size if k else 0
        series.write(k, 1.0 + k, xy, {"p": np.full(3, float(k)), "u": np.zeros((3, 3))})
        growth.append(path.stat().st_size - before)
        inode = inode or path.stat().st_ino
        assert path.stat().st_ino == inode
    # Times 1.0 ... 10000.0 print with 3 to 7 characters.
    assert max(growth[1:]) - min(growth[1:]) == 4
    assert path.read_text() == series.index()
    with meshio.xdmf.TimeSeriesReader(path) as read:
        read.read_points_cells()
        assert read.num_steps == 10_000
        for k in (0, 9_999):
            t, data, _ = read.read_data(k)
            assert t == 1.0 + k
            np.testing.assert_array_equal(data["p"], np.full(3, float(k)))
    assert output.series_run_id(str(path)) == "run-a"
    assert output.series_run_id(str(tmp_path / "pts_0009999.h5")) == "run-a"


def test_xdmf_index_rewritten_whole_when_its_end_is_not_its_own(tmp_path):
    """An index whose end another hand changed is written whole again, not appended to."""
    from solver.io import output

    path = tmp_path / "pts.xdmf"
    series = output.XdmfSeries(str(path))
    xy = np.zeros((2, 2))
    series.write(0, 0.0, xy, {"p": np.zeros(2)})
    path.write_text(path.read_text() + "<!-- edited -->\n")
    series.write(1, 1.0, xy, {"p": np.ones(2)})
    assert path.read_text() == series.index()
    assert len(_series(path)[2]) == 2


@pytest.mark.mpi(2)
def test_restart_continues_series_and_settlement(cli, tmp_path):
    """A run stopped after a checkpoint and restarted (on 2 ranks) in the same folder: the
    series keeps the steps written before the checkpoint and rewrites the later ones, the
    settlement history and the degree of consolidation go on without a gap or a repeat."""
    out = tmp_path / "run"
    quiet = ["-mpm_progress", "0", "-mpm_figures", "0"]
    first = check_ok(cli(quiet + ["-mpm_Tv_end", "0.02", "-mpm_Tv_report", "0.01,0.02",
                                  "-mpm_checkpoint_every", "100"],
                         options_file="consolidation-m1-q4", out_dir=out))
    assert first["steps"] > 1000
    s = check_ok(cli(quiet + ["-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.01,0.02,0.05",
                              "-mpm_restart", out / "checkpoint.npz"], ranks=2,
                     options_file="consolidation-m1-q4", out_dir=out))
    _, _, steps, _ = _series(out / "points.xdmf")
    want = [
        round(Tv * H**2 / (CV * s["consolidation"]["dt"])) * s["consolidation"]["dt"]
        for Tv in (0.01, 0.02, 0.05)
    ]
    assert [t for t, _, _ in steps] == pytest.approx(want, rel=1e-12)
    assert len(list(out.glob("points_*.h5"))) == 3
    d = s["consolidation"]["consolidation_degree"]
    assert d["Tv"] == [0.01, 0.02, 0.05]
    assert d["settlement_m"][:2] == pytest.approx(
        first["consolidation"]["consolidation_degree"]["settlement_m"], rel=1e-9
    )
    table = np.loadtxt(out / "settlement.csv", delimiter=",", skiprows=1)
    steps_done = np.round(table[:, 0] / s["consolidation"]["dt"]).astype(int)
    assert np.all(np.diff(steps_done) > 0) and steps_done[-1] == s["steps"]
    assert np.all(np.diff(steps_done) <= 10)


class _Points:
    """What reporting.Heights reads of the material points: views and a generation."""

    def __init__(self, **fields):
        self.fields, self.generation = fields, 0

    def views(self, *names):
        out = [self.fields[n] for n in names]
        return out if len(out) > 1 else out[0]


def test_report_errors_at_scale_cost_little_memory():
    """A report's L2 errors of 2e5 points (400 distinct depths, as a structured placement
    has): equal to evaluating the references at every point, in at most 64 bytes per point
    of temporaries the first time (the distinct depths) and 24 later (about 1 KB per point
    is the budget of a whole run)."""
    import tracemalloc

    from mpi4py import MPI

    from solver.consolidation.reporting import Heights
    from solver.references import analytic

    n, H, q = 200_000, 1.0, 1e4
    rng = np.random.default_rng(3)
    y0 = np.repeat((np.arange(400) + 0.5) / 400 * H, n // 400)
    x0 = np.column_stack([rng.random(n), y0])
    p = q * rng.random(n)
    V = rng.random(n) + 0.5
    points = _Points(x0=x0, p=p, volume=V)
    refs = [lambda y: analytic.terzaghi(H - y, 0.1, H),
            lambda y: analytic.terzaghi(H - y, 1.3, H)]
    depths = Heights()
    peaks = []
    for _ in range(2):
        tracemalloc.start()
        got = depths.l2_errors(points, MPI.COMM_SELF, q, refs)
        peaks.append(tracemalloc.get_traced_memory()[1] / n)
        tracemalloc.stop()
    want = [np.sqrt(np.sum(V * (p / q - f(y0)) ** 2) / np.sum(V)) for f in refs]
    assert np.allclose(got, want, rtol=1e-12, atol=0)
    assert peaks[0] <= 64 and peaks[1] <= 24, peaks
