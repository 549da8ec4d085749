"""Restarts that never mix two runs, the restart hint that works alone,
signals at any point of a run, and the last state of every run written.

A checkpoint carries its run (id and options): ``-mpm_restart CK`` alone continues it;
options beside it that would change the physics are refused; a restart refuses an output
folder that holds another run's results unless ``-mpm_overwrite``, and then its series is
its own run's only. SIGTERM/SIGINT in the set-up, the eigen analysis or the reporting exit
4 with one line and a summary that says where the run stopped.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import meshio
import numpy as np
import pytest
from conftest import CASES, PYTHON, REPO, check_ok, clean_env, run_command

QUIET = ["-mpm_progress", "0", "-mpm_figures", "0"]
M1 = "consolidation-m1-q4"


def _summary(folder):
    with open(os.path.join(folder, "summary.json")) as fh:
        return json.load(fh)


def _times(xdmf):
    """(t, pore pressure) of every time of a series, read by meshio."""
    with meshio.xdmf.TimeSeriesReader(xdmf) as series:
        series.read_points_cells()
        return [(t, d["pore_pressure"]) for t, d, _ in
                (series.read_data(k) for k in range(series.num_steps))]


def _index_files(xdmf):
    """The HDF5 files the index names, in order."""
    import xml.etree.ElementTree as ET

    return [item.find("DataItem").text.split(":")[0]
            for item in ET.parse(xdmf).getroot().iter("Geometry")]


def _part(cli, folder, extra=()):
    """M1-Q4 to T_v = 0.02 with a checkpoint at step 700 (of 1071)."""
    res = cli(QUIET + ["-mpm_Tv_end", "0.02", "-mpm_Tv_report", "0.01,0.02",
                       "-mpm_checkpoint_every", "700", *extra], options_file=M1,
              out_dir=folder)
    return check_ok(res), folder / "checkpoint.npz"


# -- items 1 and 2: the checkpoint carries its run ----------------------------------------
def test_restart_alone_continues_the_run(cli, tmp_path):
    """``python -m solver -mpm_restart CK`` with nothing else: the checkpoint's scene
    (here with a load and a monitor point of its own, and a shorter end) runs on in its
    own folder, to the same numbers as the run without a stop; -mpm_Tv_end may change."""
    scene = ["-mpm_load", "2e4", "-mpm_monitor_height", "0.3"]
    full = check_ok(cli(QUIET + scene + ["-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.01,0.02"],
                        options_file=M1, out_dir=tmp_path / "full"))
    first, ckpt = _part(cli, tmp_path / "run", scene)
    code, out, err = run_command([PYTHON, "-m", "solver", "-mpm_restart", ckpt,
                                  "-mpm_Tv_end", "0.05"])
    assert code == 0, err
    assert f"Restart from {ckpt} at step 700" in out
    rest = _summary(tmp_path / "run")
    assert rest["completed"] is True and rest["run_id"] == first["run_id"]
    assert (
        rest["steps"] == full["steps"]
        and rest["consolidation"]["dt"] == full["consolidation"]["dt"]
    )
    np.testing.assert_allclose(
        rest["consolidation"]["monitor"]["p_over_q"],
        full["consolidation"]["monitor"]["p_over_q"],
        rtol=1e-12,
    )
    mpm = rest["provenance"]["options"]["mpm"]
    assert mpm["load"] == 2e4 and mpm["monitor_height"] == 0.3 and mpm["Tv_end"] == 0.05
    assert rest["provenance"]["options"]["mpm_given"] == ["Tv_end", "restart"]


@pytest.mark.parametrize("how", ["command line", "scene file", "analysis"])
def test_restart_refuses_options_that_change_the_run(cli, tmp_path, how):
    first, ckpt = _part(cli, tmp_path / "run")
    before = {f: os.path.getmtime(tmp_path / "run" / f) for f in os.listdir(tmp_path / "run")}
    if how == "scene file":
        scene = tmp_path / "other.opts"
        scene.write_text((CASES / f"{M1}.opts").read_text() + "-mpm_load 2e4\n")
        args, options_file, says = [], scene, "-mpm_load 20000.0: "
    elif how == "analysis":
        args, options_file, says = ["-mpm_analysis", "eigen"], None, "-mpm_analysis eigen: "
    else:
        args, options_file, says = ["-mpm_cells", "2,20"], M1, "-mpm_cells 2,20: "
    res = cli(QUIET + args + ["-mpm_restart", ckpt], options_file=options_file,
              out_dir=tmp_path / "run")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("solver: error: " + says)
    assert f"the run of -mpm_restart {ckpt} has" in lines[0]
    if how == "scene file":
        assert f"(set in {scene}:" in lines[0]
    assert "Critical time steps" not in res.stdout
    assert before == {f: os.path.getmtime(tmp_path / "run" / f)
                      for f in os.listdir(tmp_path / "run")}


def test_restart_never_mixes_two_runs(cli, tmp_path):
    """The reported case: a 20 kPa run finished in X; a 10 kPa run stopped with a checkpoint
    elsewhere; restarting the 10 kPa run into X is refused (nothing written), and with
    -mpm_overwrite its series in X holds its own times only."""
    x = tmp_path / "X"
    other = check_ok(cli(QUIET + ["-mpm_load", "2e4", "-mpm_Tv_end", "0.05",
                                  "-mpm_Tv_report", "0.01,0.02,0.05"], options_file=M1,
                         out_dir=x))
    first, ckpt = _part(cli, tmp_path / "B")
    assert first["run_id"] != other["run_id"]
    index = (x / "points.xdmf").read_bytes()
    args = QUIET + ["-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.01,0.02,0.05",
                    "-mpm_restart", ckpt]
    res = cli(args, options_file=M1, out_dir=x)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        f"solver: error: -mpm_output {x}: summary.json holds the results of another run "
        f"({other['run_id']}; -mpm_restart {ckpt} continues run {first['run_id']})")
    assert (x / "points.xdmf").read_bytes() == index and _summary(x) == other

    s = check_ok(cli(args + ["-mpm_overwrite"], options_file=M1, out_dir=x))
    assert s["run_id"] == first["run_id"]
    from solver.io import output

    # Its own run's times only: those after the checkpoint's step 700 (the checkpoint's
    # earlier time, T_v = 0.01, lies in B's folder, not in X).
    names = _index_files(x / "points.xdmf")
    assert names == [f"points_{k:07d}.h5" for k in (1071, 2677)]
    assert {output.series_run_id(str(x / n)) for n in names} == {first["run_id"]}
    assert output.series_run_id(str(x / "points.xdmf")) == first["run_id"]
    # 10 kPa: the pore pressures stay below 1.5 x 10 kPa, the 20 kPa run's near 20 kPa.
    for t, pp in _times(x / "points.xdmf"):
        assert 0 < pp.max() < 1.5e4


def test_restart_of_its_own_folder_keeps_its_series(cli, tmp_path):
    """The series before the checkpoint continues: the times written before it stay (their
    files carry the run's id), the later ones are written again; the last at the end."""
    first, ckpt = _part(cli, tmp_path / "run")
    s = check_ok(cli(QUIET + ["-mpm_Tv_end", "0.05", "-mpm_restart", ckpt],
                     out_dir=tmp_path / "run"))
    assert _index_files(tmp_path / "run" / "points.xdmf") == [
        f"points_{k:07d}.h5" for k in (535, 1071, 2677)]
    assert s["consolidation"]["fields"] == {"times": 3, "last_step": 2677,
                           "last_t_s": pytest.approx(2677 * s["consolidation"]["dt"], rel=1e-15)}


def test_checkpoint_of_an_older_format_still_restarts(cli, tmp_path):
    """A checkpoint without the run (written before it was stored) restarts as before:
    with the scene's options given again."""
    first, ckpt = _part(cli, tmp_path / "run")
    with np.load(ckpt) as z:
        members = {k: z[k] for k in z.files if k != "run"}
    np.savez(ckpt, **members)
    s = check_ok(cli(QUIET + ["-mpm_Tv_end", "0.02", "-mpm_restart", ckpt],
                     options_file=M1, out_dir=tmp_path / "run"))
    assert s["steps"] == first["steps"]
    np.testing.assert_allclose(
        s["consolidation"]["monitor"]["p_over_q"],
        first["consolidation"]["monitor"]["p_over_q"],
        rtol=1e-12,
    )


def test_help_with_a_restart_shows_the_checkpoints_options(cli, tmp_path):
    first, ckpt = _part(cli, tmp_path / "run", ["-mpm_load", "2e4"])
    res = cli(["-mpm_restart", ckpt, "-help"], out_dir=tmp_path / "run")
    assert res.returncode == 0, res.stderr
    rows = {line.split("|")[1].strip(" `"): line.split("|")[2].strip(" `")
            for line in res.stdout.splitlines() if line.startswith("| `-mpm_")}
    assert rows["-mpm_load"] == "20000.0" and rows["-mpm_analysis"] == "consolidation"
    assert rows["-mpm_Tv_end"] == "0.02" and rows["-mpm_restart"] == str(ckpt)


# -- item 4: the last state of every run ----------------------------------------------------
def test_shortened_run_writes_its_last_state(cli, tmp_path):
    """-mpm_Tv_end 0.1 on M1-Q4: the scene's report times after it are dropped, and the
    last field written is at the run's end, t = steps x dt (0.392 s), not at the last
    report time; the run says so."""
    res = cli(QUIET + ["-mpm_Tv_end", "0.1"], options_file=M1, out_dir=tmp_path)
    s = check_ok(res)
    t_end = s["steps"] * s["consolidation"]["dt"]
    assert t_end == pytest.approx(0.1 * 1.0 ** 2 / s["consolidation"]["c_v"], rel=1e-3)
    times = [t for t, _ in _times(tmp_path / "points.xdmf")]
    assert times[-1] == pytest.approx(t_end, rel=1e-14) and times[0] < t_end / 4
    assert s["consolidation"]["fields"]["last_step"] == s["steps"] and s["consolidation"]["fields"][
        "times"
    ] == len(times)
    assert (f"the last at t = {t_end:.6g} s (step {s['steps']} of {s['steps']})"
            in res.stdout)


# -- item 3: signals at any point ---------------------------------------------------------
def _signal_in(monkeypatch, target, signum):
    """Make ``target`` ("module.function") send ``signum`` to this process, then go on:
    the signal arrives at that point of the run, as Ctrl-C or a scheduler's SIGTERM would."""
    import importlib

    module, name = target.rsplit(".", 1)
    real = getattr(importlib.import_module(module), name)

    def signalled(*args, **kwargs):
        os.kill(os.getpid(), signum)
        return real(*args, **kwargs)
    monkeypatch.setattr(target, signalled)


@pytest.mark.parametrize("target, signum, stage", [
    ("solver.stepping.timestep.discrete_limit", signal.SIGINT,
     "set-up: the stability analysis"),
    ("solver.modal.frequency.fundamental_frequency", signal.SIGTERM,
     "set-up: the fundamental frequency f1"),
    ("solver.stepping.inertia.scaling", signal.SIGINT,
     "set-up: the time scheme and mass scaling")])
def test_signal_in_the_set_up(cli, tmp_path, monkeypatch, target, signum, stage):
    _signal_in(monkeypatch, target, signum)
    res = cli(QUIET + ["-mpm_mass_scaling", "auto"], options_file=M1, out_dir=tmp_path)
    name = signal.Signals(signum).name
    assert res.returncode == 4, res.stderr
    assert res.stderr == (f"solver: error: stopped by {name} during {stage}; "
                          f"summary {tmp_path / 'summary.json'}\n")
    s = res.summary
    assert s["completed"] is False and s["steps"] == 0
    assert s["error"] == {"kind": "interrupted", "exit_code": 4, "stage": stage,
                          "message": f"stopped by {name} during {stage}"}
    assert s["provenance"]["options"]["mpm"]["mass_scaling"] == "auto" and s["run_id"]
    assert os.listdir(tmp_path) == ["summary.json"]        # no step: no checkpoint
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_signal_in_the_reporting_checkpoints_the_whole_run(cli, tmp_path, monkeypatch):
    """A signal after the last step, while the results are written: exit 4, a checkpoint
    of the whole run, from which -mpm_restart alone does the reporting again."""
    _signal_in(monkeypatch, "solver.consolidation.reporting.write_files", signal.SIGTERM)
    res = cli(QUIET + ["-mpm_Tv_end", "0.02"], options_file=M1, out_dir=tmp_path)
    assert res.returncode == 4, res.stderr
    ckpt = tmp_path / "checkpoint.npz"
    assert res.stderr.startswith("solver: error: stopped by SIGTERM during reporting; "
                                 f"checkpoint {ckpt} at step 1071 (continue with "
                                 f"-mpm_restart {ckpt}), summary ")
    assert res.stderr.count("\n") == 1
    s = res.summary
    assert s["completed"] is False and s["error"]["stage"] == "reporting"
    assert s["files"]["checkpoint"] == str(ckpt)
    monkeypatch.undo()
    again = check_ok(cli(["-mpm_restart", ckpt], out_dir=tmp_path))
    assert again["steps"] == 1071 and again["run_id"] == s["run_id"]


def test_signal_in_the_eigen_analysis(cli, tmp_path, monkeypatch):
    _signal_in(monkeypatch, "solver.modal.jacobi.solve", signal.SIGTERM)
    res = cli(["-mpm_figures", "0"], options_file="eigen-q4", out_dir=tmp_path)
    assert res.returncode == 4, res.stderr
    assert res.stderr == ("solver: error: stopped by SIGTERM during solving: Jacobi; "
                          f"summary {tmp_path / 'summary.json'}\n")
    s = res.summary
    assert s["analysis"] == "eigen" and s["completed"] is False
    assert s["error"]["kind"] == "interrupted" and s["eigen"]["ndof"] > 0


def test_ctrl_c_in_the_stability_analysis_of_m3(tmp_path):
    """The reported case end to end: Ctrl-C (SIGINT) while M3-Q4's stability analysis runs,
    then SIGTERM in the steps; both exit 4 with one line and no traceback, and the
    second's printed hint, run alone, finishes the run."""
    out = tmp_path / "m3"
    cmd = [PYTHON, "-m", "solver", "-options_file", str(CASES / "consolidation-m3-q4.opts"),
           "-mpm_figures", "0", "-mpm_progress", "0.2", "-mpm_Tv_end", "0.3",
           "-mpm_output", str(out)]
    for wait_for, signum in (("Stability analysis of the step", signal.SIGINT),
                             ("  step ", signal.SIGTERM)):      # a progress line
        proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                                text=True, env=clean_env())
        for line in proc.stdout:
            if line.startswith(wait_for):
                time.sleep(0.3)
                proc.send_signal(signum)
                break
        _, stderr = proc.communicate(timeout=180)
        assert proc.returncode == 4, stderr
        assert stderr.count("\n") == 1 and "Traceback" not in stderr, stderr
        s = _summary(out)
        assert s["completed"] is False and s["error"]["kind"] == "interrupted"
    assert s["error"]["stage"] == "stepping", stderr
    hint = stderr.split("continue with ")[1].split()
    assert hint == ["-mpm_restart", str(out / "checkpoint.npz")]
    code, _, err = run_command([sys.executable, "-m", "solver", *hint])
    assert code == 0, err
    assert _summary(out)["completed"] is True and _summary(out)["run_id"] == s["run_id"]
