"""The references that follow the scene (solver/references/analytic.py: column_*, undrained_excess;
solver/references/layered.py) against independent ones: Terzaghi's series by symmetry,
finite elements of the same 1D problems written here (exact in time through their
eigenpairs, extrapolated in space), an undrained energy minimum, and limits."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import eigh, eigh_tridiagonal

from solver.references import analytic, layered

GAMMA_W = 1000.0 * 9.81
Q = 1.0e4
DRAINAGES = [("top",), ("bottom",), ("top", "bottom"), ()]


def fe_diffusion(d, a, b, alpha, beta, base, top, cells, times):
    """Linear finite elements of (a u')' = b u_t on layers d (m, from the base up, each
    ``cells`` elements per metre rounded), u = 0 at a drained end, from u0 = alpha +
    beta (y - bottom) in each layer (its m_v-weighted projection), exact in time:
    u(t) = V exp(-L t) V^T F with (K, M) V = M V L. Returns the nodes (m) and u (times x
    nodes)."""
    per = [max(1, int(round(cells * di))) for di in d]
    edges = np.r_[0.0, np.cumsum(d)]
    y = np.unique(np.concatenate([np.linspace(edges[i], edges[i + 1], per[i] + 1)
                                  for i in range(len(d))]))
    layer = np.searchsorted(edges, 0.5 * (y[1:] + y[:-1])) - 1
    h = np.diff(y)
    n = y.size
    K, M, F = np.zeros((n, n)), np.zeros((n, n)), np.zeros(n)
    gauss = 0.5 + np.array([-0.5, 0.5]) / np.sqrt(3.0)
    for e in range(n - 1):
        i, L = slice(e, e + 2), layer[e]
        K[i, i] += a[L] / h[e] * np.array([[1, -1], [-1, 1]])
        M[i, i] += b[L] * h[e] / 6 * np.array([[2, 1], [1, 2]])
        for s in gauss:
            u0 = alpha[L] + beta[L] * (y[e] + s * h[e] - edges[L])
            F[i] += b[L] * h[e] / 2 * u0 * np.array([1 - s, s])
    free = np.ones(n, bool)
    free[0], free[-1] = not base, not top
    w, V = eigh(K[np.ix_(free, free)], M[np.ix_(free, free)])
    u = np.zeros((len(times), n))
    u[:, free] = (V * np.exp(-np.outer(times, w))[:, None, :]) @ (V.T @ F[free])
    return y, u


def richardson(fine, coarse):
    """Second-order extrapolation of a fine and a coarse (half the cells) solution."""
    return (4 * fine - coarse) / 3


# -- uniform column --------------------------------------------------------------------------

def test_uniform_load_on_each_drainage_is_terzaghi_by_symmetry():
    y = np.linspace(-0.2, 2.2, 97)  # H = 2 m; outside it, the continued solution
    depth = 2.0 - y
    for T in (1e-5, 0.003, 0.0069, 0.0071, 0.05, 0.3, 2.0):
        top = analytic.column_pressure(y, T, 2.0, ("top",), 3.0)
        base = analytic.column_pressure(y, T, 2.0, ("bottom",), 3.0)
        both = analytic.column_pressure(y, T, 2.0, ("top", "bottom"), 3.0)
        # Each is accurate to TOLERANCE x p0, and so is terzaghi.
        bound = 2 * analytic.TOLERANCE * 3.0
        assert np.abs(top - analytic.terzaghi(depth, T, 2.0, 3.0)).max() < bound
        assert np.abs(base - analytic.terzaghi(y, T, 2.0, 3.0)).max() < bound
        # Two-way: one-way on H / 2 from the nearer end, at 4 Tv.
        near = np.where(y < 1.0, y, 2.0 - y)
        assert np.abs(both - analytic.terzaghi(near, 4 * T, 1.0, 3.0)).max() < bound
        assert analytic.column_degree(T, ("top",)) == pytest.approx(
            float(analytic.degree_of_consolidation(T)), abs=2 * analytic.TOLERANCE)
        assert analytic.column_degree(T, ("top", "bottom")) == pytest.approx(
            float(analytic.degree_of_consolidation(4 * T)), abs=2 * analytic.TOLERANCE)
    # No drainage: nothing moves.
    assert np.allclose(analytic.column_pressure(y, 0.3, 2.0, (), 3.0), 3.0, rtol=1e-13)


@pytest.mark.parametrize("drained", DRAINAGES)
def test_linear_initial_excess_against_finite_elements(drained):
    """Load plus self-weight (linear in height) on every drainage, H = 1, c = 1: the FE
    solution converges to the series at order 2 (its error falls by 4 per halving of h,
    measured 4.0), and the extrapolated one is within O(h^4) (measured 3e-9 at 320 cells)."""
    p_top, p_base = 0.4, 1.3
    base, top = "bottom" in drained, "top" in drained
    times = np.array([0.02, 0.2, 0.6])
    one = np.ones(1)
    fe = {cells: fe_diffusion([1.0], one, one, [p_base], [p_top - p_base], base, top,
                              cells, times) for cells in (80, 160, 320)}
    y = fe[80][0]                                     # nodes of every mesh
    got = analytic.column_pressure(y[None, :], times[:, None], 1.0, drained, p_top, p_base)
    err = [np.abs(fe[c][1][:, ::c // 80] - got).max() for c in (80, 160, 320)]
    assert err[1] < err[0] / 3.5 and err[2] < err[1] / 3.5
    ref = richardson(fe[320][1][:, ::4], fe[160][1][:, ::2])
    assert np.abs(got - ref).max() < 2e-8
    # The depth means (trapezoid: exact for the piecewise-linear FE field), likewise.
    mean = [np.trapz(fe[c][1], fe[c][0]) for c in (320, 160)]
    assert np.abs(analytic.column_mean(times, drained, p_top, p_base)
                  - richardson(*mean)).max() < 2e-8


@pytest.mark.parametrize("drained", DRAINAGES[:3])
def test_mean_is_the_depth_integral_of_the_pressure(drained):
    """column_mean's closed forms against composite Gauss quadrature of column_pressure,
    down to Tv = 1e-6 (the image forms) for a self-weight excess (zero at the surface)."""
    x, w = np.polynomial.legendre.leggauss(8)
    edges = np.linspace(0.0, 1.0, 2001)
    y = (edges[:-1, None] + (x + 1) / 2 * np.diff(edges)[:, None]).ravel()
    wy = (w / 2 * np.diff(edges)[:, None]).ravel()
    for T in (1e-6, 1e-4, 0.0069, 0.0071, 0.1, 1.0):
        p = analytic.column_pressure(y, T, 1.0, drained, 0.0, 2.0)
        assert float(analytic.column_mean(T, drained, 0.0, 2.0)) == pytest.approx(
            wy @ p, abs=1e-12)


# -- self-weight -----------------------------------------------------------------------------

def undrained_energy_minimum(H, E_c, K_l, n, rho_s, rho_l, g, q, cells=20):
    """Linear elements of the column at t = 0+: water moves with the skeleton, so the
    mixture has the modulus E_c + K_l / n and carries its weight ((1 - n) rho_s + n rho_l) g
    and the load q; the minimum of its potential energy. Returns the element midpoints (m),
    the excess pore pressure over hydrostatic there (Pa) and the settlement (m)."""
    y = np.linspace(0.0, H, cells + 1)
    h = H / cells
    modulus = E_c + K_l / n
    K = (np.diag(np.r_[1.0, 2 * np.ones(cells - 1), 1.0]) - np.diag(np.ones(cells), 1)
         - np.diag(np.ones(cells), -1)) * modulus / h
    weight = ((1 - n) * rho_s + n * rho_l) * g
    f = -weight * h * np.r_[0.5, np.ones(cells - 1), 0.5]       # downwards, N per m2
    f[-1] -= q
    v = np.r_[0.0, np.linalg.solve(K[1:, 1:], f[1:])]          # upwards, base fixed
    mid = 0.5 * (y[1:] + y[:-1])
    p = -(K_l / n) * np.diff(v) / h                              # compression positive
    return mid, p - rho_l * g * (H - mid), -v[-1]


def test_undrained_self_weight_and_load_against_an_energy_minimum():
    H, E_c, K_l, n, rho_s, rho_l, g = 3.0, 1.2e7, 1.2e8, 0.35, 2650.0, 1000.0, 9.81
    for q in (0.0, Q):
        mid, excess, s0 = undrained_energy_minimum(H, E_c, K_l, n, rho_s, rho_l, g, q)
        p_top, p_base = analytic.undrained_excess(q, H, n, E_c, K_l, rho_s, rho_l, g)
        # Linear elements with consistent loads are nodally exact in 1D and the strain is
        # linear, so each element's strain is the exact one at its midpoint.
        line = p_base + (p_top - p_base) * mid / H
        assert np.abs(excess - line).max() < 1e-10 * np.abs(line).max()
        gamma_b = (1 - n) * (rho_s - rho_l) * g
        mean0 = (p_top + p_base) / 2
        assert float(analytic.column_settlement(mean0, H, E_c, q, gamma_b)) == pytest.approx(
            s0, rel=1e-10)
    # The excess is not B times the buoyant weight: water is compressed by its own
    # hydrostatic pressure too, which it draws from the skeleton's compression.
    B = analytic.undrained_pressure(1.0, E_c, K_l, n)
    assert p_base - p_top == pytest.approx(
        (B * ((1 - n) * rho_s + n * rho_l) - rho_l) * g * H, rel=1e-13)
    # Incompressible water: the buoyant weight q + gamma' z, the limit of stiff water.
    classic = analytic.undrained_excess(Q, H, n, E_c, None, rho_s, rho_l, g)
    assert classic == pytest.approx((Q, Q + (1 - n) * (rho_s - rho_l) * g * H), rel=1e-15)
    stiff = analytic.undrained_excess(Q, H, n, E_c, 1e20, rho_s, rho_l, g)
    assert stiff == pytest.approx(classic, rel=1e-11)


@pytest.mark.parametrize("drained", DRAINAGES[:3])
def test_self_weight_settles_to_its_drained_value(drained):
    """U from 0 to 1 and the settlement from s0 to gamma' H^2 / (2 E_c) + q H / E_c."""
    H, E_c, n, rho_s, rho_l, g = 2.0, 8.0e6, 0.4, 2700.0, 1000.0, 9.81
    gamma_b = (1 - n) * (rho_s - rho_l) * g
    for q in (0.0, Q):
        p_top, p_base = analytic.undrained_excess(q, H, n, E_c, 2e8, rho_s, rho_l, g)
        # exp(-pi^2 / 4 x 30) = 1e-32: U = 1 to round-off at Tv = 30.
        U = analytic.column_degree([0.0, 1e-3, 0.1, 1.0, 30.0], drained, p_top, p_base)
        assert U[0] == 0 and np.all(np.diff(U) > 0) and U[-1] == pytest.approx(1, abs=1e-13)
        s_end = analytic.column_settlement(analytic.column_mean(30.0, drained, p_top, p_base),
                                           H, E_c, q, gamma_b)
        assert s_end == pytest.approx(gamma_b * H * H / (2 * E_c) + q * H / E_c, rel=1e-12)
    with pytest.raises(ValueError, match="without a drained end"):
        analytic.column_degree(0.1, (), 1.0, 2.0)


def test_load_plus_self_weight_is_the_sum():
    y = np.linspace(0.0, 1.5, 31)
    for drained in DRAINAGES:
        for T in (1e-4, 0.05, 0.5):
            both = analytic.column_pressure(y, T, 1.5, drained, 1.0, 3.0)
            load = analytic.column_pressure(y, T, 1.5, drained, 1.0)
            weight = analytic.column_pressure(y, T, 1.5, drained, 0.0, 2.0)
            assert np.abs(both - load - weight).max() < 6 * analytic.TOLERANCE * 3.0


# -- layered rod -----------------------------------------------------------------------------

def fe_rod(thickness, E_c, rho, nmodes, per_metre):
    """Eigenvalues omega^2 (1/s2) of linear elements with lumped masses, fixed base, free
    top, layers from the surface down, through the tridiagonal D^-1/2 K D^-1/2."""
    d, E, r = (np.asarray(v, float)[::-1] for v in (thickness, E_c, rho))
    h = np.concatenate([np.full(int(round(di * per_metre)), di / round(di * per_metre))
                        for di in d])
    Ee = np.concatenate([np.full(int(round(di * per_metre)), Ei) for di, Ei in zip(d, E)])
    re = np.concatenate([np.full(int(round(di * per_metre)), ri) for di, ri in zip(d, r)])
    k, m = Ee / h, re * h / 2
    diag = np.r_[k[:-1] + k[1:], k[-1]]                 # nodes 1..N (node 0 fixed)
    mass = np.r_[m[:-1] + m[1:], m[-1]]
    off = -k[1:] / np.sqrt(mass[:-1] * mass[1:])
    # MRRR: the eigenvalues of a positive definite tridiagonal to high relative accuracy.
    return eigh_tridiagonal(diag / mass, off, select="i", select_range=(0, nmodes - 1),
                            lapack_driver="stemr")[0]


def rod_reference(thickness, E_c, rho, nmodes, per_metre=50):
    """FE frequencies (Hz) extrapolated twice (the eigenvalue error is a series in h^2):
    what remains is the eigensolver's round-off on the finest mesh, about eps times the
    condition number (1e-10 here: measured 2e-11 and 2e-10 in lambda for the cases below)."""
    a, b, c = (fe_rod(thickness, E_c, rho, nmodes, m * per_metre) for m in (1, 2, 4))
    r1, r2 = richardson(b, a), richardson(c, b)
    return np.sqrt((16 * r2 - r1) / 15) / (2 * np.pi)


def test_one_layer_rod_and_identical_layers():
    one = layered.rod_frequencies([12.0], 4.0e7, 1900.0, 6)
    assert one == pytest.approx(analytic.rod_frequencies(4.0e7, 1900.0, 12.0, 6), rel=1e-14)
    split = layered.rod_frequencies([1.5, 7.0, 3.5], 4.0e7, [1900.0] * 3, 6)
    assert split == pytest.approx(one, rel=1e-13)


def test_layered_rod_against_finite_elements():
    thick, E, rho = [3.0, 5.0, 4.0], [2.0e7, 8.0e7, 3.0e8], [1700.0, 1900.0, 2100.0]
    f = layered.rod_frequencies(thick, E, rho, 5)
    assert f == pytest.approx(rod_reference(thick, E, rho, 5), rel=1e-8)


def test_layered_rod_finds_close_pairs():
    """A soft top layer over a base of the same travel time and 800 times its impedance:
    nearly decoupled, so the modes come in close pairs, none of which may be missed."""
    thick, E, rho = [2.0, 8.0], [1.0e6, 3.2e9], [1000.0, 2.0e5]
    f = layered.rod_frequencies(thick, E, rho, 8)
    gaps = np.diff(f) / f[1:]
    assert gaps[::2].max() < 0.05                       # the pairs are close
    assert f == pytest.approx(rod_reference(thick, E, rho, 8), rel=1e-8)


def test_rod_modes_are_orthogonal_in_the_mass():
    thick, E, rho = [3.0, 5.0, 4.0], [2.0e7, 8.0e7, 3.0e8], [1700.0, 1900.0, 2100.0]
    x, w = np.polynomial.legendre.leggauss(20)
    edges = np.r_[0.0, 4.0, 9.0, 12.0]             # layer boundaries from the base
    cells = np.linspace(0, 1, 41)
    y, wy, r = [], [], []
    for lo, hi, ri in zip(edges[:-1], edges[1:], rho[::-1]):
        a = lo + (hi - lo) * cells
        y.append((a[:-1, None] + (x + 1) / 2 * np.diff(a)[:, None]).ravel())
        wy.append((w / 2 * np.diff(a)[:, None]).ravel())
        r.append(np.full(y[-1].size, ri))
    y, wy, r = map(np.concatenate, (y, wy, r))
    X = layered.rod_modes(thick, E, rho, 4, y)
    G = (X * r * wy) @ X.T
    assert np.abs(G - np.diag(np.diag(G))).max() < 1e-12 * np.diag(G).max()
    assert layered.rod_modes(thick, E, rho, 4, [12.0])[:, 0] == pytest.approx(1.0)


# -- layered consolidation -------------------------------------------------------------------

def test_one_layer_and_identical_layers_are_terzaghi():
    E_c, k, n, K_l, H = 1.0e7, 2.5e-4, 0.3, 1.2e8, 1.0
    c2 = analytic.consistent_coefficient(k, E_c, GAMMA_W, K_l, n)
    p0 = analytic.undrained_pressure(Q, E_c, K_l, n)
    y = np.linspace(0.0, H, 41)
    T = np.array([1e-4, 0.01, 0.05, 0.2, 0.5])
    for drained in DRAINAGES[:3]:
        ref = analytic.column_pressure(y[None, :], T[:, None], H, drained, p0)
        for thick in ([H], [0.3, 0.7], [0.25, 0.25, 0.5]):
            col = layered.LayeredColumn(thick, E_c, k, n, GAMMA_W, K_l, Q, drained)
            # Truncation below 1e-10 max|u0|; the rest is round-off.
            assert np.abs(col.pressure(y, T * H * H / c2) - ref).max() < 2e-10 * Q
            assert col.degree(T * H * H / c2) == pytest.approx(
                analytic.column_degree(T, drained), abs=2e-10)
            assert col.s0 == pytest.approx(Q * H / (E_c + K_l / n), rel=1e-13)
            assert col.s_inf == pytest.approx(Q * H / E_c, rel=1e-13)


def test_identical_layers_with_self_weight_follow_the_uniform_column():
    """Two independent routes: the phase-form modes here, images and series there."""
    E_c, k, n, K_l, H, rho_s, g = 1.0e7, 2.5e-4, 0.3, 1.2e8, 2.0, 2650.0, 9.81
    y = np.linspace(0.0, H, 41)
    for K in (K_l, None):
        c = (analytic.consistent_coefficient(k, E_c, GAMMA_W, K_l, n) if K else
             analytic.consolidation_coefficient(k, E_c, GAMMA_W))
        p_top, p_base = analytic.undrained_excess(Q, H, n, E_c, K, rho_s, 1000.0, g)
        for drained in DRAINAGES:
            col = layered.LayeredColumn([0.5, 1.5], E_c, k, n, GAMMA_W, K, Q, drained,
                                        rho_s, 1000.0, g)
            for T in (1e-4, 0.05, 0.5):
                ref = analytic.column_pressure(y, T, H, drained, p_top, p_base)
                assert np.abs(col.pressure(y, T * H * H / c) - ref).max() < 1e-9 * Q


def two_layers(K_l=1.2e8, drained=("top",), g=0.0):
    """Contrast 4 in E_c and 10 in k: a stiff, tight layer over a soft, open one."""
    return dict(thickness=[0.4, 0.6], E_c=[2.0e7, 5.0e6], k=[2.0e-5, 2.0e-4],
                n=[0.35, 0.3], gamma_w=GAMMA_W, K_l=K_l, q=Q, drained=drained,
                rho_s=[2700.0, 2600.0], rho_l=1000.0, g=g)


def test_undrained_share_of_the_load_per_layer():
    s = two_layers()
    col = layered.LayeredColumn(**s)
    B = [analytic.undrained_pressure(1.0, E, s["K_l"], n) for E, n in zip(s["E_c"], s["n"])]
    assert col.undrained == pytest.approx(B, rel=1e-15)
    # The expansion itself starts there: at t = 1e-9 H^2 / c the interior has not moved.
    y = np.array([0.1, 0.3, 0.5, 0.65, 0.8])           # from the base: soft 0-0.6, stiff
    expect = Q * np.array([B[1], B[1], B[1], B[0], B[0]])
    assert col.pressure(y, 1e-6) == pytest.approx(expect, abs=1e-9 * Q)
    assert col.s0 == pytest.approx(sum(Q * d / (E + s["K_l"] / n) for d, E, n in zip(
        s["thickness"], s["E_c"], s["n"])), rel=1e-13)
    assert col.s_inf == pytest.approx(sum(Q * d / E for d, E in zip(s["thickness"],
                                                                   s["E_c"])), rel=1e-13)


@pytest.mark.parametrize("drained,g", [(("top",), 0.0), (("top", "bottom"), 9.81),
                                       (("bottom",), 9.81)])
def test_two_layers_against_finite_elements(drained, g):
    """FE of the same layered column converge to the expansion at order 2 (errors fall by
    4 per halving) and, extrapolated, within 1e-7 q (O(h^4) and the FE eigensolver's
    round-off; measured 1.3e-9 q from 200 / 400 cells per m, scripts/references-accuracy):
    the expansion is the converged solution of the layered problem to far better than
    1e-5 q."""
    s = two_layers(drained=drained, g=g)
    col = layered.LayeredColumn(**s)
    t = np.array([0.5, 2.0, 8.0, 30.0])                  # s: U from about 0.1 to 0.9
    base, top = "bottom" in drained, "top" in drained
    a = np.array(s["k"][::-1]) / GAMMA_W
    b = col.m_v
    fe = {c: fe_diffusion(col.modes.d, a, b, col.alpha, col.beta, base, top, c, t)
          for c in (100, 200, 400)}
    y = fe[100][0]
    got = col.pressure(y, t)
    err = [np.abs(fe[c][1][:, ::c // 100] - got).max() for c in (100, 200, 400)]
    assert err[1] < err[0] / 3.5 and err[2] < err[1] / 3.5
    ref = richardson(fe[400][1][:, ::4], fe[200][1][:, ::2])
    assert np.abs(got - ref).max() < 1e-7 * Q
    # The settlement: int (sigma_v - rho_l g z - u) / E_c, the FE's u integrated exactly.
    settle = []
    for c in (400, 200):
        yy, u = fe[c]
        E_c = np.repeat(col.E_c, np.round(col.modes.d * c).astype(int))
        mid = 0.5 * (u[:, 1:] + u[:, :-1])
        settle.append(col.s_eff - (mid / E_c * np.diff(yy)).sum(axis=1))
    assert np.abs(col.settlement(t) - richardson(*settle)).max() < 1e-7 * (col.s_inf - col.s0)


def test_truncation_and_no_drainage():
    s = two_layers(g=9.81)
    y = np.linspace(0.0, 1.0, 51)
    t = np.array([1e-3, 0.1, 3.0])
    loose = layered.LayeredColumn(**s).pressure(y, t)
    tight = layered.LayeredColumn(**{**s, "K_l": s["K_l"]}, tol=1e-14).pressure(y, t)
    assert np.abs(loose - tight).max() < 1e-10 * Q
    # Without drainage water only moves between the layers: the stored volume
    # int m_v u dy stays, and u tends to its m_v-weighted mean.
    col = layered.LayeredColumn(**{**s, "drained": ()})
    x, w = np.polynomial.legendre.leggauss(10)
    edges = np.r_[np.linspace(0.0, 0.6, 41), np.linspace(0.6, 1.0, 41)[1:]]
    panels = list(zip(edges[:-1], edges[1:]))
    yq = np.concatenate([lo + (hi - lo) * (x + 1) / 2 for lo, hi in panels])
    wq = np.concatenate([(hi - lo) * w / 2 for lo, hi in panels])
    mv = np.where(yq < 0.6, col.m_v[0], col.m_v[1])
    stored = [(mv * wq) @ col.pressure(yq, ti) for ti in (0.01, 1.0, 100.0)]
    assert stored == pytest.approx([(mv * wq) @ col.initial(yq)] * 3, rel=1e-9)
    late = col.pressure(y, 1e5)
    assert np.ptp(late) < 1e-9 * Q
    with pytest.raises(ValueError, match="without a drained end"):
        col.degree(1.0)
