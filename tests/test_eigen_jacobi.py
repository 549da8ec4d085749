"""The generalized Jacobi solver (solver.modal.jacobi) on its own: random SPD pencils
against numpy, eq. (3) rotations, the round-robin ordering, the blocked method (block sizes,
orderings, every pair once per sweep), failures, and the same checks on 2 and 3 ranks
(``mpi`` tests).
"""

from __future__ import annotations

import numpy as np
import pytest

RTOL = 1e-10


# -- helpers ------------------------------------------------------------------------------
def random_pencil(n, seed):
    """Random symmetric positive definite K and M (n x n), moderately conditioned."""
    rng = np.random.default_rng(seed)
    A = rng.standard_normal((n, n))
    K = A @ A.T + n * np.eye(n)
    B = rng.standard_normal((n, n))
    M = B @ B.T / n + 0.5 * np.eye(n)
    return K, M


def reference_eigenvalues(K, M):
    """Eigenvalues of K x = lambda M x by numpy: Cholesky of M, then eigvalsh."""
    L = np.linalg.cholesky(M)
    Li = np.linalg.inv(L)
    return np.linalg.eigvalsh(Li @ K @ Li.T)


def petsc_mat(A, comm=None):
    """A parallel AIJ Mat holding the dense array A (each rank sets its own rows)."""
    from petsc4py import PETSc

    comm = comm or PETSc.COMM_WORLD
    n = A.shape[0]
    mat = PETSc.Mat().createAIJ([n, n], comm=comm)
    mat.setPreallocationNNZ((n, n))
    mat.setUp()
    lo, hi = mat.getOwnershipRange()
    cols = np.arange(n, dtype=PETSc.IntType)
    for i in range(lo, hi):
        mat.setValues(i, cols, A[i])
    mat.assemble()
    return mat


def gather_vectors(vectors):
    """The full arrays of a list of parallel Vecs (on every rank)."""
    from petsc4py import PETSc

    out = []
    for v in vectors:
        scatter, seq = PETSc.Scatter.toAll(v)
        scatter.scatter(v, seq, PETSc.InsertMode.INSERT, PETSc.ScatterMode.FORWARD)
        out.append(seq.getArray().copy())
        scatter.destroy()
        seq.destroy()
    return np.array(out)


def check_pencil(n, seed, nmodes=None, block=None):
    """Solve a random pencil (``block``: the Jacobi block sizes, None: automatic); return
    (max rel eigenvalue error, orthonormality error, max relative residual, sweeps)."""
    from solver.modal import jacobi

    Kd, Md = random_pencil(n, seed)
    K, M = petsc_mat(Kd), petsc_mat(Md)
    nmodes = n if nmodes is None else nmodes
    res = jacobi.solve(K, M, nmodes, tol=1e-15, max_sweeps=50, block=block)
    ref = reference_eigenvalues(Kd, Md)
    eig_err = float(np.max(np.abs(res.eigenvalues - ref) / np.abs(ref)))
    Phi = gather_vectors(res.vectors).T          # (n, nmodes)
    orth = float(np.max(np.abs(Phi.T @ Md @ Phi - np.eye(nmodes))))
    lam = res.eigenvalues[:nmodes]
    R = Kd @ Phi - (Md @ Phi) * lam
    resid = float(np.max(np.linalg.norm(R, axis=0) / (np.linalg.norm(Kd, 2) *
                                                      np.linalg.norm(Phi, axis=0))))
    assert len(res.eigenvalues) == n and len(res.vectors) == nmodes
    K.destroy()
    M.destroy()
    return eig_err, orth, resid, res.sweeps


@pytest.mark.parametrize("n, seed", [(37, 1), (60, 2), (1, 3), (2, 4), (5, 5)])
def test_random_spd_pencil(n, seed):
    eig_err, orth, resid, sweeps = check_pencil(n, seed)
    assert eig_err <= RTOL
    assert orth <= RTOL          # Phi^T M Phi = I
    assert resid <= RTOL         # K phi = lambda M phi
    assert 1 <= sweeps <= 50


