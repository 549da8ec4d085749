"""The study machinery: -mpm_target_error against the shipped work-precision data (and
those data against what scripts/convergence-study makes), the stability map's blow-up
detection against the discrete limit, the batch runner (which keeps a finished run of any
analysis), and the outputs the study scripts read (profiles.csv, -mpm_stability_analysis
0), and the study scripts themselves: executables from a shell whose python3 lacks
petsc4py, help for every option, results under output/ unless published, convergence
charts."""

from __future__ import annotations

import json
import math
import os
import subprocess

import numpy as np
import pytest
from conftest import (PYTHON, REPO, check_ok, clean_env, option_entries, run_command,
                      script_module)

from solver.consolidation import workprecision
from solver.io import output
from solver.studies import study

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
        # The measure judges everything a run reports: the largest of the monitor's error,
        # the profile's L2 (in % of q) and both U's errors, over every report time of the
        # study.
        assert sorted(r["by_tv"]) == ["0.02", "0.2", "0.5", "1"]
        largest = max(max(abs(mon), 100 * l2, abs(us), abs(up))
                      for mon, l2, us, up in r["by_tv"].values())
        assert r["measure"] == pytest.approx(largest, rel=1e-12)
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
    assert (
        s["consolidation"]["element"] == want["element"]
        and s["consolidation"]["cells"] == want["cells"]
    )
    assert s["consolidation"]["ppc"] == want["ppc"]
    assert s["consolidation"]["target"]["picked"]["dt_safety"] == want["dt_safety"]
    overrides = next(line for line in res.stdout.splitlines() if "this overrides" in line)
    assert "picked" in res.stdout and "-mpm_cells 2,20" in overrides
    # Met when run: every error the run reports, against the compressible-water reference.
    largest = _largest_error(s)
    assert largest <= target and s["consolidation"]["target"]["met"] is True
    assert s["consolidation"]["target"]["achieved_pct"] == pytest.approx(largest, rel=1e-12)
    assert f"Target error {target:g} %: met: largest error {largest:.2f} %" in res.stdout


def _largest_error(s):
    """The largest error (%) of all a run reports at its report times, against the
    compressible-water references: p at the monitor, the profile's L2 (% of q), both U."""
    mon, l2, deg = (
        s["consolidation"]["monitor"],
        s["consolidation"]["profile_l2"],
        s["consolidation"]["consolidation_degree"],
    )
    return max([abs(e) for e in mon["error_consistent_pct"]]
               + [100 * e for e in l2["consistent"]]
               + [abs(e) for e in deg["error_settlement_consistent_pct"]]
               + [abs(e) for e in deg["error_pressure_consistent_pct"]])


def test_target_error_says_met_only_when_measured_met(cli, tmp_path):
    """Data that claim 0.5 % for Q4 1 x 10 with one point per cell (whose U from the
    settlement is 30 % off at T_v = 0.02): the pick trusts them, the run's own check does
    not: NOT met, naming the worst quantity."""
    data = _data()
    run = next(r for r in data["runs"] if r["element"] == "q4" and r["cells"] == [1, 10]
               and r["ppc"] == 1)
    for r in data["runs"]:
        r["measure"] = 0.5 if r is run else 50.0
    path = tmp_path / "claims.json"
    path.write_text(json.dumps(data))
    res = cli(["-mpm_target_error", "1", "-mpm_work_precision", str(path),
               "-mpm_progress", "0", "-mpm_figures", "0"],
              options_file="consolidation-m1-q4", timeout=600)
    s = check_ok(res)
    assert s["consolidation"]["ppc"] == 1 and s["consolidation"]["cells"] == [1, 10]
    largest = _largest_error(s)
    worst_us = max(
        abs(e)
        for e in s["consolidation"]["consolidation_degree"]["error_settlement_consistent_pct"]
    )
    assert largest == worst_us > 10                # U from the settlement is the worst
    assert s["consolidation"]["target"]["met"] is False
    assert s["consolidation"]["target"]["errors_pct"]["U_s"]["error_pct"] == pytest.approx(
        worst_us, rel=1e-12
    )
    assert (f"Target error 1 %: NOT met: largest error {largest:.2f} % (U_s at T_v = 0.02)"
            in res.stdout)
    # The time predicted from the run's own steps, not from the data's wall time.
    assert "us per step on this machine" in res.stdout
    assert s["consolidation"]["target"]["predicted_seconds"] > 0 and "rank(s))" not in res.stdout


