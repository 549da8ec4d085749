"""The finite-element Biot reference (solver/references/biot.py) against independent references:
Terzaghi's series with compressible water (one-way and two-way drainage), a layered column
by a fine finite-volume solution written here, and its own convergence on a block drained
through its sides, which has no closed form."""

from __future__ import annotations

import numpy as np
import pytest
from petsc4py import PETSc
from scipy.linalg import eigh

from conftest import scene_options
from solver.common.errors import InputError
from solver.model.soil import constrained_modulus
from solver.references import analytic, biot

SELF = PETSc.COMM_SELF
GAMMA_W = 1000.0 * 9.81
Q = 1.0e4
TV = np.array([0.05, 0.2, 0.5])


def column(drained, element="q9", nu=0.3, cells=32):
    """A 1 m column (0.1 m wide, rollers on the sides, fixed base) under a uniform load;
    p at 65 heights and the settlement at TV in the compressible-water diffusivity c2."""
    E, n, K_l, k = 1.0e7, 0.3, 1.2e8, 2.5e-4
    body = biot.Body(size=(0.1, 1.0), E=E, nu=nu, k=k, porosity=n, K_l=K_l, load=Q,
                     drained=drained)
    E_c = constrained_modulus(E, nu)
    c2 = analytic.consistent_coefficient(k, E_c, GAMMA_W, K_l, n)
    y = np.linspace(0.0, 1.0, 65)
    r = biot.solve(SELF, body, TV / c2, np.stack([np.full_like(y, 0.05), y], -1),
                   cells=(1, cells), element=element)
    return r, y, {"E_c": E_c, "c2": c2, "p0": analytic.undrained_pressure(Q, E_c, K_l, n),
                  "s0": Q / (E_c + K_l / n), "s_inf": Q / E_c}


# Spatial error of the pressure (bilinear in each cell) on 32 cells: O(h^2), measured
# 6.2e-4 q at T = 0.05 (the steepest profile; 1.4e-4 at T = 0.2, 0.5), 2.4e-3 q on 16 cells;
# the time error of the default steps is about 1e-5 q (tests below). Layered column, 40 cells:
# 5.9e-4 q (2.0e-4 on 80; the finite volumes' own error 1e-6 q).
P_BOUND = 1.0e-3


@pytest.mark.parametrize("element", ["q9", "q8"])
def test_column_drained_at_the_top_follows_terzaghi(element):
    r, y, ref = column(("top",), element)
    exact = analytic.terzaghi(1.0 - y[None, :], TV[:, None], 1.0, ref["p0"])
    assert np.abs(r.pressure - exact).max() < P_BOUND * Q
    # u linear and p uniform at 0+ and at the end: in the FE space, so exact to round-off.
    assert r.undrained == pytest.approx(ref["s0"], rel=1e-10)
    assert r.drained == pytest.approx(ref["s_inf"], rel=1e-10)
    assert np.allclose(r.undrained_pressure, ref["p0"], rtol=1e-10, atol=0)
    # s = s0 + (s_inf - s0) U(T): the depth integral of the same p error.
    U = analytic.degree_of_consolidation(TV)
    s = ref["s0"] + (ref["s_inf"] - ref["s0"]) * U
    assert np.abs(r.settlement - s).max() < P_BOUND * (ref["s_inf"] - ref["s0"])


def test_column_drained_at_the_base_mirrors_terzaghi():
    r, y, ref = column(("bottom",))
    exact = analytic.terzaghi(y[None, :], TV[:, None], 1.0, ref["p0"])
    assert np.abs(r.pressure - exact).max() < P_BOUND * Q


def test_column_drained_at_both_ends_is_two_half_layers():
    r, y, ref = column(("top", "bottom"))
    # By symmetry each half drains one way through a layer of thickness H / 2.
    T_half = TV * 4.0
    exact = analytic.terzaghi(np.minimum(y, 1.0 - y)[None, :], T_half[:, None], 0.5,
                              ref["p0"])
    assert np.abs(r.pressure - exact).max() < P_BOUND * Q