def test_lowest_modes_only_and_ascending():
    from solver.modal import jacobi

    Kd, Md = random_pencil(24, 7)
    res = jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 4)
    assert np.all(np.diff(res.eigenvalues) >= 0)
    ref = reference_eigenvalues(Kd, Md)
    np.testing.assert_allclose(res.eigenvalues, ref, rtol=RTOL)
    Phi = gather_vectors(res.vectors).T
    assert Phi.shape == (24, 4)
    np.testing.assert_allclose(Kd @ Phi, (Md @ Phi) * ref[:4], rtol=0,
                               atol=RTOL * np.abs(Kd @ Phi).max())


def test_diagonal_pencil_needs_no_rotation():
    from solver.modal import jacobi

    k = np.array([5.0, 1.0, 3.0, 2.0, 4.0])
    m = np.array([1.0, 2.0, 0.5, 1.0, 4.0])
    res = jacobi.solve(petsc_mat(np.diag(k)), petsc_mat(np.diag(m)), 5)
    np.testing.assert_allclose(res.eigenvalues, np.sort(k / m), rtol=1e-15)
    Phi = gather_vectors(res.vectors).T
    np.testing.assert_allclose(Phi.T @ np.diag(m) @ Phi, np.eye(5), atol=1e-15)


def _rotate(K, M, i, j, alpha, gamma):
    n = K.shape[0]
    P = np.eye(n)
    P[i, j] = alpha
    P[j, i] = gamma
    return P.T @ K @ P, P.T @ M @ P


def test_rotation_parameters_zero_the_pair():
    """Eq. (3): P^T K P and P^T M P have zero (i, j) entries, for many random 2 x 2 pairs."""
    from solver.modal import jacobi

    rng = np.random.default_rng(11)
    for trial in range(300):
        K, M = random_pencil(2, 1000 + trial)
        if trial % 3 == 0:            # indefinite-ish K (a symmetric K is all eq. 3 needs)
            K = K - 2.5 * np.eye(2) * rng.uniform()
        a, g = jacobi.rotation_parameters(K[0, 0], K[1, 1], K[0, 1], M[0, 0], M[1, 1], M[0, 1])
        Kr, Mr = _rotate(K, M, 0, 1, float(a), float(g))
        assert abs(Kr[0, 1]) <= 1e-12 * np.abs(K).max()
        assert abs(Mr[0, 1]) <= 1e-12 * np.abs(M).max()
        assert abs(Kr[1, 0]) <= 1e-12 * np.abs(K).max()


def test_rotation_parameters_vectorised_and_special_cases():
    from solver.modal import jacobi

    pairs = [random_pencil(2, 2000 + t) for t in range(50)]
    # Proportional blocks (K = c M): x = 0 in Bathe's formula.
    Mp = random_pencil(2, 99)[1]
    pairs.append((3.7 * Mp, Mp))
    # Equal ratios on the diagonal (kb = 0) with coupling.
    pairs.append((np.array([[2.0, 0.3], [0.3, 2.0]]), np.array([[1.0, 0.4], [0.4, 1.0]])))
    pairs.append((np.array([[2.0, 0.0], [0.0, 4.0]]), np.array([[1.0, 0.0], [0.0, 2.0]])))
    Ks = np.array([p[0] for p in pairs])
    Ms = np.array([p[1] for p in pairs])
    a, g = jacobi.rotation_parameters(Ks[:, 0, 0], Ks[:, 1, 1], Ks[:, 0, 1],
                                      Ms[:, 0, 0], Ms[:, 1, 1], Ms[:, 0, 1])
    assert a.shape == g.shape == (len(pairs),)
    assert np.all(np.isfinite(a)) and np.all(np.isfinite(g))
    for k, (K, M) in enumerate(pairs):
        Kr, Mr = _rotate(K, M, 0, 1, a[k], g[k])
        assert abs(Kr[0, 1]) <= 1e-12 * np.abs(K).max(), k
        assert abs(Mr[0, 1]) <= 1e-12 * np.abs(M).max(), k
        # The rotated pencil keeps the eigenvalues.
        np.testing.assert_allclose(reference_eigenvalues(Kr, Mr), reference_eigenvalues(K, M),
                                   rtol=1e-12)


def test_rotation_in_a_larger_matrix():
    """Rotating (i, j) inside an n x n pencil zeroes exactly that pair."""
    from solver.modal import jacobi

    K, M = random_pencil(7, 21)
    for i, j in [(0, 6), (2, 3), (5, 1)]:
        a, g = jacobi.rotation_parameters(K[i, i], K[j, j], K[i, j], M[i, i], M[j, j], M[i, j])
        Kr, Mr = _rotate(K, M, i, j, float(a), float(g))
        assert abs(Kr[i, j]) <= 1e-12 * np.abs(K).max()
        assert abs(Mr[i, j]) <= 1e-12 * np.abs(M).max()


@pytest.mark.parametrize("n", [2, 4, 6, 8, 10, 38, 60])
def test_tournament_visits_every_pair_once(n):
    from solver.modal import jacobi

    src = jacobi.tournament(n)
    assert sorted(src.tolist()) == list(range(n))       # a permutation of the slots
    index = np.arange(n)
    seen = {}
    for rnd in range(n - 1):
        pairs = [tuple(sorted((int(index[2 * k]), int(index[2 * k + 1])))) for k in range(n // 2)]
        assert len({x for p in pairs for x in p}) == n   # disjoint pairs within a round
        for p in pairs:
            seen[p] = seen.get(p, 0) + 1
        index = index[src]
    assert len(seen) == n * (n - 1) // 2
    assert set(seen.values()) == {1}
    # The next n - 1 rounds (the next sweep) cover every pair once again.
    seen2 = set()
    for rnd in range(n - 1):
        seen2 |= {tuple(sorted((int(index[2 * k]), int(index[2 * k + 1]))))
                  for k in range(n // 2)}
        index = index[src]
    assert len(seen2) == n * (n - 1) // 2


def test_too_few_sweeps_raise_numerical_error():
    from solver.common.errors import NumericalError
    from solver.modal import jacobi

    Kd, Md = random_pencil(20, 31)
    with pytest.raises(NumericalError, match="did not converge"):
        jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 3, tol=1e-15, max_sweeps=1)
    assert NumericalError.exit_code == 3


def test_zero_mass_diagonal_raises_numerical_error():
    from solver.common.errors import NumericalError
    from solver.modal import jacobi

    Kd, Md = random_pencil(9, 32)
    Md[4, :] = Md[:, 4] = 0.0      # a DOF without mass: singular M
    with pytest.raises(NumericalError):
        jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 3)


def test_indefinite_mass_raises_numerical_error():
    from solver.common.errors import NumericalError
    from solver.modal import jacobi

    Kd = np.eye(4)
    Md = np.eye(4)
    Md[1:3, 1:3] = [[1.0, 2.0], [2.0, 1.0]]    # positive diagonal, eigenvalue -1
    with pytest.raises(NumericalError):
        jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 2)


def test_singular_mass_with_positive_diagonal_raises_numerical_error():
    from solver.common.errors import NumericalError
    from solver.modal import jacobi

    Kd, _ = random_pencil(6, 33)
    v = np.ones((6, 1))
    Md = v @ v.T + np.diag([0, 0, 0, 0, 1.0, 1.0])   # rank 3, all diagonal entries > 0
    with pytest.raises(NumericalError):
        jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 2, max_sweeps=30)


# -- the blocked method -------------------------------------------------------------------
@pytest.mark.parametrize("n, block, seed", [
    (37, (4, 1), 1),              # padded to 40: two decoupled dummy indices
    (64, (8, 1), 2),
    (64, (32, 8, 2, 1), 3),       # a single block pair: only the round-0 sweep of the pair
    (100, (16, 4, 1), 4),         # padded to 128
    (101, (8, 2, 1), 5),
    (150, (15, 5, 1), 6),         # block sizes that are no powers of 2
    (250, None, 7),               # chosen automatically
])
def test_blocked_random_spd_pencil(n, block, seed):
    """The blocked method against numpy: every eigenvalue, M-orthonormal modes, residuals."""
    eig_err, orth, resid, sweeps = check_pencil(n, seed, nmodes=min(n, 12), block=block)
    assert eig_err <= RTOL
    assert orth <= RTOL
    assert resid <= RTOL
    assert 1 <= sweeps <= 20


def test_blocked_and_scalar_agree():
    """The same pencil by the scalar method (block 1) and by blocks: same eigenvalues and
    modes, and the blocked sweep count within one of the scalar one (both rotate every pair
    once per sweep, in different orders)."""
    from solver.modal import jacobi

    Kd, Md = random_pencil(96, 8)
    scalar = jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 6, block=1)
    blocked = jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 6, block=(16, 4, 1))
    np.testing.assert_allclose(blocked.eigenvalues, scalar.eigenvalues, rtol=1e-12)
    for a, b in zip(gather_vectors(scalar.vectors), gather_vectors(blocked.vectors)):
        assert abs(abs(a @ Md @ b) - 1) <= 1e-10          # the same mode up to its sign
    assert abs(blocked.sweeps - scalar.sweeps) <= 1


def test_pipelined_rounds_match_sequential(monkeypatch):
    """On one rank the next round's pair problems are built from this round's data and
    swept in a second thread; without that thread (as on several ranks) the results agree
    to rounding and take the same sweeps."""
    from solver.modal import jacobi

    Kd, Md = random_pencil(120, 12)
    piped = jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 5, block=(12, 3, 1))
    monkeypatch.setattr(jacobi, "ThreadPoolExecutor", lambda max_workers: None)
    plain = jacobi.solve(petsc_mat(Kd), petsc_mat(Md), 5, block=(12, 3, 1))
    np.testing.assert_allclose(piped.eigenvalues, plain.eigenvalues, rtol=1e-13)
    assert piped.sweeps == plain.sweeps