def test_pace_predicts_from_the_measured_steps():
    """The prediction is the warm-up's time plus the measured cost per step times the steps
    left after the warm-up, said once, after 1 % of the steps (at least 50) or 0.5 s."""
    pace = workprecision.Pace(first=1, last=10000, t0=100.0)
    said = [(k, pace.tick(k, 100.0 + 0.05 + 1e-4 * (k - 10) if k >= 10 else 100.0 + 0.005 * k))
            for k in range(1, 200)]
    lines = [(k, line) for k, line in said if line]
    assert len(lines) == 1 and lines[0][0] == 110            # 1 % of 10000 after step 10
    assert pace.predicted == pytest.approx(0.05 + 1e-4 * (10000 - 10), rel=1e-9)
    assert "100 us per step on this machine (steps 11-110)" in lines[0][1]


def test_old_data_judging_the_monitor_only_are_refused(cli, tmp_path):
    data = _data()
    del data["judged"]
    path = tmp_path / "old.json"
    path.write_text(json.dumps(data))
    res = cli(["-mpm_target_error", "5", "-mpm_work_precision", str(path)] + SHORT,
              options_file="consolidation-m1-q4")
    assert res.returncode == 2 and "judge the monitor point only" in res.stderr


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
    lim = s["consolidation"]["dt_critical"]
    assert "discrete" not in lim and s["consolidation"]["dt_governing"] == "drag"
    lam = 0.3 * 9.81 / 2.5e-4 * (1 + 0.3 * 1000 / (0.7 * 2700))
    assert lim["drag"] == pytest.approx(2 / lam, rel=1e-12)
    assert s["consolidation"]["dt"] == pytest.approx(
        math.floor(0.5 * 2 / lam * 1e7) / 1e7, rel=1e-12
    )


def test_profiles_csv_holds_every_point_and_the_monitor_value(cli, tmp_path):
    s = check_ok(cli(SHORT, options_file="consolidation-m1-q4"))
    prof = np.loadtxt(tmp_path / "out" / "profiles.csv", delimiter=",", skiprows=1, ndmin=2)
    at = prof[np.isclose(prof[:, 0], 0.02)]
    assert len(at) == s["consolidation"]["n_points"] == 40
    assert at[:, 5].sum() == pytest.approx(0.1 * 1.0, rel=1e-12)      # volumes fill the body
    mon = at[np.isclose(at[:, 3], s["consolidation"]["monitor"]["height"])]
    assert mon[:, 4].mean() == pytest.approx(
        s["consolidation"]["monitor"]["p_over_q"][0], rel=1e-12
    )


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


# -- the harness keeps what finished, whatever the analysis ------------------------------
SITE = ["-options_file", "cases/dynamic-layers.opts", "-mpm_figures", "0", "-mpm_progress",
        "0"]
FINISHED = {"analysis": "dynamic", "run_id": "r1", "completed": True, "steps": 92000,
            "wall": {"setup_s": 1.0, "stepping_s": 9.5, "reporting_s": 1.5, "total_s": 12.0}}


def _failed(kind, code):
    return dict(FINISHED, completed=False, steps=500, error={
        "kind": kind, "stage": "stepping", "exit_code": code, "message": f"a {kind} end"})


