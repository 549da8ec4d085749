"""A memory estimate made before anything is allocated, so that an oversized model is an
input error with a number rather than a crash half-way."""

from __future__ import annotations

import os

from ..common.errors import InputError
from ..model.shapes import lattice_nodes

# Bytes per material point of a consolidation run and per grid node: generous bounds; they
# only have to separate a model that fits from one that cannot. Measured peak: 447 B per Q4
# point, 483 B per Q9 point at 1e6 points, the process's fixed part included
# (docs/performance.md).
BYTES_PER_POINT = 1000
BYTES_PER_NODE = 2000


def available() -> int:
    """Physical memory of this machine (bytes)."""
    try:
        return os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):
        return 1 << 62


def estimate(body, jacobi: bool = False) -> int:
    """Bytes the whole job on ``body`` (scene.Body) needs, over all ranks; ``jacobi``: with
    the dense Jacobi eigensolver."""
    nx, ny = body.cells
    nodes = lattice_nodes(body.element, body.cells)
    points = nx * ny * body.ppc ** 2
    total = points * BYTES_PER_POINT + nodes * BYTES_PER_NODE
    if jacobi:
        # The blocked Jacobi holds about 8 dense n x n arrays (K, M, Phi^T and their
        # products) over the ranks, and the mass check one more on rank 0.
        total += 9 * 8 * (2 * nodes) ** 2
    return total


def check(body, jacobi: bool = False):
    """InputError if the model (:func:`estimate`'s arguments) cannot fit in this machine's
    memory, with the advice that fits: SLEPc in place of Jacobi only where Jacobi's dense
    matrices are what does not fit (an eigen analysis), else fewer cells or points."""
    need, have = estimate(body, jacobi), available()
    if need <= 0.8 * have:
        return
    advice = "fewer cells, or fewer points per cell (-mpm_ppc)"
    if jacobi and estimate(body) <= 0.8 * have:
        advice = (f"Jacobi's dense matrices take most of it: with -mpm_eigen_solver slepc "
                  f"it needs about {estimate(body) / 2**30:.1f} GiB; or " + advice)
    raise InputError(f"-mpm_cells {body.cells[0]},{body.cells[1]}: the model needs about "
                     f"{need / 2**30:.1f} GiB, more than this machine's "
                     f"{have / 2**30:.1f} GiB allows ({advice})")