def test_block_sizes_choice():
    from solver.modal import jacobi

    for n in (1, 2, 20, 60, 80, jacobi.BLOCKED_MIN_DOFS - 1):
        assert jacobi.block_sizes(n) == (1,), n          # the paper's models stay scalar
    for n in (jacobi.BLOCKED_MIN_DOFS, 150, 480, 1000, 1001, 2000, 3000, 6000):
        for ranks in (1, 2, 3):
            sizes = jacobi.block_sizes(n, ranks)
            assert sizes[-1] == 1 and len(sizes) >= 2, (n, sizes)
            assert all(a % b == 0 and a > b for a, b in zip(sizes, sizes[1:])), sizes
            nblk = -(-n // sizes[0])
            nblk += nblk % 2
            assert nblk >= 2 * ranks                      # every rank owns a block pair
            assert nblk * sizes[0] - n < 2 * sizes[0]     # padding below one block pair


@pytest.mark.parametrize("nb", [1, 2, 3, 4, 5, 8])
def test_tournament_moves_are_the_tournament(nb):
    """Writing pair q's blocks through _tournament_moves lands them where tournament() puts
    them for the next round."""
    from solver.modal import jacobi

    src = jacobi.tournament(2 * nb)
    label = np.arange(2 * nb)
    moved = np.full(2 * nb, -1)
    for pairs, half, to in jacobi._tournament_moves(nb):
        moved[to] = label[2 * np.arange(nb)[pairs] + half]
    np.testing.assert_array_equal(moved, label[src])


def _pairs_of_level(labels, sizes, cross, seen):
    """Follow the labels of one problem through a blocked sweep (as jacobi._level moves
    them), recording each scalar pair rotated; returns the labels in their final slots."""
    from solver.modal import jacobi

    N, s = len(labels), sizes[0]
    plan = jacobi._plan(N, s, cross)
    if plan.order is not None:
        labels = labels[plan.order]
    for r, (se, _, _, _) in enumerate(plan.rounds):
        pairs = labels.reshape(plan.p, plan.m)
        if s == 1:
            seen.extend(tuple(sorted(p)) for p in pairs.tolist())
        else:
            pairs = np.array([_pairs_of_level(q, sizes[1:], cross or r > 0, seen)
                              for q in pairs])
        labels = pairs.ravel()[se]
    return labels


@pytest.mark.parametrize("N, sizes, cross", [
    (8, (1,), False), (8, (1,), True), (16, (4, 1), False), (16, (4, 1), True),
    (64, (8, 2, 1), False), (60, (10, 5, 1), True), (96, (12, 3, 1), False),
])
def test_level_rotates_every_pair_once(N, sizes, cross):
    """One sweep of a level rotates every pair exactly once (cross: every pair between the
    two halves) and returns every index to its slot."""
    seen = []
    out = _pairs_of_level(np.arange(N), sizes, cross, seen)
    np.testing.assert_array_equal(out, np.arange(N))
    if cross:
        want = {(i, j) for i in range(N // 2) for j in range(N // 2, N)}
    else:
        want = {(i, j) for i in range(N) for j in range(i + 1, N)}
    assert len(seen) == len(want) and set(seen) == want


def test_fast_rotations_match_rotation_parameters():
    """The blocked method's batched formulas give eq. (3)'s alpha, gamma (special cases
    included)."""
    from solver.modal import jacobi

    pairs = [random_pencil(2, 3000 + t) for t in range(200)]
    Mp = random_pencil(2, 99)[1]
    pairs += [(3.7 * Mp, Mp), (np.diag([2.0, 4.0]), np.diag([1.0, 2.0])),
              (np.array([[2.0, 0.3], [0.3, 2.0]]), np.array([[1.0, 0.4], [0.4, 1.0]]))]
    e = np.array([[K[0, 0], K[1, 1], K[0, 1], M[0, 0], M[1, 1], M[0, 1]] for K, M in pairs]).T
    out = np.ones((len(pairs), 2, 2))
    jacobi._rotations(e, out)
    a, g = jacobi.rotation_parameters(*e)
    np.testing.assert_allclose(out[:, 1, 0], a, rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(out[:, 0, 1], g, rtol=1e-12, atol=1e-15)


# -- under MPI: every rank solves its share and checks the whole ---------------------------
def _assert_accurate(n, seed, **kwargs):
    eig_err, orth, resid, _ = check_pencil(n, seed, **kwargs)
    assert eig_err <= RTOL and orth <= RTOL and resid <= RTOL, (n, eig_err, orth, resid)


@pytest.mark.parametrize("ranks", [pytest.param(r, marks=pytest.mark.mpi(r)) for r in (2, 3)])
def test_blocked_pencil_under_mpi(ranks):
    """The blocked method with block pairs spread over the ranks (block rows that travel
    between ranks after every round): same accuracy as on one rank."""
    for n, block, seed in ((101, (8, 2, 1), 5), (96, (16, 4, 1), 6), (150, None, 7)):
        _assert_accurate(n, seed, nmodes=10, block=block)


@pytest.mark.parametrize("ranks", [pytest.param(r, marks=pytest.mark.mpi(r)) for r in (2, 3)])
def test_random_spd_pencil_under_mpi(ranks):
    """n = 37 (odd), 60 and 11 on several ranks: same accuracy as on one."""
    for n, seed in ((37, 1), (60, 2), (11, 3)):
        _assert_accurate(n, seed)


@pytest.mark.mpi(2)
def test_indefinite_mass_under_mpi_raises_on_every_rank():
    """Every rank must raise NumericalError (not only the rank holding the bad pivot)."""
    from solver.common.errors import NumericalError
    from solver.modal import jacobi

    Kd, Md = np.eye(4), np.eye(4)
    Md[0:2, 0:2] = [[1.0, 2.0], [2.0, 1.0]]
    K, M = petsc_mat(Kd), petsc_mat(Md)
    try:
        with pytest.raises(NumericalError):
            jacobi.solve(K, M, 2)
    finally:
        K.destroy()
        M.destroy()


@pytest.mark.mpi(2)
def test_tiny_pencil_on_more_ranks_than_pairs():
    """n = 2 on 2 ranks: one pair, so rank 0 owns no slot; the solve must still work."""
    _assert_accurate(2, 42)
