"""What the command line promises and the run keeps: each check runs
the command and asserts its exit code, its one-line message and the files it writes."""

from __future__ import annotations

import json
import os
import re
import sys

import numpy as np
import pytest

from conftest import CASES, REPO, check_ok, run_command

QUIET = ["-mpm_progress", "0", "-mpm_figures", "0"]
M1 = "consolidation-m1-q4"


def _error_line(stderr):
    """The one line of a refused command (asserting there is only that one)."""
    lines = stderr.strip().splitlines()
    assert len(lines) == 1, stderr
    return lines[0]


def _solver(args, cwd, **kw):
    """``python -m solver ARGS`` in a fresh process started in ``cwd`` (this worktree's
    solver first on the path): (exit code, stdout, stderr)."""
    return run_command([sys.executable, "-m", "solver", *args], cwd=cwd,
                       env={"PYTHONPATH": str(REPO)}, **kw)


def test_command_line_wins_before_the_scene_file(tmp_path):
    """Options before -options_file win over the scene's: the run goes to the folder the
    command line names, with its number of modes; the scene's folder is not written."""
    code, out, err = _solver(["-mpm_nmodes", "2", "-mpm_output", "mine",
                              "-mpm_eigen_solver", "jacobi", "-mpm_figures", "0",
                              "-options_file", CASES / "eigen-q4.opts"], tmp_path)
    assert code == 0, err
    assert not (tmp_path / "output").exists()
    with open(tmp_path / "mine" / "summary.json") as fh:
        summary = json.load(fh)
    assert len(summary["eigen"]["frequencies_hz"]["jacobi"]) == 2


def test_restart_ending_before_its_checkpoint_is_refused(cli, tmp_path):
    """A restart whose -mpm_Tv_end lies before the checkpoint's step (700 of M1-Q4's 1071
    to T_v 0.02: T_v 0.0131) exits 2 naming the end and the checkpoint's T_v, and writes
    nothing; the checkpoint's own folder is left as it was."""
    first = tmp_path / "first"
    assert cli(QUIET + ["-mpm_Tv_end", "0.02", "-mpm_checkpoint_every", "700"],
               options_file=M1, out_dir=first).returncode == 0
    before = sorted(os.listdir(first))
    ckpt = first / "checkpoint.npz"
    res = cli(["-mpm_restart", ckpt, "-mpm_Tv_end", "0.01"], out_dir=tmp_path / "again")
    assert res.returncode == 2
    line = _error_line(res.stderr)
    assert line.startswith("solver: error: -mpm_Tv_end 0.01: before the state of "
                           f"-mpm_restart {ckpt} (step 700,")
    tv = float(re.search(r"T_v = ([0-9.e-]+)\)", line).group(1))
    assert abs(tv - 0.02 * 700 / 1071) < 0.02 / 1071        # within a step of step 700
    assert not (tmp_path / "again").exists()
    assert sorted(os.listdir(first)) == before


def test_footing_narrower_than_the_point_spacing(cli, tmp_path):
    """A footing that covers no column of material points (points every 0.0625 m from
    x = 0.03125 m on the strip scene's 16 x 8 cells) exits 2 in one line naming -mpm_load_extent and the
    narrowest load that works, and writes nothing; that load runs, its settlement under
    the load measured and set beside the static ends."""
    res = cli(QUIET + ["-mpm_cells", "16,8", "-mpm_load_extent", "0,0.02"],
              options_file="consolidation-strip")
    assert res.returncode == 2
    assert _error_line(res.stderr) == (
        "solver: error: -mpm_load_extent 0,0.02: covers no column of material points, where "
        "the settlement under the load is measured; the narrowest load that works from "
        "there is -mpm_load_extent 0,0.03125 (0.03125 m wide, to the points at x = "
        "0.03125 m)")
    assert not (tmp_path / "out").exists()
    res = cli(QUIET + ["-mpm_cells", "16,8", "-mpm_load_extent", "0,0.03125", "-mpm_Tv_end",
                       "0.001", "-mpm_stability_analysis", "0"],
              options_file="consolidation-strip")
    summary = check_ok(res)
    assert res.stderr == ""
    ends = summary["consolidation"]["static_references"]
    assert 0 < ends["undrained_m"] < ends["final_m"]
    assert ends["settlement_last_m"] > 0