@pytest.mark.parametrize("summary, reused", [
    (FINISHED, True),
    (_failed("numerical", 3), True),           # a blow-up comes again: it is the result
    (_failed("interrupted", 4), False),
    (_failed("input", 2), False),
    (_failed("internal", 5), False),
    ({k: v for k, v in FINISHED.items() if k != "completed"}, False),   # says nothing
], ids=["completed", "numerical", "interrupted", "input", "internal", "unsaid"])
def test_the_harness_reuses_a_finished_run_of_any_analysis(summary, reused, tmp_path,
                                                           monkeypatch):
    """A dynamic run's folder as the harness leaves it (summary.json, and args.json with its
    arguments): execute() takes the stored summary of a completed run, or of one that blew
    up, without launching anything; it runs again one that was stopped or failed for
    another reason, one whose arguments differ, and any with fresh=True (a timed run)."""
    folder = tmp_path / "site"
    folder.mkdir()
    (folder / "summary.json").write_text(json.dumps(summary))
    code = (summary.get("error") or {}).get("exit_code", 0)
    (folder / "args.json").write_text(json.dumps({"args": SITE, "ranks": 1, "code": code,
                                                  "seconds": 12.5}))
    launched = []

    def launch(cmd, **kw):
        launched.append(cmd)
        return subprocess.CompletedProcess(cmd, 0, "", "")

    monkeypatch.setattr(study.subprocess, "run", launch)
    logged = []
    run = study.execute(study.Run("site", SITE, str(folder)), log=logged.append)
    assert run.reused is reused and bool(launched) is not reused
    if reused:
        assert run.result == summary and (run.code, run.seconds) == (code, 12.5)
        assert logged == [f"  site: stored result (exit {code})"]
    else:
        assert launched[0][-len(SITE) - 2:] == [*SITE, "-mpm_output", str(folder)]
        # The launch wrote no summary: the stored one is not taken for its own.
        assert run.result is None and not (folder / "summary.json").exists()
    launched.clear()
    other = study.execute(study.Run("site", SITE + ["-mpm_t_end", "1"], str(folder)),
                          log=logged.append)
    assert launched and not other.reused
    launched.clear()
    (folder / "args.json").write_text(json.dumps({"args": SITE, "ranks": 1, "code": code}))
    again = study.execute(study.Run("site", SITE, str(folder)), log=logged.append,
                          fresh=True)
    assert launched and not again.reused


def test_the_shipped_work_precision_data_are_what_the_command_makes(tmp_path, monkeypatch):
    """solver/data/work_precision.json, which -mpm_target_error reads, is made by
    ``scripts/convergence-study --publish``; ``--check`` makes its two cheapest runs again
    (Q4 1 x 10 with one point per cell, Q9 1 x 5: about 2 s each) and compares them and the
    whole file with what the command makes of them: a real check, which a file that no
    longer holds fails, naming each difference."""
    runs_dir = tmp_path / "runs"
    res = subprocess.run([PYTHON, str(REPO / "scripts" / "convergence-study"), "--check",
                          "--runs", str(runs_dir)], capture_output=True, text=True,
                         timeout=120, env=clean_env())
    assert res.returncode == 0, res.stdout + res.stderr
    assert "solver/data/work_precision.json: holds (26 runs" in res.stdout
    # The same runs, reused (the check left them finished), against files that do not hold.
    mod = script_module("convergence_study")
    monkeypatch.chdir(REPO)
    args = mod.arguments(["--check", "--runs", str(runs_dir)])
    assert args.data == workprecision.DEFAULT
    runs = [r for r in mod.make_runs(args) if r.name in mod.CHECKED]
    assert len(runs) == 2
    logged = []
    study.execute_all(runs, log=logged.append)
    assert len(logged) == 2 and all("stored result" in m for m in logged)
    assert mod.differences(_data(), runs) == []
    bad = _data()
    row = next(r for r in bad["runs"] if r["element"] == "q4" and r["ppc"] == 1
               and r["cells"] == [1, 10])
    row["steps"] += 1                               # not what the run gives
    bad["orders"]["q9"]["monitor_consistent"] = 1.0     # not the fit of its own rows
    bad["runs"][-1]["measure"] /= 2                 # not the largest of its errors
    del bad["runs"][0]                              # a run of the study missing
    found = mod.differences(bad, runs)
    assert any(line.startswith("q4-1x10-ppc1-dt0.5: steps: stored 53535") for line in found)
    assert any(line.startswith("orders.q9.monitor_consistent: stored 1.0") for line in found)
    assert any("is not the largest of its errors" in line for line in found)
    assert any(line.startswith("runs: stored [] beyond the study's") for line in found)


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
    lim = s["consolidation"]["dt_critical"]
    assert "oscillator" not in lim and s["consolidation"]["f1_hz"] is None
    assert lim["discrete"] == pytest.approx(lim["drag"], rel=0.01)
    res = cli(["-mpm_ppc", "1", "-mpm_damping", "0", "-mpm_stability_analysis", "0",
               "-mpm_dt", repr(0.99 * lim["discrete"])] + SHORT,
              options_file="consolidation-m1-q4")
    assert study.stable(check_ok(res))      # completed, no blow-up


# -- the study scripts as executables ---------------------------------------------------
SCRIPTS = ("reproduce-paper", "convergence-study", "eigen-study")


