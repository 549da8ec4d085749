"""The static analysis: a rigid footing pushed into weightless Tresca soil, against
Prandtl's (2 + pi) c_u."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import check_ok

PRANDTL = (2 + math.pi) * 10e3


Q4 = ["-mpm_element", "q4", "-mpm_ppc", "2"]
MC = ["-mpm_material", "mohr-coulomb", "-mpm_friction_angle", "30", "-mpm_nu", "0.3",
      "-mpm_footing_settlement", "0.1"]


def _footing(cli, out, cells, *extra, ranks=1):
    return check_ok(cli(["-mpm_cells", cells, "-mpm_figures", "0", *extra],
                        options_file="footing-tresca", out_dir=out, ranks=ranks,
                        timeout=600))["static"]


def test_q9_footings_converge_to_prandtl(cli, tmp_path):
    """The scenes' Q9 cells with B-bar (a linear volumetric strain per cell): the smooth
    footing on Tresca soil +3.7 % and +1.8 % of (2 + pi) c_u on 8 x 4 and 16 x 8 cells
    (+1.0 % on 32 x 16), on weightless c-phi soil +7.2 % and +5.1 % of Prandtl-Reissner's
    N_c c (+2.9 % on 32 x 16: docs/studies.md)."""
    errors = {}
    for name, extra in (("tresca", []), ("mc", MC)):
        errors[name] = [_footing(cli, tmp_path / f"{name}{c}", c, *extra)["error_pct"]
                        for c in ("8,4", "16,8")]
    assert 0 < errors["tresca"][1] < errors["tresca"][0] < 5, errors
    assert errors["tresca"][1] < 3, errors
    assert 0 < errors["mc"][1] < errors["mc"][0] < 10, errors


def test_a_rough_footing_converges_to_prandtl(cli, tmp_path):
    """The rough footing (its nodes held in x too) on weightless Tresca soil, whose Prandtl
    load is the smooth one's: +6.7 % and +4.0 % of (2 + pi) c_u on Q9 8 x 4 and 16 x 8
    cells (+2.1 % on 32 x 16: docs/studies.md), above the smooth footing's."""
    rough = [_footing(cli, tmp_path / f"r{c}", c, "-mpm_footing_interface",
                      "rough")["error_pct"] for c in ("8,4", "16,8")]
    assert 0 < rough[1] < rough[0] < 8, rough
    assert 1.8 < rough[1] < 5, rough


def test_tresca_footing_converges_to_prandtl_with_bbar_and_locks_without(cli, tmp_path):
    """B-bar: +13.8 % and +7.0 % of (2 + pi) c_u on 16 x 8 and 32 x 16 Q4 cells (first
    order: the error halves with the cell; +3.6 % on 64 x 32, docs/studies.md); without it
    the nearly incompressible cells lock, +250 % on 16 x 8."""
    coarse = _footing(cli, tmp_path / "c", "16,8", *Q4)
    fine = _footing(cli, tmp_path / "f", "32,16", *Q4)
    assert coarse["reference"] == "Prandtl (2 + pi) c_u"
    assert coarse["reference_pa"] == pytest.approx(PRANDTL, rel=1e-12)
    e1, e2 = coarse["error_pct"], fine["error_pct"]
    assert 0 < e2 < e1 < 15 and 1.6 < e1 / e2 < 2.5, (e1, e2)
    locked = _footing(cli, tmp_path / "l", "16,8", *Q4, "-mpm_bbar", "0")
    assert locked["error_pct"] > 100


def test_newton_converges_quadratically(cli, tmp_path):
    """Newton's order, log(e_k+1 / e_k) / log(e_k / e_k-1) over the relative residuals of
    each step above round-off (1e-9 of the step's first), is about 2: the material's
    algorithmic tangent is the Jacobian of its return (measured: 4.7e-3, 3.9e-4, 1.3e-6,
    order 2.3; a median of 1.7 to 2 over the steps)."""
    s = _footing(cli, tmp_path, "16,8", *Q4)
    orders = []
    for r in s["newton_residuals"]:
        e = np.asarray(r) / r[0]
        for k in range(1, len(e) - 1):
            if e[k + 1] > 1e-9 and e[k] < 0.1:
                orders.append(np.log(e[k + 1] / e[k]) / np.log(e[k] / e[k - 1]))
    assert len(orders) >= 5 and np.median(orders) > 1.5, orders


@pytest.mark.mpi(2)
def test_two_ranks_give_one_ranks_capacity(cli, tmp_path):
    one = _footing(cli, tmp_path / "one", "16,8", *Q4)
    two = _footing(cli, tmp_path / "two", "16,8", *Q4, ranks=2)
    assert two["bearing_capacity_pa"] == pytest.approx(one["bearing_capacity_pa"], rel=1e-8)


@pytest.mark.parametrize("extra,message", [
    (["-mpm_footing", "0,5"], "outside the top"),
    (["-mpm_material", "mcc", "-mpm_void_ratio", "1"], "no strength")])
def test_bad_footings_are_one_line_and_exit_2(cli, tmp_path, extra, message):
    res = cli(["-mpm_figures", "0", *extra], options_file="footing-tresca",
              out_dir=tmp_path / "out")
    assert res.returncode == 2, res.stderr
    assert message in res.stderr and len(res.stderr.strip().splitlines()) == 1


def test_outputs_are_in_the_readme(cli, tmp_path):
    from conftest import check_readme_outputs

    check_ok(cli(["-mpm_cells", "8,4", "-mpm_load_steps", "4"], options_file="footing-tresca",
                 out_dir=tmp_path))
    check_readme_outputs(tmp_path)


def test_the_benchmark_grid_holds_the_points_it_is_asked():
    from conftest import script_module

    cells_for = script_module("static_benchmark").cells_for
    for points in (25000, 100000):
        nx, ny = cells_for(points)
        assert nx == 2 * ny and nx % 8 == 0 and points <= 9 * nx * ny < 1.2 * points


def test_newton_giving_up_exits_3_with_the_converged_steps_written(cli, tmp_path):
    """Newton allowed two iterations: the elastic first steps converge, the plastic ones are
    halved six times and the run gives up (exit 3, one line), its converged steps in
    load_displacement.csv and the summary not completed."""
    res = cli(["-mpm_cells", "8,4", *Q4, "-mpm_snes_max_it", "2", "-mpm_figures", "0"],
              options_file="footing-tresca", out_dir=tmp_path)
    assert res.returncode == 3, res.stderr
    assert "Newton did not converge" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
    assert res.summary["completed"] is False
    table = np.loadtxt(tmp_path / "load_displacement.csv", delimiter=",", skiprows=1, ndmin=2)
    assert table[0, 0] == 0 and len(table) >= 2 and np.all(np.diff(table[:, 0]) > 0)


def test_point_fields_open_as_a_series(cli, tmp_path):
    """points.xdmf: one time per step (the settlement), the displacement at the points
    under the footing its settlement, the plastic multiplier where the soil yielded."""
    import meshio

    s = check_ok(cli(["-mpm_cells", "8,4", *Q4, "-mpm_load_steps", "4", "-mpm_figures", "0"],
                     options_file="footing-tresca", out_dir=tmp_path))
    reader = meshio.xdmf.TimeSeriesReader(str(tmp_path / "points.xdmf"))
    points, _ = reader.read_points_cells()
    assert reader.num_steps == len(s["static"]["newton_iterations"])
    t, data, _ = reader.read_data(reader.num_steps - 1)
    assert t == pytest.approx(0.05)
    assert data["displacement"][:, 1].min() == pytest.approx(-0.05, rel=0.2)
    assert data["plastic_multiplier"].max() > 0 and set(np.unique(data["yielding"])) <= {0, 1}


def test_a_surcharge_adds_its_prandtl_reissner_share(cli, tmp_path):
    """A surcharge q0 on the top beside the footing, on from the start: Prandtl's (2 + pi)
    c_u + q0 on Tresca soil (q0 20 kPa: +0.35 %) and Prandtl-Reissner's N_c c + N_q q0 on
    associated c-phi soil (phi 30, q0 10 kPa: +3.7 %, against +5.1 % without) on Q9 16 x
    8 cells; the footing's force leaves out the surcharge's share on its edge nodes."""
    tresca = _footing(cli, tmp_path / "t", "16,8", "-mpm_surcharge", "20e3")
    assert tresca["reference_pa"] == pytest.approx(PRANDTL + 20e3, rel=1e-12)
    assert 0 < tresca["error_pct"] < 2
    mc = _footing(cli, tmp_path / "mc", "16,8", *MC, "-mpm_surcharge", "10e3")
    N_q = math.exp(math.pi / math.sqrt(3)) * 3.0
    assert mc["reference_pa"] == pytest.approx((N_q - 1) * math.sqrt(3) * 10e3 + N_q * 10e3,
                                               rel=1e-12)
    assert 0 < mc["error_pct"] < 5


