"""Consolidation of soil that yields (-mpm_material in the implicit scheme: Newton at each
stage, solver/consolidation/implicit/yielding.py): a soil too strong to yield runs as the
linear scheme does, an undrained column fails where its closed form says, ranks agree, a
restart takes up the history, and the clay footing scene runs to the end."""

from __future__ import annotations

import meshio
import numpy as np
import pytest

from conftest import check_ok

STRIP = ["-mpm_analysis", "consolidation", "-mpm_figures", "0", "-mpm_fe_reference", "0",
         "-mpm_size", "1,0.5", "-mpm_cells", "8,4", "-mpm_load", "10e3",
         "-mpm_load_extent", "0,0.25", "-mpm_E", "10e6", "-mpm_nu", "0.3", "-mpm_k", "2.5e-4",
         "-mpm_gravity", "0", "-mpm_Tv_end", "0.5", "-mpm_Tv_report", "0.05,0.5"]


def test_a_soil_too_strong_to_yield_runs_as_the_linear_scheme(cli, tmp_path):
    """Tresca with c_u = 1e9 Pa never yields: its Newton (the same equations with the
    material's stress and tangent) gives the linear scheme's pore pressure and settlement
    within 1e-8 of q and of the settlement, in at most 2 iterations per stage."""
    linear = check_ok(cli(STRIP, out_dir=tmp_path / "linear"))["consolidation"]
    strong = check_ok(cli(STRIP + ["-mpm_material", "tresca", "-mpm_cohesion", "1e9"],
                          out_dir=tmp_path / "strong"))["consolidation"]
    np.testing.assert_allclose(strong["monitor"]["p_over_q"], linear["monitor"]["p_over_q"],
                               rtol=0, atol=1e-8)
    s0 = np.array(linear["consolidation_degree"]["settlement_m"])
    np.testing.assert_allclose(strong["consolidation_degree"]["settlement_m"], s0,
                               rtol=1e-8)
    its = strong["implicit"]
    assert its["newton_solves"] == 2 * its["steps"] + 1 and its["newton_most"] <= 2


def test_a_weaker_soil_yields_and_settles_more(cli, tmp_path):
    """The same strip on Tresca soil with c_u = 2.5 kPa (the load 10 kPa is 0.78 of
    Prandtl's (2 + pi) c_u): it yields under the load's edge, settles more than the
    elastic soil at every report, and Newton converges within 12 iterations a stage."""
    linear = check_ok(cli(STRIP, out_dir=tmp_path / "linear"))["consolidation"]
    weak = check_ok(cli(STRIP + ["-mpm_material", "tresca", "-mpm_cohesion", "2.5e3"],
                        out_dir=tmp_path / "weak"))["consolidation"]
    s_lin = np.array(linear["consolidation_degree"]["settlement_m"])
    s_weak = np.array(weak["consolidation_degree"]["settlement_m"])
    assert np.all(s_weak > 1.05 * s_lin)
    assert weak["implicit"]["newton_most"] <= 12
    assert not weak["reference"]["available"]     # every reference here is linear


RAMPED = ["-mpm_element", "q9", "-mpm_ppc", "3", "-mpm_material", "tresca",
          "-mpm_cohesion", "2.5e3", "-mpm_load_ramp", "0.01", "-mpm_stability_analysis", "0"]


def test_the_explicit_step_and_the_implicit_scheme_agree_on_a_yielding_strip(cli, tmp_path):
    """The strip on Tresca soil (c_u 2.5 kPa) on Q9 8 x 4 cells, the load ramped over
    0.01 s (T_v 0.014: a sudden load's dynamic overshoot would yield the explicit step's
    soil further, a physical difference): the explicit step (the stress from the
    material at each step, implicit drag, mass scaling S = 0.006) and the implicit scheme
    agree within 0.5 % of q at the monitor and 3 % / 0.5 % in the settlement at T_v 0.05 /
    0.5 (measured: 0.21 and 0.20 % of q, 1.3 and 0.04 %). S is pinned: auto's 0.0624 keeps
    the elastic body's inertia within 0.2 % of q, but the soil yields further under it
    (0.55 % of q)."""
    runs = [check_ok(cli(STRIP + RAMPED + extra, out_dir=tmp_path / name))["consolidation"]
            for name, extra in (("implicit", []), ("explicit", [
                "-mpm_scheme", "explicit", "-mpm_drag", "implicit", "-mpm_mass_scaling",
                "0.006"]))]
    imp, exp = runs
    assert exp["scheme"] == "explicit" and imp["scheme"] == "implicit"
    np.testing.assert_allclose(exp["monitor"]["p_over_q"], imp["monitor"]["p_over_q"],
                               rtol=0, atol=5e-3)
    s_imp = np.array(imp["consolidation_degree"]["settlement_m"])
    s_exp = np.array(exp["consolidation_degree"]["settlement_m"])
    assert np.all(np.abs(s_exp / s_imp - 1) < [0.03, 0.005])


