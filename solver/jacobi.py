"""Generalized Jacobi eigensolver for K phi = lambda M phi (paper Section 2.1, eqs. 2-5).

Each rotation P (ones on the diagonal, alpha above and gamma below it at (i, j)) zeroes
K_ij and M_ij at once; alpha and gamma solve eq. (3) (closed form of Bathe, 2014, Sec. 11.3).
A sweep rotates every pair (i, j) once. Convergence (eq. 4) asks, after a sweep, that every
coupling factor sqrt(A_ij^2 / |A_ii A_jj|) of K and M is at most xi and that no eigenvalue
estimate K_ii / M_ii moved by more than xi relative since the previous sweep. Then
Lambda = diag(K_ii / M_ii) (eq. 5a) and Phi = P^1 ... P^l diag(M_ii)^(-1/2) (eq. 5b).

Parallel ordering. The n indices sit in n slots; slots (2k, 2k+1) form the pairs of a round.
Between rounds the slots are permuted as in a round-robin tournament (index 0 stays, the
others circulate), so n - 1 rounds rotate every pair once, and the n / 2 rotations of a round
are disjoint and independent. Each rank stores the dense rows (of K, M and Phi^T) of the
slots it owns: the row operations of a rotation are then local to the rank owning the pair,
the column operations need only the round's 2 x n/2 rotation parameters, which every rank
receives. After a round only the rows that change owner travel. Every operation is a numpy
array operation over all pairs of the round; no Python loop per rotation.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from petsc4py import PETSc

from .errors import NumericalError


@dataclass
class JacobiResult:
    eigenvalues: np.ndarray   # all n, ascending, (rad/s)^2
    vectors: list             # PETSc Vecs (layout of K) of the lowest nmodes, M-normalised
    sweeps: int
    seconds: float
    coupling: float           # largest coupling factor reached
    change: float             # largest relative eigenvalue change in the last sweep


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

    def allgather(self, local):
        """Concatenate each rank's one value per owned slot, in slot order (all ranks)."""
        if self.mpi.Get_size() == 1:
            return local
        from mpi4py import MPI

        out = np.empty(int(self.counts.sum()))
        self.mpi.Allgatherv(np.ascontiguousarray(local, dtype=float),
                            [out, self.counts, MPI.DOUBLE])
        return out


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


def solve(K, M, nmodes: int, tol: float = 1e-15, max_sweeps: int = 50) -> JacobiResult:
    """All eigenvalues of K phi = lambda M phi and the lowest ``nmodes`` eigenvectors.

    K and M are parallel symmetric PETSc Mats with M positive definite. Raises
    :class:`NumericalError` if the tolerance is not met within ``max_sweeps``.
    """
    t0 = time.perf_counter()
    comm = K.getComm()
    n = K.getSize()[0]
    n2 = n + n % 2                      # an odd n gets one decoupled dummy index
    slots = _Slots(comm, n2)
    index = np.arange(n2)               # index[s]: the matrix index held in slot s
    mine = np.arange(slots.lo, slots.hi)
    nloc = mine.size

    # Rows of K, M and Phi^T side by side: one array to permute between rounds.
    W = np.zeros((nloc, 3, n2))
    W[:, 0] = _dense_rows(K, mine, n, n2)
    W[:, 1] = _dense_rows(M, mine, n, n2)
    W[np.arange(nloc), 2, mine] = 1.0
    if n2 > n:
        W[mine == n, 0, n] = W[mine == n, 1, n] = 1.0

    lam_old = np.zeros(n2)
    kd, md = W[np.arange(nloc), 0, mine], W[np.arange(nloc), 1, mine]
    with np.errstate(divide="ignore", invalid="ignore"):
        lam_old[index[mine]] = kd / md
    lam_old = _allreduce_sum(slots, lam_old)
    if np.any(_allreduce_sum(slots, _scatter(index[mine], md, n2))[:n] <= 0):
        raise NumericalError("Jacobi: the mass matrix has a zero or negative diagonal "
                             "entry (a DOF without mass); it must be positive definite")

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
        raise NumericalError(
            f"Jacobi did not converge in {max_sweeps} sweeps: coupling {coupling:.2e}, "
            f"eigenvalue change {change:.2e}, tolerance -mpm_jacobi_tol {tol:.1e} "
            "(raise -mpm_jacobi_max_sweeps or loosen the tolerance)")

    idx = index[mine]
    md = mdiag[idx]
    lam = lam_old[:n]
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
