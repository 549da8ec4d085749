"""Results on disk: JSON summaries, VTU fields (meshio), XDMF + HDF5 time series of point
fields and figures (PNG, PDF, SVG), written whole.

Every file is written to a temporary name in the same folder and renamed into place, so a job
killed mid-write leaves the previous version or nothing, never a truncated file. Only rank 0
writes; callers gather what it needs.
"""

from __future__ import annotations

import json
import os
import re
import tempfile
from contextlib import contextmanager
from dataclasses import dataclass
from xml.sax.saxutils import escape, quoteattr, unescape

import numpy as np

from ..model import shapes


@dataclass(frozen=True)
class Outputs:
    """Where a run's results go: the ``folder``, the summary file, figures (on/off and their
    formats). Both analyses' plans hold one."""

    folder: str
    summary: str
    figures: bool = True
    formats: str = "png"


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


def write_vtu(path, points, cells, point_data=None, cell_data=None, field_data=None):
    """An unstructured-grid VTU file (ParaView) from 2D points (N, 2) and meshio cell blocks;
    ``field_data``: arrays that belong to the whole data set (ParaView's Field Data)."""
    import meshio

    xyz = np.column_stack([points, np.zeros(len(points))])
    mesh = meshio.Mesh(xyz, cells, point_data=point_data or {}, cell_data=cell_data or {},
                       field_data=field_data or {})
    with atomic(path) as tmp:
        meshio.write(tmp, mesh, file_format="vtu")
        if field_data:
            _add_field_data(tmp, field_data)


def _add_field_data(path, field_data):
    """Add a FieldData block to the VTU file ``path`` unless meshio wrote one (meshio 5.0's
    VTU writer drops field data): ASCII arrays, every digit of a double."""
    with open(path) as fh:
        text = fh.read()
    if "<FieldData" in text:
        return
    arrays = []
    for name, value in field_data.items():
        value = np.asarray(value, dtype=float).reshape(-1)
        arrays.append(f'<DataArray type="Float64" Name="{name}" NumberOfTuples="{len(value)}" '
                      'format="ascii">' + " ".join(f"{v:.17g}" for v in value)
                      + "</DataArray>")
    block = "<FieldData>\n" + "\n".join(arrays) + "\n</FieldData>\n"
    head, tag, rest = text.partition("<UnstructuredGrid>")
    if not tag:
        raise ValueError(f"{path}: no <UnstructuredGrid> element to hold field data")
    with open(path, "w") as fh:
        fh.write(head + tag + "\n" + block + rest.lstrip("\n"))


