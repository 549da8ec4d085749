"""Terzaghi's references (solver.references.analytic) against references written here: the Fourier
series summed to thousands of terms, and the short-time image solution built on the
standard library's math.erfc. Also: scalars and arrays in and out, and memory O(points)."""

from __future__ import annotations

import math
import tracemalloc

import numpy as np
import pytest

from solver.references import analytic

# The promise: 1e-10 absolute in units of p0 for every Tv > 0.
ATOL = 1e-10
DEPTHS = np.linspace(0.0, 1.0, 41)          # z / H over the whole layer, both ends included
TVS = np.concatenate([np.logspace(-6, 1, 22),
                      [0.00699, 0.007, 0.00701, 0.02, 0.5, 1.0]])   # and the report times


def series(z, Tv, terms):
    """sum_m (2 / M) sin(M z) exp(-M^2 Tv), M = (2m + 1) pi / 2, summed over ``terms``
    terms for a few depths z (array) at one Tv: a (depths x terms) table, small here."""
    M = (2 * np.arange(terms) + 1) * np.pi / 2
    return np.sum(2 / M * np.sin(np.outer(z, M)) * np.exp(-M * M * Tv), axis=1)


def reference(z, Tv):
    """The series to round-off: enough terms that the first one left out is below 1e-30
    (M^2 Tv > 70)."""
    terms = int(math.sqrt(70 / Tv) / math.pi) + 10
    return series(np.asarray(z, dtype=float), Tv, terms)


def images(z, Tv, pairs=8):
    """Carslaw and Jaeger's image solution of the same problem with math.erfc, a Python
    loop over the points (small arrays only)."""
    s = 2 * math.sqrt(Tv)
    return np.array([1 - sum((-1) ** n * (math.erfc((2 * n + zz) / s)
                                          + math.erfc((2 * n + 2 - zz) / s))
                             for n in range(pairs)) for zz in z])


@pytest.mark.parametrize("Tv", TVS)
def test_classic_matches_the_series_to_1e_10(Tv):
    H = 2.5                                   # depth and H in m: only z / H matters
    got = analytic.terzaghi(DEPTHS * H, Tv, H)
    err = np.max(np.abs(got - reference(DEPTHS, Tv)))
    assert err < ATOL, f"Tv = {Tv:g}: largest error {err:.2e}"
    assert err < 1e-12                        # what it reaches: a margin on the promise


@pytest.mark.parametrize("Tv", [1e-12, 1e-9, 1e-7, 1e-5, 1e-3, 0.05])
def test_short_times_match_the_image_solution(Tv):
    """Down to Tv = 1e-12, where the former 4000-term series was wrong by O(1) near the
    surface (it resolves nothing thinner than about 1/4000 of the layer)."""
    got = analytic.terzaghi(DEPTHS, Tv)
    assert np.max(np.abs(got - images(DEPTHS, Tv))) < ATOL
    if Tv > 1e-3:
        return
    # A boundary layer of thickness ~ sqrt(Tv), far from the base's images: the profile is
    # erf(z / (2 sqrt(Tv))) there.
    z = np.array([0.5, 1.0, 2.0]) * math.sqrt(Tv)
    erf = np.array([math.erf(v / (2 * math.sqrt(Tv))) for v in z])
    assert np.max(np.abs(analytic.terzaghi(z, Tv) - erf)) < ATOL