# -- every KSP and EPS checks that it converged (exit 3) ---------------------------------
def test_static_solve_that_does_not_converge_exits_3(cli, tmp_path):
    """The static ends of the strip footing by 5 iterations of Jacobi-preconditioned CG
    (far from the solution): exit 3 naming the solve, its options and the reason, not a
    settlement of a few per cent of the true one."""
    res = cli(QUIET + ["-static_ksp_type", "cg", "-static_pc_type", "jacobi",
                       "-static_ksp_max_it", "5", "-mpm_Tv_end", "0.001",
                       "-mpm_stability_analysis", "0"], options_file="consolidation-strip")
    assert res.returncode == 3
    assert _error_line(res.stderr) == (
        "solver: error: the static undrained settlement (options -static_ksp_*, "
        "-static_pc_*): KSP cg did not converge (DIVERGED_MAX_IT after 5 iterations)")
    assert "Settlement under the load" not in res.stdout


@pytest.mark.parametrize("given, said", [
    (["-eps_max_it", "1", "-eps_ncv", "6", "-eps_tol", "1e-16"],
     "SLEPc's eigensolve (options -eps_*, -st_*): EPS krylovschur did not converge "
     "(DIVERGED_ITS after 1 iterations)"),
    (["-st_ksp_type", "cg", "-st_pc_type", "jacobi", "-st_ksp_max_it", "2"],
     "SLEPc's eigensolve's linear solves (options -st_ksp_*, -st_pc_*): KSP cg did not "
     "converge (DIVERGED_MAX_IT after 2 iterations)"),
])
def test_eigensolve_that_does_not_converge_exits_3(cli, given, said):
    """SLEPc stopped at its iteration limit, or its shift-and-invert's linear solves at
    theirs: exit 3 with the reason, the summary saying the run did not complete."""
    res = cli(["-mpm_figures", "0", "-mpm_eigen_solver", "slepc", *given],
              options_file="eigen-q4")
    assert res.returncode == 3
    assert _error_line(res.stderr).startswith(f"solver: error: {said}")
    assert res.summary["completed"] is False and res.summary["error"]["exit_code"] == 3


def test_f1_solve_that_does_not_converge_exits_3(cli):
    """f1 by SLEPc with linear solves that stop short is the run's failure (exit 3), not
    a dropped criterion: the options chose that solver."""
    res = cli(QUIET + ["-mpm_eigen_solver", "slepc", "-f1_st_ksp_type", "cg",
                       "-f1_st_pc_type", "jacobi", "-f1_st_ksp_max_it", "2",
                       "-mpm_Tv_end", "0.01"], options_file=M1)
    assert res.returncode == 3
    assert _error_line(res.stderr) == (
        "solver: error: SLEPc's eigensolve's linear solves (options -f1_st_ksp_*, "
        "-f1_st_pc_*): KSP cg did not converge (DIVERGED_MAX_IT after 2 iterations)")


def test_biot_solve_that_does_not_converge_raises():
    """The Biot reference's steps by 2 iterations of unpreconditioned GMRES: NotConverged
    (a NumericalError, exit 3 where a command runs it), not a wrong reference."""
    from petsc4py import PETSc

    from solver.common.errors import NotConverged, NumericalError
    from solver.io import options
    from solver.references import biot

    with options.command_line(["test", "-biot_ksp_type", "gmres", "-biot_pc_type", "none",
                               "-biot_ksp_max_it", "2"]):
        with pytest.raises(NotConverged) as err:
            biot.solve(PETSc.COMM_SELF, biot.Body(size=(0.1, 1.0)), [1.0], [[0.05, 0.5]],
                       cells=(1, 4))
    assert isinstance(err.value, NumericalError)
    assert str(err.value) == ("biot: the step's solve (options -biot_ksp_*, -biot_pc_*): "
                              "KSP gmres did not converge (DIVERGED_MAX_IT after 2 "
                              "iterations)")