COLUMN = ["-mpm_analysis", "consolidation", "-mpm_figures", "0", "-mpm_cells", "2,10",
          "-mpm_size", "0.2,1", "-mpm_E", "1e7", "-mpm_nu", "0.3", "-mpm_k", "1e-8",
          "-mpm_gravity", "0", "-mpm_bc_left", "x", "-mpm_bc_right", "none",
          "-mpm_bc_bottom", "y", "-mpm_bc_top", "none", "-mpm_drained", "top",
          "-mpm_material", "tresca", "-mpm_cohesion", "5e3", "-mpm_Tv_end", "0.05",
          "-mpm_Tv_report", "0.05"]


@pytest.mark.parametrize("ratio", [0.97, 1.03])
def test_an_unconfined_column_fails_undrained_past_twice_c_u(cli, tmp_path, ratio):
    """A column free at one side and on rollers at its base (the axis x = 0 on rollers):
    its undrained strength under a top load is 2 c_u (Tresca bounds sigma_1 - sigma_3, the
    same in total and effective stress, and the free side holds sigma_3 = 0). At 0.97 of it
    the run ends; at 1.03 it stops at t = 0+ with exit 3 and one line naming the failure."""
    res = cli(COLUMN + ["-mpm_load", f"{ratio * 2 * 5e3:g}"], out_dir=tmp_path / "run")
    if ratio < 1:
        check_ok(res)
        return
    assert res.returncode == 3
    line = res.stderr.strip().splitlines()
    assert len(line) == 1 and "no equilibrium at t = 0+ (undrained)" in line[0]
    assert "fails under the load" in line[0]
    assert res.summary["error"]["exit_code"] == 3


@pytest.mark.parametrize("args, message", [
    (["-mpm_material", "mcc", "-mpm_void_ratio", "1"], "needs -mpm_initial_state geostatic"),
    (["-mpm_material", "mcc", "-mpm_void_ratio", "1", "-mpm_gravity", "9.81",
      "-mpm_initial_state", "geostatic", "-mpm_scheme", "explicit"],
     "Cam Clay's stiffness outgrows"),
    (["-mpm_material", "tresca"], "needs the undrained strength"),
])
def test_bad_combinations_are_one_line_and_exit_2(cli, args, message):
    res = cli(["-mpm_analysis", "consolidation", *args])
    assert res.returncode == 2
    assert message in res.stderr and len(res.stderr.strip().splitlines()) == 1


SCENE = ["-mpm_cells", "12,6", "-mpm_figures", "0", "-mpm_Tv_end", "0.5",
         "-mpm_Tv_report", "0.1,0.5"]