class XdmfSeries:
    """Point fields as an XDMF 3 time series with HDF5 data: ParaView opens the .xdmf
    directly (its XDMF readers), meshio reads it (``meshio.xdmf.TimeSeriesReader``).

    A killed job loses nothing already written, and each output costs the same however
    many came before: each time step's data go to their own HDF5 file (``<stem>_<step>.h5``,
    written whole), and its entry is written into the .xdmf index in place of the closing
    tags, followed by them again (one write at the end of the file), so the index stays
    whole after every output. Rewriting the index whole after each output made a run's
    output time grow as the square of the outputs (1,181 outputs: 100 s). The index is
    written whole (under a temporary name, then renamed) at the first output of a writer,
    which is how a restart takes up a series. meshio's ``TimeSeriesWriter`` is not used
    because it writes its index only when closed and keeps one HDF5 file open throughout.

    Every step carries its points' current positions (m, z = 0) as its geometry and one
    VTK vertex cell per point (XDMF Polyvertex); each field is an Attribute on the points:
    (N,) arrays are scalars, (N, 3) vectors. ``run_id`` (a string) marks the index (an
    Information element of its Domain) and every HDF5 file (attribute ``run_id``), so that
    a restart tells its own series from another run's. Only rank 0 writes; callers gather.
    """

    def __init__(self, path, entries=(), run_id=None):
        self.path = path
        self.folder = os.path.dirname(os.path.abspath(path))
        self.stem = os.path.splitext(os.path.basename(path))[0]
        self.run_id = run_id
        self.entries = entries

    @property
    def entries(self) -> list:
        """(t (s), HDF5 file name, number of points, [[field, components], ...]) per step:
        plain lists, so a checkpoint stores them as JSON and a restart rebuilds the index."""
        return self._entries

    @entries.setter
    def entries(self, entries):
        self._entries = [list(e) for e in entries]
        self._names = {e[1] for e in self._entries}
        self._appending = False     # True once the index on disk lists exactly the entries

    def write(self, step: int, t: float, xy, fields: dict):
        """Add step ``step`` at time ``t`` (s): points ``xy`` (N, 2) in m and ``fields``
        {name: (N,) or (N, c) array, or a function returning one, called in turn so that
        only one field at a time need be in memory}; then add it to the index."""
        import h5py

        n = len(xy)
        name = f"{self.stem}_{step:07d}.h5"
        layout = []
        with atomic(os.path.join(self.folder, name)) as tmp:
            with h5py.File(tmp, "w") as h5:
                if self.run_id:
                    h5.attrs["run_id"] = self.run_id
                h5["geometry"] = np.column_stack([xy, np.zeros(n)])
                h5["topology"] = np.arange(n, dtype=np.int64).reshape(-1, 1)
                for key, value in fields.items():
                    value = np.asarray(value() if callable(value) else value, dtype=float)
                    h5[key] = value
                    layout.append([key, int(np.prod(value.shape[1:]))])
                    del value
        entry = [t, name, n, layout]
        if name in self._names:         # a step written again replaces its entry
            self.entries = [e for e in self._entries if e[1] != name]
        self._entries.append(entry)
        self._names.add(name)
        if not (self._appending and self._append(entry)):
            self.rewrite()

    def resume(self, entries, run_id):
        """Continue the series of a checkpoint of run ``run_id``: its times whose files
        are in this folder and were written by that run (None, an older checkpoint that
        does not say: every file there). A restart elsewhere starts a new series, and the
        index of another run there is replaced by this run's (or removed: no time of it
        there yet); older checkpoints held VTU names."""
        def own(entry):
            path = os.path.join(self.folder, str(entry[1]))
            return os.path.isfile(path) and (run_id is None or series_run_id(path) == run_id)
        self.entries = [list(e) for e in entries
                        if isinstance(e, (list, tuple)) and len(e) == 4 and own(e)]
        self.rewrite()

    def rewrite(self):
        """Write the index whole from the entries (a series taken up again); with none,
        remove an index left at the path (another series')."""
        if self.entries:
            write_text(self.path, self.index())
            self._appending = True
        elif os.path.exists(self.path):
            os.remove(self.path)

    def _append(self, entry) -> bool:
        """Write ``entry``'s grid over the closing tags of the index on disk, and the tags
        after it; False (nothing written) when the index does not end as this writer left
        it."""
        tail = _XDMF_TAIL.encode()
        text = (self._grid(*entry) + _XDMF_TAIL).encode()
        try:
            fd = os.open(self.path, os.O_RDWR)
        except OSError:
            return False
        try:
            end = os.lseek(fd, 0, os.SEEK_END)
            if end < len(tail) or os.pread(fd, len(tail), end - len(tail)) != tail:
                return False
            os.pwrite(fd, text, end - len(tail))     # one write: longer than the tail
        finally:
            os.close(fd)
        return True

    def index(self) -> str:
        """The .xdmf text: a temporal collection of one grid per entry."""
        info = "" if not self.run_id else \
            f'    <Information Name="run_id" Value={quoteattr(str(self.run_id))} />\n'
        return ('<?xml version="1.0"?>\n<Xdmf Version="3.0">\n  <Domain>\n' + info
                + f'    <Grid Name={quoteattr(self.stem)} GridType="Collection" '
                'CollectionType="Temporal">\n'
                + "".join(self._grid(*e) for e in self.entries) + _XDMF_TAIL)

    @staticmethod
    def _grid(t, name, n, layout) -> str:
        """The index's grid of one entry: time, points as vertices, fields."""
        def item(where, shape, kind="Float", pad=10):
            # An HDF5 DataItem of 8-byte numbers of ``shape`` at file:/dataset ``where``.
            return (" " * pad + f'<DataItem DataType="{kind}" Precision="8" Format="HDF" '
                    f'Dimensions="{" ".join(map(str, shape))}">{escape(where)}</DataItem>\n')

        lines = [f'      <Grid Name={quoteattr(os.path.splitext(name)[0])} '
                 'GridType="Uniform">\n',
                 f'        <Time Value="{float(t)!r}" />\n',
                 f'        <Topology TopologyType="Polyvertex" NumberOfElements="{n}" '
                 'NodesPerElement="1">\n', item(f"{name}:/topology", (n, 1), "Int"),
                 '        </Topology>\n        <Geometry GeometryType="XYZ">\n',
                 item(f"{name}:/geometry", (n, 3)), '        </Geometry>\n']
        for key, comps in layout:
            kind = "Scalar" if comps == 1 else "Vector"
            lines += [f'        <Attribute Name={quoteattr(key)} Center="Node" '
                      f'AttributeType="{kind}">\n',
                      item(f"{name}:/{key}", (n,) if comps == 1 else (n, comps)),
                      '        </Attribute>\n']
        return "".join(lines + ["      </Grid>\n"])


_XDMF_TAIL = "    </Grid>\n  </Domain>\n</Xdmf>\n"


