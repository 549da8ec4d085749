"""Results on disk: JSON summaries, VTU fields (meshio) and figures (PNG, PDF, SVG), written
whole.

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


# Formats save_figure writes: PNG for the reports and the docs, PDF and SVG (vector) for
# papers and slides.
FIGURE_FORMATS = ("png", "pdf", "svg")


def figure_formats(spec="png") -> tuple:
    """The figure formats named by ``spec``: "png,pdf" or a sequence of names, checked against
    FIGURE_FORMATS, duplicates dropped, order kept. ValueError for an unknown name."""
    names = spec.split(",") if isinstance(spec, str) else list(spec)
    names = [n.strip().lower().lstrip(".") for n in names if n.strip()]
    bad = [n for n in names if n not in FIGURE_FORMATS]
    if bad or not names:
        raise ValueError(f"{','.join(bad) or 'nothing'}: not a figure format "
                         f"(choose from {', '.join(FIGURE_FORMATS)})")
    return tuple(dict.fromkeys(names))


def save_figure(fig, path, dpi=150, formats=("png",)):
    """Save a Matplotlib figure, each file whole, and close it; return the paths written.

    ``path`` names the figure (its extension is replaced); one file per format in
    ``formats`` ("png", "pdf", "svg", or a string "png,pdf"), side by side: ``x.png``,
    ``x.pdf``. ``dpi`` sets the resolution of the PNG (dots per inch); PDF and SVG are
    vector files.
    """
    import matplotlib
    import matplotlib.pyplot as plt

    stem = os.path.splitext(path)[0]
    written = []
    try:
        for fmt in figure_formats(formats):
            target = f"{stem}.{fmt}"
            # No date and fixed SVG ids: the same figure gives the same file, so tracked
            # figures change only when their content does.
            with atomic(target) as tmp, matplotlib.rc_context({"svg.hashsalt": "mpm-geo"}):
                fig.savefig(tmp, dpi=dpi, format=fmt, bbox_inches="tight",
                            metadata=_NO_DATE.get(fmt))
            written.append(target)
    finally:
        plt.close(fig)
    return written


_NO_DATE = {"pdf": {"CreationDate": None}, "svg": {"Date": None}}


def pyplot():
    """Matplotlib's pyplot on the file-only Agg backend (batch jobs have no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt
