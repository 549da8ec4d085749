"""Consolidation of layered ground: each material point carries its layer's
material through the step, the stability analysis, the static ends, the checkpoint and the
field output, and the run is compared with the layered column's own reference.

The reference, ``layered.LayeredColumn`` (a series of the exact modes of the layered 1D
problem), is tested against finite elements in tests/test_references.py; here it is built
from the run's summary (its layers), not through the solver's plumbing.
"""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from conftest import check_ok

from solver.consolidation.plan import References
from solver.model.scene import Body, Loading
from solver.model.soil import G_REF, Ground, Soil, constrained_modulus
from solver.references import layered, static

Q = 10e3
# Two layers, contrast 4 in E and 10 in k, compressible water (the scene).
TWO = [
    "-mpm_analysis",
    "consolidation",
    "-mpm_scheme",
    "explicit",
    "-mpm_layers",
    "0.5,0.5",
    "-mpm_E",
    "40e6,10e6",
    "-mpm_k",
    "2.5e-4,2.5e-5",
    "-mpm_progress",
    "0",
    "-mpm_figures",
    "0",
]


def _column(summary, drained=("top",), K_l=True):
    """The layered reference of the run's summary (its layers, load q = Q)."""
    lay = summary["consolidation"]["layers"]
    return layered.LayeredColumn(
        [s["thickness_m"] for s in lay], [constrained_modulus(s["E"], s["nu"]) for s in lay],
        [s["k"] for s in lay], [s["porosity"] for s in lay], lay[0]["rho_l"] * G_REF,
        lay[0]["K_l"] if K_l else None, Q, drained)


def _profiles(out_dir):
    """Rows (Tv, t, x, y0, p/q, V) of profiles.csv."""
    return np.loadtxt(out_dir / "profiles.csv", delimiter=",", skiprows=1)


def test_two_layers_within_two_percent_of_their_reference(cli, tmp_path):
    """Q4, 1 x 40 cells: every point at every report time within 2 % of q of the layered
    column with compressible water (measured: 0.40 % at T_v = 0.02, 0.04 % at 0.5), and
    the run reports that reference, with U from the settlement against its own."""
    out = tmp_path / "two"
    s = check_ok(cli(TWO + ["-mpm_cells", "1,40", "-mpm_Tv_end", "0.5", "-mpm_Tv_report",
                            "0.02,0.05,0.2,0.5"], out_dir=out, timeout=300))
    assert [lay["E"] for lay in s["consolidation"]["layers"]] == [40e6, 10e6]
    assert "layered column" in s["consolidation"]["reference"]["description"]
    col = _column(s)
    rows = _profiles(out)
    times = np.unique(rows[:, 0])
    assert len(times) >= 4
    worst = 0.0
    for Tv in times:
        r = rows[rows[:, 0] == Tv]
        worst = max(worst, float(np.abs(r[:, 4] - col.pressure(r[:, 3], r[0, 1]) / Q).max()))
    assert worst < 0.02
    # U is the layered column's, from the settlement (measured: within 0.2 % of it).
    U = s["consolidation"]["consolidation_degree"]
    for Tv, con in zip(U["Tv"], U["consistent"]):      # T_v = c_v t / H^2, H = 1 m
        assert con == pytest.approx(float(col.degree(Tv / s["consolidation"]["c_v"])), rel=1e-9)
    assert max(abs(e) for e in U["error_settlement_consistent_pct"]) < 2.0


def test_static_ends_of_a_layered_column_are_the_closed_forms():
    """A load over the whole top of a layered column with rollers: the static ends are the
    1D sums, q sum d_i / E_c,i drained and q sum d_i / (E_c,i + K_l / n_i) undrained."""
    from petsc4py import PETSc

    ground = Ground((0.3, 0.7), (Soil(E=40e6, nu=0.3, porosity=0.4), Soil(E=10e6, nu=0.2)))
    body = Body(element="q4", cells=(2, 10), size=(0.2, 1.0))
    ends = static.settlements(PETSc.COMM_WORLD, body, ground, Loading(load=Q))
    E_c = ground.per_layer("constrained_modulus")
    d = np.array(ground.thickness)
    assert ends.final == pytest.approx(Q * float(np.sum(d / E_c)), rel=1e-9)
    undrained = E_c + ground.K_l / ground.per_layer("porosity")
    assert ends.undrained == pytest.approx(Q * float(np.sum(d / undrained)), rel=1e-9)