def _script_env(tmp_path, python=None):
    """A shell whose first python3 has no petsc4py (nor numpy: -I -S drops every
    site-packages), as a fresh shell with a pyenv first on PATH has; the scripts fall back
    to ``python`` ($MPM_GEO_PYTHON; default this test's interpreter)."""
    bare = tmp_path / "bin" / "python3"
    bare.parent.mkdir(exist_ok=True)
    bare.write_text(f'#!/bin/sh\nexec "{PYTHON}" -I -S "$@"\n')
    bare.chmod(0o755)
    env = clean_env()
    env["PATH"] = f"{bare.parent}{os.pathsep}{env.get('PATH', '')}"
    env["MPM_GEO_PYTHON"] = str(python or PYTHON)
    env.pop("PYTHONPATH", None)
    return env, bare


def _run_script(name, args, env, cwd):
    return subprocess.run([str(REPO / "scripts" / name), *args], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=120)


@pytest.mark.parametrize("name", SCRIPTS)
def test_script_runs_as_an_executable_and_every_option_has_help(name, tmp_path):
    env, bare = _script_env(tmp_path)
    # The bare interpreter really lacks petsc4py (the case the scripts must survive).
    probe = subprocess.run([str(bare), "-c", "import petsc4py"], capture_output=True,
                           env=env)
    assert probe.returncode != 0
    res = _run_script(name, ["--help"], env, tmp_path)
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith(f"usage: {name}")
    entries = option_entries(res.stdout)
    assert len(entries) >= 6
    for head, text in entries:
        assert len(text) > 10, f"{name}: {head} has no help text"
    for flag in ("--publish", "--formats", "--dry-run", "--out"):
        assert any(head.startswith(flag) for head, _ in entries), flag


def test_script_without_a_petsc_python_says_what_to_do(tmp_path):
    env, bare = _script_env(tmp_path, python=tmp_path / "nowhere" / "python")
    res = _run_script("reproduce-paper", ["--help"], env, tmp_path)
    assert res.returncode == 2 and res.stdout == ""
    assert res.stderr.count("\n") == 1
    assert "petsc4py cannot be imported" in res.stderr and "scripts/install" in res.stderr
    # Pointing at another Python without petsc4py stops after one try, no loop.
    env["MPM_GEO_PYTHON"] = str(bare)
    res = _run_script("eigen-study", ["--help"], env, tmp_path)
    assert res.returncode == 2 and "has no petsc4py either" in res.stderr


def _dry(name, args, tmp_path):
    env, _ = _script_env(tmp_path)
    return _run_script(name, ["--dry-run", *args], env, tmp_path)


@pytest.mark.parametrize("name, folder", [("reproduce-paper", "paper"),
                                          ("convergence-study", "convergence"),
                                          ("eigen-study", "eigen")])
def test_scripts_write_under_output_unless_published(name, folder, tmp_path):
    res = _dry(name, [], tmp_path)
    assert res.returncode == 0, res.stderr
    assert f"results: {REPO / 'output' / 'studies' / folder}\n" in res.stdout
    res = _dry(name, ["--publish"], tmp_path)
    assert res.returncode == 0, res.stderr
    assert f"results: {REPO / 'docs' / 'results'}\n" in res.stdout
    res = _dry(name, ["--out", str(tmp_path / "x")], tmp_path)
    assert f"results: {tmp_path / 'x'}\n" in res.stdout
    res = _dry(name, ["--formats", "png,jpg"], tmp_path)
    assert res.returncode == 2 and "jpg: not a figure format" in res.stderr


def test_convergence_study_publishes_the_shipped_data_only_for_the_whole_study(tmp_path):
    res = _dry("convergence-study", [], tmp_path)
    assert (f"work-precision data: {REPO / 'output' / 'studies' / 'convergence'}"
            "/work_precision.json\n") in res.stdout
    assert "Convergence study of cases/consolidation-m1-q4.opts: 45 runs" in res.stdout
    res = _dry("convergence-study", ["--publish"], tmp_path)
    assert f"work-precision data: {workprecision.DEFAULT}\n" in res.stdout
    for bad in (["--quick"], ["-options_file", "cases/consolidation-m2-q4.opts"],
                ["--data", "x.json"]):
        res = _dry("convergence-study", ["--publish", *bad], tmp_path)
        assert res.returncode == 2 and "--publish writes the tracked results" in res.stderr
    res = _dry("convergence-study", ["--quick"], tmp_path)
    assert ": 6 runs" in res.stdout


def _convergence_module():
    return script_module("convergence_study")