def series_run_id(path):
    """The run id that marks the XDMF index or HDF5 file ``path`` (XdmfSeries), or None
    (none, or not readable)."""
    try:
        if path.endswith(".h5"):
            import h5py

            with h5py.File(path, "r") as h5:
                value = h5.attrs.get("run_id")
            return None if value is None else str(value)
        # The mark is in the index's first lines: no need to parse a long series.
        with open(path, encoding="utf-8", errors="replace") as fh:
            head = fh.read(4096)
        found = re.search(r'<Information Name="run_id" Value="([^"]*)"', head)
        return None if found is None else unescape(found.group(1))
    except Exception:   # noqa: BLE001  (damaged or foreign: not this run's)
        return None


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


def save_figures(fig, folder, name, formats=("png",)) -> dict:
    """Save ``fig`` as ``folder/name.<format>`` for each of ``formats`` (see save_figure);
    return the files written as {"<name>_<format>": path}, the keys of summary["files"]."""
    paths = save_figure(fig, os.path.join(folder, name + ".png"), formats=formats)
    return {f"{name}_{os.path.splitext(f)[1][1:]}": f for f in paths}


_NO_DATE = {"pdf": {"CreationDate": None}, "svg": {"Date": None}}


def pyplot():
    """Matplotlib's pyplot on the file-only Agg backend (batch jobs have no display)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def results_line(folder, files: dict) -> str:
    """The line that says where a run's results are: ``Results in FOLDER: a, b, ...``, the
    names of ``files`` (the summary's ``files``: paths, or lists of paths) relative to the
    folder, a list as its count and first name."""
    def name(path):
        rel = os.path.relpath(path, folder)
        return path if rel.startswith("..") else rel

    names = []
    for value in files.values():
        if isinstance(value, (list, tuple)):
            if value:
                names.append(f"{len(value)} files {name(value[0])}, ..." if len(value) > 1
                             else name(value[0]))
        else:
            names.append(name(value))
    return f"Results in {folder}: " + ", ".join(names)


def layer_interfaces(ax, soil, label: bool = False):
    """Dashed red horizontal lines (red: visible over the pressure colours) at the layer
    interfaces of ``soil`` (a soil.Ground; nothing for one soil), on a plot against height
    y (m); ``label`` names them once in the legend."""
    for i, level in enumerate(getattr(soil, "bottoms", ())[:-1]):
        ax.axhline(level, color="tab:red", lw=1.2, ls="--", zorder=3,
                   label="layer interface" if label and i == 0 else None)


def plastic_zone(path, formats, x, eps, size, loaded, title: str) -> list:
    """The plastic-zone figure at ``path`` (its formats): every point at x (np, 2) (m)
    coloured by its accumulated plastic multiplier ``eps`` (where the soil yielded), on a
    body of ``size`` (W, H) (m) with the loaded part of its top (x0, x1) (m) marked."""
    plt = pyplot()
    W, H = size
    fig, ax = plt.subplots(figsize=(8, 8 * H / W + 0.8))
    shown = ax.scatter(x[:, 0], x[:, 1], c=eps, s=4, cmap="magma_r",
                       vmin=0, vmax=max(float(eps.max()), 1e-12))
    ax.plot(loaded, [H, H], "c-", lw=4, label="footing")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(title)
    fig.colorbar(shown, ax=ax, label="accumulated plastic multiplier (-)", shrink=0.8)
    ax.legend(loc="lower right")
    return save_figure(fig, path, formats=formats)


def load_displacement(outputs, curve, ref, name, ylabel, window=None) -> dict:
    """load_displacement.csv (settlement_m, pressure_pa) of ``curve`` (n, 2) and its figure
    with the reference ``ref`` (Pa) named ``name`` ('': none) over the settlements
    ``window`` (m; None: all); returns the files by key."""
    folder = outputs.folder
    os.makedirs(folder, exist_ok=True)
    path = os.path.join(folder, "load_displacement.csv")
    with atomic(path) as tmp:
        np.savetxt(tmp, curve, delimiter=",", comments="", header="settlement_m,pressure_pa")
    files = {"load_displacement": path}
    if outputs.figures:
        plt = pyplot()
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.plot(1e3 * curve[:, 0], curve[:, 1] / 1e3, "o-" if len(curve) < 60 else "-",
                ms=3, label="material points")
        if name and window is None:
            ax.axhline(ref / 1e3, color="k", ls="--", label=name)
        elif name:
            ax.plot([1e3 * w for w in window], [ref / 1e3] * 2, "k--", lw=2, label=name)
        ax.set_xlabel("settlement (mm)")
        ax.set_ylabel(ylabel)
        ax.legend()
        ax.grid(alpha=0.3)
        files["figures"] = save_figure(
            fig, os.path.join(folder, "load_displacement.png"), formats=outputs.formats)
    return files
