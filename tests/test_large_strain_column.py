"""The large-strain column (-mpm_scheme implicit -mpm_kinematics large) against Xie and
Leo's published numbers; its drained end against the closed form; the permeability laws; a
restart; the small-strain run of the same column; what it refuses."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import check_ok, check_readme_outputs
from petsc4py import PETSc
from test_options import assert_input_error

from solver.consolidation.implicit.largestrain import LargeStrain, parse_k_law, permeability
from solver.model.scene import Body, Loading
from solver.model.soil import Soil

# Xie and Leo (2004): settlement 1.4818 m at 6.3496e8 s, 3.2776 m at 8e9 s, half the
# final settlement at 7.872e8 s.
PUBLISHED = {"s1": 1.4818, "s2": 3.2776, "t_half": 7.872e8}


@pytest.fixture(scope="module")
def column(tmp_path_factory):
    from conftest import run_cli

    out = tmp_path_factory.mktemp("large-strain") / "out"
    res = run_cli([], out, options_file="consolidation-large-strain")
    return res, out


def test_xie_and_leo(column):
    """The scene within 1 % of the published settlements, the half-time within 2 %, the
    excess pore pressure within 1 % of q at both report times."""
    res, out = column
    c = check_ok(res)["consolidation"]
    first, last = c["reports"]
    assert first["settlement_m"] == pytest.approx(PUBLISHED["s1"], rel=1e-2)
    assert last["settlement_m"] == pytest.approx(PUBLISHED["s2"], rel=1e-2)
    assert c["t_half_s"] == pytest.approx(PUBLISHED["t_half"], rel=2e-2)
    for r in c["reports"]:
        assert r["pressure_error_pct_of_q"] < 1.0
    # The small strain's beside it: 4.0 m at the end (m_v q H).
    assert c["small_strain_final_m"] == pytest.approx(4.0, rel=1e-2)
    assert "Xie and Leo" in res.stdout
    check_readme_outputs(out)


def test_the_small_strain_run_of_the_same_column(cli, tmp_path):
    """-mpm_kinematics small runs the implicit small-strain scheme on the scene: 4.0 m at
    the end, where large strain gives 3.3."""
    check_ok(cli(["-mpm_kinematics", "small", "-mpm_figures", "0"],
                 options_file="consolidation-large-strain", out_dir=tmp_path / "o"))
    text = (tmp_path / "o" / "settlement.csv").read_text().splitlines()
    head = text[0].split(",")
    s_end = float(text[-1].split(",")[head.index("settlement_m_downwards_positive")])
    # Terzaghi's U(T_v = 2) = 0.9942 of m_v q H = 4.0 m.
    assert s_end == pytest.approx(4.0 * 0.9942, rel=5e-3)


def drained_column(k_law, stress, q=100e3):
    soil = Soil(E=250e3, nu=0.0, rho_s=2700, porosity=0.75, k=1e-9, rho_l=1e4 / 9.81)
    body = Body(element="q4", cells=(1, 10), size=(1.0, 10.0), ppc=2,
                bcs=(("left", "x"), ("right", "x"), ("bottom", "xy"), ("top", "none")),
                drained=("top",))
    return LargeStrain(PETSc.COMM_SELF, body, soil, Loading(load=q), k_law, stress)


@pytest.mark.parametrize("stress", ["cauchy", "kirchhoff"])
def test_drained_to_its_end(stress):
    """Steps far longer than the consolidation take the column to its drained end:
    cauchy, E_c ln V = -q: H (1 - exp(-q / E_c)); kirchhoff, E_c ln V = -q V (the
    Kirchhoff stress is J times the Cauchy)."""
    col = drained_column(("power", 2.0), stress)
    col.step(0.0, 100e3)
    # Each step carries the last one's residual; the stiffness is the elastic one, the
    # Kirchhoff law's Cauchy tangent 1.7 times it here: its error shrinks by 0.7 a step.
    for _ in range(8 if stress == "cauchy" else 60):
        col.step(1e14, 100e3)
    if stress == "cauchy":
        V = math.exp(-0.4)
    else:                    # ln V + 0.4 V = 0 by Newton
        V = 0.7
        for _ in range(50):
            V -= (math.log(V) + 0.4 * V) / (1 / V + 0.4)
    assert col.settlement == pytest.approx(10 * (1 - V), rel=1e-6)
    np.testing.assert_allclose(col.J, V, rtol=1e-6)


SELF_WEIGHT = ["-mpm_gravity", "9.81", "-mpm_rho_s", "2650", "-mpm_rho_l", "1000",
               "-mpm_load", "0", "-mpm_Tv_report", "0.1,4", "-mpm_Tv_end", "4",
               "-mpm_large_strain_stress", "kirchhoff", "-mpm_figures", "0"]


def test_a_column_under_its_own_weight(cli, tmp_path):
    """The scene's clay, weighing (1 - n0)(rho_s - rho_l) g = 4.17 kN/m3 buoyant, deposited
    at once and drained to its end (T_v = 4): its effective stress against the weight of
    the solids above each point, gamma' (H - a) in material heights a, and its settlement
    against the closed form (analytic.large_strain_final; 0.701 m where small strain gives
    0.809): the settlement within 0.05 %, the stress within half a cell's weight (of the
    largest: 1 / (2 x cells), first order, as the stress is constant over a cell) on 10 and
    20 cells, the error halving."""
    errors = []
    for cells in (10, 20):
        out = tmp_path / f"c{cells}"
        res = cli(SELF_WEIGHT + ["-mpm_cells", f"1,{cells}"],
                  options_file="consolidation-large-strain", out_dir=out)
        c = check_ok(res)["consolidation"]
        d = c["drained_end"]
        assert d["largest_excess_pct_of_start"] < 1.0
        assert c["settlement_final_m"] == pytest.approx(d["closed_form_settlement_m"],
                                                        rel=5e-4)
        assert d["closed_form_settlement_m"] == pytest.approx(0.70099, rel=1e-4)
        assert d["stress_error_pct_of_largest"] < 100 / (2 * cells)
        errors.append(d["stress_error_pct_of_largest"])
        assert "Xie and Leo" not in res.stdout and "Drained end" in res.stdout
    assert errors[1] == pytest.approx(errors[0] / 2, rel=0.1)
    check_readme_outputs(out)
    # The scene's own Cauchy law under gravity: its drained end, not Xie and Leo's column.
    res = cli(SELF_WEIGHT + ["-mpm_large_strain_stress", "cauchy"],
              options_file="consolidation-large-strain", out_dir=tmp_path / "cauchy")
    c = check_ok(res)["consolidation"]
    assert "Xie and Leo" not in res.stdout and "reference" not in c
    assert c["settlement_final_m"] == pytest.approx(
        c["drained_end"]["closed_form_settlement_m"], rel=5e-4)


def test_permeability_laws():
    e0, e = 3.0, np.array([3.0, 2.0, 1.0])
    np.testing.assert_allclose(permeability(1e-9, e0, e, parse_k_law("power:2")),
                               1e-9 * ((1 + e) / 4) ** 2)
    np.testing.assert_allclose(permeability(1e-9, e0, e, parse_k_law("kozeny-carman")),
                               1e-9 * (e ** 3 / (1 + e)) / (27 / 4))
    np.testing.assert_allclose(permeability(1e-9, e0, e, parse_k_law("constant")), 1e-9)


def test_restart_ends_where_the_whole_run_does(cli, tmp_path, column):
    """Stopped at a checkpoint half way and restarted, the column ends on the whole run's
    settlement, bit for bit."""
    res, _ = column
    whole = check_ok(res)["consolidation"]
    half = tmp_path / "half"
    check_ok(cli(["-mpm_Tv_end", "0.15874", "-mpm_Tv_report", "0.15874",
                  "-mpm_checkpoint_every", "40", "-mpm_figures", "0"],
                 options_file="consolidation-large-strain", out_dir=half))
    again = check_ok(cli(["-mpm_restart", half / "checkpoint.npz", "-mpm_Tv_end", "2",
                          "-mpm_Tv_report", "0.15874,2", "-mpm_output", tmp_path / "again",
                          "-mpm_figures", "0"]))["consolidation"]
    assert again["settlement_final_m"] == whole["settlement_final_m"]


@pytest.mark.mpi(2)
def test_one_and_two_ranks_agree(cli, tmp_path):
    """The column under its load and weight on one rank and on two (each assembling the
    points of its own cells, the solution gathered to both): the same settlement at every
    step and the same pressures at the report times, to 1e-9 of their largest."""
    args = ["-mpm_gravity", "9.81", "-mpm_rho_s", "2650", "-mpm_Tv_report", "0.1,0.5",
            "-mpm_Tv_end", "0.5", "-mpm_figures", "0"]
    runs = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        check_ok(cli(args, ranks=ranks, options_file="consolidation-large-strain",
                     out_dir=out))
        runs.append([np.loadtxt(out / name, delimiter=",", skiprows=1)
                     for name in ("settlement.csv", "profiles.csv")])
    for a, b in zip(*runs):
        assert a.shape == b.shape
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(a))


@pytest.mark.parametrize("args, words", [
    (["-mpm_element", "q9"], "takes Q4 cells"),
    (["-mpm_k_law", "power:x"], "power:A"),
    (["-mpm_gravity", "9.81", "-mpm_initial_state", "geostatic"], "starts deposited"),
    (["-mpm_drained", "left"], "drains at its top or base"),
], ids=["q9", "k-law", "geostatic", "side-drained"])
def test_large_strain_column_bad_input(cli, tmp_path, args, words):
    out = tmp_path / "out"
    assert_input_error(cli(args, options_file="consolidation-large-strain", out_dir=out),
                       words, out)


def test_its_options_are_refused_elsewhere(cli, tmp_path):
    out = tmp_path / "out"
    assert_input_error(cli(["-mpm_k_law", "power:2"], options_file="consolidation-m1-q4",
                           out_dir=out), "-mpm_kinematics large only", out)
