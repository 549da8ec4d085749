"""Generalized Jacobi eigensolver for K phi = lambda M phi (paper Section 2.1, eqs. 2-5).

Each rotation P (ones on the diagonal, alpha above and gamma below it at (i, j)) zeroes
K_ij and M_ij at once; alpha and gamma solve eq. (3) (closed form of Bathe, 2014, Sec. 11.3).
A sweep rotates every pair (i, j) once. Convergence (eq. 4) asks, after a sweep, that every
coupling factor sqrt(A_ij^2 / |A_ii A_jj|) of K and M is at most xi and that no eigenvalue
estimate K_ii / M_ii moved by more than xi relative since the previous sweep. Then
Lambda = diag(K_ii / M_ii) (eq. 5a) and Phi = P^1 ... P^l diag(M_ii)^(-1/2) (eq. 5b).

Parallel ordering (the scalar method, models below BLOCKED_MIN_DOFS: the paper's). The n
indices sit in n slots; slots (2k, 2k+1) form the pairs of a round. Between rounds the slots
are permuted as in a round-robin tournament (index 0 stays, the others circulate), so n - 1
rounds rotate every pair once, and the n / 2 rotations of a round are disjoint and
independent. Each rank stores the dense rows (of K, M and Phi^T) of the slots it owns: the
row operations of a rotation are then local to the rank owning the pair, the column
operations need only the round's 2 x n/2 rotation parameters, which every rank receives.
After a round only the rows that change owner travel. Every operation is a numpy array
operation over all pairs of the round; no Python loop per rotation.

Blocked method (larger models). A scalar round costs a pass over the whole n x n matrices
for only n/2 rotations, so the cost of a sweep grows as n^3 in memory traffic. The blocked
method runs the same tournament over blocks of B indices: each round, the 2B x 2B problem of
every block pair is swept by the same eq. (3) rotations (recursively: blocks of blocks,
down to single indices, see :func:`_level`), which yields one 2B x 2B transformation T per
pair; T is then applied to the rows and columns of K, M and Phi^T by matrix products
(BLAS-3). Round 0 of a sweep sweeps every pair inside the two blocks too, the later rounds
only the pairs between them, so a sweep still rotates every pair (i, j) exactly once: a
cyclic Jacobi sweep in another order, with the same convergence test (eq. 4) on the whole
matrices after it. The pair problems' own results (exact zeros where a rotation zeroed an
entry) replace their diagonal blocks after the products, as the scalar method stores its
zeros. The new basis vectors are scaled to unit modal mass after each round. On one rank the
next round's pair problems are swept in a second thread while the current round's products
run (see :func:`_next_problems`); on several, each rank sweeps its own pairs.
"""

from __future__ import annotations

import time
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from ..common.errors import NumericalError


@dataclass
class JacobiResult:
    eigenvalues: np.ndarray   # all n, ascending, (rad/s)^2
    vectors: list             # PETSc Vecs (layout of K) of the lowest nmodes, M-normalised
    sweeps: int
    seconds: float
    coupling: float           # largest coupling factor reached
    change: float             # largest relative eigenvalue change in the last sweep
    residual: np.ndarray = None   # ||K phi - lambda M phi|| / (||K phi|| + |lambda| ||M phi||)
    block: tuple = (1,)       # block sizes of the levels; (1,): the scalar method


class MassError(NumericalError):
    """The mass matrix is not positive definite, so the generalized Jacobi method cannot
    run: ``rank`` of ``n`` eigenvalues of D^-1/2 M D^-1/2 are clearly positive,
    ``negative`` clearly negative (``kind``: 'diagonal', 'singular' or 'indefinite')."""

    def __init__(self, message, kind, rank, n, negative=0):
        super().__init__(message)
        self.kind, self.rank, self.n, self.negative = kind, rank, n, negative


def rotation_parameters(Kii, Kjj, Kij, Mii, Mjj, Mij):
    """alpha, gamma solving eq. (3) for arrays of pairs (Bathe's closed form).

    With kb = Kii Mjj - Kjj Mii, kii = Kii Mij - Mii Kij, kjj = Kjj Mij - Mjj Kij and
    x = kb/2 + sign(kb) sqrt((kb/2)^2 + kii kjj): gamma = -kii / x, alpha = kjj / x. The sign
    choice avoids cancellation; x = 0 (proportional 2x2 blocks) takes alpha = 0,
    gamma = -Kij / Kjj.
    """
    kii = Kii * Mij - Mii * Kij
    kjj = Kjj * Mij - Mjj * Kij
    kb = Kii * Mjj - Kjj * Mii
    root = np.sqrt(np.maximum(0.25 * kb * kb + kii * kjj, 0.0))
    x = 0.5 * kb + np.where(kb >= 0, 1.0, -1.0) * root
    scale = np.abs(Kii * Mjj) + np.abs(Kjj * Mii)
    special = np.abs(x) <= 1e-300 + 1e-14 * scale
    xs = np.where(special, 1.0, x)
    gamma = np.where(special, -Kij / np.where(Kjj == 0, 1.0, Kjj), -kii / xs)
    alpha = np.where(special, 0.0, kjj / xs)
    return alpha, gamma


# The products Kii Mij, Mii Kij, Kjj Mij, Mjj Kij, Kii Mjj, Kjj Mii from the stacked
# (Kii, Kjj, Kij, Mii, Mjj, Mij).
_LEFT, _RIGHT = np.array([0, 3, 1, 4, 0, 1]), np.array([5, 2, 5, 2, 4, 3])


