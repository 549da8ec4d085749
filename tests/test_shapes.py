"""Shape functions of the background cells (solver.model.shapes) against independent references."""

import numpy as np
import pytest
from numba import njit

from solver.stepping import kernels
from solver.model import shapes

ELEMENTS = ("q4", "q8", "q9")
NEN = {"q4": 4, "q8": 8, "q9": 9}


def _natural_nodes(element):
    """Natural coordinates of the solver's local nodes, from its lattice offsets."""
    p = shapes.ORDER[element]
    return -1.0 + 2.0 * shapes.OFFSETS[element] / p


def _samples(n=200, seed=0):
    rng = np.random.default_rng(seed)
    pts = rng.uniform(-1, 1, size=(n, 2))
    # Edges and corners too.
    edge = np.array([(-1, -1), (1, 1), (-1, 1), (1, -1), (0, 1), (1, 0), (-1, 0.3), (0.7, -1)])
    return np.vstack([pts, edge])


@pytest.mark.parametrize("element", ELEMENTS)
def test_node_count_and_lattice(element):
    off = shapes.OFFSETS[element]
    assert off.shape == (NEN[element], 2)
    assert len({tuple(o) for o in off}) == NEN[element]
    if element == "q8":
        assert (1, 1) not in {tuple(o) for o in off}  # no centre node


