"""Figures: every format on request (output.save_figure), the consolidation figures'
references, labels, units and colour map (solver.consolidation.plots)."""

from __future__ import annotations

import numpy as np
import pytest
from test_analytic import reference

from solver.consolidation import plots as figures
from solver.io import output


def _figure():
    plt = output.pyplot()
    fig, ax = plt.subplots()
    ax.plot([0, 1], [0, 1])
    return plt, fig


def test_save_figure_writes_each_format_whole(tmp_path):
    plt, fig = _figure()
    written = output.save_figure(fig, str(tmp_path / "a.png"), formats="png,pdf,svg")
    assert written == [str(tmp_path / f"a.{x}") for x in ("png", "pdf", "svg")]
    heads = {x: (tmp_path / f"a.{x}").read_bytes()[:64] for x in ("png", "pdf", "svg")}
    assert heads["png"].startswith(b"\x89PNG") and heads["pdf"].startswith(b"%PDF")
    assert b"<svg" in (tmp_path / "a.svg").read_bytes()[:2000]
    assert not plt.fignum_exists(fig.number)                     # closed
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.pdf", "a.png", "a.svg"]


def test_save_figure_default_is_png_only_and_vector_files_are_reproducible(tmp_path):
    _, fig = _figure()
    assert output.save_figure(fig, str(tmp_path / "b.png")) == [str(tmp_path / "b.png")]
    assert [p.name for p in tmp_path.iterdir()] == ["b.png"]
    for run in ("1", "2"):
        _, fig = _figure()
        output.save_figure(fig, str(tmp_path / run / "c.png"), formats=("pdf", "svg"))
    for ext in ("pdf", "svg"):       # no creation date: the same figure gives the same file
        assert (tmp_path / "1" / f"c.{ext}").read_bytes() == \
            (tmp_path / "2" / f"c.{ext}").read_bytes()


@pytest.mark.parametrize("spec, want", [("png", ("png",)), ("PDF, png,pdf", ("pdf", "png")),
                                        (["svg"], ("svg",)), (".pdf", ("pdf",))])
def test_figure_formats(spec, want):
    assert output.figure_formats(spec) == want


@pytest.mark.parametrize("spec", ["jpg", "png,eps", "", ","])
def test_figure_formats_rejects(spec):
    with pytest.raises(ValueError, match="not a figure format"):
        output.figure_formats(spec)


def test_isochrones_draw_both_references_labelled_by_tv():
    plt = output.pyplot()
    fig, ax = plt.subplots()
    tvs, H, ratio, p0 = [0.02, 0.1, 0.5], 2.0, 0.9756, 0.9756
    figures.isochrone_references(ax, tvs, figures.tv_colors(plt, 3), H, ratio, p0)
    lines = [ln for ln in ax.get_lines() if len(ln.get_xdata())]
    assert len(lines) == 2 * len(tvs)
    for i, tv in enumerate(tvs):
        for ln, t, scale in ((lines[2 * i], tv, 1.0), (lines[2 * i + 1], tv * ratio, p0)):
            height = np.asarray(ln.get_ydata())
            want = scale * reference((H - height) / H, t)
            assert np.max(np.abs(np.asarray(ln.get_xdata()) - want)) < 1e-10
        assert lines[2 * i].get_linestyle() == "-" and lines[2 * i + 1].get_linestyle() == ":"
    assert [t.get_text() for t in ax.texts] == ["T_v = 0.02", "T_v = 0.1", "T_v = 0.5"]
    legend = [ln.get_label() for ln in ax.get_lines() if not len(ln.get_xdata())]
    assert legend == ["Terzaghi, classic", "Terzaghi, compressible water"]
    assert "(m)" in ax.get_ylabel() and "p / q" in ax.get_xlabel()
    plt.close(fig)


def test_pressure_field_uses_a_perceptual_map_in_kpa():
    plt = output.pyplot()
    x, y = np.meshgrid([0.025, 0.075], np.linspace(0.05, 0.95, 10))
    snaps = [(0.1, x.ravel(), y.ravel(), 1e4 * (1 - y.ravel())), (0.5, x.ravel(), y.ravel(),
                                                                   5e3 * (1 - y.ravel()))]
    fig = figures.pressure_field(plt, snaps, 1e4, "field", width=0.1)
    axes = [a for a in fig.axes if a.get_label() != "<colorbar>"]
    assert len(axes) == 2
    for ax, (tv, _, yy, pp) in zip(axes, snaps):
        sc = ax.collections[0]
        assert sc.get_cmap().name == "viridis"
        assert sc.get_clim() == (0, 10.0)                        # 0 to q, in kPa
        assert np.allclose(sc.get_array(), pp / 1e3)
        assert ax.get_xlabel() == "x (m)" and ax.get_title() == f"T_v = {tv:g}"
    assert "(m)" in axes[0].get_ylabel()
    colorbar = [a for a in fig.axes if a not in axes][0]
    assert colorbar.get_ylabel() == "excess pore pressure (kPa)"
    plt.close(fig)


@pytest.mark.parametrize("t_end, unit, seconds", [(3.9, "s", 1.0), (3.644e4, "h", 3600.0),
                                                   (8e5, "days", 86400.0)])
