"""What a site-response run says of itself: the warning where its linear soil is strained
past 1e-4, with the peak strain and its depth."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import check_ok

from solver.dynamic.histories import COLUMNS, Recorder
from solver.dynamic.reporting import strain_warning


def recorder(u_top):
    """A column of rows 0, 1, 2, 3 m high whose x displacement is u_top (m) times the
    height over 3 m, except the top interval, which takes twice the rest's strain."""
    rec = Recorder([0.0, 1.0, 2.0, 3.0], 3.0, (), "x")
    means = np.zeros((4, len(COLUMNS)))
    means[:, 2] = u_top * np.array([0.0, 1.0, 2.0, 4.0]) / 4
    rec.sample(0.0, means)
    return rec


def test_the_strain_warning_names_the_peak_and_its_depth():
    rec = recorder(4e-4)                     # strains 1e-4, 1e-4, 2e-4 from the base up
    words = strain_warning(rec, 3.0)
    assert "shear strain 0.0002 (0.02 %) at 0.5 m depth" in words
    assert strain_warning(recorder(2e-4), 3.0) == ""        # 1e-4 at most: none


def test_a_strong_motion_on_a_linear_soil_warns(cli, tmp_path):
    """The uniform layer under its Ricker wavelet scaled up 20 times strains past 1e-4:
    the run says so, in its output and in the summary's warnings."""
    res = cli(["-mpm_figures", "0", "-mpm_progress", "0", "-mpm_t_end", "1.0",
               "-mpm_cells", "1,50", "-mpm_base_motion_scale", "20"],
              options_file="dynamic-uniform", out_dir=tmp_path / "out")
    s = check_ok(res)["dynamic"]
    assert len(s["warnings"]) == 1 and "linear elastic" in s["warnings"][0]
    peak = float(s["warnings"][0].split("shear strain ")[1].split(" ")[0])
    assert peak > 1e-4
    assert "Warning: the peak shear strain" in res.stdout
    quiet = check_ok(cli(["-mpm_figures", "0", "-mpm_progress", "0", "-mpm_t_end", "1.0",
                          "-mpm_cells", "1,50", "-mpm_base_motion_scale", "0.01"],
                         options_file="dynamic-uniform", out_dir=tmp_path / "quiet"))
    assert "warnings" not in quiet["dynamic"]


def newmark_psa(a, dt, period, damping):
    """PSA (m/s2) of one oscillator by Newmark's average acceleration, written here."""
    w = 2 * np.pi / period
    k_eff = w * w + 2 * damping * w * 2 / dt + 4 / dt ** 2
    u = v = 0.0
    acc = -a[0]
    peak = 0.0
    for p in -a[1:]:
        rhs = p + (4 / dt ** 2) * u + (4 / dt) * v + acc + 2 * damping * w * (2 / dt * u + v)
        u_new = rhs / k_eff
        v_new = 2 / dt * (u_new - u) - v
        acc = p - 2 * damping * w * v_new - w * w * u_new
        u, v = u_new, v_new
        peak = max(peak, abs(u))
    return w * w * peak


def test_psa_damping_and_periods_are_the_users(cli, tmp_path):
    """-mpm_psa_damping 0.02 -mpm_psa_periods 0.05,2,12: spectra.csv's PSA rows at those 12
    log-spaced periods, the input's within 0.5 % of Newmark's oscillators at 2 % damping
    on the Ricker wavelet sampled ten times finer."""
    from solver.model.motion import Motion, parse

    out = tmp_path / "out"
    check_ok(cli(["-mpm_figures", "0", "-mpm_progress", "0", "-mpm_t_end", "2.0",
                  "-mpm_cells", "1,50", "-mpm_psa_damping", "0.02",
                  "-mpm_psa_periods", "0.05,2,12"],
                 options_file="dynamic-uniform", out_dir=out))
    rows = [line.split(",") for line in (out / "spectra.csv").read_text().splitlines()[1:]
            if line.startswith("psa")]
    periods = np.array([float(r[1]) for r in rows])
    np.testing.assert_allclose(periods, np.logspace(np.log10(0.05), np.log10(2), 12),
                               rtol=1e-6)
    motion = Motion(parse("ricker:5,1"), 1.0, None)
    t = np.arange(0, 2.0 + 1e-12, 2e-5)
    a = motion.acceleration(t)
    for r, T in zip(rows, periods):
        assert float(r[2]) == pytest.approx(newmark_psa(a, 2e-5, T, 0.02), rel=5e-3), T


def test_peaks_with_depth(cli, tmp_path):
    """peaks.csv of the uniform layer: the surface's peak |v| and |u| those of its history
    (the same samples), the strain in % 100 times the strain, and the shear stress G
    times it (G = E / 2 (1 + nu) of the scene: 76 MPa)."""
    import csv

    out = tmp_path / "out"
    check_ok(cli(["-mpm_figures", "0", "-mpm_progress", "0", "-mpm_t_end", "1.0",
                  "-mpm_cells", "1,50"], options_file="dynamic-uniform", out_dir=out))
    with open(out / "peaks.csv") as fh:
        peaks = list(csv.DictReader(fh))
    with open(out / "histories.csv") as fh:
        surface = [r for r in csv.DictReader(fh) if float(r["depth_m"]) == 0.0]
    top = peaks[0]
    assert float(top["peak_v_m_s"]) == pytest.approx(
        max(abs(float(r["v_x"])) for r in surface), rel=1e-6)
    assert float(top["peak_u_rel_m"]) == pytest.approx(
        max(abs(float(r["u_x"])) for r in surface), rel=1e-6)
    G = 197.6e6 / 2.6
    for row in peaks[:-1]:
        strain = float(row["peak_strain"])
        assert float(row["peak_shear_strain_pct"]) == pytest.approx(100 * strain, rel=1e-6)
        assert float(row["peak_shear_stress_pa"]) == pytest.approx(G * strain, rel=1e-6)
    assert float(peaks[-1]["peak_u_rel_m"]) == 0.0          # the base, relative to itself