def test_a_load_past_the_capacity_fails_the_soil_with_exit_3(cli, tmp_path):
    """Load control (-mpm_load on -mpm_load_extent, no footing): a flexible strip load of
    60 kPa on weightless Tresca soil fails it below (2 + pi) c_u = 51.4 kPa, whose exact
    collapse pressure it is too: exit 3, one line naming the failure, and the last load
    carried within 3 % below Prandtl's (measured -2.1 % on Q9 16 x 8)."""
    res = cli(["-mpm_analysis", "static", "-mpm_material", "tresca", "-mpm_cohesion", "10e3",
               "-mpm_E", "10e6", "-mpm_nu", "0.49", "-mpm_element", "q9", "-mpm_ppc", "3",
               "-mpm_cells", "16,8", "-mpm_size", "4,2", "-mpm_bc_bottom", "xy",
               "-mpm_load", "60e3", "-mpm_load_extent", "0,0.5", "-mpm_figures", "0"],
              out_dir=tmp_path)
    assert res.returncode == 3, res.stderr
    line = res.stderr.strip().splitlines()
    assert len(line) == 1 and "the soil failed under" in line[0]
    s = res.summary["static"]
    assert s["control"] == "load" and -3 < s["error_pct"] < 0


def test_gravity_starts_at_rest_and_cam_clay_takes_a_footing(cli, tmp_path):
    """Under gravity the body starts at rest (K0 effective stress, buoyant weight) and a
    first solve at zero settlement takes up what the points' quadrature leaves out of
    balance (on Q9 cells 2 % of the weight: the sub-cell midpoints do not integrate the
    quadratic cells' terms exactly; on Q4 cells nothing): before the footing moves its
    pressure is within 1 % of gamma' H. Cam Clay (which a weightless body cannot take)
    then carries the footing with hardening: the pressure rises at every step."""
    s = check_ok(cli(["-mpm_analysis", "static", "-mpm_material", "mcc", "-mpm_mcc_M", "1.2",
                      "-mpm_mcc_lambda", "0.15", "-mpm_mcc_kappa", "0.03", "-mpm_void_ratio",
                      "1", "-mpm_mcc_ocr", "2", "-mpm_nu", "0.3", "-mpm_porosity", "0.5",
                      "-mpm_rho_s", "2650", "-mpm_gravity", "9.81", "-mpm_element", "q9",
                      "-mpm_ppc", "3", "-mpm_cells", "8,4", "-mpm_size", "6,3",
                      "-mpm_footing", "0,1", "-mpm_footing_settlement", "0.1",
                      "-mpm_load_steps", "10", "-mpm_figures", "0"], out_dir=tmp_path))
    table = np.loadtxt(tmp_path / "load_displacement.csv", delimiter=",", skiprows=1)
    gamma_H = 0.5 * 1650 * 9.81 * 3
    assert abs(table[0, 1]) < 1e-2 * gamma_H
    assert np.all(np.diff(table[:, 1]) > 0) and s["static"]["reference"] is None


def test_a_restart_ends_where_the_uninterrupted_run_does(cli, tmp_path):
    """A run to 2.5 cm with a checkpoint every 5 steps, restarted on 2 ranks with
    -mpm_footing_settlement 0.05 (the steps keep their length): the same curve to 1e-10 and
    the same capacity as the run straight to 5 cm (the points' stresses and plastic
    history, the nodal state and the predictor restored). A restart that changes the
    physics is refused in one line (exit 2)."""
    base = ["-mpm_cells", "8,4", *Q4, "-mpm_figures", "0"]
    full = check_ok(cli(base, options_file="footing-tresca", out_dir=tmp_path / "full"))
    part = cli(base + ["-mpm_footing_settlement", "0.025", "-mpm_load_steps", "10",
                       "-mpm_checkpoint_every", "5"], options_file="footing-tresca",
               out_dir=tmp_path / "part")
    ckpt = tmp_path / "part" / "checkpoint.npz"
    assert part.returncode == 0 and ckpt.is_file()
    rest = check_ok(cli(["-mpm_restart", str(ckpt), "-mpm_footing_settlement", "0.05",
                         "-mpm_output", str(tmp_path / "rest")], ranks=2,
                        out_dir=tmp_path / "rest", process=True))
    a = np.loadtxt(tmp_path / "full" / "load_displacement.csv", delimiter=",", skiprows=1)
    b = np.loadtxt(tmp_path / "rest" / "load_displacement.csv", delimiter=",", skiprows=1)
    np.testing.assert_allclose(b, a, rtol=1e-10)
    assert rest["static"]["bearing_capacity_pa"] == pytest.approx(
        full["static"]["bearing_capacity_pa"], rel=1e-10)
    bad = cli(["-mpm_restart", str(ckpt), "-mpm_cohesion", "5e3", "-mpm_output",
               str(tmp_path / "bad")], out_dir=tmp_path / "bad")
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