# -- the wall time of every phase, from the command's start ------------------------------
def test_wall_time_counts_every_phase_from_the_process_start(tmp_path):
    """The last line gives the total and the set-up, stepping and reporting in it, from
    the process's own start: a second slept before the command line runs is in the set-up
    and the total; the summary's ``wall`` holds the same, the phases summing to the
    total, which fits within the time the parent saw the process run."""
    import time

    script = ("import sys, time; time.sleep(1.0); from solver.__main__ import main; "
              "sys.exit(main(sys.argv))")
    t0 = time.perf_counter()
    code, out, err = run_command(
        [sys.executable, "-c", script, "-options_file", CASES / f"{M1}.opts", *QUIET,
         "-mpm_Tv_end", "0.01", "-mpm_output", tmp_path / "out"], cwd=tmp_path,
        env={"PYTHONPATH": str(REPO)})
    elapsed = time.perf_counter() - t0
    assert code == 0, err
    with open(tmp_path / "out" / "summary.json") as fh:
        summary = json.load(fh)
    wall = summary["wall"]
    assert set(wall) == {"setup_s", "stepping_s", "reporting_s", "total_s"}
    assert wall["setup_s"] + wall["stepping_s"] + wall["reporting_s"] == pytest.approx(
        wall["total_s"], abs=1e-9)
    assert min(wall.values()) >= 0
    assert 1.0 <= wall["setup_s"] and wall["total_s"] <= elapsed
    last = out.strip().splitlines()[-1]
    assert last == (f"Wall time {wall['total_s']:.1f} s: set-up {wall['setup_s']:.1f} s, "
                    f"stepping {wall['stepping_s']:.1f} s, reporting "
                    f"{wall['reporting_s']:.1f} s; summary {tmp_path / 'out' / 'summary.json'}")


# -- per-layer and per-fluid values -------------------------------------------------------
LAYERED = dict(layers="1,3", size="0.1,4", cells="1,20", E="40e6,5e6", nu="0.25,0.3",
               rho_s="2650,2700", porosity="0.35,0.5", gravity=9.81,
               initial_state="geostatic", load=5e4)


@pytest.mark.parametrize("K0, want", [("0.5,0.6", (0.5, 0.6)), ("0.45", (0.45, 0.45)),
                                      (None, (0.25 / 0.75, 0.3 / 0.7))])
def test_geostatic_start_takes_K0_per_layer(K0, want):
    """The geostatic start of a layered column sets sigma'_xx = K0 sigma'_yy with each
    layer's K0: one per layer as given, one for all, or each layer's nu / (1 - nu)."""
    from petsc4py import PETSc

    from conftest import scene_options
    from solver.stepping import twophase
    from solver.model import scene
    from solver.model.soil import Ground

    p = scene_options(**LAYERED, **({"K0": K0} if K0 else {}))
    ground = Ground.from_options(p)
    body = scene.Body.from_options(p)
    grid, points = scene.two_phase_body(PETSc.COMM_SELF, body, ground,
                                        dict(twophase.POINT_FIELDS, layer=1))
    try:
        scene.geostatic_state(points, body, ground, scene.Loading.from_options(p))
        with points.fields("stress", "layer", "x0") as (sig, layer, x0):
            assert np.all(sig[:, 1] < 0)
            assert set(layer.astype(int)) == {0, 1}
            np.testing.assert_allclose(sig[:, 0] / sig[:, 1],
                                       np.array(want)[layer.astype(int)], rtol=1e-14)
            assert np.array_equal(layer.astype(int), (x0[:, 1] < 3.0).astype(int))
    finally:
        scene.destroy(points, grid)


