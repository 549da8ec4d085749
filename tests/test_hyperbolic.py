"""The hyperbolic soil (a multi-surface Iwan J2 model) against its closed forms: the
backbone tau = G gamma / (1 + gamma / gamma_r), Masing's damping, a loop's branches, the
same backbone in any direction of shear; and the cyclic simple-shear test as a user runs
it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import check_ok, check_readme_outputs
from test_options import assert_input_error

from solver.materials import soiltest
from solver.materials.hyperbolic import Hyperbolic

E, NU, GAMMA_R = 2.6e7, 0.3, 1e-3
G = E / (2 * (1 + NU))


def hyperbola(gamma):
    """The backbone written here, independently of the model."""
    return G * gamma / (1 + abs(gamma) / GAMMA_R)


def masing(x):
    return (4 / math.pi) * (1 + 1 / x) * (1 - math.log(1 + x) / x) - 2 / math.pi


@pytest.fixture(scope="module")
def soil():
    return Hyperbolic(E, NU, GAMMA_R, 25)


def test_the_backbone_in_simple_shear(soil):
    """Monotonic simple shear to 10 gamma_r: within 1 % of the hyperbola at 0.1, 1 and 10
    gamma_r, and within 1 % everywhere from 1e-3 gamma_r (the chords of 25 surfaces,
    dense about gamma_r)."""
    path = soiltest.run(soil, "simple-shear", 0.0, 10 * GAMMA_R, 2000)
    gamma, tau = path["axial_strain"][1:], -path["stress_pa"][1:, 3]
    exact = np.array([hyperbola(g) for g in gamma])
    for x in (0.1, 1.0, 10.0):
        i = int(np.argmin(np.abs(gamma - x * GAMMA_R)))
        assert gamma[i] == pytest.approx(x * GAMMA_R, rel=1e-9)
        assert tau[i] == pytest.approx(exact[i], rel=1e-2)
    assert np.max(np.abs(tau / exact - 1)) < 1e-2
    assert soil.elements()[0].sum() == pytest.approx(G, rel=2e-3)    # the small strains


@pytest.mark.parametrize("x", [0.1, 1.0, 10.0])
def test_masing_damping_and_modulus(soil, x):
    """A cycle at amplitude x gamma_r: the secant modulus G / (1 + x), the damping within
    3 % of Masing's closed form (0.1448 at x = 1); at 0.1 gamma_r, where the loop spans
    few chords and the damping is small (0.0202), within 0.002 of it (about 6 %)."""
    path = soiltest.run(soil, "simple-shear-cyclic", 0.0, x * GAMMA_R, 400, 2)
    c = soiltest.last_cycle(path, 400)
    assert c["secant_modulus_pa"] / G == pytest.approx(1 / (1 + x), rel=1e-6)
    if x < 1:
        assert c["damping_ratio"] == pytest.approx(masing(x), abs=2e-3)
    else:
        assert c["damping_ratio"] == pytest.approx(masing(x), rel=3e-2)
    if x == 1.0:
        assert masing(x) == pytest.approx(0.1448, abs=1e-4)


def test_a_loop_follows_masing(soil):
    """Unloading from the tip (gamma_a, tau_a) follows tau_a - 2 F((gamma_a - gamma) / 2)
    and reloading from the other tip the mirror of it, within 1 % of tau_a."""
    a = GAMMA_R
    path = soiltest.run(soil, "simple-shear-cyclic", 0.0, a, 400, 1)
    gamma, tau = path["axial_strain"], -path["stress_pa"][:, 3]
    down = slice(100, 301)                # from +a to -a
    up = slice(300, 501)                  # from -a back to +a
    tau_a = hyperbola(a)
    branch = tau_a - 2 * np.array([hyperbola((a - g) / 2) for g in gamma[down]])
    assert np.max(np.abs(tau[down] - branch)) < 1e-2 * tau_a
    branch = -tau_a + 2 * np.array([hyperbola((g + a) / 2) for g in gamma[up]])
    assert np.max(np.abs(tau[up] - branch)) < 1e-2 * tau_a


def test_the_backbone_in_any_direction_of_shear(soil):
    """Pure shear at 45 degrees to the axes (eps_xx = -eps_yy = e, an engineering shear
    strain 2 e) follows the same hyperbola in (sigma_xx - sigma_yy) / 2, loading and
    unloading: Masing's rules hold in the deviatoric plane's other direction too."""
    stress = np.zeros((1, 4))
    state = soil.initial_state(stress)
    e_path = np.concatenate([np.linspace(0, 2e-3, 201)[1:], np.linspace(2e-3, -2e-3, 401)[1:]])
    e_old, out = 0.0, []
    for e in e_path:
        d = np.zeros((1, 4))
        d[0, 0], d[0, 1] = e - e_old, -(e - e_old)
        stress, state = soil.update(stress, d, state)
        out.append(0.5 * (stress[0, 0] - stress[0, 1]))
        e_old = e
    out = np.array(out)
    assert out[199] == pytest.approx(hyperbola(4e-3), rel=1e-2)
    # Unloading by 2 e_a: the backbone scaled by 2 from the tip.
    assert out[-1] == pytest.approx(hyperbola(4e-3) - 2 * hyperbola(4e-3), rel=1e-2)


def test_cyclic_soil_test_from_the_command_line(cli, tmp_path):
    """`-mpm_soiltest simple-shear-cyclic` of the hyperbolic soil at gamma_r: G / G_max and
    the damping of the last cycle in the summary, Masing's beside them, the loops drawn."""
    out = tmp_path / "out"
    res = cli(["-mpm_analysis", "soiltest", "-mpm_soiltest", "simple-shear-cyclic",
               "-mpm_material", "hyperbolic", "-mpm_reference_strain", str(GAMMA_R),
               "-mpm_E", str(E), "-mpm_nu", str(NU), "-mpm_strain_end", str(GAMMA_R),
               "-mpm_strain_steps", "400", "-mpm_cycles", "2"], out_dir=out)
    s = check_ok(res)["soiltest"]
    assert s["g_over_gmax"] == pytest.approx(0.5, rel=1e-6)
    assert s["damping_ratio"] == pytest.approx(masing(1.0), rel=3e-2)
    assert s["reference"]["damping_ratio"] == pytest.approx(masing(1.0), rel=1e-12)
    assert "Masing" in res.stdout
    assert (out / "soiltest.png").is_file()
    check_readme_outputs(out)


@pytest.mark.parametrize("args, words", [
    (["-mpm_material", "hyperbolic"], "-mpm_reference_strain"),
    (["-mpm_material", "hyperbolic", "-mpm_reference_strain", "1e-3", "-mpm_surfaces", "4"],
     "at least 6"),
], ids=["no-reference-strain", "surfaces"])
def test_hyperbolic_bad_input(cli, tmp_path, args, words):
    out = tmp_path / "out"
    assert_input_error(cli(["-mpm_analysis", "soiltest", "-mpm_soiltest", "simple-shear",
                            *args], out_dir=out), words, out)