def layered_reference(t, thick, E_c, k, n, K_l, cells=1000):
    """p (Pa) at the cell centres (depths, m) of a fine finite-volume column drained at the
    top, impermeable at the base, and its settlement (m), at times t: storage
    (1/E_c + n/K_l) dp/dt = d/dz(k/gamma_w dp/dz), integrated exactly in time through the
    generalized eigenpairs of the (stiffness, storage) pair."""
    dz = thick.sum() / cells
    z = (np.arange(cells) + 0.5) * dz
    layer = np.searchsorted(np.cumsum(thick), z)
    m_v = 1 / E_c[layer] + n[layer] / K_l
    lam = k[layer] / GAMMA_W
    face = 1 / (dz / (2 * lam[:-1]) + dz / (2 * lam[1:]))   # harmonic: flux continuity
    A = np.diag(np.r_[2 * lam[0] / dz + face[0], face[:-1] + face[1:], face[-1]])
    A -= np.diag(face, 1) + np.diag(face, -1)
    C = m_v * dz
    w, V = eigh(A, np.diag(C))
    p0 = Q / (E_c[layer] * m_v)
    p = (V * np.exp(-np.outer(t, w))[:, None, :]) @ (V.T @ (C * p0))
    settlement = ((Q - p) / E_c[layer]).sum(axis=-1) * dz
    return z, p, settlement


def test_layered_column_against_finite_volumes():
    thick = np.array([0.4, 0.6])
    # A stiff, tight top layer over a soft, open one: the top holds the water back.
    E, nu, k, n, K_l = np.array([2.0e7, 5.0e6]), 0.3, np.array([2e-5, 4e-4]), np.array(
        [0.35, 0.3]), 1.2e8
    body = biot.Body(size=(0.1, 1.0), E=tuple(E), nu=nu, k=tuple(k), porosity=tuple(n),
                     K_l=K_l, load=Q, layers=tuple(thick))
    E_c = constrained_modulus(E, nu)
    t = np.array([0.5, 2.0, 8.0])     # s: max p 0.98, 0.92, 0.67 q; U 0.08 to 0.38
    z, p_ref, s_ref = layered_reference(t, thick, E_c, k, n, K_l)
    depth = z[5::50]
    r = biot.solve(SELF, body, t, np.stack([np.full_like(depth, 0.05), 1 - depth], -1),
                   cells=(1, 40))
    assert np.abs(r.pressure - p_ref[:, 5::50]).max() < P_BOUND * Q
    s_span = Q * (thick / E_c).sum()
    assert np.abs(r.settlement - s_ref).max() < P_BOUND * s_span
    # Drained: u piecewise linear with kinks on cell boundaries, in the FE space.
    assert r.drained == pytest.approx(s_span, rel=1e-10)


def block(cells=(16, 16), steps=16):
    """The block W = H = 1.2 m drained left and right, rollers on the sides, fixed base,
    q = 15 kPa: p / q on a 9 x 9 lattice and the settlement / s_inf at TV (classic c_v)."""
    body = biot.Body(size=(1.2, 1.2), E=8e6, nu=0.2, k=2e-4, porosity=0.4, K_l=1.2e8,
                     load=15e3, drained=("left", "right"))
    c_v = analytic.consolidation_coefficient(2e-4, constrained_modulus(8e6, 0.2), GAMMA_W)
    g = np.linspace(0.0, 1.2, 9)
    X, Y = np.meshgrid(g, g)
    r = biot.solve(SELF, body, TV * 1.2**2 / c_v, np.stack([X.ravel(), Y.ravel()], -1),
                   cells=cells, steps=steps)
    return r.pressure / 15e3, r.settlement / r.drained, r


def assert_second_order(runs):
    """Differences between successive halvings shrink by 4 (2^1.6 to 2^2.5 allowed) at each
    T, for p and for the settlement."""
    for k in (0, 1):
        d = [np.abs(a[k] - b[k]).reshape(len(TV), -1).max(axis=1)
             for a, b in zip(runs[:-1], runs[1:])]
        rate = np.log2(d[0] / d[1])
        assert ((rate > 1.6) & (rate < 2.5)).all(), (k, d, rate)


def test_block_drained_at_its_sides_converges_in_space():
    runs = [block(cells=(c, c)) for c in (8, 16, 32)]
    assert_second_order(runs)
    E_c = constrained_modulus(8e6, 0.2)
    # With rollers on the sides the end states are one-dimensional: exact.
    r = runs[-1][2]
    assert r.drained == pytest.approx(15e3 * 1.2 / E_c, rel=1e-10)
    assert r.undrained == pytest.approx(15e3 * 1.2 / (E_c + 1.2e8 / 0.4), rel=1e-10)


