"""The site-response references of the dynamic analysis (solver/references/site.py) against
closed forms written here, and the base motions (solver/model/motion.py, solver/io/records.py)."""

from __future__ import annotations

import numpy as np
import pytest

from solver.common.errors import InputError
from solver.io import records
from solver.model.motion import Motion, ricker, sine
from solver.references.site import Column, layer_frequencies, peaks, response, transfer

H, VS, RHO = 20.0, 200.0, 1900.0


def _f(n=2000, top=25.0):
    return np.linspace(0.01, top, n)


def test_uniform_layer_on_a_rigid_base_is_one_over_cos():
    """Undamped: |H_w| = 1 / |cos(w H / Vs)|; damped: H_w = 1 / cos(w H / V*), V* = Vs
    sqrt(1 + 2 i xi) (Kramer 1996, eq. 7.17-7.21)."""
    f = _f()
    k = 2 * np.pi * f / VS
    bare = transfer(Column((H,), (VS,), (RHO,)), f, "within")
    np.testing.assert_allclose(np.abs(bare), 1 / np.abs(np.cos(k * H)), rtol=1e-9)
    damped = transfer(Column((H,), (VS,), (RHO,), (0.05,)), f, "within")
    kstar = 2 * np.pi * f / (VS * np.sqrt(1 + 0.1j))
    np.testing.assert_allclose(damped, 1 / np.cos(kstar * H), rtol=1e-10)


def test_uniform_layer_on_elastic_rock():
    """Undamped soil on an elastic half-space: H_o = 1 / (cos kH + i alpha sin kH), alpha the
    soil's impedance over the rock's; its peaks are 1 / alpha at (2n - 1) Vs / 4H."""
    rock = (800.0, 2400.0, 0.0)
    col = Column((H,), (VS,), (RHO,), rock=rock)
    f = _f()
    k = 2 * np.pi * f / VS
    alpha = RHO * VS / (rock[1] * rock[0])
    np.testing.assert_allclose(transfer(col, f), 1 / (np.cos(k * H) + 1j * alpha * np.sin(k * H)),
                               rtol=1e-10)
    fine = np.linspace(0.01, 25.0, 200001)
    np.testing.assert_allclose(peaks(fine, transfer(col, fine)), layer_frequencies(H, VS),
                               rtol=1e-6)
    assert np.max(np.abs(transfer(col, fine))) == pytest.approx(1 / alpha, rel=1e-6)


def test_identical_sublayers_change_nothing():
    one = Column((H,), (VS,), (RHO,), (0.03,), rock=(600.0, 2200.0, 0.01))
    three = Column((5.0, 8.0, 7.0), (VS,) * 3, (RHO,) * 3, (0.03,) * 3, rock=one.rock)
    f = _f()
    for base in ("outcrop", "within"):
        np.testing.assert_allclose(transfer(three, f, base), transfer(one, f, base),
                                   rtol=1e-11)


def test_surface_history_is_the_sum_of_its_reflections():
    """A Ricker through an undamped layer on elastic rock: by d'Alembert the surface
    acceleration is 2 / (1 + alpha) sum_n (-r)^n a(t - (2n + 1) tau), r = (1 - alpha) /
    (1 + alpha), tau = H / Vs; the FFT route agrees within 1e-6 of the peak."""
    rock = (600.0, 2200.0, 0.0)
    col = Column((H,), (VS,), (RHO,), rock=rock)
    dt, T = 1e-3, 8.0
    t = np.arange(0, T, dt)
    a_in = ricker(t, 5.0, 1.0)
    alpha = RHO * VS / (rock[1] * rock[0])
    r, tau = (1 - alpha) / (1 + alpha), H / VS
    exact = sum(2 / (1 + alpha) * (-r) ** n * ricker(t - (2 * n + 1) * tau, 5.0, 1.0)
                for n in range(80))
    got = response(col, dt, a_in, pad=8)
    assert np.max(np.abs(got - exact)) < 1e-6 * np.max(np.abs(exact))


def test_a_rigid_base_has_no_outcrop_and_bad_columns_are_refused():
    with pytest.raises(InputError, match="within"):
        transfer(Column((H,), (VS,), (RHO,)), [1.0], "outcrop")
    with pytest.raises(InputError, match="> 0"):
        Column((H,), (-VS,), (RHO,))
    with pytest.raises(InputError, match="values of rho"):
        Column((H, H), (VS, VS), (RHO,))


def test_ricker_and_sine():
    """The Ricker's peak is AMP at 1.5 / F0 and its spectrum peaks at F0; the sine stops
    after its cycles."""
    dt = 1e-3
    t = np.arange(0, 4.0, dt)
    a = ricker(t, 5.0, 2.0)
    assert t[np.argmax(a)] == pytest.approx(0.3, abs=dt) and a.max() == pytest.approx(2.0)
    f = np.fft.rfftfreq(1 << 16, dt)
    spectrum = np.abs(np.fft.rfft(a, 1 << 16))
    assert f[np.argmax(spectrum)] == pytest.approx(5.0, rel=0.01)
    s = sine(t, 2.0, 1.0, 3)
    assert np.all(s[t > 1.5] == 0) and s[t <= 1.5].max() == pytest.approx(1.0, rel=1e-4)