def test_compressible_water_variant():
    """The compressible-water reference as the solver calls it: Tv scaled by c2 / c_v and the
    undrained pressure p0 < q, for the paper's soil (E = 10 MPa, nu = 0, n = 0.3,
    K_l = 120 MPa, k = 2.5e-4 m/s), the coefficients checked against their formulas."""
    E_c, n, K_l, k, gw = 10e6, 0.3, 120e6, 2.5e-4, 1000 * 9.81
    cv = analytic.consolidation_coefficient(k, E_c, gw)
    c2 = analytic.consistent_coefficient(k, E_c, gw, K_l, n)
    p0 = analytic.undrained_pressure(1.0, E_c, K_l, n)
    assert cv == pytest.approx(k * E_c / gw, rel=1e-15)
    assert c2 / cv == pytest.approx(1 / (1 + n * E_c / K_l), rel=1e-14)      # = 0.97561
    assert p0 == pytest.approx(400e6 / (400e6 + 10e6), rel=1e-14)           # = 0.97561
    H = 1.0
    for Tv in (1e-6, 1e-3, 0.02, 0.5, 1.0, 3.0):
        got = analytic.terzaghi(DEPTHS * H, Tv * c2 / cv, H, p0)
        ref = p0 * reference(DEPTHS, Tv * c2 / cv)
        assert np.max(np.abs(got - ref)) < ATOL
    # Slower diffusion and a smaller start: below the classic curve at mid-depth early on.
    assert analytic.terzaghi(0.5, 0.02 * c2 / cv, H, p0) < analytic.terzaghi(0.5, 0.02, H)


def test_the_soils_coefficients_are_the_closed_forms():
    """solver.model.soil writes its coefficients out (the model does not build on the references):
    c_v, c2 and the undrained share of a load agree with the closed forms, for a soil whose
    water's compressibility shows (n E_c / K_l = 0.054)."""
    from solver.model.soil import G_REF, Soil, constrained_modulus

    soil = Soil(E=20e6, nu=0.3, rho_s=2650.0, porosity=0.4, k=1e-5, rho_l=1000.0, K_l=200e6)
    E_c, gw = constrained_modulus(20e6, 0.3), 1000.0 * G_REF
    assert soil.c_v == pytest.approx(analytic.consolidation_coefficient(1e-5, E_c, gw),
                                     rel=1e-14)
    assert soil.c2 == pytest.approx(analytic.consistent_coefficient(1e-5, E_c, gw, 200e6, 0.4),
                                    rel=1e-14)
    assert soil.undrained_ratio == pytest.approx(
        analytic.undrained_pressure(1.0, E_c, 200e6, 0.4), rel=1e-14)
    assert soil.c2 < soil.c_v and 0.5 < soil.undrained_ratio < 1


def test_long_times_are_the_first_term():
    """For Tv >= 2 the second term is below 1e-18 of the first (exp(-2 pi^2 Tv) / 3): the
    result is the first term to round-off, relative as well as absolute. Round-off here is
    that of exp's argument a = pi^2 Tv / 4, formed in another order on each side (a few ulp
    of a, which exp turns into a relative error of a few eps times a), and of exp itself (a
    few ulp; NumPy's AVX-512 kernel differs from the others)."""
    eps = np.finfo(float).eps
    for Tv in (2.0, 10.0, 50.0):
        a = np.pi ** 2 * Tv / 4
        first = 4 / np.pi * np.sin(np.pi * DEPTHS / 2) * np.exp(-a)
        np.testing.assert_allclose(analytic.terzaghi(DEPTHS, Tv), first,
                                   rtol=8 * eps * (1 + a), atol=0)
    assert analytic.terzaghi(0.7, 1e4) == 0.0                      # underflow, no warning


def test_start_and_surface():
    """Tv <= 0 gives the limit: p0 inside, 0 at the drained surface, as before; at Tv > 0
    the surface stays drained and the base keeps the most pressure."""
    assert analytic.terzaghi([0.0, 0.3, 1.0], 0.0).tolist() == [0.0, 1.0, 1.0]
    assert analytic.terzaghi(0.5, -1.0, p0=2.0) == 2.0
    assert np.all(np.abs(analytic.terzaghi(0.0, TVS)) < 1e-14)
    base = analytic.terzaghi(1.0, TVS)
    assert np.all(base >= analytic.terzaghi(0.9, TVS))


