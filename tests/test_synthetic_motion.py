"""scripts/synthetic_motion.py, Boore's (2003) stochastic point-source record: seeded and
reproducible, its peak the requested PGA, its mean Fourier spectrum the Brune * path *
kappa shape (written here from the formulas, not the script's), and its CSV read back by the
solver's record reader."""

import importlib.util
import re

import numpy as np
import pytest

from conftest import REPO
from solver.io import records

SCRIPT = REPO / "scripts" / "synthetic_motion.py"
DEFAULTS = dict(magnitude=6.5, distance_km=20.0, stress_drop_bar=100.0, kappa=0.03,
                pga=2.0, dt=0.005, duration=20.0)


@pytest.fixture(scope="module")
def sm():
    spec = importlib.util.spec_from_file_location("synthetic_motion_under_test", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def brune_path_kappa_squared(f, magnitude, distance_km, stress_drop_bar, kappa):
    """|A(f)|^2 up to a constant: Boore (2003) eq. 3-8 with beta = 3.5 km/s, omega-squared
    source, 1/R, Q = 180 f^0.45, exp(-pi kappa f)."""
    beta = 3.5
    m0 = 10.0 ** (1.5 * magnitude + 16.05)                       # dyne-cm
    f0 = 4.906e6 * beta * (stress_drop_bar / m0) ** (1.0 / 3.0)  # Hz, 0.200 here
    q = 180.0 * f ** 0.45
    amp = ((2 * np.pi * f) ** 2 / (1 + (f / f0) ** 2) / distance_km
           * np.exp(-np.pi * f * distance_km / (q * beta)) * np.exp(-np.pi * kappa * f))
    return amp ** 2


def test_the_seed_fixes_the_record(sm):
    t1, a1 = sm.generate(seed=3, **DEFAULTS)
    t2, a2 = sm.generate(seed=3, **DEFAULTS)
    _, a3 = sm.generate(seed=4, **DEFAULTS)
    assert np.array_equal(t1, t2) and np.array_equal(a1, a2)           # bit for bit
    assert len(t1) == 4001 and t1[-1] == pytest.approx(20.0)
    assert np.max(np.abs(a1 - a3)) > 0.5                                # m/s2, of a PGA 2


@pytest.mark.parametrize("pga", [0.3, 2.0, 7.5])
def test_the_peak_is_the_requested_pga(sm, pga):
    _, a = sm.generate(seed=11, **{**DEFAULTS, "pga": pga})
    assert np.max(np.abs(a)) == pytest.approx(pga, rel=1e-12)


def test_the_mean_spectrum_has_the_target_shape(sm):
    """Over 40 seeds, each |FFT(a)|^2 normalised by its mean over 0.3-10 Hz, the mean against
    the target's |A|^2 (normalised the same way), both averaged over f +- 10 %.

    Each band holds ~0.2 f T_eff independent periodogram values per seed (chi-squared, 2
    degrees of freedom each), T_eff = (int w^2)^2 / int w^4 = 5.6 s for the Saragoni-Hart
    window of t_eta = 12 s, so the ratio's relative scatter is ~1 / sqrt(40 * 0.2 f T_eff):
    7.4 %, 6.1 %, 5.3 % at 4, 6, 8 Hz (400 sets of 40 seeds: 6.7 %, 5.8 %, 5.3 %). The
    bounds [0.75, 1.33] lie beyond 3.9 standard deviations there; below 3 Hz they would not
    (11 % at 1 Hz), so the plateau is held through the normalisation over 0.3-10 Hz only.
    A kappa of 0.045 s instead of 0.03 s gives 0.60 at 8 Hz, a distance of 40 km 0.72."""
    dt = DEFAULTS["dt"]
    f = np.fft.rfftfreq(4001, dt)
    band = (f >= 0.3) & (f <= 10.0)
    mean = np.zeros_like(f)
    for seed in range(40):
        _, a = sm.generate(seed=seed, **DEFAULTS)
        power = np.abs(np.fft.rfft(a)) ** 2
        mean += power / power[band].mean() / 40
    target = brune_path_kappa_squared(np.maximum(f, 1e-9), 6.5, 20.0, 100.0, 0.03)
    mean, target = mean / mean[band].mean(), target / target[band].mean()
    for fc in (4.0, 6.0, 8.0):
        near = (f >= 0.9 * fc) & (f <= 1.1 * fc)
        ratio = mean[near].mean() / target[near].mean()
        assert 0.75 <= ratio <= 1.33, (fc, ratio)


def test_the_csv_reads_back(sm, tmp_path):
    path = tmp_path / "new" / "motion.csv"           # the folder is made
    assert sm.main(["--seed", "7", "--output", str(path)]) == 0
    first = path.read_text().splitlines()[0]
    assert first.startswith("#") and "seed=7 " in first
    t, a = records.read(str(path))
    t_ref, a_ref = sm.generate(seed=7, **DEFAULTS)
    assert np.all(np.diff(t) > 0) and len(t) == len(t_ref)
    assert np.max(np.abs(t - t_ref)) <= 5e-5                            # %.4f
    assert np.all(np.abs(a - a_ref) <= 5e-7 * np.abs(a_ref) + 1e-300)   # %.6e
    assert np.max(np.abs(a)) == pytest.approx(2.0, rel=1e-6)
    assert sorted(p.name for p in path.parent.iterdir()) == ["motion.csv"]   # no leftover


def test_the_shipped_record_is_what_its_header_says(sm):
    """cases/motions/three-layers.csv: regenerated from the parameters of its own header."""
    path = REPO / "cases" / "motions" / "three-layers.csv"
    words = dict(re.findall(r"(\w+)=([^\s]+)", path.read_text().splitlines()[0]))
    t, a = records.read(str(path))
    t_ref, a_ref = sm.generate(
        seed=int(words["seed"]), magnitude=float(words["magnitude"]),
        distance_km=float(words["distance_km"]), stress_drop_bar=float(words["stress_drop_bar"]),
        kappa=float(words["kappa_s"]), pga=float(words["pga_m_s2"]), dt=float(words["dt_s"]),
        duration=float(words["duration_s"]))
    assert len(t) == len(t_ref) and np.max(np.abs(t - t_ref)) <= 5e-5
    assert np.max(np.abs(a - a_ref)) <= 1e-6 * np.max(np.abs(a_ref))
