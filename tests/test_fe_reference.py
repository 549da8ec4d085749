"""A scene without a closed form set against its own finite-element solution: the
strip footing of cases/ solved again by solver/references/biot.py, its report (the
settlement at the axis and the mean under the load, the monitor point's excess pore
pressure, the column under the axis, the trough) and its files.

The FE numbers the run reports are checked against biot.solve called here on a body built
from the scene's options by hand, with its own time schedule (16 steps per doubling at the
report times alone, where the run takes 8 and more times): they agree to the FE's time
error (3e-5 q on the strip, docs/method.md), not to round-off.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pytest
from conftest import check_ok, check_readme_outputs, readme_section, run_cli

from solver.consolidation import fe_reference, plan
from solver.model.scene import Body, Loading
from solver.model.soil import Ground, Soil

SHORT = ["-mpm_cells", "8,4", "-mpm_fe_cells", "16,8", "-mpm_Tv_end", "0.05",
         "-mpm_Tv_report", "0.01,0.05", "-mpm_progress", "0"]
SIDES = ("left", "right", "bottom", "top")


@pytest.fixture(scope="module")
def strip(tmp_path_factory):
    """The strip of cases/ on 8 x 4 cells to T_v = 0.05 with its figures: (the CliResult,
    its output folder)."""
    out = tmp_path_factory.mktemp("strip")
    res = run_cli(SHORT, out, options_file="consolidation-strip")
    check_ok(res)
    return res, out


def _biot(o, times, points, surface=None, cells=(16, 8)):
    """biot.solve of the body of the run options ``o`` (the summary's), built here."""
    from petsc4py import PETSc

    from solver.references import biot

    layered = len(o["layers"]) > 1
    body = biot.Body(size=tuple(o["size"]), E=o["E"], nu=o["nu"], k=o["k"],
                     porosity=o["porosity"], K_l=o["K_l"], rho_l=o["rho_l"], load=o["load"],
                     loaded=tuple(o["load_extent"]) or None, drained=tuple(o["drained"]),
                     bcs={side: o[f"bc_{side}"] for side in SIDES},
                     layers=tuple(o["layers"]) if layered else None)
    return biot.solve(PETSc.COMM_SELF, body, times, points, surface=surface, cells=cells)


def test_the_fe_reference_is_the_scenes_own(strip):
    """The FE's settlement at the axis, its mean under the load and the monitor's p / q at
    the report times, and its undrained and drained ends, are biot.solve's of the scene."""
    s = strip[0].summary
    o, fe = s["provenance"]["options"]["mpm"], s["consolidation"]["fe_reference"]
    assert fe["available"] and fe["cells"] == [16, 8] and fe["axis_x_m"] == 0.0
    t = s["consolidation"]["consolidation_degree"]["t"]
    q = o["load"]
    mean = _biot(o, t, [fe["monitor_m"]])
    axis = _biot(o, t, [fe["monitor_m"]], surface=[0.0])
    np.testing.assert_allclose(fe["fe_p_over_q"], mean.pressure[:, 0] / q, rtol=0, atol=2e-4)
    np.testing.assert_allclose(fe["fe_settlement_mean_m"], mean.settlement, rtol=2e-4)
    np.testing.assert_allclose(fe["fe_settlement_axis_m"], axis.settlement[:, 0], rtol=2e-4)
    assert fe["undrained"]["settlement_mean_m"] == pytest.approx(mean.undrained, rel=1e-9)
    assert fe["drained"]["settlement_mean_m"] == pytest.approx(mean.drained, rel=1e-9)
    assert fe["drained"]["settlement_axis_m"] == pytest.approx(axis.drained[0], rel=1e-9)


def test_the_errors_are_the_runs_against_the_fe(strip):
    """The error columns: the settlement in % of the FE's, p in % of q, each from the
    run's own numbers (consolidation_degree, monitor), printed in one table."""
    res, _ = strip
    s = res.summary
    fe, deg, mon = (
        s["consolidation"]["fe_reference"],
        s["consolidation"]["consolidation_degree"],
        s["consolidation"]["monitor"],
    )
    assert fe["settlement_axis_m"] == deg["settlement_axis_m"]
    assert fe["settlement_mean_m"] == deg["settlement_m"]
    assert fe["p_over_q"] == mon["p_over_q"]
    for key in ("axis", "mean"):
        want = 100 * (np.array(fe[f"settlement_{key}_m"]) / fe[f"fe_settlement_{key}_m"] - 1)
        np.testing.assert_allclose(fe[f"error_settlement_{key}_pct"], want, rtol=1e-12)
    np.testing.assert_allclose(fe["error_p_pct_of_q"],
                               100 * (np.array(mon["p_over_q"]) - fe["fe_p_over_q"]),
                               rtol=1e-12)
    lines = res.stdout.splitlines()
    head = next(i for i, ln in enumerate(lines) if ln.startswith("Against the FE reference"))
    assert "Q9/Q4 on 16 x 8 cells" in lines[head]
    assert lines[head + 1].split() == ["T_v", "axis", "FE", "error", "mean", "FE", "error",
                                       "p/q", "FE", "error", "column", "RMS", "max"]
    row = lines[head + 2].split()
    assert float(row[0]) == 0.01 and float(row[1]) == pytest.approx(
        1e3 * deg["settlement_axis_m"][0], abs=1e-4)
    # No Terzaghi and no other reference's error columns.
    assert "Terzaghi" not in res.stdout and s["consolidation"]["reference"]["available"] is False


def _profile(out, Tv):
    """(x, y0, p/q) of every point at isochrone time Tv, from profiles.csv."""
    rows = np.loadtxt(out / "profiles.csv", delimiter=",", skiprows=1)
    r = rows[np.isclose(rows[:, 0], Tv)]
    return r[:, 2], r[:, 3], r[:, 4]


def test_the_monitor_is_the_point_under_the_axis(strip):
    """The default monitor of the strip is the point nearest the axis x = 0 in the row
    highest below mid-height (8 x 4 cells, 2 x 2 points: (0.0625, 0.4375) m), not the mean
    of the row across the width (the issue: 0.247 against 0.681 under the axis)."""
    res, out = strip
    mon = res.summary["consolidation"]["monitor"]
    assert (mon["x"], mon["height"]) == (0.0625, 0.4375)
    assert "monitor at (x, y) = (0.0625, 0.4375) m" in res.stdout
    for Tv, p in zip(mon["Tv"], mon["p_over_q"]):
        x, y0, pq = _profile(out, Tv)
        row = np.isclose(y0, 0.4375)
        point = row & (np.abs(x - 0.0625) < 0.01)
        assert point.sum() == 1 and p == pytest.approx(pq[point][0], abs=1e-9)
        assert abs(p - pq[row].mean()) > 0.05


def test_settlement_at_the_axis_and_under_the_load(strip):
    """The settlement at the axis is the top nodes' at x = 0: the trough's first two
    columns (x = h/4, 3h/4 of the first Q4 cell, the top's linear interpolation)
    extrapolated; the mean under the load is the mean of the trough's columns there; both
    in settlement.csv by name."""
    res, out = strip
    s = res.summary
    deg = s["consolidation"]["consolidation_degree"]
    rows = np.loadtxt(out / "settlement_trough.csv", delimiter=",", skiprows=1)
    for Tv, axis, mean in zip(deg["Tv"], deg["settlement_axis_m"], deg["settlement_m"]):
        r = rows[rows[:, 0] == Tv]
        assert r[0, 1] == 0.0625 and r[1, 1] == 0.1875
        assert axis == pytest.approx(1.5 * r[0, 2] - 0.5 * r[1, 2], rel=1e-9)
        assert mean == pytest.approx(r[r[:, 1] <= 0.5, 2].mean(), rel=1e-9)
    head = (out / "settlement.csv").read_text().splitlines()[0].split(",")
    assert head == ["t_s", "Tv", "settlement_mean_under_load_m_downwards_positive",
                    "mean_excess_pore_pressure_pa_compression_positive",
                    "settlement_axis_m_downwards_positive"]
    assert "settlement_axis_m at x = 0 m" in deg["surface"]
    assert "Mean settlement under the load (0 <= x <= 0.5 m) against static" in res.stdout


def test_the_trough_file_says_what_its_rows_are(strip):
    """settlement_trough.csv: a comment line under the header says that T_v = 0 and inf
    are the static ends; the FE's column holds its trough at the same x and time."""
    res, out = strip
    lines = (out / "settlement_trough.csv").read_text().splitlines()
    assert lines[0] == ("Tv,x_m,settlement_m_downwards_positive,"
                        "fe_settlement_m_downwards_positive")
    assert lines[1].startswith("# rows with Tv = 0: the static undrained surface, "
                               "Tv = inf: the static final one")
    rows = np.loadtxt(out / "settlement_trough.csv", delimiter=",", skiprows=1)
    assert set(rows[:, 0]) == {0.0, 0.01, 0.05, np.inf}
    static = res.summary["consolidation"]["static_references"]
    ends = rows[rows[:, 0] == np.inf]
    assert ends[0, 1] == 0.0 and ends[-1, 1] == 2.0          # the top nodes
    o = res.summary["provenance"]["options"]["mpm"]
    x = rows[rows[:, 0] == 0.01, 1]
    t = res.summary["consolidation"]["consolidation_degree"]["t"][0]
    ref = _biot(o, [t], [[0.5, 0.5]], surface=x)
    np.testing.assert_allclose(rows[rows[:, 0] == 0.01, 3], ref.settlement[0], rtol=0,
                               atol=2e-4 * static["final_m"])
    np.testing.assert_allclose(ends[:, 3], _biot(o, [t], [[0.5, 0.5]], surface=ends[:, 1])
                               .drained, rtol=1e-9)


def test_fe_reference_csv(strip):
    """fe_reference.csv: the FE's history at the run's times, its ends as rows t = 0
    (undrained) and inf (drained), said under the header."""
    res, out = strip
    lines = (out / "fe_reference.csv").read_text().splitlines()
    assert lines[0].split(",") == ["t_s", "Tv", "settlement_axis_m_downwards_positive",
                                   "settlement_mean_under_load_m_downwards_positive",
                                   "monitor_excess_p_over_q_compression_positive"]
    assert "t_s = 0 undrained (t = 0+), t_s = inf drained (p = 0)" in lines[1]
    rows = np.loadtxt(out / "fe_reference.csv", delimiter=",", skiprows=1)
    fe = res.summary["consolidation"]["fe_reference"]
    assert rows[-2, 0] == 0.0 and rows[-1, 0] == np.inf and rows[-1, 4] == 0.0
    assert rows[-1, 3] == pytest.approx(fe["drained"]["settlement_mean_m"], rel=1e-12)
    for t, s in zip(
        res.summary["consolidation"]["consolidation_degree"]["t"], fe["fe_settlement_mean_m"]
    ):
        assert rows[np.isclose(rows[:, 0], t, rtol=1e-12), 3] == pytest.approx(s, rel=1e-12)
    # The curve's times: halvings of time before the first report, ten at most, down to the
    # run's first sample (10 explicit steps, or the implicit scheme's first step).
    t = rows[:-2, 0]
    first = np.flatnonzero(
        np.isclose(t, res.summary["consolidation"]["consolidation_degree"]["t"][0])
    )[0]
    assert first >= 3 and np.allclose(t[1:first + 1] / t[:first], 2.0)
    sample = res.summary["consolidation"]["dt"] * (
        10 if res.summary["consolidation"]["scheme"] == "explicit" else 1
    )
    assert t[0] >= sample and (sample > t[0] / 2 or first == 10)




def test_the_readme_lists_every_file_a_scene_without_a_closed_form_writes(strip):
    """Every file of the run (the summary's files, each on disk) is named in the README's
    Outputs: by file name, a figure by its name in backticks, a series' HDF5 files as
    points_<step>.h5; each CSV file's columns in its row of the table."""
    res, out = strip
    readme = readme_section("Outputs")
    files = [f for v in res.summary["files"].values() for f in (v if isinstance(v, list)
                                                                   else [v])]
    assert {p.name for p in out.iterdir() if not p.name.startswith(".")} == \
        {f.split("/")[-1] for f in files}
    for path in files:
        name = path.split("/")[-1]
        stem, ext = name.rsplit(".", 1)
        named = (f"`{name}`" in readme or (ext in ("png", "pdf", "svg") and f"`{stem}`"
                                            in readme)
                 or f"`{re.sub(r'_[0-9]+[.]', '_<step>.', name)}`" in readme)
        assert named, name
    check_readme_outputs(out)
    for name in ("settlement_trough.csv", "fe_reference.csv", "settlement_time",
                 "settlement_trough"):
        assert name in {p.name for p in out.iterdir()} | {p.stem for p in out.iterdir()}


def test_gravity_at_rest_reports_the_excess_against_the_same_fe(cli, tmp_path, strip):
    """Under gravity from rest (geostatic) the strip's 'excess' is over hydrostatic on the
    screen and in the files, as without gravity (the issue: 0.404 against 0.098), and its
    FE reference is the gravity-free one; a fresh deposit under gravity has none, and says
    why."""
    plain = strip[0].summary
    args = [*SHORT[:4], "-mpm_Tv_end", "0.01", "-mpm_Tv_report", "0.01", "-mpm_progress",
            "0", "-mpm_figures", "0", "-mpm_gravity", "9.81"]
    res = cli([*args, "-mpm_initial_state", "geostatic"], options_file="consolidation-strip",
              out_dir=tmp_path / "geo")
    geo = check_ok(res)
    assert geo["consolidation"]["monitor"]["p_over_q"][0] == pytest.approx(
        plain["consolidation"]["monitor"]["p_over_q"][0], abs=2e-3
    )
    assert geo["consolidation"]["fe_reference"]["fe_p_over_q"][0] == pytest.approx(
        plain["consolidation"]["fe_reference"]["fe_p_over_q"][0], rel=1e-9)
    head = (tmp_path / "geo" / "monitor.csv").read_text().splitlines()[0]
    assert head == "t_s,Tv,excess_p_over_q_compression_positive"
    _, y0, pq = _profile(tmp_path / "geo", 0.01)
    rows = np.loadtxt(tmp_path / "geo" / "profiles.csv", delimiter=",", skiprows=1)
    excess = rows[np.isclose(rows[:, 0], 0.01), 6]
    np.testing.assert_allclose(pq - excess, 1000 * 9.81 * (1 - y0) / 1e4, rtol=1e-9)
    res = cli([*args], options_file="consolidation-strip", out_dir=tmp_path / "dep")
    dep = check_ok(res)
    assert dep["consolidation"]["fe_reference"] == {"available": False, "why": fe_reference.why_not(
        plan.References(1, 1, 1, 1, 1, why="x"), Loading(gravity=9.81), True)}
    assert res.stdout.count("No FE reference: a fresh deposit under gravity") == 1
    assert not (tmp_path / "dep" / "fe_reference.csv").exists()


def test_monitor_placed_by_option(cli, tmp_path):
    """-mpm_monitor x,y: the point nearest it (ties to the larger), and the FE there."""
    s = check_ok(cli([*SHORT[:4], "-mpm_Tv_end", "0.01", "-mpm_Tv_report", "0.01",
                      "-mpm_progress", "0", "-mpm_figures", "0", "-mpm_monitor", "1,0.2"],
                     options_file="consolidation-strip", out_dir=tmp_path))
    assert (s["consolidation"]["monitor"]["x"], s["consolidation"]["monitor"]["height"]) == (
        1.0625,
        0.1875,
    )
    o = s["provenance"]["options"]["mpm"]
    ref = _biot(o, s["consolidation"]["consolidation_degree"]["t"], [[1.0625, 0.1875]])
    assert s["consolidation"]["fe_reference"]["fe_p_over_q"][0] == pytest.approx(
        ref.pressure[0, 0] / o["load"], abs=2e-4)
    assert s["consolidation"]["fe_reference"]["monitor_m"] == [1.0625, 0.1875]


@pytest.mark.parametrize("args, message", [
    (["-mpm_monitor", "2.5,0.5"], "-mpm_monitor 2.5,0.5: outside the body "
                                  "(0 <= x <= 2, 0 <= y <= 1 m)"),
    (["-mpm_monitor", "1,0.5", "-mpm_monitor_height", "0.5"],
     "-mpm_monitor_height: -mpm_monitor x,y places the monitor (give one)"),
    (["-mpm_layers", "0.3,0.7", "-mpm_cells", "16,10", "-mpm_fe_cells", "32,16"],
     "-mpm_fe_cells 32,16: a layer interface lies inside an FE cell (16 cells up; "
     "interfaces at depths 0.3 m)")])
def test_bad_monitor_and_fe_grid_are_one_line(cli, tmp_path, args, message):
    out = tmp_path / "never"
    res = cli(args, options_file="consolidation-strip", out_dir=out)
    assert res.returncode == 2
    assert res.stderr.strip().splitlines() == [f"solver: error: {message}"]
    assert not out.exists()


def test_fe_grid_follows_the_scene():
    """Square cells, 32 across the shorter side within about 2048 cells; the layer
    interfaces on cell boundaries (a multiple of the MPM's coarsest aligned grid where
    32 would cut one); the load's edges too where the MPM's cells put them on theirs."""
    strip = Body(cells=(16, 8), size=(2.0, 1.0))
    assert fe_reference.cells(strip, Soil(), Loading(extent=(0.0, 0.5))) == (64, 32)
    ground = Ground((0.5, 1.5), (Soil(), Soil(E=40e6)))
    layered = Body(cells=(64, 32), size=(4.0, 2.0))
    assert fe_reference.cells(layered, ground, Loading(extent=(0.0, 1.0))) == (64, 32)
    odd = Ground((0.3, 0.7), (Soil(), Soil(E=40e6)))
    assert fe_reference.cells(Body(cells=(10, 10), size=(1.0, 1.0)), odd, Loading()) == \
        (32, 40)
    # An edge off the MPM's cell boundaries: the plain count.
    assert fe_reference.cells(strip, Soil(), Loading(extent=(0.0, 0.51))) == (64, 32)
    wide = Body(cells=(100, 5), size=(20.0, 1.0))           # within about 2048 cells
    nx, ny = fe_reference.cells(wide, Soil(), Loading())
    assert ny * nx <= 2100 and ny >= 10 and abs(20 / nx - 1 / ny) < 0.01


def test_fe_reference_only_where_it_is_the_scenes_own():
    refs = plan.References(1, 1, 1, 1, 1, why="a load over part of the top")
    assert fe_reference.why_not(refs, Loading(extent=(0, 0.5)), True) == ""
    # At rest under gravity, drained sides included (they hold the water table): the excess
    # is the FE's.
    assert fe_reference.why_not(refs, Loading(gravity=9.81, geostatic=True), True) == ""
    assert "turned off" in fe_reference.why_not(refs, Loading(), False)
    assert "applies it at once" in fe_reference.why_not(refs, Loading(ramp=1.0), True)
    assert "closed form" in fe_reference.why_not(plan.References(1, 1, 1, 1, 1), Loading(),
                                                 True)


def test_the_axis_of_a_scene():
    """The axis under the load: a half model's rollers side, else the load's middle."""
    body = Body(size=(2.0, 1.0))
    assert plan.axis(body, Loading(extent=(0.0, 0.5))) == 0.0
    assert plan.axis(body, Loading(extent=(1.5, 2.0))) == 2.0
    assert plan.axis(body, Loading(extent=(0.5, 1.0))) == 0.75
    assert plan.axis(body, Loading()) == 1.0
    free = Body(size=(2.0, 1.0), bcs=(("left", "none"), ("right", "x"), ("bottom", "xy"),
                                      ("top", "none")))
    assert plan.axis(free, Loading(extent=(0.0, 0.5))) == 0.25


def test_mean_under_the_load_is_exact_for_the_cells_polynomials():
    """The Gauss points and weights of the mean under the load integrate a piecewise
    quadratic surface exactly, edges inside cells included."""
    x, w = fe_reference._mean_points((8, 4), 2.0, (0.1, 0.9))
    assert w.sum() == pytest.approx(1.0, rel=1e-14)
    f = np.where(x < 0.5, x ** 2, 0.25 + (x - 0.5))        # quadratic, then linear at 0.5
    want = ((0.5 ** 3 - 0.1 ** 3) / 3 + 0.25 * 0.4 + 0.4 ** 2 / 2) / 0.8
    assert w @ f == pytest.approx(want, rel=1e-13)


def test_fe_times_are_the_runs():
    """The FE is asked the run's report and isochrone steps' times exactly, and halvings
    of time before them down to the first sample."""
    from solver.consolidation.plan import Schedule

    sched = Schedule(dt=1e-3, nsteps=2000, report_steps={100: 0.01, 2000: 0.2},
                     iso_steps={100: 0.01, 500: 0.05, 2000: 0.2}, Tv_end=0.2,
                     Tv_report=(0.01, 0.2))
    t, Tv = fe_reference.times(sched, lambda t: t / 10)
    assert list(t[-3:]) == [100 * 1e-3, 500 * 1e-3, 2000 * 1e-3]
    assert list(Tv[-3:]) == [0.01, 0.05, 0.2]
    assert t[0] >= 10e-3 and np.allclose(t[1:-2] / t[:-3], 2.0)
    assert Tv[0] == pytest.approx(t[0] / 10)
    assert math.isclose(t[-3] / t[-4], 2.0)


def test_layers_under_a_local_load_against_their_fe(cli, tmp_path):
    """The layered strip of cases/ (0.5 m of sand over 1.5 m of clay, shortened): its FE
    reference is biot.solve's of the same layers (E, nu, k, n per layer), on a grid with
    the interface on a cell boundary."""
    s = check_ok(cli(["-mpm_cells", "16,8", "-mpm_fe_cells", "32,16", "-mpm_Tv_end", "0.01",
                      "-mpm_Tv_report", "0.01", "-mpm_progress", "0", "-mpm_figures", "0"],
                     options_file="consolidation-strip-layered", out_dir=tmp_path))
    o, fe = s["provenance"]["options"]["mpm"], s["consolidation"]["fe_reference"]
    assert o["layers"] == [0.5, 1.5] and fe["axis_x_m"] == 0.0
    t = s["consolidation"]["consolidation_degree"]["t"]
    mean = _biot(o, t, [fe["monitor_m"]], cells=(32, 16))
    axis = _biot(o, t, [fe["monitor_m"]], surface=[0.0], cells=(32, 16))
    assert fe["fe_p_over_q"][0] == pytest.approx(mean.pressure[0, 0] / o["load"], abs=2e-4)
    assert fe["fe_settlement_mean_m"][0] == pytest.approx(mean.settlement[0], rel=2e-4)
    assert fe["fe_settlement_axis_m"][0] == pytest.approx(axis.settlement[0, 0], rel=2e-4)
    # Not the uniform clay's: the sand on top settles less.
    uniform = dict(o, layers=[], E=o["E"][1], nu=o["nu"][1], k=o["k"][1],
                   porosity=o["porosity"][1])
    assert _biot(uniform, t, [fe["monitor_m"]], cells=(32, 16)).settlement[0] > \
        1.05 * fe["fe_settlement_mean_m"][0]
