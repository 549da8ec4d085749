"""Hostile input, tried systematically: every failure is a clean exit code and one line.

Random option values (seeded), negative, huge and non-finite numbers, truncated and corrupted
scene files and checkpoints. Each run must end with exit code 0, 2 (bad input) or 3
(numerical failure); when it fails, stderr holds exactly one `solver: error:` line and no
Python traceback.
"""

from __future__ import annotations

import random

import pytest
from conftest import REPO, clean_env, typed

JUNK = ["", "nan", "inf", "-inf", "1e31", "-1e31", "-1", "0", "abc", "1,2,3", ",", "1e-320",
        "99999999999", "0x10", "1..2", "  ", "true", "-0", "1,nan", "q5", "4,", ",4"]


def _clean(res):
    assert res.returncode in (0, 2, 3), (res.returncode, res.stderr[-2000:])
    assert "Traceback" not in res.stderr, res.stderr[-2000:]
    if res.returncode:
        lines = res.stderr.strip().splitlines()
        assert len(lines) == 1 and lines[0].startswith("solver: error: "), res.stderr[-2000:]


def test_every_option_with_junk_in_process():
    """Each -mpm_ option with each junk value: parsed, or an InputError naming it."""
    from petsc4py import PETSc

    from solver.common.errors import InputError
    from solver.io import options

    for opt in options.SPEC:
        analysis = "eigen" if "eigen" in opt.used_by else opt.used_by[0]
        for value in JUNK:
            db = PETSc.Options()
            for key in list(db.getAll()):
                db.delValue(key)
            db.setValue("mpm_analysis", analysis)
            db.setValue(f"mpm_{opt.name}", value)
            try:
                options.read(db=db)
            except InputError as exc:
                text = str(exc)
                assert "\n" not in text and f"-mpm_{opt.name}" in text, (opt.name, value, text)
            finally:
                for key in list(db.getAll()):
                    db.delValue(key)


EIGEN_ARGS = ["-mpm_figures", "0"]
CONS_ARGS = ["-mpm_figures", "0", "-mpm_progress", "0", "-mpm_Tv_end", "0.002",
             "-mpm_Tv_report", "0.002"]


@pytest.mark.parametrize("seed", range(12))
def test_random_option_values_on_the_command_line(cli, tmp_path, seed):
    from solver.io import options

    rng = random.Random(seed)
    scene, base = rng.choice([("eigen-q4", EIGEN_ARGS), ("consolidation-m1-q4", CONS_ARGS)])
    analysis = "eigen" if scene.startswith("eigen") else "consolidation"
    usable = [o for o in options.SPEC if analysis in o.used_by and o.name not in
              ("analysis", "output", "summary", "restart", "Tv_end", "progress",
                        "debug")]
    args = list(base)
    for opt in rng.sample(usable, 3):
        value = rng.choice(JUNK + ["2", "0.3", "1e6", "-5", "3,7", "q9", "gauss"])
        args += [f"-mpm_{opt.name}", value]
    _clean(cli(args, options_file=scene, timeout=120))


@pytest.mark.parametrize("seed", range(6))
def test_truncated_and_corrupted_scene_files(cli, tmp_path, seed):
    rng = random.Random(100 + seed)
    data = (REPO / "cases" / "eigen-q4.opts").read_bytes()
    if seed % 2:
        data = data[: rng.randrange(len(data))]
    else:
        data = bytearray(data)
        for _ in range(5):
            data[rng.randrange(len(data))] = rng.randrange(256)
        data = bytes(data)
    scene = tmp_path / "scene.opts"
    scene.write_bytes(data)
    out = tmp_path / "out"
    res = cli(EIGEN_ARGS + ["-mpm_output", out], options_file=scene, out_dir=out)
    _clean(res)
    if res.returncode == 2:
        assert not out.exists()


def test_malformed_scene_file_names_file_and_line(cli, tmp_path):
    scene = tmp_path / "bad.opts"
    scene.write_text("-mpm_analysis eigen\n# fine\nmpm_E 10e6\n")
    res = cli([], options_file=scene)
    assert res.returncode == 2
    assert f"{scene}:3:" in res.stderr and res.stderr.count("\n") == 1


def test_bad_value_in_a_scene_file_names_its_line(cli, tmp_path):
    scene = tmp_path / "bad.opts"
    scene.write_text("-mpm_analysis eigen\n-mpm_nu 0.7\n")
    res = cli([], options_file=scene)
    assert res.returncode == 2
    assert "-mpm_nu" in res.stderr and f"{scene}:2" in res.stderr


@pytest.mark.parametrize("seed", range(4))
def test_corrupted_checkpoint(cli, tmp_path, seed):
    ck = cli(CONS_ARGS + ["-mpm_checkpoint_every", "10"], options_file="consolidation-m1-q4",
             out_dir=tmp_path / "ck")
    assert ck.returncode == 0
    path = tmp_path / "ck" / "checkpoint.npz"
    data = bytearray(path.read_bytes())
    rng = random.Random(seed)
    for _ in range(20):
        data[rng.randrange(len(data))] = rng.randrange(256)
    path.write_bytes(bytes(data))
    res = cli(CONS_ARGS + ["-mpm_restart", path], options_file="consolidation-m1-q4",
              out_dir=tmp_path / "rest")
    _clean(res)