def test_K0_per_layer_runs_and_counts_its_layers(cli, tmp_path):
    """-mpm_K0 with one value per layer runs the layered scene and is recorded; a count
    that is not the layers' exits 2 in one line, as for the material options."""
    short = QUIET + ["-mpm_Tv_end", "0.001", "-mpm_stability_analysis", "0"]
    summary = check_ok(cli(short + ["-mpm_K0", "0.5,0.6"],
                           options_file="consolidation-layered"))
    assert summary["provenance"]["options"]["mpm"]["K0"] == [0.5, 0.6]
    res = cli(short + ["-mpm_K0", "0.5,0.6,0.7"], options_file="consolidation-layered",
              out_dir=tmp_path / "three")
    assert res.returncode == 2
    assert _error_line(res.stderr) == (
        "solver: error: -mpm_K0 0.5,0.6,0.7: 3 values for 2 layer(s) of -mpm_layers; give "
        "one value or one per layer")
    assert not (tmp_path / "three").exists()


@pytest.mark.parametrize("name", ["rho_l", "K_l", "mu_l"])
def test_fluid_per_layer_is_one_line(cli, tmp_path, name):
    """The pore water's properties take one value: a list exits 2 in one line saying the
    water is one fluid (not 'could not convert string to float')."""
    res = cli(QUIET + [f"-mpm_{name}", "1000,1100"], options_file="consolidation-layered")
    assert res.returncode == 2
    assert _error_line(res.stderr) == (
        f"solver: error: -mpm_{name} 1000,1100: one value: the pore water is one fluid, the "
        "same in every layer (per layer: -mpm_E, -mpm_nu, -mpm_rho_s, -mpm_porosity, "
        "-mpm_k, -mpm_K0, -mpm_cohesion, -mpm_friction_angle, -mpm_dilation_angle, "
        "-mpm_tension_cutoff, -mpm_reference_strain)")
    assert not (tmp_path / "out").exists()


# -- advice that fits the analysis ----------------------------------------------------------
def test_memory_advice_fits_the_analysis(cli, tmp_path, monkeypatch):
    """On a 16 GiB machine: a consolidation model too large is told to use fewer cells or
    points (it has no eigen solver to change); an eigen model whose Jacobi matrices alone
    do not fit is told SLEPc's need, under the limit; one too large for SLEPc as well is
    not told to use it. Nothing is written."""
    from solver.io import memory

    monkeypatch.setattr(memory, "available", lambda: 16 * 2**30)
    res = cli(QUIET + ["-mpm_cells", "2000,2000"], options_file=M1)
    assert res.returncode == 2
    line = _error_line(res.stderr)
    assert line.startswith("solver: error: -mpm_cells 2000,2000: the model needs about ")
    assert line.endswith("more than this machine's 16.0 GiB allows (fewer cells, or fewer "
                         "points per cell (-mpm_ppc))")
    res = cli(["-mpm_figures", "0", "-mpm_cells", "40,400"], options_file="eigen-q4")
    assert res.returncode == 2
    line = _error_line(res.stderr)
    slepc = float(re.search(r"with -mpm_eigen_solver slepc it needs about ([0-9.]+) GiB",
                            line).group(1))
    assert slepc < 0.8 * 16 and line.endswith("; or fewer cells, or fewer points per cell "
                                              "(-mpm_ppc))")
    res = cli(["-mpm_figures", "0", "-mpm_cells", "2000,2000"], options_file="eigen-q4")
    assert res.returncode == 2 and "slepc" not in _error_line(res.stderr)
    assert not (tmp_path / "out").exists()