def _rotations(e, out):
    """alpha, gamma of eq. (3) for e = (Kii, Kjj, Kij, Mii, Mjj, Mij) stacked on axis 0,
    written to ``out[..., 1, 0]`` and ``out[..., 0, 1]`` (the 2 x 2 blocks of T^T).

    The formulas of :func:`rotation_parameters` in fewer array operations: the blocked method
    evaluates them n times per sweep on small arrays, where each operation's fixed cost
    counts. (x's sign for kb = -0 may differ; both roots solve eq. 3 there.)
    """
    prod = e[_LEFT] * e[_RIGHT]
    k = prod[0::2] - prod[1::2]                          # kii, kjj, kb
    kb = k[2]
    x = np.copysign(np.sqrt(np.maximum(0.25 * kb * kb + k[0] * k[1], 0.0)), kb)
    x += 0.5 * kb
    special = np.abs(x) <= 1e-14 * np.abs(prod[4:]).sum(axis=0)
    if special.any():
        # Proportional 2 x 2 pencils (x = 0): alpha = 0, gamma = -Kij / Kjj.
        xs = np.where(special, 1.0, x)
        Kjj = np.where(e[1] == 0, 1.0, e[1])
        out[..., 1, 0] = np.where(special, 0.0, k[1] / xs)
        out[..., 0, 1] = np.where(special, -e[2] / Kjj, -k[0] / xs)
        return
    np.divide(k[1], x, out=out[..., 1, 0])
    np.divide(k[0], x, out=out[..., 0, 1])
    np.negative(out[..., 0, 1], out=out[..., 0, 1])


def tournament(n2: int) -> np.ndarray:
    """src[s] = the slot whose row moves into slot s between two rounds (n2 even)."""
    m = n2 // 2
    top = 2 * np.arange(m)
    bot = top + 1
    new_top = np.concatenate([top[:1], bot[:1], top[1:m - 1]]) if m > 1 else top
    new_bot = np.concatenate([bot[1:], top[m - 1:]]) if m > 1 else bot
    src = np.empty(n2, dtype=np.int64)
    src[0::2] = new_top
    src[1::2] = new_bot
    return src