def test_convergence_orders_read_as_orders_or_not_converging():
    mod = _convergence_module()
    assert mod.order_text(1.0234) == "order 1.02"
    assert mod.order_text(0.08) == "error stalls (slope 0.08)"
    assert mod.order_text(-0.4) == "not converging"
    assert mod.order_text(0.0) == "not converging"
    assert mod.order_text(math.nan) == "one run, no order"
    # The fit itself: errors 4, 2, 1 over h = 1/10, 1/20, 1/40 are first order; growing
    # errors give a negative slope, which the charts call not converging.
    rows = [{"cells": [1, n], "e": e} for n, e in ((10, 4.0), (20, 2.0), (40, 1.0))]
    assert mod.order(rows, "e") == pytest.approx(1.0, rel=1e-12)
    rows = [{"cells": [1, n], "e": e} for n, e in ((10, 1.0), (20, 1.5), (40, 2.0))]
    assert mod.order(rows, "e") < 0


def _synthetic_rows():
    """A study's rows: Q4 converging at first order, Q9 with growing errors, Q8 stalling;
    runs off the series at nearly the same places, so that their labels would collide."""
    rows = []

    def row(series, e, cells, err, ppc=2, safety=0.5, variant=""):
        cost = cells[0] * cells[1] * ppc ** 2 * 1000.0 * cells[1]
        rows.append({"series": series, "variant": variant, "element": e, "cells": cells,
                     "ppc": ppc, "dt_safety": safety, "stable": True, "cost": cost,
                     "wall_seconds": cost * 1e-6, "monitor_classic": 3 + err,
                     "monitor_consistent": err, "l2_classic": 0.003 + err / 1e3,
                     "l2_consistent": err / 1e3})

    for n in (10, 20, 40, 80):
        row("refine", "q4", (1, n), 4.0 * 10 / n)
        row("refine", "q9", (1, n // 2), 0.5 * n / 10)
        row("refine", "q8", (1, n // 2), (10 / n) ** 0.1)
    for k in (1, 3, 4):
        row("ppc", "q4", (1, 20), 2.0 * (1 + 0.01 * k), ppc=k)
    for s in (0.25, 0.9):
        row("dt", "q4", (1, 20), 2.0 * (1 + 0.01 * s), safety=s)
    row("wide", "q4", (2, 20), 2.0)
    row("variant", "q4", (1, 20), 1.5, variant="moving points")
    return rows


def test_convergence_charts_have_no_overlapping_labels_and_no_negative_orders(tmp_path):
    mod = _convergence_module()
    rows = _synthetic_rows()
    orders = {}
    for e in mod.PPC:
        ser = sorted((r for r in rows if r["series"] == "refine" and r["element"] == e),
                     key=lambda r: r["cells"][1])
        orders[e] = {k: mod.order(ser, k) for k in ("monitor_classic", "monitor_consistent",
                                                    "l2_classic", "l2_consistent")}
    assert orders["q4"]["monitor_consistent"] == pytest.approx(1.0, rel=1e-9)
    assert orders["q9"]["monitor_consistent"] == pytest.approx(-1.0, rel=1e-9)

    plt = output.pyplot()
    drawn = []
    real_save = output.save_figure

    def keep(fig, path, **kw):          # look at the figure before it is saved and closed
        renderer = fig.canvas.get_renderer()     # drawn by draw() already
        texts = [t for ax in fig.axes for t in ax.texts]
        drawn.append((path, [t.get_window_extent(renderer) for t in texts],
                      [t.get_text() for lg in fig.legends for t in lg.get_texts()]))
        return real_save(fig, path, **kw)

    mod.output.save_figure = keep
    mod.PANELS = mod.PANELS[:1]          # the monitor chart (the L2 one is drawn alike)
    try:
        mod.draw(rows, orders, str(tmp_path), formats=("png", "pdf"))
    finally:
        mod.output.save_figure = real_save
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "convergence-monitor.pdf", "convergence-monitor.png"]
    for path, boxes, legend in drawn:
        assert len(boxes) >= 6
        for i, a in enumerate(boxes):
            assert not any(a.overlaps(b) for b in boxes[i + 1:]), path
        text = " ".join(legend)
        assert "Q4, 1 x 10 to 1 x 80 cells: order 1.00" in text
        assert "Q9, 1 x 5 to 1 x 40 cells: not converging" in text
        assert "Q8, 1 x 5 to 1 x 40 cells: error stalls" in text
        assert "order -" not in text
    assert not plt.get_fignums()