def test_too_large_a_model_is_refused(cli, tmp_path):
    res = cli(["-mpm_cells", "100000,100000"], options_file="consolidation-m1-q4")
    assert res.returncode == 2 and "GiB" in res.stderr


def test_too_many_steps_are_refused(cli, tmp_path):
    res = cli(CONS_ARGS[:4] + ["-mpm_Tv_end", "1e12", "-mpm_Tv_report", "1"],
              options_file="consolidation-m1-q4")
    assert res.returncode == 2 and "-mpm_Tv_end" in res.stderr


def test_point_leaving_the_grid_stops_the_run(cli, tmp_path):
    """An unsupported column falling under gravity: its lowest points leave the grid. (Its
    base impermeable: a drained base would stand in the water table, whose pressure buoys
    the column.)"""
    res = cli(["-mpm_load", "0", "-mpm_gravity", "9.81", "-mpm_bc_bottom", "none",
               "-mpm_drained", "top", "-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.05",
               "-mpm_progress", "0", "-mpm_figures", "0"], options_file="consolidation-m1-q4",
              timeout=300)
    assert res.returncode == 3
    line = res.stderr.strip()
    assert "\n" not in line and "left the grid" in line and "step" in line
    assert res.summary["error"]["kind"] == "numerical"
    # Free fall: the lowest points (y = 0.025 m) leave after sqrt(2 y / g) = 0.071 s or
    # later, as the self-weight compresses the falling column (measured 0.103 s).
    t = float(line.split("t = ")[1].split(" ")[0])
    assert 0.06 < t < 0.12


def test_inverted_point_stops_the_run(cli, tmp_path):
    """1 GPa on a 10 MPa soil: the undrained strain q / (K_l/n + E_c) > 1 inverts points.
    With moving points and pressures kept per point: with small kinematics a point leaves
    the grid before its volume ratio turns negative, and with the projection the pressure
    blows up first (the tests above cover both messages)."""
    res = cli(["-mpm_load", "1e9", "-mpm_Tv_end", "0.01", "-mpm_Tv_report", "0.01",
               "-mpm_progress", "0", "-mpm_figures", "0", "-mpm_kinematics", "large",
               "-mpm_pressure_projection", "none"], options_file="consolidation-m1-q4")
    assert res.returncode == 3
    line = res.stderr.strip()
    assert "\n" not in line and line.startswith("solver: error: inverted: volume ratio J = -")
    assert "material point" in line and res.summary["error"]["kind"] == "numerical"


def test_non_finite_values_are_caught():
    """A NaN in one point's pore pressure stops the run and names the point and step."""
    import numpy as np
    from petsc4py import PETSc

    from solver.common.errors import NumericalError
    from solver.stepping.twophase import TwoPhase, point_fields
    from solver.io import options
    from solver.model.grid import Grid
    from solver.model.points import place

    db = PETSc.Options()
    for key in list(db.getAll()):
        db.delValue(key)
    db.setValue("mpm_analysis", "consolidation")
    try:
        p = options.read(db=db)
    finally:
        db.delValue("mpm_analysis")
    grid = Grid(PETSc.COMM_WORLD, p.element, p.cells, p.size)
    t = typed(p)
    points = place(grid, p.ppc, t.soil.density, "uniform", point_fields(t.scheme))
    with points.fields("J", "id") as (J, ids):
        J[:] = 1.0
        ids[:] = np.arange(len(ids))
    model = TwoPhase(grid, points, t.soil, t.body, t.loading, t.scheme)
    model.check(1, 0.0, 1e4)                      # a sound state passes
    with points.fields("p") as pp:
        pp[3] = np.nan
    with pytest.raises(NumericalError, match=r"non-finite values at material point 3 .*step 7"):
        model.check(7, 0.5, 1e4)


def test_sigint_and_timed_checkpoints(tmp_path):
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "solver", "-options_file",
           str(REPO / "cases" / "consolidation-m1-q4.opts"), "-mpm_progress", "0",
           "-mpm_figures", "0", "-mpm_checkpoint_seconds", "0.2", "-mpm_output", str(out)]
    # clean_env: without it the child inherits the MPI identity of this process (PMIX_*,
    # OMPI_MCA_ess).
    proc = subprocess.Popen(cmd, cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, env=clean_env())
    deadline = time.time() + 120
    while not (out / "checkpoint.npz").exists() and time.time() < deadline:
        time.sleep(0.05)
    assert (out / "checkpoint.npz").exists(), "no timed checkpoint"
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 4 and "SIGINT" in stderr and stderr.count("\n") == 1


@pytest.mark.parametrize("top", ["xy", "y"])
def test_load_on_a_fixed_top_is_refused(cli, tmp_path, top):
    """A surface load on a top held vertically: the support would carry
    it and U_p = 1 would read as consolidation; one line naming the option, nothing written."""
    out = tmp_path / "out"
    res = cli(["-mpm_bc_top", top, "-mpm_output", str(out)], options_file="consolidation-m1-q4")
    assert res.returncode == 2
    assert res.stderr.strip() == (f"solver: error: -mpm_bc_top {top}: a top fixed vertically "
                                  "cannot carry -mpm_load 10000 (use -mpm_bc_top none or x, "
                                  "or -mpm_load 0)")
    assert not out.exists()