def test_block_drained_at_its_sides_converges_in_time():
    assert_second_order([block(cells=(8, 8), steps=s) for s in (16, 32, 64)])


def test_settlement_profile_and_mean_over_a_partial_load():
    body = biot.Body(size=(1.0, 1.0), E=1e7, nu=0.25, k=1e-4, porosity=0.3, load=Q,
                     loaded=(0.13, 0.61), drained=("top",))
    x = np.linspace(0.13, 0.61, 2001)
    r = biot.solve(SELF, body, [0.0, 20.0], [[0.5, 0.5]], surface=x, cells=(8, 8))
    mean = biot.solve(SELF, body, [0.0, 20.0], [[0.5, 0.5]], cells=(8, 8))
    profile = np.vstack([r.undrained, r.settlement[1], r.drained])
    trapezoid = (profile[:, 1:] + profile[:, :-1]).sum(axis=1) / 2 * (x[1] - x[0]) / 0.48
    means = np.array([mean.undrained, mean.settlement[1], mean.drained])
    # The trapezoid rule on 2000 intervals: 1e-6 of the settlement.
    assert np.allclose(means, trapezoid, rtol=1e-6)
    assert np.array_equal(r.settlement[0], r.undrained)
    assert (profile > 0).all() and (np.diff(profile, axis=0) > 0).all()


def test_from_options_matches_a_body():
    p = scene_options(size="0.1,1", E=1e7, nu=0.3, k=2.5e-4, porosity=0.3, load=Q)
    r = biot.solve(SELF, biot.from_options(p), [0.0], [[0.05, 0.5]], cells=(1, 4))
    assert r.drained == pytest.approx(Q / constrained_modulus(1e7, 0.3), rel=1e-10)
    with pytest.raises(InputError):
        biot.from_options(scene_options(load_ramp=1.0))


def test_the_reference_knows_the_scenes_sides_and_supports():
    """biot states its sides and support choices itself (the references sit below the
    options): they must be the scene's and the command line's."""
    from solver.io import options
    from solver.model import scene

    assert biot.SIDES == scene.SIDES
    assert biot.BC_CHOICES == options.BC_CHOICES
    assert set(biot.DEFAULT_BCS) == set(scene.SIDES)
    assert all(biot.DEFAULT_BCS[side] == getattr(options.from_mapping({}), f"bc_{side}")
               for side in scene.SIDES)


BAD = [
    (dict(layers=(0.5, 0.6)), "sum to"),
    (dict(layers=(0.3, 0.7), E=(1e7, 2e7)), "inside a cell"),
    (dict(layers=(0.5, 0.5), E=(1e7, 2e7, 3e7)), "one per layer"),
    (dict(drained=("top", "front")), "unknown side"),
    (dict(bcs={"front": "x"}), "unknown side"),
    (dict(bcs={"left": "z"}), "choose from"),
    (dict(bcs={"bottom": "y", "left": "none", "right": "none"}), "rigid-body"),
    (dict(loaded=(0.0, 0.2)), "loaded"),
    (dict(nu=0.5), "nu"),
]


@pytest.mark.parametrize("change, words", BAD)
def test_bad_input_is_one_line(change, words):
    with pytest.raises(InputError) as err:
        body = biot.Body(**{"size": (0.1, 1.0), **change})
        biot.solve(SELF, body, [1.0], [[0.05, 0.5]], cells=(1, 4))
    assert words in str(err.value) and "\n" not in str(err.value)


@pytest.mark.parametrize("call, words", [
    (dict(points=[[0.2, 0.5]]), "outside"),
    (dict(element="q4"), "element"),
    (dict(times=[-1.0]), "times"),
])
def test_bad_run_is_one_line(call, words):
    args = {"times": [1.0], "points": [[0.05, 0.5]], **call}
    with pytest.raises(InputError) as err:
        biot.solve(SELF, biot.Body(size=(0.1, 1.0)), cells=(1, 4), **args)
    assert words in str(err.value) and "\n" not in str(err.value)
