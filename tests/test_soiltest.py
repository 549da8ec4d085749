"""The soil-test analysis as a user runs it (``-mpm_analysis soiltest``)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import check_ok

MC = ["-mpm_analysis", "soiltest", "-mpm_material", "mohr-coulomb", "-mpm_E", "20e6",
      "-mpm_nu", "0.3", "-mpm_figures", "0"]


def test_mcc_scene_reaches_the_critical_state_of_its_closed_form(cli, tmp_path):
    """cases/soiltest-mcc-undrained.opts: p'_f = p'_0 2^(-(lambda - kappa)/lambda), q_f =
    M p'_f within 1 % (the return is exact: 1e-6), the excess pore pressure what the
    total stress path leaves, and soiltest.csv holds every step."""
    s = check_ok(cli([], options_file="soiltest-mcc-undrained", out_dir=tmp_path))
    b = s["soiltest"]
    pf = 100e3 * 2 ** (-(0.2 - 0.04) / 0.2)
    assert b["final_p_eff_pa"] == pytest.approx(pf, rel=1e-6)
    assert b["final_q_pa"] == pytest.approx(1.2 * pf, rel=1e-6)
    table = np.loadtxt(tmp_path / "soiltest.csv", delimiter=",", skiprows=1)
    assert table.shape == (1501, 9)
    assert table[-1, 4] == pytest.approx(100e3 + b["final_q_pa"] / 3 - pf, rel=1e-6)
    assert (tmp_path / "soiltest.png").is_file()


@pytest.mark.parametrize("test,extra,expected", [
    ("plane-strain", ["-mpm_cohesion", "10e3", "-mpm_friction_angle", "30",
                      "-mpm_confining", "0"], 2 * 10e3 * math.tan(math.radians(60))),
    ("triaxial-drained", ["-mpm_friction_angle", "30"], 200e3)])
def test_mohr_coulomb_peaks(cli, tmp_path, test, extra, expected):
    """Plane-strain unconfined compression sigma_1 = 2 c tan(45 + phi/2); drained triaxial
    with c = 0 from 100 kPa, q_f = (K_p - 1) sigma_3 = 200 kPa (phi 30 degrees)."""
    s = check_ok(cli([*MC, "-mpm_soiltest", test, "-mpm_strain_end", "0.05", *extra],
                     out_dir=tmp_path))
    assert s["soiltest"]["peak_q_pa"] == pytest.approx(expected, rel=1e-9)


@pytest.mark.parametrize("extra,message", [
    (["-mpm_material", "tresca", "-mpm_cohesion", "20e3", "-mpm_friction_angle", "10"],
     "tresca has none"),
    (["-mpm_friction_angle", "20", "-mpm_dilation_angle", "25"], "above the friction angle"),
    (["-mpm_material", "mcc"], "needs the initial void ratio"),
    (["-mpm_friction_angle", "95"], "must lie in [0, 90)")])
def test_bad_combinations_are_one_line_and_exit_2(cli, tmp_path, extra, message):
    res = cli([*MC, *extra], out_dir=tmp_path / "out")
    assert res.returncode == 2, res.stderr
    assert message in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "out").exists()


def test_outputs_are_in_the_readme(cli, tmp_path):
    from conftest import check_readme_outputs

    check_ok(cli(["-mpm_strain_steps", "20"], options_file="soiltest-mcc-undrained",
                 out_dir=tmp_path))
    check_readme_outputs(tmp_path)
