"""The shaken body (solver/dynamic/column.py, issue 30) against the exact site response
(solver/references/site.py, d'Alembert's reflections) and the Jacobi eigenfrequencies of the
same column."""

from __future__ import annotations

import numpy as np
import pytest
from petsc4py import PETSc

from solver.dynamic.column import ShakenBody, Shaking
from solver.eigen import jacobi
from solver.eigen.frequency import frequencies
from solver.model.motion import ricker, ricker_velocity
from solver.model.scene import Body, build, destroy
from solver.model.soil import Soil
from solver.references.site import Column, layer_frequencies, peaks, response

H, VS, RHO, NU = 20.0, 200.0, 2000.0, 0.3
ROCK = (2400.0, 800.0)


def _soil():
    n = 0.3
    G = RHO * VS ** 2
    return Soil(E=2 * G * (1 + NU), nu=NU, rho_s=(RHO - n * 1000.0) / (1 - n), porosity=n)


def _run(shaking, f0, t_end, cells=(1, 100)):
    body = Body(element="q4", cells=cells, size=(1.0, H), ppc=2)
    model = ShakenBody(PETSc.COMM_WORLD, body, _soil(), shaking)
    try:
        return model.run(t_end, lambda t: ricker_velocity(t, f0, 1.0),
                         lambda t: ricker(t, f0, 1.0))
    finally:
        model.destroy()


def test_layer_on_rock_follows_the_exact_response():
    """A 5 Hz Ricker as the outcrop motion under 20 m of soil on rock (1 x 100 Q4 cells):
    the surface acceleration within 3 % of its peak of the exact one (measured 0.6 %)."""
    r = _run(Shaking("x", "compliant", *ROCK), 5.0, 4.0)
    exact = response(Column((H,), (VS,), (RHO,), rock=(ROCK[1], ROCK[0], 0.0)), r["dt"],
                     ricker(r["t"], 5.0, 1.0), pad=8)
    assert np.max(np.abs(r["surface"] - exact)) < 0.03 * np.max(np.abs(exact))


def test_rigid_base_is_the_sum_of_reflections():
    """On a rigid base (the input is the base's own motion) the undamped layer's surface is
    2 sum_n (-1)^n a_b(t - (2n + 1) H / Vs): within 3 % of its peak over the first second,
    five passages of the pulse (measured 1.9 %; undamped, it bounces forever, and the
    step's dispersion adds about 2 % of the peak a second)."""
    r = _run(Shaking("x", "rigid"), 5.0, 1.0)
    tau = H / VS
    exact = sum(2 * (-1) ** n * ricker(r["t"] - (2 * n + 1) * tau, 5.0, 1.0)
                for n in range(20))
    assert np.max(np.abs(r["surface"] - exact)) < 0.03 * np.max(np.abs(exact))


def test_transfer_peaks_are_the_layers_and_jacobis_frequencies():
    """The surface over the outcrop (an 8 Hz Ricker, 6 s): its first three peaks within 1 %
    of (2n - 1) Vs / 4H and of the Jacobi eigenfrequencies of the same column on a fixed
    base."""
    r = _run(Shaking("x", "compliant", *ROCK), 8.0, 6.0)
    n = 1 << 16
    f = np.fft.rfftfreq(n, r["dt"])
    tf = np.fft.rfft(r["surface"], n) / np.fft.rfft(ricker(r["t"], 8.0, 1.0), n)
    band = (f > 0.5) & (f < 16)
    found = peaks(f[band], tf[band])
    np.testing.assert_allclose(found, layer_frequencies(H, VS), rtol=0.01)
    body = Body(element="q4", cells=(1, 100), size=(1.0, H), ppc=2,
                bcs=Shaking("x", "rigid").supports())
    grid, points, K, M, free = build(PETSc.COMM_WORLD, body, _soil())
    try:
        eig = frequencies(jacobi.solve(K, M, 3).eigenvalues[:3])
    finally:
        destroy(K, M, free, points, grid)
    np.testing.assert_allclose(found, eig, rtol=0.01)


def test_a_pulse_leaves_through_a_matched_base():
    """Rock of the soil's own impedance: the pulse reflected at the surface leaves through
    the base; what comes back is at most 2 % of the peak."""
    r = _run(Shaking("x", "compliant", RHO, VS), 5.0, 2.0)
    gone = r["t"] > 2 * H / VS + 0.3 + 3 / 5.0
    assert np.max(np.abs(r["surface"][gone])) <= 0.02 * np.max(np.abs(r["surface"]))


def test_bad_shaking_is_refused():
    from solver.common.errors import InputError

    with pytest.raises(InputError, match="rigid or compliant"):
        Shaking("x", "soft")
    with pytest.raises(InputError, match="density and wave speed"):
        Shaking("x", "compliant")
