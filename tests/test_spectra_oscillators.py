"""The pseudo-spectral acceleration's oscillators (solver/references/spectra.py:
Oscillators) against SciPy's own exact integration of a linear system under an input
linear between samples (scipy.signal.lsim), at a coarse and at a fine step, fed whole and
in pieces (as a dynamic run feeds them, across a checkpoint)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy.signal import lsim

from solver.references.spectra import Oscillators, pseudo_acceleration


def _lsim_psa(a, dt, T, z=0.05):
    """w^2 max|u| of u'' + 2 z w u' + w^2 u = -a, a linear between samples, by lsim."""
    w = 2 * np.pi / T
    sys = (np.array([[0.0, 1.0], [-w * w, -2 * z * w]]), np.array([[0.0], [-1.0]]),
           np.array([[1.0, 0.0]]), np.array([[0.0]]))
    t = np.arange(len(a)) * dt
    _, u, _ = lsim(sys, a, t, interp=True)
    return w * w * np.max(np.abs(u))


@pytest.mark.parametrize("dt", [5e-3, 1e-4])
def test_psa_is_lsims_exact_integration(dt):
    """A random ground motion of 2 s: within 1e-7 of lsim's (both exact for a motion
    linear between samples; they differ by rounding, amplified at the fine step where the
    long period's displacement is the sum of many small increments: measured 1e-13 at
    5e-3 s, 8e-9 at T = 10 s and 1e-4 s), 0.01 to 10 s. At
    w dt = 6e-5 (T = 10 s, dt = 1e-4 s) Nigam and Jennings' closed form lost 1e-4 of its
    input matrix to cancellation."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal(int(round(2.0 / dt)))
    periods = np.array([0.01, 0.05, 0.3, 2.0, 10.0])
    mine = pseudo_acceleration(a, dt, periods)
    for T, value in zip(periods, mine):
        assert value == pytest.approx(_lsim_psa(a, dt, T), rel=1e-7), T


def test_pieces_and_a_checkpoint_change_nothing():
    """Fed in pieces of 1, 2, 1 and the rest samples, the state passed through JSON in the
    middle (a checkpoint): the peaks of the whole record fed at once, to rounding."""
    rng = np.random.default_rng(4)
    a = rng.standard_normal(3000)
    periods = np.logspace(-2, 1, 30)
    whole = Oscillators(periods, 2e-3).feed(a).psa
    parts = Oscillators(periods, 2e-3)
    parts.feed(a[:1]).feed(a[1:3]).feed(a[3:4]).feed(a[4:1000])
    saved = json.loads(json.dumps(parts.state()))
    again = Oscillators(periods, 2e-3).restore(saved)
    again.feed(a[1000:2999]).feed([]).feed(a[2999:])
    assert again.count == len(a)
    np.testing.assert_allclose(again.psa, whole, rtol=1e-12)


def test_a_stiff_oscillator_follows_the_ground():
    """T = 0.001 s under a 2 Hz sine (amplitude 1.5) sampled every 1e-4 s: the PSA is the
    peak ground acceleration within the quasi-static error (T f)^2 ~ 4e-6 and the
    damping's phase lag."""
    t = np.arange(0, 1.0, 1e-4)
    a = 1.5 * np.sin(2 * np.pi * 2.0 * t)
    assert pseudo_acceleration(a, 1e-4, [0.001])[0] == pytest.approx(1.5, rel=1e-4)