def test_settlement_time_in_the_scenes_own_unit(t_end, unit, seconds):
    """Settlement (mm, downwards) against time in s, h or days by the run's
    length, log time axis; the references are s_inf U (classic) and s0 + (s_inf - s0) U of
    the compressible water, against Terzaghi's U summed and integrated independently
    (test_outputs.terzaghi_mean)."""
    from test_outputs import terzaghi_mean

    from solver.references.analytic import degree_of_consolidation

    H, cv, ratio, s0, s_inf = 1.0, 1.0 / t_end, 0.97, 1e-5, 1e-3   # T_v = 1 at t_end
    t = np.geomspace(t_end / 1e4, t_end, 50)
    settled = s0 + (s_inf - s0) * degree_of_consolidation(cv * t * ratio / H ** 2)
    fig = figures.settlement_time(output.pyplot(), t, settled, s0, s_inf, cv, ratio, H, "x")
    ax = fig.axes[0]
    assert ax.get_xlabel() == f"time t ({unit})" and ax.get_xscale() == "log"
    assert "mm" in ax.get_ylabel() and ax.yaxis_inverted()
    lines = {ln.get_label(): ln for ln in ax.get_lines()}
    mpm = lines["MPM, surface settlement"]
    np.testing.assert_allclose(mpm.get_xdata(), t / seconds, rtol=1e-12)
    np.testing.assert_allclose(mpm.get_ydata(), 1e3 * settled, rtol=1e-12)
    classic = lines["Terzaghi, classic"]
    T = cv * classic.get_xdata() * seconds / H ** 2
    want = 1e3 * s_inf * np.array([1 - terzaghi_mean(T_i) for T_i in T[::40]])
    np.testing.assert_allclose(classic.get_ydata()[::40], want, atol=1e-9)
    output.pyplot().close(fig)


def test_pressure_field_of_a_wide_body_stacks_its_panels():
    """A body wider than high (a strip footing's block) gets its snapshots one above the
    other, each panel as wide as the figure; a column keeps them side by side."""
    from solver.consolidation import plots as figures
    from solver.io import output

    plt = output.pyplot()
    x, y = np.meshgrid(np.linspace(0.05, 1.95, 20), np.linspace(0.05, 0.95, 10))
    snaps = [(Tv, x.ravel(), y.ravel(), np.full(x.size, 5e3)) for Tv in (0.01, 0.1, 0.5)]
    wide = figures.pressure_field(plt, snaps, 1e4, "t", width=2.0, height=1.0)
    tall = figures.pressure_field(plt, snaps, 1e4, "t", width=0.1, height=1.0)
    boxes = [[ax.get_position() for ax in f.axes if ax.get_label() != "<colorbar>"][:3]
             for f in (wide, tall)]
    assert all(abs(b.x0 - boxes[0][0].x0) < 1e-9 for b in boxes[0])      # one column
    assert boxes[0][0].y0 > boxes[0][1].y0 > boxes[0][2].y0               # top to bottom
    assert all(abs(b.y0 - boxes[1][0].y0) < 1e-9 for b in boxes[1])      # one row
    for f in (wide, tall):
        plt.close(f)


def test_profile_under_the_axis_names_each_time_and_draws_the_fe():
    """A scene without a closed form: the column under the axis at each T_v, named in the
    legend, with the FE's profile in the same colour (the overlay of every
    column had no labels and no time legend)."""
    plt = output.pyplot()
    y = np.linspace(0.05, 0.95, 10)
    snaps = [(Tv, y, np.exp(-Tv) * (1 - y)) for Tv in (0.01, 0.1, 0.5)]
    lines = [(Tv, np.linspace(0, 1, 5), np.full(5, Tv)) for Tv in (0.01, 0.5)]
    fig = figures.axis_profiles(plt, snaps, lines, 1.0, "t")
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert labels == ["T_v = 0.01", "T_v = 0.1", "T_v = 0.5", "FE reference", "MPM points"]
    drawn = [ln for ln in ax.get_lines() if len(ln.get_xdata())]
    assert len(drawn) == 5                      # three columns of points, two FE profiles
    fe = [ln for ln in drawn if ln.get_marker() in ("None", "", None)]
    assert len(fe) == 2 and fe[1].get_color() is not None
    np.testing.assert_allclose(fe[1].get_xdata(), 0.5)
    plt.close(fig)


def test_settlement_time_of_a_scene_without_a_closed_form():
    """The settlement at the axis and the mean under the load, the run's and the FE's,
    named, against time in the scene's unit, with the static ends of the mean."""
    plt = output.pyplot()
    t = np.geomspace(1e-2, 2e4, 50)              # 5.6 hours
    fe = (t[::5], 2e-3 * np.ones(10), 1e-3 * np.ones(10), (64, 32))
    fig = figures.settlement_time_2d(plt, t, 2e-3 * np.ones(50), 1e-3 * np.ones(50), 0.0,
                                     (0.0, 0.5), fe, (0.8e-3, 3e-3), "t")
    ax = fig.axes[0]
    labels = [x.get_text() for x in ax.get_legend().get_texts()]
    assert labels == ["MPM, at the axis x = 0 m",
                      "MPM, mean under the load (0 <= x <= 0.5 m)",
                      "FE (64 x 32 Q9/Q4), at the axis", "FE (64 x 32 Q9/Q4), mean under the load"]
    assert ax.get_xlabel() == "time t (h)" and ax.yaxis_inverted()
    mm = sorted({round(float(ln.get_ydata()[0]), 6) for ln in ax.get_lines()})
    assert mm == [0.8, 1.0, 2.0, 3.0]           # mm: the curves and the static ends
    plt.close(fig)
