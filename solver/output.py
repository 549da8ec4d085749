"""Results on disk: JSON summaries, VTU fields (meshio) and PNG figures, written whole.

Every file is written to a temporary name in the same folder and renamed into place, so a job
killed mid-write leaves the previous version or nothing, never a truncated file. Only rank 0
writes; callers gather what it needs.
"""

from __future__ import annotations

import json
import os
import tempfile
from contextlib import contextmanager

import numpy as np

from . import shapes

# VTK node order of each cell type, as lattice offsets (i, j) within the cell.
_VTK_ORDER = {
    "q4": ("quad", [(0, 0), (1, 0), (1, 1), (0, 1)]),
    "q8": ("quad8", [(0, 0), (2, 0), (2, 2), (0, 2), (1, 0), (2, 1), (1, 2), (0, 1)]),
    "q9": ("quad9", [(0, 0), (2, 0), (2, 2), (0, 2), (1, 0), (2, 1), (1, 2), (0, 1), (1, 1)]),
}


_UMASK = os.umask(0)
os.umask(_UMASK)


@contextmanager
def atomic(path):
    """Yield a temporary path next to ``path``; rename it to ``path`` if the block succeeds."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    suffix = os.path.splitext(path)[1]
    fd, tmp = tempfile.mkstemp(prefix=".partial-", suffix=suffix, dir=folder)
    os.close(fd)
    try:
        yield tmp
        os.chmod(tmp, 0o666 & ~_UMASK)   # mkstemp makes 0600; results are for sharing
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _jsonable(obj.tolist())
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, float) and not np.isfinite(obj):
        return None
    return obj


def write_json(path, data):
    """Write ``data`` as indented JSON (non-finite floats become null)."""
    with atomic(path) as tmp:
        with open(tmp, "w") as fh:
            json.dump(_jsonable(data), fh, indent=2)
            fh.write("\n")


def write_text(path, text: str):
    """Write ``text`` (a Markdown table, a CSV) whole or not at all."""
    with atomic(path) as tmp:
        with open(tmp, "w") as fh:
            fh.write(text if text.endswith("\n") else text + "\n")


def grid_cells(grid):
    """meshio cell block of the background grid: (cell type, connectivity in natural order)."""
    kind, order = _VTK_ORDER[grid.element]
    conn = grid.cell_connectivity()
    lattice = [tuple(o) for o in shapes.OFFSETS[grid.element]]
    cols = [lattice.index(o) for o in order]
    return kind, conn[:, cols]


def write_vtu(path, points, cells, point_data=None, cell_data=None):
    """An unstructured-grid VTU file (ParaView) from 2D points (N, 2) and meshio cell blocks."""
    import meshio

    xyz = np.column_stack([points, np.zeros(len(points))])
    mesh = meshio.Mesh(xyz, cells, point_data=point_data or {}, cell_data=cell_data or {})
    with atomic(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")


def save_figure(fig, path, dpi=150):
    """Save a Matplotlib figure as PNG, whole, and close it."""
    import matplotlib.pyplot as plt

    with atomic(path) as tmp:
        fig.savefig(tmp, dpi=dpi, format="png", bbox_inches="tight")
    plt.close(fig)


def pyplot():
    """Matplotlib's pyplot on the file-only Agg backend (batch jobs have no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