def test_scalars_and_arrays_as_before():
    one = analytic.terzaghi(0.5, 0.2)
    assert isinstance(one, float) and np.ndim(one) == 0           # float() works on it
    assert one == pytest.approx(reference([0.5], 0.2)[0], abs=1e-13)
    assert float(analytic.terzaghi(0.5, 0.2, 1.0, 0.9)) == pytest.approx(0.9 * one, rel=1e-15)
    # A list, and depths x times broadcast to a table, mixing both forms and Tv = 0.
    depth = np.linspace(0, 2, 9)[:, None]
    Tv = np.array([0.0, 1e-4, 0.01, 0.3])
    table = analytic.terzaghi(depth, Tv, H=2.0)
    assert table.shape == (9, 4)
    for j, tv in enumerate(Tv):
        col = analytic.terzaghi(list(depth[:, 0]), tv, 2.0)
        assert np.max(np.abs(table[:, j] - col)) < 1e-13
        if tv > 0:
            assert np.max(np.abs(col - reference(depth[:, 0] / 2, tv))) < ATOL
    # A history at one depth (Tv an array, as the monitor figure draws it).
    Tv = np.logspace(-5, 0, 50)
    hist = analytic.terzaghi(0.75, Tv)
    assert hist.shape == (50,)
    assert np.max(np.abs(hist - [reference([0.75], t)[0] for t in Tv])) < ATOL
    assert analytic.terzaghi(np.zeros((0,)), 0.5).shape == (0,)


def test_outside_the_layer_the_series_continues():
    """Depths outside [0, H] give the series' own (odd, periodic) values, as before."""
    z = np.linspace(-1.0, 5.0, 61)
    for Tv in (1e-4, 0.05, 0.5):
        assert np.max(np.abs(analytic.terzaghi(z, Tv) - reference(z, Tv))) < ATOL


def test_a_given_number_of_terms_sums_exactly_those():
    """terms=N keeps the former truncated series (4000 terms, the old default)."""
    z = np.concatenate([[1e-4], np.linspace(0, 1, 11)])
    got = analytic.terzaghi(z, 1e-8, terms=4000)
    assert np.max(np.abs(got - series(z, 1e-8, 4000))) < 1e-12
    # Why it is not the default: in the boundary layer (z ~ sqrt(Tv)) it is off by 0.03,
    # elsewhere by 1e-5, where the default form meets 1e-10.
    exact = images(z, 1e-8)
    assert abs(got[0] - exact[0]) > 0.01 and np.min(np.abs(got - exact)[2:]) > 1e-5
    assert np.max(np.abs(analytic.terzaghi(z, 1e-8) - exact)) < ATOL


def test_erfc_to_round_off():
    """The erfc the image forms use (SciPy's, scalar C code whatever NumPy's SIMD paths) is
    within a few units of round-off of the standard library's: the absolute accuracy that
    TOLERANCE's margin assumes. Measured: 2.8e-16 at most on [0, 30]."""
    x = np.concatenate([np.linspace(0, 8, 4001), [6.5 - 1e-12, 6.5, 30.0]])
    ref = np.array([math.erfc(v) for v in x])
    assert np.max(np.abs(analytic._erfc(x) - ref)) <= 4 * np.finfo(float).eps


@pytest.mark.parametrize("Tv", [1e-5, 0.02, 1.0, "per point"])
def test_memory_is_bounded_per_point(Tv):
    """1e6 points: the peak of the Python heap (numpy's buffers included) beyond the input
    stays well under 1 KB per point; the result itself is 8 bytes per point. The former
    version built a 1e6 x 4000 table (32 GB)."""
    n = 1_000_000
    depth = np.linspace(0, 1, n)
    times = np.linspace(1e-5, 1, n) if Tv == "per point" else Tv
    tracemalloc.start()
    try:
        tracemalloc.reset_peak()
        out = analytic.terzaghi(depth, times)
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert out.shape == (n,) and np.all(np.isfinite(out))
    assert peak / n < 64, f"{peak / n:.1f} bytes per point"     # measured: 17
    # Spot check against the reference.
    pick = np.arange(0, n, 99_991)
    tv = times[pick] if Tv == "per point" else np.full(len(pick), Tv)
    ref = [reference(depth[i:i + 1], t)[0] for i, t in zip(pick, tv)]
    assert np.max(np.abs(out[pick] - ref)) < ATOL
