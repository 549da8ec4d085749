"""The waves a sudden load sets going (solver.stepping.waves), against the undrained rod and
the fast-part damper's own equation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.model.scene import Body, Loading
from solver.model.soil import Soil
from solver.stepping import inertia, waves


def test_column_swings_are_the_undrained_rods():
    """A 1 x 40 Q4 column on rollers with a fixed base under a sudden top load is an
    undrained rod of modulus E_c + K_l / n: its modes that the load excites are
    w_k = (2k - 1) pi c1 / (2H), and the uniform undrained pressure p_s = q (K_l / n) /
    (E_c + K_l / n) expands as p_s sum_k (4 / pi) (-1)^(k+1) / (2k - 1) cos((2k - 1) pi y /
    (2H)): mode 1 swings by (4 / pi) p_s cos(pi y / 2H) at height y."""
    soil = Soil()
    H = 1.0
    body = Body(cells=(1, 40), size=(0.1, H), ppc=2)
    sw = waves.swings(body, soil, Loading(load=1e4))
    c1 = soil.wave_speeds()["c1"]
    share = np.max(sw.amplitude, axis=0)                     # each mode's largest swing
    excited = share > 1e-3 * share.max()
    first = np.flatnonzero(excited)[0]
    assert sw.omega[first] == pytest.approx(math.pi * c1 / (2 * H), rel=2e-3)
    second = np.flatnonzero(excited)[1]
    assert sw.omega[second] == pytest.approx(3 * math.pi * c1 / (2 * H), rel=1e-2)
    B = (soil.K_l / soil.porosity) / (soil.constrained_modulus + soil.K_l / soil.porosity)
    y = 0.25 * H / 40                                        # the lowest points
    expected = 4 / math.pi * B * math.cos(math.pi * y / (2 * H))
    assert share[first] == pytest.approx(expected, rel=5e-3)


def test_the_tuned_mode_decays_as_the_closed_form_says():
    """A mode at the fast-part damper's own frequency w1 decays per damped period T_d by
    the factor r of inertia.decay (zeta = 0.5: r = 0.36, T_d = 1.34 T_w); local damping
    alpha adds (1 - alpha) / (1 + alpha) per period."""
    w1 = 2 * math.pi * 10.0
    for zeta in (0.2, 0.5, 1.0):
        r, stretch = inertia.decay(0.0, zeta)
        rate = waves.decay_rates([w1], 0.0, zeta, w1)[0]
        assert math.exp(-rate * stretch * 2 * math.pi / w1) == pytest.approx(r, rel=1e-9)
    rate = waves.decay_rates([w1], 0.5, 0.0, w1)[0]
    assert math.exp(-rate * 2 * math.pi / w1) == pytest.approx(1 / 3, rel=1e-12)


def test_a_ramped_load_excites_less():
    """A load reached over a ramp T_r leaves each mode |sinc(w T_r / 2)| of a step's swing
    (the undamped oscillator under a linear rise); the static state is the same."""
    soil = Soil()
    body = Body(cells=(1, 20), size=(0.1, 1.0), ppc=2)
    step = waves.swings(body, soil, Loading(load=1e4))
    T = 4.0 / soil.wave_speeds()["c1"]
    ramped = waves.swings(body, soil, Loading(load=1e4, ramp=0.3 * T))
    factor = np.abs(np.sinc(step.omega * 0.3 * T / (2 * np.pi)))
    assert np.allclose(ramped.amplitude, step.amplitude * factor, rtol=1e-9, atol=1e-15)