class _Slots:
    """Which rank owns which slot, and how rows move between rounds."""

    def __init__(self, comm, n2):
        self.mpi = comm.tompi4py()
        size, rank = self.mpi.Get_size(), self.mpi.Get_rank()
        m = n2 // 2
        bounds = 2 * (np.arange(size + 1) * m // size)
        self.lo, self.hi = bounds[rank], bounds[rank + 1]
        self.owner = np.searchsorted(bounds, np.arange(n2), side="right") - 1
        self.counts = np.diff(bounds)
        self.src = tournament(n2)
        dest = np.empty(n2, dtype=np.int64)
        dest[self.src] = np.arange(n2)
        mine_old = np.arange(self.lo, self.hi)
        self.send_order = np.argsort(self.owner[dest[mine_old]], kind="stable")
        self.send_counts = np.bincount(self.owner[dest[mine_old]], minlength=size)
        new = np.arange(self.lo, self.hi)
        src_rank = self.owner[self.src[new]]
        self.recv_place = np.lexsort((self.src[new], src_rank))
        self.recv_counts = np.bincount(src_rank, minlength=size)
        self.local_src = self.src[new] - self.lo  # only meaningful with one rank

    def permute(self, rows):
        """Move the rows (nloc, width) to their slots of the next round."""
        if self.mpi.Get_size() == 1:
            return rows[self.local_src]
        from mpi4py import MPI

        width = rows.shape[1]
        send = np.ascontiguousarray(rows[self.send_order])
        recv = np.empty((self.hi - self.lo, width))
        self.mpi.Alltoallv([send, self.send_counts * width, MPI.DOUBLE],
                           [recv, self.recv_counts * width, MPI.DOUBLE])
        out = np.empty_like(recv)
        out[self.recv_place] = recv
        return out

    def allgather_pairs(self, local):
        """Concatenate each rank's arrays, one (...) per owned pair of slots, in slot order."""
        if self.mpi.Get_size() == 1:
            return local
        from mpi4py import MPI

        per = int(np.prod(local.shape[1:]))
        counts = self.counts // 2 * per
        out = np.empty((int(self.counts.sum()) // 2,) + local.shape[1:])
        self.mpi.Allgatherv(np.ascontiguousarray(local, dtype=float), [out, counts, MPI.DOUBLE])
        return out

    def allgather(self, local):
        """Concatenate each rank's one value per owned slot, in slot order (all ranks)."""
        if self.mpi.Get_size() == 1:
            return local
        from mpi4py import MPI

        out = np.empty(int(self.counts.sum()))
        self.mpi.Allgatherv(np.ascontiguousarray(local, dtype=float),
                            [out, self.counts, MPI.DOUBLE])
        return out


def _initial_rows(K, M, slots, mine, n, n2):
    """Dense rows of K, M and Phi^T = I for the indices ``mine`` held by this rank, as one
    (len, 3, n2) array (padding indices >= n decoupled with K = M = 1), and the initial
    eigenvalue estimates K_ii / M_ii of all indices (every rank)."""
    nloc = mine.size
    W = np.zeros((nloc, 3, n2))
    W[:, 0] = _dense_rows(K, mine, n, n2)
    W[:, 1] = _dense_rows(M, mine, n, n2)
    if _any(slots, not np.all(np.isfinite(W[:, 0]))):
        raise NumericalError("Jacobi: the stiffness matrix has non-finite entries (NaN or "
                             "Inf); the model itself is broken")
    r = np.arange(nloc)
    W[r, 2, mine] = 1.0
    pad = mine >= n
    W[pad, 0, mine[pad]] = W[pad, 1, mine[pad]] = 1.0
    kd, md = W[r, 0, mine], W[r, 1, mine]
    lam = np.zeros(n2)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam[mine] = kd / md
    lam = _allreduce_sum(slots, lam)
    if np.any(_allreduce_sum(slots, _scatter(mine, md, n2))[:n] <= 0):
        raise NumericalError("Jacobi: the mass matrix has a zero or negative diagonal "
                             "entry (a DOF without mass); it must be positive definite")
    return W, lam


def _dense_rows(A, rows, n, n2):
    """Rows of the parallel Mat A (global indices ``rows``, < n) as a dense (len, n2) array."""
    keep = rows[rows < n]
    isr = PETSc.IS().createGeneral(keep.astype(PETSc.IntType), comm=PETSc.COMM_SELF)
    isc = PETSc.IS().createStride(n, 0, 1, comm=PETSc.COMM_SELF)
    sub = A.createSubMatrices(isr, isc)[0]
    indptr, cols, vals = sub.getValuesCSR()
    dense = np.zeros((rows.size, n2))
    dense[np.repeat(np.arange(keep.size), np.diff(indptr)), cols] = vals
    for obj in (sub, isr, isc):
        obj.destroy()
    return dense


# Below this many DOFs the scalar method of the paper runs (its sweeps and results are the
# paper's); above it the blocked method, whose matrix products make large models affordable.
BLOCKED_MIN_DOFS = 100


def solve(K, M, nmodes: int, tol: float = 1e-15, max_sweeps: int = 50,
          block=None) -> JacobiResult:
    """All eigenvalues of K phi = lambda M phi and the lowest ``nmodes`` eigenvectors.

    K and M are parallel symmetric PETSc Mats with M positive definite (checked first:
    :class:`MassError` otherwise). ``block``: the block sizes of the levels (see
    :func:`block_sizes`, which chooses them from n when None); 1 selects the scalar method.
    Raises :class:`NumericalError` if the tolerance is not met within ``max_sweeps``. The
    result's ``residual`` is the relative residual of each returned mode: the accuracy the
    tolerance actually bought.
    """
    t0 = time.perf_counter()
    n = K.getSize()[0]
    ranks = K.getComm().getSize()
    sizes = block_sizes(n, ranks) if block is None else _check_sizes(block, n, ranks)
    check_mass(M)
    if sizes == (1,):
        res = _solve_scalar(K, M, nmodes, tol, max_sweeps, t0)
    else:
        res = _solve_blocked(K, M, nmodes, tol, max_sweeps, sizes, t0)
    res.block = sizes
    res.residual = residuals(K, M, res.eigenvalues[:nmodes], res.vectors)
    return res


# A mass matrix whose unit-diagonal form D^-1/2 M D^-1/2 has an eigenvalue below this
# fraction of its largest is treated as singular: the consistent mass of too few points per
# cell has exact null vectors, which rounding leaves at about 1e-16.
MASS_RANK_TOL = 1e-10


def check_mass(M):
    """Raise :class:`MassError` (on every rank) unless M is positive definite.

    M is gathered densely on rank 0 and, scaled to unit diagonal, factored by Cholesky (n^3/3
    operations, little beside a Jacobi sweep); only when that fails or meets a pivot near
    zero are its eigenvalues computed, to tell a singular from an indefinite matrix and give
    its numerical rank.
    """
    comm = M.getComm().tompi4py()
    n = M.getSize()[0]
    lo, hi = M.getOwnershipRange()
    rows = _dense_rows(M, np.arange(lo, hi), n, n)
    status = None
    if comm.Get_size() == 1:
        status = _mass_status(rows)
    else:
        from mpi4py import MPI

        counts = np.array(comm.allgather((hi - lo) * n))
        full = np.empty((n, n)) if comm.Get_rank() == 0 else None
        comm.Gatherv(np.ascontiguousarray(rows), [full, counts, MPI.DOUBLE], root=0)
        if comm.Get_rank() == 0:
            status = _mass_status(full)
        status = comm.bcast(status, root=0)
    if status is None:
        return
    kind, rank, negative, detail = status
    if kind == "finite":
        raise NumericalError(f"Jacobi: the mass matrix has {detail} non-finite entries "
                             "(NaN or Inf); the model itself is broken")
    if kind == "diagonal":
        raise MassError(f"Jacobi: the mass matrix has {detail} zero or negative diagonal "
                        f"entries (DOFs without mass); it must be positive definite",
                        kind, rank, n, negative)
    what = (f"singular (numerical rank {rank} of {n})" if kind == "singular" else
            f"indefinite ({negative} negative eigenvalues of {n})")
    raise MassError(f"Jacobi: the mass matrix is {what}; the generalized Jacobi method needs "
                    "it positive definite", kind, rank, n, negative)


def _mass_status(A):
    """None if the dense symmetric A is positive definite, else (kind, rank, negative,
    detail) as :func:`check_mass` reports it."""
    n = A.shape[0]
    bad = int(np.count_nonzero(~np.isfinite(A)))
    if bad:
        return ("finite", 0, 0, bad)
    d = np.diag(A).copy()
    if np.any(d <= 0):
        return ("diagonal", int(np.count_nonzero(d > 0)), 0, int(np.count_nonzero(d <= 0)))
    s = 1.0 / np.sqrt(d)
    S = A * s[:, None] * s[None, :]
    try:
        if np.min(np.diag(np.linalg.cholesky(S))) ** 2 > MASS_RANK_TOL:
            return None
    except np.linalg.LinAlgError:
        pass
    w = np.linalg.eigvalsh(S)
    cut = MASS_RANK_TOL * w[-1]
    rank, negative = int(np.count_nonzero(w > cut)), int(np.count_nonzero(w < -cut))
    if rank == n:
        return None
    return ("indefinite" if negative else "singular", rank, negative, float(w[0] / w[-1]))


def residuals(K, M, eigenvalues, vectors) -> np.ndarray:
    """Relative residual ||K phi - lambda M phi|| / (||K phi|| + |lambda| ||M phi||) of each
    eigenpair (0: exact; about the coupling tolerance for a loosely converged one)."""
    out = []
    for lam, v in zip(eigenvalues, vectors):
        kv, mv = K.createVecLeft(), M.createVecLeft()
        K.mult(v, kv)
        M.mult(v, mv)
        scale = kv.norm() + abs(lam) * mv.norm()
        kv.axpy(-lam, mv)
        out.append(kv.norm() / scale if scale > 0 else 0.0)
        kv.destroy()
        mv.destroy()
    return np.array(out)


def _check_sizes(block, n, ranks):
    """An explicit ``block`` (an int B or a tuple of level sizes) as a valid tuple of sizes."""
    sizes = (int(block),) if np.isscalar(block) else tuple(int(b) for b in block)
    if sizes[0] == 1:
        return (1,)
    if sizes[-1] != 1:
        sizes = sizes + (1,)
    for big, small in zip(sizes, sizes[1:]):
        if small < 1 or big % small:
            raise ValueError(f"Jacobi block sizes {sizes}: each must divide the one before")
    nblk = -(-n // sizes[0])
    if nblk + nblk % 2 < 2 * ranks:
        return (1,)                      # too few blocks for every rank to own a pair
    return sizes


def block_sizes(n: int, ranks: int = 1) -> tuple:
    """The block sizes of the levels of the blocked method for n DOFs on ``ranks`` ranks.

    ``(1,)`` selects the scalar method of the paper (every model below BLOCKED_MIN_DOFS, so
    the paper's models keep their sweeps and frequencies exactly). Otherwise the top block B
    is about n / 10 (about ten blocks: few rounds of large matrix products, pair problems
    small enough to sweep cheaply; measured best at n = 500 to 2000), chosen among the
    nearby sizes for the least padding to a multiple of 2 B, with at least one block pair per
    rank; the levels below divide it by 3 to 6 down to single indices, e.g. (100, 20, 4, 1).
    """
    if n < BLOCKED_MIN_DOFS:
        return (1,)
    target = min(max(n / 10.0, 16.0), 256.0)
    best = None
    for B in range(max(4, int(target / 1.5)), int(target * 1.5) + 1):
        sizes = _chain(B)
        nblk = -(-n // B)
        nblk += nblk % 2
        if sizes is None or nblk < 2 * ranks:
            continue
        key = (nblk * B, abs(np.log(B / target)))
        if best is None or key < best[0]:
            best = (key, sizes)
    return (1,) if best is None else best[1]


def _chain(B):
    """Block sizes from B down to 1, each dividing the one before by 3 to 6 (None if B has
    no such chain, e.g. a prime)."""
    sizes = [B]
    while sizes[-1] > 6:
        for r in (5, 4, 3, 6):
            if sizes[-1] % r == 0:
                sizes.append(sizes[-1] // r)
                break
        else:
            return None
    if sizes[-1] > 1:
        sizes.append(1)
    return tuple(sizes)


class _Plan:
    """Index arrays of one level of the blocked sweep, for problems of size N, blocks of s.

    ``cross``: only the pairs (i, j) with i in the first and j in the second half of the N
    indices are rotated (the second half's blocks circulate past the first half's, p rounds);
    otherwise every pair (round-robin tournament of the 2p blocks, 2p - 1 rounds). The last
    round's permutation returns every block to its input position, so that the parent level
    finds its blocks where it left them and a sweep rotates every pair exactly once.
    """

    def __init__(self, N, s, cross):
        nblk = N // s
        p = nblk // 2
        m = 2 * s
        if cross:
            order = np.empty(nblk, dtype=np.int64)
            order[0::2], order[1::2] = np.arange(p), p + np.arange(p)
            src = np.arange(nblk)
            src[1::2] = 2 * ((np.arange(p) + 1) % p) + 1
            rounds = p
        else:
            order, src, rounds = np.arange(nblk), tournament(nblk), nblk - 1
        self.order = None if not cross else _elements(order, s)
        self.rounds = []
        label = order.copy()
        pair_rows = np.arange(N).reshape(p, m)
        for r in range(rounds):
            step = np.argsort(label) if r == rounds - 1 else src
            label = label[step]
            se = _elements(step, s)
            dest = np.empty_like(se)
            dest[se] = np.arange(N)
            # Y = T^T K is transposed and its rows permuted in one gather:
            # W[i, a, j] = Y[se[j], a, i], i.e. K T Pi^T (K symmetric).
            i, a, j = np.ix_(np.arange(N), np.arange(2), np.arange(N))
            transpose = ((se[j] * 2 + a) * N + i).ravel()
            # After the second product the rows are still in this round's order and the
            # columns already permuted: pair k's diagonal block sits in rows pair_rows[k],
            # columns dest[pair_rows[k]].
            rows = pair_rows[:, :, None, None]
            cols = dest[pair_rows][:, None, None, :]
            a = np.arange(2)[None, None, :, None]
            block = ((rows * 2 + a) * N + cols).ravel()
            if s == 1:
                # Positions of K_ii, K_jj, K_ij, M_ii, M_jj, M_ij of each pair (before the
                # round), and of the two off-diagonal entries the rotation zeroes (after it).
                i, j = pair_rows[:, 0], pair_rows[:, 1]
                entries = np.stack([(i * 2 + 0) * N + i, (j * 2 + 0) * N + j,
                                    (i * 2 + 0) * N + j, (i * 2 + 1) * N + i,
                                    (j * 2 + 1) * N + j, (i * 2 + 1) * N + j])
                block = np.concatenate([(i * 2 + a) * N + dest[j] for a in (0, 1)] +
                                       [(j * 2 + a) * N + dest[i] for a in (0, 1)])
            else:
                entries = None
            self.rounds.append((se, transpose, entries, block))
        self.p, self.m, self.s, self.N = p, m, s, N


_PLANS = {}


def _plan(N, s, cross):
    key = (N, s, cross)
    if key not in _PLANS:
        _PLANS[key] = _Plan(N, s, cross)
    return _PLANS[key]


def _elements(blocks, s):
    """Indices of the elements of the given blocks of s consecutive indices."""
    return (np.asarray(blocks)[:, None] * s + np.arange(s)).ravel()


def _level(KM, sizes, cross):
    """One blocked sweep over c independent pencils; returns (KM', Tt).

    KM (c, N, 2, N): rows of K (``[:, :, 0]``) and M (``[:, :, 1]``) of each pencil.
    ``sizes``: block size of this level, then of the levels below, ending with 1 (the
    scalar rotations of eq. 3). Each round, the 2s x 2s diagonal blocks of the round's block
    pairs are solved by the level below (one sweep of it), and the resulting transformations
    T (2s x 2s per pair) are applied to the rows and columns of the whole pencils by matrix
    products. Returns the transformed pencils KM' and Tt (c, N, N), whose rows are the new
    basis vectors in the input coordinates: K' = Tt K Tt^T, M' = Tt M Tt^T.
    """
    c, N = KM.shape[:2]
    s = sizes[0]
    plan = _plan(N, s, cross)
    p, m = plan.p, plan.m
    if plan.order is not None:
        KM = KM[:, plan.order][..., plan.order]
        Tt = np.zeros((c, N, N))
        Tt[:, np.arange(N), plan.order] = 1.0
    else:
        Tt = np.broadcast_to(np.eye(N), (c, N, N)).copy()
    if s == 1:
        Ts = np.ones((c, p, 2, 2))       # [[1, gamma], [alpha, 1]] per pair
    for r, (se, transpose, entries, block) in enumerate(plan.rounds):
        if s == 1:
            e = KM.reshape(c, -1)[:, entries]                  # (c, 6, p)
            _rotations(e.transpose(1, 0, 2), Ts)
            sub_out = None
        else:
            sub = np.diagonal(KM.reshape(c, p, m, 2, p, m), axis1=1, axis2=4)
            sub = np.ascontiguousarray(sub.transpose(0, 4, 1, 2, 3)).reshape(c * p, m, 2, m)
            sub_out, Tsub = _level(sub, sizes[1:], cross or r > 0)
            Ts = Tsub.reshape(c, p, m, m)
        # K' = Pi T^T K T Pi^T by symmetry: Y = T^T K; (Y^T, columns permuted) = K T Pi^T;
        # T^T from the left; the rows permuted.
        Y = np.matmul(Ts, KM.reshape(c, p, m, 2 * N)).reshape(c, -1)
        A = np.matmul(Ts, np.take(Y, transpose, axis=1).reshape(c, p, m, 2 * N)).reshape(c, -1)
        if sub_out is None:
            A[:, block] = 0.0      # the rotated pairs: store the zero, not the residue
        else:
            A[:, block] = sub_out.reshape(c, -1)   # the level below's own (exact) result
        KM = np.take(A.reshape(c, N, 2, N), se, axis=1)
        Tt = np.take(np.matmul(Ts, Tt.reshape(c, p, m, N)).reshape(c, N, N), se, axis=1)
    return KM, Tt


def _solve_blocked(K, M, nmodes, tol, max_sweeps, sizes, t0):
    """The blocked method: round-robin over blocks of B = sizes[0] indices, each round's
    2B x 2B pair problems swept by :func:`_level`, their transformations applied by matrix
    products to the distributed rows (and, with every rank's T, to the columns)."""
    comm = K.getComm()
    n = K.getSize()[0]
    B = sizes[0]
    nblk = -(-n // B)
    nblk += nblk % 2
    n2, nb, m = nblk * B, nblk // 2, 2 * B
    slots = _Slots(comm, nblk)           # a slot holds a block of B indices
    mine = _elements(np.arange(slots.lo, slots.hi), B)
    nloc = mine.size
    npl, q0 = (slots.hi - slots.lo) // 2, slots.lo // 2
    index = np.arange(n2)                # index[s]: the basis vector held in slot s

    W, lam_old = _initial_rows(K, M, slots, mine, n, n2)
    r = np.arange(nloc)

    src = tournament(nblk)
    se = _elements(src, B)
    dest = np.argsort(src)               # the block slot each block moves to
    moves = _tournament_moves(nb)
    alone = slots.mpi.Get_size() == 1
    Y = np.empty((nloc, 2, n2))
    Z = np.empty((nloc, 3, n2))
    # On one rank the pair problems of the next round are swept in a second thread while
    # this one applies the current round's products (BLAS, which releases the interpreter):
    # the Python-bound sweeps of the small problems then overlap the matrix products.
    pool = ThreadPoolExecutor(max_workers=1) if alone and nb >= 2 else None
    pending = None
    # Leave the worker thread (or the other ranks of this node) their cores: BLAS threads
    # beyond the free cores only wait for each other (measured 20 % slower at n = 1000).
    blas = _BlasThreads(slots.mpi, pool is not None)
    try:
        for sweep in range(1, max_sweeps + 1):
            for rnd in range(nblk - 1):
                if pending is not None:
                    sub_out, Tt = pending.result()
                    pending = None
                else:
                    # The pair problems of this rank: its rows, the columns of its pairs.
                    sub = W.reshape(npl, m, 3, nb, m)[:, :, :2, q0:q0 + npl, :]
                    sub = np.ascontiguousarray(
                        np.diagonal(sub, axis1=0, axis2=3).transpose(3, 0, 1, 2))
                    # Round 0 of a sweep also sweeps the pairs inside each block; later
                    # rounds only those between a pair's two blocks (each pair once a sweep).
                    sub_out, Tt = _level(sub, sizes[1:], rnd > 0)
                d = np.diagonal(sub_out[:, :, 1, :], axis1=1, axis2=2)
                if _any(slots, np.any(~(d > 0))):
                    raise NumericalError(
                        f"Jacobi: the mass matrix is singular or indefinite (a transformed "
                        f"M_ii <= 0 in sweep {sweep}); check for too few points per cell")
                # Scale the new basis vectors to unit modal mass: M near I, K near Lambda.
                scale = 1.0 / np.sqrt(d)
                Tt *= scale[:, :, None]
                sub_out *= scale[:, :, None, None] * scale[:, None, None, :]
                if pool is not None:
                    # After a sweep's last round comes round 0 of the next sweep (swept in
                    # vain if this sweep converges).
                    pending = pool.submit(_level, _next_problems(W, Tt, sub_out, src),
                                          sizes[1:], rnd < nblk - 2)
                W, Z = _apply_round(W, Y, Z, Tt, sub_out, slots, moves, dest, B, alone)
                index = index[se]
            coupling, change, lam_old, mdiag = _convergence(slots, W, index[mine], n, n2,
                                                            lam_old)
            if coupling <= tol and change <= tol:
                break
        else:
            raise _not_converged(max_sweeps, coupling, change, tol, n)
    finally:
        if pool is not None:
            pool.shutdown(wait=True)
        blas.restore()
    return _finish(K, slots, W, index[mine], mdiag, lam_old, n, nmodes, sweep, t0, coupling,
                   change)


class _BlasThreads:
    """Set OpenBLAS's thread count to the cores this rank may use, restore it afterwards.

    Cores: os.cpu_count() shared by the ranks on this node, one of them left to the sweep
    thread when there is one. Any other BLAS (no openblas_set_num_threads) is left alone.
    """

    def __init__(self, mpi, worker):
        import ctypes
        import os

        self.lib, self.old = None, None
        try:
            lib = ctypes.CDLL("libblas.so.3")
            get, put = lib.openblas_get_num_threads, lib.openblas_set_num_threads
        except (OSError, AttributeError):
            return
        from mpi4py import MPI

        node = mpi.Split_type(MPI.COMM_TYPE_SHARED)
        cores = max(1, (os.cpu_count() or 1) // node.Get_size() - (1 if worker else 0))
        node.Free()
        self.lib, self.old = lib, get()
        put(min(cores, self.old))

    def restore(self):
        if self.lib is not None:
            self.lib.openblas_set_num_threads(self.old)


def _next_problems(W, Tt, sub_out, src):
    """The next round's pair problems (nb, 2B, 2, 2B) on one rank, from this round's rows W
    (before its products), transformations Tt and pair results sub_out.

    The next pair q' joins block slots a = src[2q'] and b = src[2q' + 1], which belong to
    different pairs of this round: its diagonal blocks are parts of those pairs' results, its
    off-diagonal block is (rows of Tt for a) K[pair(a), pair(b)] (rows of Tt for b)^T. The
    matrix products of the round later give the same numbers up to rounding; the pair
    results are written over them, as always.
    """
    nb, m = Tt.shape[:2]
    B = m // 2
    a, b = src[0::2], src[1::2]
    half = sub_out.reshape(nb, 2, B, 2, 2, B)
    Ta = Tt.reshape(nb, 2, B, m)[a // 2, a % 2]              # (nb, B, m)
    Tb = Tt.reshape(nb, 2, B, m)[b // 2, b % 2]
    Kab = W.reshape(nb, m, 3, nb, m)[a // 2, :, :2, b // 2, :]     # (nb, m, 2, m)
    X = np.matmul(np.matmul(Ta[:, None], Kab.transpose(0, 2, 1, 3)),
                  Tb[:, None].transpose(0, 1, 3, 2))         # (nb, 2, B, B)
    out = np.empty((nb, m, 2, m))
    out[:, :B, :, :B] = half[a // 2, a % 2, :, :, a % 2, :]
    out[:, B:, :, B:] = half[b // 2, b % 2, :, :, b % 2, :]
    out[:, :B, :, B:] = X.transpose(0, 2, 1, 3)
    out[:, B:, :, :B] = X.transpose(0, 3, 1, 2)
    return out


def _apply_round(W, Y, Z, Tt, sub_out, slots, moves, dest, B, alone):
    """Apply the round's pair transformations to the rows [K; M; Phi^T] W (Y, Z: work
    arrays); returns (W of the next round, the free work array)."""
    nloc, _, n2 = W.shape
    npl, m = Tt.shape[:2]
    nb, nblk = n2 // m, n2 // B
    q0 = slots.lo // 2
    kk = np.arange(npl)
    # Rows: T^T [K; M; Phi^T] for this rank's pairs. On one rank they are written
    # straight to the rows the tournament moves them to; on several, moved after.
    T = slots.allgather_pairs(Tt).transpose(0, 2, 1)
    Xr = W.reshape(npl, m, 3 * n2)
    if alone:
        for pairs, h, to in moves:
            np.matmul(Tt[pairs, h * B:(h + 1) * B], Xr[pairs, :, :2 * n2],
                      out=Y.reshape(nblk, B, 2 * n2)[to])
            np.matmul(Tt[pairs, h * B:(h + 1) * B], Xr[pairs, :, 2 * n2:],
                      out=Z.reshape(nblk, B, 3 * n2)[to, :, 2 * n2:])
        rowblk = dest[2 * kk[:, None] + np.arange(2)]
    else:
        np.matmul(Tt, Xr[:, :, :2 * n2], out=Y.reshape(npl, m, 2 * n2))
        np.matmul(Tt, Xr[:, :, 2 * n2:], out=Z.reshape(npl, m, 3 * n2)[:, :, 2 * n2:])
        rowblk = 2 * kk[:, None] + np.arange(2)
    # Columns: K T and M T with every rank's T, written to the next round's columns.
    for a in (0, 1):
        Xc = Y[:, a].reshape(nloc, nb, m).transpose(1, 0, 2)
        out = Z[:, a].reshape(nloc, nblk, B).transpose(1, 0, 2)
        for pairs, h, to in moves:
            np.matmul(Xc[pairs], T[pairs, :, h * B:(h + 1) * B], out=out[to])
    # The pair problems' own results (exact zeros where they rotated), where the
    # tournament moves the pairs' rows and columns.
    Z6 = Z.reshape(nloc // B, B, 3, nblk, B)
    colblk = dest[2 * (q0 + kk[:, None]) + np.arange(2)]
    for h1 in (0, 1):
        for h2 in (0, 1):
            Z6[rowblk[:, h1], :, :2, colblk[:, h2], :] = \
                sub_out[:, h1 * B:(h1 + 1) * B, :, h2 * B:(h2 + 1) * B]
    if alone:
        return Z, W
    return slots.permute(Z.reshape(nloc // B, B * 3 * n2)).reshape(nloc, 3, n2), Z


def _tournament_moves(nb):
    """Where :func:`tournament` moves the blocks of the nb block pairs, as slices.

    A list of (pairs, half, to): the blocks ``half`` (0: first, 1: second) of the pairs
    ``pairs`` go to the block slots ``to`` of the next round. Pair 0 keeps its first block
    and hands its second to slot 2, first blocks move one pair right, second blocks one pair
    left, the last pair's first block becomes its second. Writing products through these
    slices puts them where the next round wants them, without a permutation pass.
    """
    if nb == 1:
        return [(slice(0, 1), 0, slice(0, 1)), (slice(0, 1), 1, slice(1, 2))]
    moves = [(slice(0, 1), 0, slice(0, 1)), (slice(0, 1), 1, slice(2, 3)),
             (slice(1, nb), 1, slice(1, 2 * nb - 2, 2)),
             (slice(nb - 1, nb), 0, slice(2 * nb - 1, 2 * nb))]
    if nb > 2:
        moves.append((slice(1, nb - 1), 0, slice(4, 2 * nb, 2)))
    return moves

def _not_converged(max_sweeps, coupling, change, tol, n):
    """The error of a run stopped by -mpm_jacobi_max_sweeps, with what it still lacked."""
    if 0 < coupling < 1e-2:
        # Convergence is quadratic near the end: each sweep about squares the coupling.
        # The eigenvalue change lags one sweep behind the coupling: one more.
        left = 1 + (max(1, int(np.ceil(np.log2(np.log(tol) / np.log(coupling)))))
                    if coupling > tol else 0)
        hint = f"about {left} more sweep(s) would do"
    else:
        hint = f"models of {n} DOFs take about 7 to 12 sweeps"
    return NumericalError(
        f"Jacobi did not converge in {max_sweeps} sweeps (coupling {coupling:.2e}, eigenvalue "
        f"change {change:.2e}, tolerance -mpm_jacobi_tol {tol:.1e}; {hint}): raise "
        "-mpm_jacobi_max_sweeps or loosen -mpm_jacobi_tol")

def _any(slots, flag) -> bool:
    """True on every rank if ``flag`` is true on any (a collective decision)."""
    if slots.mpi.Get_size() == 1:
        return bool(flag)
    from mpi4py import MPI

    return bool(slots.mpi.allreduce(bool(flag), op=MPI.LOR))


def _finish(K, slots, W, idx, mdiag, lam_all, n, nmodes, sweep, t0, coupling, change):
    """JacobiResult from the converged rows: eigenvalues by basis vector, M-normalised modes."""
    md = mdiag[idx]
    lam = lam_all[:n]
    order = np.argsort(lam, kind="stable")
    wanted = order[:nmodes]
    modes = np.zeros((nmodes, n))
    for k, g in enumerate(wanted):
        at = np.flatnonzero(idx == g)
        if at.size:
            modes[k] = W[at[0], 2, :n] / np.sqrt(md[at[0]])
    modes = _allreduce_sum(slots, modes)
    vectors = []
    lo, hi = K.getOwnershipRange()
    for k in range(nmodes):
        v = K.createVecRight()
        v.setArray(modes[k, lo:hi])
        vectors.append(v)
    return JacobiResult(lam[order], vectors, sweep, time.perf_counter() - t0, coupling, change)


def _solve_scalar(K, M, nmodes, tol, max_sweeps, t0):
    """The paper's method: one scalar rotation per pair, round-robin over single indices."""
    comm = K.getComm()
    n = K.getSize()[0]
    n2 = n + n % 2                      # an odd n gets one decoupled dummy index
    slots = _Slots(comm, n2)
    index = np.arange(n2)               # index[s]: the matrix index held in slot s
    mine = np.arange(slots.lo, slots.hi)
    nloc = mine.size

    # Rows of K, M and Phi^T side by side: one array to permute between rounds.
    W, lam_old = _initial_rows(K, M, slots, mine, n, n2)

    r = np.arange(nloc // 2)
    for sweep in range(1, max_sweeps + 1):
        for _ in range(n2 - 1):
            idx = index[mine]
            ti, bj = idx[0::2], idx[1::2]
            Kt, Kb, Mt, Mb = W[0::2, 0], W[1::2, 0], W[0::2, 1], W[1::2, 1]
            alpha, gamma = rotation_parameters(Kt[r, ti], Kb[r, bj], Kt[r, bj],
                                               Mt[r, ti], Mb[r, bj], Mt[r, bj])
            both = slots.allgather(np.stack([alpha, gamma], axis=1).ravel()).reshape(-1, 2)
            I, J = index[0::2], index[1::2]
            A, G = both[:, 0], both[:, 1]
            # Column operations A P on the local rows of K and M, every pair of the round.
            cI = W[:, :2, I]
            cJ = W[:, :2, J]
            W[:, :2, I] = cI + G * cJ
            W[:, :2, J] = A * cI + cJ
            # Row operations P^T (A P) on the local pairs, and Phi^T <- P^T Phi^T.
            top = W[0::2].copy()
            W[0::2] += gamma[:, None, None] * W[1::2]
            W[1::2] += alpha[:, None, None] * top
            # The rotation zeroes (i, j) exactly; store the zero, not the rounding residue.
            W[0::2, 0][r, bj] = W[0::2, 1][r, bj] = 0.0
            W[1::2, 0][r, ti] = W[1::2, 1][r, ti] = 0.0
            W = slots.permute(W.reshape(nloc, 3 * n2)).reshape(nloc, 3, n2)
            index = index[slots.src]
        coupling, change, lam_old, mdiag = _convergence(slots, W, index[mine], n, n2, lam_old)
        # The diagonals are global here, so every rank takes the same decision.
        if np.any(mdiag[:n] <= 0):
            raise NumericalError(
                f"Jacobi: the mass matrix is singular or indefinite (a transformed M_ii <= 0 "
                f"in sweep {sweep}); check for empty cells or too few points per cell")
        if coupling <= tol and change <= tol:
            break
    else:
        raise _not_converged(max_sweeps, coupling, change, tol, n)

    return _finish(K, slots, W, index[mine], mdiag, lam_old, n, nmodes, sweep, t0, coupling,
                   change)


def _scatter(idx, values, n2):
    out = np.zeros(n2)
    out[idx] = values
    return out


def _allreduce_sum(slots, a):
    if slots.mpi.Get_size() == 1:
        return a
    from mpi4py import MPI

    out = np.empty_like(a)
    slots.mpi.Allreduce(np.ascontiguousarray(a), out, op=MPI.SUM)
    return out


def _convergence(slots, W, idx, n, n2, lam_old):
    """Largest coupling factor of K and M, largest eigenvalue change, new estimates."""
    from mpi4py import MPI

    r = np.arange(idx.size)
    diag = np.zeros((2, n2))
    diag[0, idx] = W[r, 0, idx]
    diag[1, idx] = W[r, 1, idx]
    diag = _allreduce_sum(slots, diag)
    coupling = 0.0
    for a in range(2):
        off = W[:, a, :].copy()
        off[r, idx] = 0.0
        denom = np.sqrt(np.abs(diag[a][idx][:, None] * diag[a][None, :]))
        with np.errstate(divide="ignore", invalid="ignore"):
            c = np.where(off != 0, np.abs(off) / denom, 0.0)
        coupling = max(coupling, float(c.max()) if c.size else 0.0)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = diag[0] / diag[1]
        change = float(np.max(np.abs(lam - lam_old) / np.abs(lam)))
    coupling = slots.mpi.allreduce(coupling, op=MPI.MAX)
    return coupling, change, lam, diag[1]