def test_ranks_agree_and_a_restart_takes_up_the_history(cli, tmp_path):
    """The clay footing scene on 12 x 6 cells: 1 and 2 ranks agree within 1e-9 of q and of
    the settlement; a checkpoint at T_v 0.1 (the points' stress zz, p_c, plastic
    multiplier), restarted on 2 ranks, ends where the uninterrupted run does."""
    runs = [check_ok(cli(SCENE, ranks=n, options_file="footing-clay-consolidation",
                         out_dir=tmp_path / str(n), process=True))["consolidation"]
            for n in (1, 2)]
    for key, block in (("p_over_q", "monitor"), ("settlement_m", "consolidation_degree")):
        np.testing.assert_allclose(runs[1][block][key], runs[0][block][key], rtol=1e-9,
                                   atol=1e-12)
    part = cli(SCENE[:4] + ["-mpm_Tv_end", "0.1", "-mpm_Tv_report", "0.1",
                            "-mpm_checkpoint_every", "40"],
               options_file="footing-clay-consolidation", out_dir=tmp_path / "part")
    ckpt = tmp_path / "part" / "checkpoint.npz"
    assert part.returncode == 0 and ckpt.is_file()
    rest = check_ok(cli(["-mpm_restart", str(ckpt), "-mpm_Tv_end", "0.5", "-mpm_Tv_report",
                         "0.1,0.5", "-mpm_output", str(tmp_path / "rest")], ranks=2,
                        out_dir=tmp_path / "rest", process=True))["consolidation"]
    for key, block in (("p_over_q", "monitor"), ("settlement_m", "consolidation_degree")):
        np.testing.assert_allclose(rest[block][key][-1], runs[0][block][key][-1], rtol=1e-9)


def test_the_clay_footing_scene_consolidates_and_yields(cli, tmp_path):
    """cases/footing-clay-consolidation.opts on 12 x 6 cells: the settlement grows as the
    water drains (by more than a third after the undrained start), the excess pressure
    falls below 1 % of q, the clay yields and the elastic crust does not, and the fields
    hold the plastic multiplier and the preconsolidation pressure for ParaView;
    plastic_zone.png is written."""
    res = cli(["-mpm_cells", "12,6"], options_file="footing-clay-consolidation",
              out_dir=tmp_path / "run")
    s = check_ok(res)
    c = s["consolidation"]
    settle = np.loadtxt(tmp_path / "run" / "settlement.csv", delimiter=",", skiprows=1)
    assert settle[-1, 2] > 1.33 * settle[0, 2]
    assert abs(c["monitor"]["p_over_q"][-1]) < 0.01
    assert (tmp_path / "run" / "plastic_zone.png").is_file()
    assert s["files"]["plastic_zone"]
    mesh = meshio.xdmf.TimeSeriesReader(str(tmp_path / "run" / "points.xdmf"))
    mesh.read_points_cells()
    _, data, _ = mesh.read_data(mesh.num_steps - 1)
    assert np.max(data["plastic_multiplier"]) > 0 and "yielding" in data
    points = mesh.read_points_cells()[0]
    clay = points[:, 1] < 2.5                     # below the elastic crust
    assert np.all(data["preconsolidation_pressure"][clay] > 0)
    assert np.all(data["plastic_multiplier"][~clay] == 0)


LAYERED = ["-options_file", "cases/consolidation-strip-layered.opts", "-mpm_cells", "8,4",
           "-mpm_figures", "0", "-mpm_fe_reference", "0", "-mpm_Tv_end", "0.05",
           "-mpm_Tv_report", "0.05"]


def test_each_layer_takes_its_own_material(cli, tmp_path):
    """-mpm_material per layer: the layered strip with elastic silty sand over clay of
    Mohr-Coulomb (c 3 kPa, phi 20 degrees) yields in the clay alone (the plastic
    multiplier zero in the top 0.5 m); and a list of the wrong length is one line, exit 2."""
    check_ok(cli(LAYERED + ["-mpm_material", "elastic,mohr-coulomb", "-mpm_cohesion", "0,3e3",
                            "-mpm_friction_angle", "0,20"], out_dir=tmp_path / "run"))
    mesh = meshio.xdmf.TimeSeriesReader(str(tmp_path / "run" / "points.xdmf"))
    points, _ = mesh.read_points_cells()
    _, data, _ = mesh.read_data(mesh.num_steps - 1)
    eps = np.ravel(data["plastic_multiplier"])
    sand = points[:, 1] > 1.5
    assert np.all(eps[sand] == 0) and eps[~sand].max() > 0
    res = cli(LAYERED + ["-mpm_material", "elastic,mohr-coulomb,tresca"],
              out_dir=tmp_path / "bad")
    assert res.returncode == 2 and len(res.stderr.strip().splitlines()) == 1
    assert "-mpm_material: 3 values for 2 layer(s)" in res.stderr