# -- scripts/install waits for another apt ---------------------------------------------------
FAKE_APT = """#!/bin/bash
echo "$*" >> "$FAKE_LOG"
if [ "$1" = update ]; then
    n=$(cat "$FAKE_STATE" 2>/dev/null || echo 0)
    echo $((n + 1)) > "$FAKE_STATE"
    if [ "$n" -lt "$FAKE_FAILS" ]; then
        echo "E: Could not get lock /var/lib/apt/lists/lock. It is held by process 1 (apt-get)" >&2
        exit 100
    fi
fi
"""


def _install(tmp_path, fails, wait=None):
    """scripts/install in a copy of its folder, with apt-get, sudo and ln stand-ins on PATH
    (apt-get update failing on its lock ``fails`` times) and a .venv Python that does
    nothing: (exit code, stderr, the apt-get calls)."""
    import shutil

    root = tmp_path / "repo"
    (root / "scripts").mkdir(parents=True)
    shutil.copy(REPO / "scripts" / "install", root / "scripts" / "install")
    fake = tmp_path / "bin"
    fake.mkdir()
    for name, text in {"apt-get": FAKE_APT, "sudo": '#!/bin/sh\nexec "$@"\n',
                       "ln": "#!/bin/sh\nexit 0\n"}.items():
        (fake / name).write_text(text)
        (fake / name).chmod(0o755)
    (root / ".venv" / "bin").mkdir(parents=True)
    (root / ".venv" / "bin" / "python").write_text("#!/bin/sh\nexit 0\n")
    (root / ".venv" / "bin" / "python").chmod(0o755)
    log = tmp_path / "apt.log"
    env = {"PATH": f"{fake}:{os.environ['PATH']}", "FAKE_LOG": str(log),
           "FAKE_STATE": str(tmp_path / "state"), "FAKE_FAILS": str(fails)}
    if wait is not None:
        env["MPM_GEO_APT_WAIT"] = str(wait)
    code, _, err = run_command(["bash", root / "scripts" / "install"], cwd=root, env=env)
    return code, err, log.read_text().splitlines() if log.exists() else []


def test_install_waits_for_the_package_lock(tmp_path):
    """apt-get update is tried again while another process holds the lists' lock (one line
    says it waits), and apt-get install waits for dpkg's lock by itself."""
    code, err, calls = _install(tmp_path, fails=1)
    assert code == 0, err
    assert calls[:2] == ["update -qq", "update -qq"]
    assert calls[2].startswith("install -o DPkg::Lock::Timeout=600 -y -qq ")
    assert err.count("waiting for it (up to 600 s, MPM_GEO_APT_WAIT)") == 1


def test_install_stops_when_the_lock_stays(tmp_path):
    """With no time to wait (MPM_GEO_APT_WAIT=0) a held lock stops the install with apt's
    own message, before anything is installed."""
    code, err, calls = _install(tmp_path, fails=5, wait=0)
    assert code != 0
    assert "Could not get lock /var/lib/apt/lists/lock" in err
    assert calls == ["update -qq"]


# -- a Python without PETSc ------------------------------------------------------------------
def test_python_without_petsc_says_how_to_activate_the_venv(tmp_path):
    """``python3 -m solver`` under a Python that cannot import petsc4py (here the same
    interpreter without its site-packages, -S, as a pyenv's python3 first on PATH) exits 2
    with one line saying how to activate .venv, not a traceback; nothing is written."""
    code, out, err = run_command([sys.executable, "-S", "-m", "solver", "-options_file",
                                  CASES / "eigen-q4.opts", "-mpm_output", tmp_path / "out"])
    assert code == 2 and out == ""
    venv = REPO / ".venv" / "bin"
    where = (f"activate the repository's environment (. {venv}/activate), or run "
             f"{venv}/python -m solver" if os.access(venv / "python", os.X_OK) else
             f"there is no {venv}/python: bash {REPO}/scripts/install creates it")
    assert _error_line(err) == (f"solver: error: petsc4py cannot be imported by "
                                f"{sys.executable}: {where}")
    assert not (tmp_path / "out").exists()
