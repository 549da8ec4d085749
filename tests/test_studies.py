"""The study machinery: -mpm_target_error against the shipped work-precision data, the
stability map's blow-up detection against the discrete limit, the batch runner, and the
outputs the study scripts read (profiles.csv, -mpm_stability_analysis 0)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from conftest import PYTHON, REPO, check_ok, run_command

from solver import study, workprecision

SHORT = ["-mpm_Tv_end", "0.02", "-mpm_Tv_report", "0.02", "-mpm_progress", "0",
         "-mpm_figures", "0"]


def _data():
    with open(workprecision.DEFAULT) as fh:
        return json.load(fh)


def test_shipped_data_are_measurements():
    data = _data()
    runs = [r for r in data["runs"] if r["stable"]]
    assert len(runs) >= 8
    for r in runs:
        # The measure is what workprecision.measure computes from the run's errors.
        assert r["measure"] == pytest.approx(r["monitor_consistent"], rel=1e-12)
        assert r["cost"] == r["n_points"] * r["steps"]
        assert r["n_points"] == r["cells"][0] * r["cells"][1] * r["ppc"] ** 2
    # Q4 converges at first order against the compressible-water solution; the stored
    # order is the fit of the stored errors.
    ser = sorted((r for r in runs if r["series"] == "refine" and r["element"] == "q4"),
                 key=lambda r: r["cells"][1])
    assert len(ser) >= 3
    assert all(a["measure"] > b["measure"] for a, b in zip(ser, ser[1:]))
    h = np.log([1 / r["cells"][1] for r in ser])
    fit = np.polyfit(h, np.log([r["monitor_consistent"] for r in ser]), 1)[0]
    assert data["orders"]["q4"]["monitor_consistent"] == pytest.approx(fit, rel=1e-9)
    assert 0.8 < fit < 1.3


def test_target_error_picks_the_cheapest_and_meets_it(cli):
    data = _data()
    runs = [r for r in data["runs"] if r["stable"]]
    # A target between the measured errors, so that some runs meet it and some miss it.
    target = 1.01 * float(np.median([r["measure"] for r in runs]))
    meets = [r for r in runs if r["measure"] <= target]
    assert 0 < len(meets) < len(runs)
    want = min(meets, key=lambda r: r["cost"])
    res = cli(["-mpm_target_error", repr(target), "-mpm_progress", "0", "-mpm_figures", "0"],
              options_file="consolidation-m2-q4", timeout=600)
    s = check_ok(res)
    assert s["element"] == want["element"] and s["cells"] == want["cells"]
    assert s["ppc"] == want["ppc"]
    assert s["target"]["picked"]["dt_safety"] == want["dt_safety"]
    assert "picked" in res.stdout and "overrides -mpm_cells 2,20" in res.stdout
    # Met when run: the run's own error against the compressible-water reference.
    mon = s["monitor"]
    errs = [abs(e) for tv, e in zip(mon["Tv"], mon["error_consistent_pct"]) if tv >= 0.5]
    assert len(errs) == 2 and max(errs) <= target
    assert s["target"]["achieved_pct"] == pytest.approx(max(errs), rel=1e-12)
    assert f"this run reached {max(errs):.2f} % (met)" in res.stdout


@pytest.mark.parametrize("args, message", [
    (["-mpm_target_error", "1e-4"], "no measured discretization reaches it"),
    (["-mpm_target_error", "5", "-mpm_k", "1e-4"], "measured with -mpm_k"),
    (["-mpm_target_error", "5", "-mpm_dt", "1e-5"], "picks the time step"),
    (["-mpm_target_error", "-1"], "must be > 0"),
    (["-mpm_work_precision", "x.json"], "only used with -mpm_target_error"),
    (["-mpm_target_error", "5", "-mpm_work_precision", "/nonexistent.json"],
     "cannot be read"),
])
def test_target_error_bad_input(cli, args, message):
    res = cli(args + SHORT, options_file="consolidation-m1-q4")
    assert res.returncode == 2, res.stderr
    assert message in res.stderr and res.stderr.count("\n") == 1, res.stderr


def test_target_error_rejects_a_file_that_is_not_data(cli, tmp_path):
    bad = tmp_path / "bad.json"
    bad.write_text("[1, 2]")
    res = cli(["-mpm_target_error", "5", "-mpm_work_precision", str(bad)] + SHORT,
              options_file="consolidation-m1-q4")
    assert res.returncode == 2 and "not a work-precision file" in res.stderr


def test_without_stability_analysis_the_drag_limit_governs_m1(cli):
    s = check_ok(cli(["-mpm_stability_analysis", "0"] + SHORT,
                     options_file="consolidation-m1-q4"))
    lim = s["dt_critical"]
    assert "discrete" not in lim and s["dt_governing"] == "drag"
    lam = 0.3 * 9.81 / 2.5e-4 * (1 + 0.3 * 1000 / (0.7 * 2700))
    assert lim["drag"] == pytest.approx(2 / lam, rel=1e-12)
    assert s["dt"] == pytest.approx(math.floor(0.5 * 2 / lam * 1e7) / 1e7, rel=1e-12)


def test_profiles_csv_holds_every_point_and_the_monitor_value(cli, tmp_path):
    s = check_ok(cli(SHORT, options_file="consolidation-m1-q4"))
    prof = np.loadtxt(tmp_path / "out" / "profiles.csv", delimiter=",", skiprows=1, ndmin=2)
    at = prof[np.isclose(prof[:, 0], 0.02)]
    assert len(at) == s["n_points"] == 40
    assert at[:, 5].sum() == pytest.approx(0.1 * 1.0, rel=1e-12)      # volumes fill the body
    mon = at[np.isclose(at[:, 3], s["monitor"]["height"])]
    assert mon[:, 4].mean() == pytest.approx(s["monitor"]["p_over_q"][0], rel=1e-12)


def test_batch_runner_reuses_identical_runs_only(tmp_path):
    args = ["-options_file", str(REPO / "cases" / "eigen-q4.opts"), "-mpm_figures", "0"]
    run = study.execute(study.Run("a", args, str(tmp_path / "a")), log=lambda m: None)
    assert run.code == 0 and run.result["jacobi"]["sweeps"] == 7
    logged = []
    again = study.execute(study.Run("a", args, str(tmp_path / "a")), log=logged.append)
    assert "stored result" in logged[0] and again.result == run.result
    other = study.execute(study.Run("a", args + ["-mpm_nmodes", "3"], str(tmp_path / "a")),
                          log=logged.append)
    assert "stored" not in logged[1] and len(other.result["frequencies_hz"]["jacobi"]) == 3


def test_stability_map_brackets_the_discrete_limit(tmp_path):
    code, out, err = run_command(
        [PYTHON, REPO / "scripts" / "stability-map", "--scenes", "m1-q4", "--ratios", "0.5,1.5",
         "--bisect", "2", "--steps", "1500", "--out", tmp_path, "--runs", tmp_path / "runs"],
        timeout=900)
    assert code == 0, out + err
    res = json.loads((tmp_path / "stability-map.json").read_text())["scenes"]["m1-q4"]
    disc = res["limits_s"]["discrete"]
    undamped = res["measured_s"]["0"]
    # The linear analysis is exact without damping: the limit lies in the measured bracket.
    assert undamped["stable_s"] <= disc * (1 + 1e-9) <= undamped["unstable_s"]
    assert undamped["unstable_s"] - undamped["stable_s"] <= 0.25 * disc * (1 + 1e-9)
    for d in ("0", "0.5"):
        runs = res["runs"][d]
        assert any(r["stable"] for r in runs) and any(not r["stable"] for r in runs)
        # No run is declared stable above the limit.
        assert all(r["dt_s"] <= disc * (1 + 1e-9) for r in runs if r["stable"]), runs
        assert res["measured_s"][d]["consistent"]
    assert (tmp_path / "stability-map.png").stat().st_size > 10000
    assert "M1-Q4" in (tmp_path / "stability-map.md").read_text()


def test_one_point_per_q4_cell_runs_at_the_drag_limit(cli):
    """One point per Q4 cell leaves zero-energy modes: the consistent mass is singular (no
    f1, no oscillator criterion) and the linearised step has unit eigenvalues in Jordan
    blocks, which must not pass for an instability; the run is stable at 0.99 x the
    discrete limit, which the drag sets as for 2 x 2 points."""
    s = check_ok(cli(["-mpm_ppc", "1"] + SHORT, options_file="consolidation-m1-q4"))
    lim = s["dt_critical"]
    assert "oscillator" not in lim and s["f1_hz"] is None
    assert lim["discrete"] == pytest.approx(lim["drag"], rel=0.01)
    res = cli(["-mpm_ppc", "1", "-mpm_damping", "0", "-mpm_stability_analysis", "0",
               "-mpm_dt", repr(0.99 * lim["discrete"])] + SHORT,
              options_file="consolidation-m1-q4")
    assert check_ok(res)["stable"] is True
