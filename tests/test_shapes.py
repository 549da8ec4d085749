"""Shape functions of the background cells (solver.shapes) against independent references."""

import numpy as np
import pytest

from solver import shapes

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