def test_records_read_and_interpolated(tmp_path):
    """A CSV (a header, comments) and a PEER .AT2 (in g) give the same record; a run longer
    than the record is padded with zeros and says so."""
    t = np.arange(0, 1.0, 0.01)
    a = np.sin(2 * np.pi * 3 * t)
    csv = tmp_path / "m.csv"
    csv.write_text("t_s,a_mps2\n# a test record\n"
                   + "".join(f"{x!r},{y!r}\n" for x, y in zip(t, a)))
    at2 = tmp_path / "m.AT2"
    at2.write_text("PEER NGA STRONG MOTION DATABASE RECORD\nTEST\nACCELERATION TIME SERIES IN "
                   "UNITS OF G\nNPTS=  100, DT=   .0100 SEC\n"
                   + "\n".join(" ".join(f"{v:.9E}" for v in a[i:i + 5] / records.G_STANDARD)
                               for i in range(0, 100, 5)) + "\n")
    for path in (csv, at2):
        tr, ar = records.read(str(path))
        np.testing.assert_allclose(tr, t, atol=1e-12)
        np.testing.assert_allclose(ar, a, atol=1e-8)
    motion = Motion(("file", str(csv)), 1.0, (t, a))
    out = motion.acceleration(np.arange(0, 2.0, 0.004))
    assert motion.end < 2.0 and np.all(out[np.arange(0, 2.0, 0.004) > 1.0] == 0)
    np.testing.assert_allclose(out[:240:5], np.interp(np.arange(0, 0.96, 0.02), t, a))


@pytest.mark.parametrize("text, message", [
    ("0,1\n0.02,2\n0.01,3\n", "time does not increase at sample 3"),
    ("0,1\n", "fewer than two"),
    ("0,1\n0.1,x\n", "not a readable record"),
])
def test_bad_records_are_one_line_input_errors(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=message) as err:
        records.read(str(path))
    assert "\n" not in str(err.value)
    with pytest.raises(InputError, match="no such file"):
        records.read(str(tmp_path / "missing.csv"))


# -- spectra (solver/references/spectra.py) ---------------------------------------------------
def test_fourier_amplitude_of_a_ricker_is_its_closed_form():
    """|R(f)| = AMP 2 f^2 / (sqrt(pi) f0^3) e^(-f^2 / f0^2) (the Ricker's transform)."""
    from solver.references.spectra import fourier_amplitude

    dt, f0 = 1e-3, 5.0
    a = ricker(np.arange(0, 4.0, dt), f0, 2.0)
    f, amp = fourier_amplitude(a, dt, 1 << 14)
    exact = 2.0 * 2 * f ** 2 / (np.sqrt(np.pi) * f0 ** 3) * np.exp(-(f / f0) ** 2)
    assert np.max(np.abs(amp - exact)) < 1e-6 * exact.max()


def test_konno_ohmachi_keeps_what_is_linear_in_log_frequency():
    """Its weights are symmetric in log10 f and sum to one: a constant comes back unchanged
    everywhere, and a line in log10 f at the centre of a log-uniform grid symmetric about
    it (the whole window is taken: away from that centre the grid's ends make it
    lopsided)."""
    from solver.references.spectra import konno_ohmachi

    f = np.logspace(-1, 2, 601)
    np.testing.assert_allclose(konno_ohmachi(f, np.full_like(f, 3.0)), 3.0, rtol=1e-12)
    line = 1.0 + 2.0 * np.log10(f)
    for lo, hi in ((-1, 2), (-2, 1.5), (0.2, 0.4)):
        g = np.logspace(lo, hi, 801)
        centre = 10 ** ((lo + hi) / 2)
        value = konno_ohmachi(g, 1.0 + 2.0 * np.log10(g), [centre])[0]
        assert value == pytest.approx(1.0 + 2.0 * np.log10(centre), abs=1e-12)
    assert np.max(np.abs(konno_ohmachi(f, line) - line)) > 1e-6   # lopsided near the ends


def test_pseudo_acceleration_is_the_oscillators_exact_peak():
    """Against the oscillator integrated here by SciPy to 1e-11 (a random ground motion,
    linear between samples): within 1e-6; a stiff oscillator's PSA is the PGA."""
    from scipy.integrate import solve_ivp

    from solver.references.spectra import pseudo_acceleration

    rng = np.random.default_rng(1)
    dt = 0.01
    a = rng.standard_normal(300)
    t = np.arange(300) * dt
    for T in (0.05, 0.3, 2.0):
        w, z = 2 * np.pi / T, 0.05
        sol = solve_ivp(lambda s, y: [y[1], -np.interp(s, t, a) - 2 * z * w * y[1] - w * w * y[0]],
                        (0, t[-1]), [0.0, 0.0], t_eval=t, rtol=1e-11, atol=1e-13,
                        max_step=dt / 4)
        assert pseudo_acceleration(a, dt, [T])[0] == pytest.approx(
            w * w * np.max(np.abs(sol.y[0])), rel=1e-6)
    smooth = ricker(np.arange(0, 3.0, 1e-3), 2.0, 1.5)
    assert pseudo_acceleration(smooth, 1e-3, [0.01])[0] == pytest.approx(1.5, rel=0.01)