@pytest.mark.parametrize("element", ELEMENTS)
def test_partition_of_unity(element):
    x = _samples()
    N, dN = shapes.evaluate(element, x[:, 0], x[:, 1])
    assert N.shape == (len(x), NEN[element])
    assert dN.shape == (len(x), NEN[element], 2)
    np.testing.assert_allclose(N.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    np.testing.assert_allclose(dN.sum(axis=1), 0.0, rtol=0, atol=1e-13)


@pytest.mark.parametrize("element", ELEMENTS)
def test_kronecker_delta_at_nodes(element):
    nodes = _natural_nodes(element)
    N, _ = shapes.evaluate(element, nodes[:, 0], nodes[:, 1])
    np.testing.assert_allclose(N, np.eye(NEN[element]), rtol=0, atol=1e-15)


@pytest.mark.parametrize("element", ELEMENTS)
def test_polynomial_completeness(element):
    """Sum_a N_a f(node_a) = f for every monomial the element spans."""
    nodes = _natural_nodes(element)
    x = _samples(seed=1)
    N, dN = shapes.evaluate(element, x[:, 0], x[:, 1])
    monos = [lambda s, t: s, lambda s, t: t, lambda s, t: s * t]
    if element in ("q8", "q9"):
        monos += [lambda s, t: s * s, lambda s, t: t * t, lambda s, t: s * s * t,
                  lambda s, t: s * t * t]
    if element == "q9":
        monos += [lambda s, t: s * s * t * t]
    for f in monos:
        np.testing.assert_allclose(N @ f(nodes[:, 0], nodes[:, 1]), f(x[:, 0], x[:, 1]),
                                   rtol=0, atol=1e-13)
    # Gradient of the linear field (xi, eta) is the identity.
    np.testing.assert_allclose(np.einsum("pa,pak->pk", np.broadcast_to(nodes[:, 0], N.shape),
                                         dN), np.tile([1.0, 0.0], (len(x), 1)), atol=1e-13)


@pytest.mark.parametrize("element", ELEMENTS)
def test_derivatives_by_finite_differences(element):
    x = _samples(50, seed=2) * 0.999  # stay inside for the central differences
    h = 1e-6
    _, dN = shapes.evaluate(element, x[:, 0], x[:, 1])
    Np, _ = shapes.evaluate(element, x[:, 0] + h, x[:, 1])
    Nm, _ = shapes.evaluate(element, x[:, 0] - h, x[:, 1])
    np.testing.assert_allclose(dN[..., 0], (Np - Nm) / (2 * h), rtol=0, atol=1e-8)
    Np, _ = shapes.evaluate(element, x[:, 0], x[:, 1] + h)
    Nm, _ = shapes.evaluate(element, x[:, 0], x[:, 1] - h)
    np.testing.assert_allclose(dN[..., 1], (Np - Nm) / (2 * h), rtol=0, atol=1e-8)


@pytest.mark.parametrize("element", ELEMENTS)
def test_matches_independent_formulas(element, ref_shapes):
    """Same values and derivatives as the test's own Q4 / serendipity Q8 / Lagrange Q9."""
    ref_shape, ref_nodes = ref_shapes
    nodes = _natural_nodes(element)
    # The solver's local node a is the reference's node perm[a].
    perm = [int(np.flatnonzero(np.all(ref_nodes[element] == nd, axis=1))[0]) for nd in nodes]
    assert sorted(perm) == list(range(NEN[element]))
    x = _samples(60, seed=3)
    N, dN = shapes.evaluate(element, x[:, 0], x[:, 1])
    for k, (s, t) in enumerate(x):
        Nr, dNr = ref_shape(element, s, t)
        np.testing.assert_allclose(N[k], Nr[perm], rtol=0, atol=1e-14)
        np.testing.assert_allclose(dN[k], dNr[perm], rtol=0, atol=1e-13)


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_uniform_points_are_subcell_centres(n):
    s, w = shapes.uniform_1d(n)
    np.testing.assert_allclose(s, [-1 + (2 * k + 1) / n for k in range(n)], atol=1e-15)
    np.testing.assert_allclose(w, 2.0 / n)


@pytest.mark.parametrize("n", [1, 2, 3])
def test_gauss_points_integrate_exactly(n):
    s, w = shapes.gauss_1d(n)
    for k in range(2 * n):
        exact = (1 - (-1) ** (k + 1)) / (k + 1)
        assert np.dot(w, s ** k) == pytest.approx(exact, abs=1e-14)


@pytest.mark.parametrize("order", [1, 2])
def test_lagrange1d_interpolates_its_nodes(order):
    """1 at its own node, 0 at the others; derivatives sum to 0 and match differences."""
    nodes = np.linspace(-1, 1, order + 1)
    v, _ = shapes.lagrange1d(order, nodes)
    np.testing.assert_allclose(v, np.eye(order + 1), rtol=0, atol=1e-15)
    s, h = np.linspace(-0.9, 0.9, 7), 1e-6
    _, d = shapes.lagrange1d(order, s)
    fd = (shapes.lagrange1d(order, s + h)[0] - shapes.lagrange1d(order, s - h)[0]) / (2 * h)
    np.testing.assert_allclose(d, fd, rtol=0, atol=1e-8)
    np.testing.assert_allclose(d.sum(axis=1), 0.0, rtol=0, atol=1e-15)


@njit
def _kernel_rows(off, C, R, x, blend):
    """The step kernels' rows of S at points x (n, 2): N, dN/dx, dN/dy and, with ``blend``,
    N_hat and its derivatives; the cells' base nodes and the natural coordinates used."""
    n = x.shape[0]
    S = np.zeros((n, kernels.NS, len(off)))
    base = np.zeros(n, dtype=np.int64)
    nat = np.zeros((n, 2))
    for k in range(n):
        base[k], nat[k, 0], nat[k, 1] = kernels._shape(off, C, R, x[k, 0], x[k, 1], S[k])
        if blend:
            kernels._blended(off, R, nat[k, 0], nat[k, 1], S[k])
    return S, base, nat


@pytest.mark.parametrize("element", ELEMENTS)
def test_step_kernels_use_the_same_functions(element):
    """The explicit step's shape functions (kernels._shape: the point's cell and natural
    coordinates, the formulas of solver.model.shapes compiled with the kernels' options, d/dx =
    2/h d/dxi) and blended basis (kernels._blended) equal shapes.evaluate and
    shapes.blended at the same natural coordinates, at random points of a 4 x 2 grid;
    evaluate itself is checked against independent references above. Fused multiply-adds
    in the kernels may move the last bits only."""
    hx, hy, cells, stride = 0.25, 0.5, (4, 2), 9
    R = np.zeros(kernels.NR)
    R[kernels.RHX], R[kernels.RHY] = hx, hy
    R[kernels.RSX], R[kernels.RSY] = 2 / hx, 2 / hy
    R[kernels.RBLEND] = shapes.BLEND
    C = kernels.context({kernels.AR: R})
    order = shapes.ORDER[element]
    C[kernels.ICMX], C[kernels.ICMY] = cells[0] - 1, cells[1] - 1
    C[kernels.ISTX], C[kernels.ISTY] = order, order * stride
    off = tuple(int(i + stride * j) for i, j in shapes.OFFSETS[element])
    x = np.random.default_rng(4).uniform(0, 1, size=(300, 2)) * [cells[0] * hx, cells[1] * hy]
    S, base, nat = _kernel_rows(off, C, R, x, True)

    cx, cy = np.floor(x[:, 0] / hx), np.floor(x[:, 1] / hy)
    np.testing.assert_array_equal(base, order * (cx + stride * cy))
    np.testing.assert_allclose(nat, 2 * (x / [hx, hy] - np.stack([cx, cy], -1)) - 1,
                               rtol=0, atol=1e-14)
    N, dN = shapes.evaluate(element, nat[:, 0], nat[:, 1])
    Nh, dNh = shapes.blended(element, N, dN, nat[:, 0], nat[:, 1])
    eps = np.finfo(float).eps
    for rows, (n, d) in (((kernels.SN, kernels.SX, kernels.SY), (N, dN)),
                         ((kernels.SNL, kernels.SLX, kernels.SLY), (Nh, dNh))):
        np.testing.assert_allclose(S[:, rows[0]], n, rtol=0, atol=8 * eps)
        np.testing.assert_allclose(S[:, rows[1]], d[..., 0] * 2 / hx, rtol=0, atol=32 * eps / hx)
        np.testing.assert_allclose(S[:, rows[2]], d[..., 1] * 2 / hy, rtol=0, atol=32 * eps / hy)