def test_references_of_layered_ground_follow_the_drainage():
    """Two-way drainage and a base drained alone give the layered column of that
    drainage; the uniform closed forms are never taken for layers."""
    ground = Ground((0.5, 0.5), (Soil(E=40e6, k=2.5e-4), Soil(E=10e6, k=2.5e-5)))
    for drained in (("top", "bottom"), ("bottom",)):
        refs = References.of(ground, Loading(load=Q), Body(cells=(1, 20), drained=drained))
        assert refs.layered and not refs.terzaghi and refs.drained == drained
        col = layered.LayeredColumn((0.5, 0.5), ground.per_layer("constrained_modulus"),
                                    (2.5e-4, 2.5e-5), 0.3, 1000 * G_REF, ground.K_l, Q,
                                    drained)
        y = np.linspace(0, 1, 7)
        np.testing.assert_allclose(refs.pressure(y, 0.1, "consistent"),
                                   col.pressure(y, refs.time(0.1)) / Q, rtol=0, atol=1e-12)


def test_discrete_limit_of_layered_ground_is_sharp(cli, tmp_path):
    """The stability analysis with each point's material: runs at 0.97 x its limit are
    stable and at 1.03 x blow up (explicit drag, no damping: the limit is the stiff
    layer's wave and the permeable layer's drag together)."""
    scene = TWO + ["-mpm_cells", "1,20", "-mpm_drag", "explicit", "-mpm_k", "1e-3,1e-4",
                   "-mpm_damping", "0", "-mpm_fast_damping", "0"]
    s = check_ok(cli(scene + ["-mpm_Tv_end", "1e-3", "-mpm_Tv_report", "1e-3"],
                     out_dir=tmp_path / "limit"))
    limit = s["consolidation"]["dt_critical"]["discrete"]
    assert (
        0.3
        < limit
        / min(
            s["consolidation"]["dt_critical"]["undrained"],
            s["consolidation"]["dt_critical"]["drag"],
        )
        < 2
    )
    for factor, code in ((0.97, 0), (1.03, 3)):
        res = cli(scene + ["-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.05", "-mpm_dt",
                           repr(factor * limit), "-mpm_stability_analysis", "0"],
                  out_dir=tmp_path / f"x{factor}", timeout=300)
        assert res.returncode == code, (factor, res.stderr)


def test_geostatic_layered_ground_drives_the_excess_of_the_load_alone(cli, tmp_path):
    """Under gravity, the geostatic start of layered ground (hydrostatic water, each layer's
    buoyant weight and K0) is in equilibrium: the load then drives the excess over
    hydrostatic that it drives without gravity (to 1e-3 of q: the stress path differs by
    the grains' weight only in the geometric terms)."""
    rest = ["-mpm_rho_s", "2650,2700", "-mpm_porosity", "0.4,0.3", "-mpm_nu", "0.3,0.2",
            "-mpm_cells", "1,20", "-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.02,0.05"]
    runs = [check_ok(cli(TWO + rest + extra, out_dir=tmp_path / name)) for name, extra in
            (("free", []), ("geo", ["-mpm_gravity", "9.81", "-mpm_initial_state",
                                    "geostatic"]))]
    free, geo = (_profiles(tmp_path / name) for name in ("free", "geo"))
    head = open(tmp_path / "geo" / "profiles.csv").readline().strip().split(",")
    excess = geo[:, head.index("excess_p_over_q_compression_positive")]
    np.testing.assert_allclose(excess, free[:, 4], rtol=0, atol=1e-3)
    assert (
        runs[1]["consolidation"]["reference"]["description"]
        == runs[0]["consolidation"]["reference"]["description"]
    )


@pytest.mark.parametrize("extra", [[], ["-mpm_kinematics", "large", "-mpm_element", "q9",
                                         "-mpm_ppc", "3", "-mpm_cells", "1,10"]],
                         ids=["q4", "q9-large"])
def test_layers_on_one_and_two_ranks_agree_and_restart(cli, tmp_path, extra):
    """1 and 2 ranks agree to 1e-10 of q; a checkpoint carries the layers (the points'
    ``layer`` and the options): a restart on the other rank count ends where the
    uninterrupted run does; the field series holds each point's layer."""
    base = TWO + ["-mpm_cells", "1,20", "-mpm_layers", "0.3,0.7", *extra]
    end = ["-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.02,0.05"]
    runs = [check_ok(cli(base + end, ranks=n, out_dir=tmp_path / str(n), process=True))
            for n in (1, 2)]
    np.testing.assert_allclose(
        runs[1]["consolidation"]["monitor"]["p_over_q"],
        runs[0]["consolidation"]["monitor"]["p_over_q"],
        rtol=0,
        atol=1e-10,
    )
    part = cli(base + ["-mpm_Tv_end", "0.02", "-mpm_Tv_report", "0.02",
                       "-mpm_checkpoint_every", "500"], ranks=2, out_dir=tmp_path / "part",
               process=True)
    ckpt = tmp_path / "part" / "checkpoint.npz"
    assert part.returncode == 0 and ckpt.is_file()
    assert "layer" in str(np.load(ckpt)["layout"])
    rest = check_ok(cli(["-mpm_restart", str(ckpt), "-mpm_Tv_end", "0.05", "-mpm_Tv_report",
                         "0.02,0.05", "-mpm_output", str(tmp_path / "rest")],
                        out_dir=tmp_path / "rest"))
    np.testing.assert_allclose(
        rest["consolidation"]["monitor"]["p_over_q"],
        runs[0]["consolidation"]["monitor"]["p_over_q"],
        rtol=0,
        atol=1e-10,
    )
    h5 = sorted((tmp_path / "1").glob("points_*.h5"))[-1]
    with h5py.File(h5) as fh:
        names = _datasets(fh)
        layer, xy = fh["layer"][()].ravel(), fh["geometry"][()]
    assert len(names) and len(layer) == len(xy)
    # Layer 0 (the top, 0.3 m thick) above y = 0.7 m, layer 1 below.
    np.testing.assert_array_equal(layer, np.where(xy[:, 1] > 0.7, 0.0, 1.0))


def _datasets(fh):
    out = []
    fh.visititems(lambda name, obj: out.append(name) if isinstance(obj, h5py.Dataset) else None)
    return out


def test_layer_interfaces_are_drawn_at_the_layer_bottoms():
    """The figures' interface lines lie at the layers' bottoms (not the base); none for one
    soil."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from solver.io import output as figures

    fig, ax = plt.subplots()
    figures.layer_interfaces(ax, Ground((0.25, 0.5, 0.25), (Soil(),) * 3), label=True)
    figures.layer_interfaces(ax, Soil())
    levels = sorted(line.get_ydata()[0] for line in ax.get_lines())
    assert levels == pytest.approx([0.25, 0.75])
    assert [t.get_text() for t in ax.legend().get_texts()] == ["layer interface"]
    plt.close(fig)


@pytest.mark.parametrize("scene, extra", [
    ("consolidation-layered", ["-mpm_Tv_end", "0.01", "-mpm_Tv_report", "0.005,0.01"]),
    ("consolidation-strip-layered", ["-mpm_cells", "16,8", "-mpm_Tv_end", "0.01",
                                     "-mpm_Tv_report", "0.005,0.01", "-mpm_fe_cells",
                                     "32,16"])])
def test_layered_scenes_agree_on_one_and_two_ranks(cli, tmp_path, scene, extra):
    """The layered scenes of cases/ (shortened: gravity, geostatic start and mass scaling;
    a local load with its static ends) on 1 and 2 ranks: reports and profiles equal to
    1e-10 of q, the static ends to 1e-10 relative."""
    runs = [check_ok(cli(extra + ["-mpm_progress", "0", "-mpm_figures", "0"], ranks=n,
                         options_file=scene, out_dir=tmp_path / str(n), process=True))
            for n in (1, 2)]
    assert runs[1]["provenance"]["ranks"] == 2 and len(runs[0]["consolidation"]["layers"]) == 2
    np.testing.assert_allclose(
        runs[1]["consolidation"]["monitor"]["p_over_q"],
        runs[0]["consolidation"]["monitor"]["p_over_q"],
        rtol=0,
        atol=1e-10,
    )
    one, two = (_profiles(tmp_path / str(n)) for n in (1, 2))
    order = [np.lexsort((r[:, 2], r[:, 3], r[:, 0])) for r in (one, two)]
    np.testing.assert_allclose(two[order[1]], one[order[0]], rtol=0, atol=1e-10)
    if "static_references" in runs[0]:
        for key in ("undrained_m", "final_m", "settlement_last_m"):
            assert runs[1]["consolidation"]["static_references"][key] == pytest.approx(
                runs[0]["consolidation"]["static_references"][key], rel=1e-10)
        for key in ("fe_settlement_mean_m", "settlement_axis_m", "fe_p_over_q"):
            np.testing.assert_allclose(runs[1]["consolidation"]["fe_reference"][key],
                                       runs[0]["consolidation"]["fe_reference"][key], rtol=1e-9)
