"""Shared helpers of the test suite.

* :func:`run_cli` runs the solver's command line, in this process (``solver.__main__.main``
  on a communicator: the ranks of an ``mpi`` test, or this rank alone) or, for the end-to-end
  tests, as ``python -m solver`` in a subprocess; output in a temporary folder. It returns
  the exit code, stdout, stderr and the parsed ``summary.json`` (None when there is none).
* ``@pytest.mark.mpi(N)`` runs a test in-process on every rank of ``mpirun -n N``
  (``mpi_pytest``); temporary folders are shared by its ranks.
* ``paper_run`` (session fixture) runs each paper scene once per rank count and caches it.
* ``ref_shapes`` (fixture): Q4/Q8/Q9 shape functions written independently of
  ``solver.model.shapes`` (generic 1D Lagrange products and the serendipity formulas), used as the
  reference of the shape-function and dense-assembly tests.
* ``readme_section``, ``readme_table``, ``readme_outputs``, ``check_readme_outputs``: the
  README's sections and tables, for the tests that hold them to the code.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import NamedTuple, Optional

import numpy as np
import pytest

# Open MPI refuses to run as root without these; subprocesses inherit them.
os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
os.environ.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
# No display in batch runs.
os.environ.setdefault("MPLBACKEND", "Agg")

REPO = Path(__file__).resolve().parents[1]
PYTHON = sys.executable
MPIRUN = shutil.which("mpirun")
CASES = REPO / "cases"
ELEMENTS = ("q4", "q8", "q9")

pytest_plugins = ["mpi_pytest"]

# A test that runs as it is on one rank and, in-process, on each of two (``ranks`` is the
# size of PETSc.COMM_WORLD it runs on).
ONE_AND_TWO_RANKS = pytest.mark.parametrize(
    "ranks", [1, pytest.param(2, marks=pytest.mark.mpi(2))], ids=["1rank", "2ranks"])


class CliResult(NamedTuple):
    returncode: int
    stdout: str
    stderr: str
    summary: Optional[dict]


def _option_value(args, flag):
    value = None
    for a, b in zip(args, list(args[1:]) + [None]):
        if a == flag:
            value = b
    return value


def mpi_command(ranks: int, argv):
    """``argv`` under ``mpirun -n ranks`` (plain when ranks is 1)."""
    if ranks == 1:
        return list(argv)
    if MPIRUN is None:
        pytest.skip("mpirun not found")
    return [MPIRUN, "-n", str(ranks), "--oversubscribe", *argv]


def clean_env():
    """The environment for subprocesses: Python's view of it, without the variables an
    in-process MPI initialisation (petsc4py in this pytest process) adds at C level (PMIX_*,
    OMPI_MCA_*), which would make a child ``mpirun`` fail."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("PMIX_", "OMPI_MCA_", "OMPI_APP_", "OMPI_COMM_", "OMPI_FILE_"))}
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT", "1")
    env.setdefault("OMPI_ALLOW_RUN_AS_ROOT_CONFIRM", "1")
    env.setdefault("MPLBACKEND", "Agg")
    return env


def run_command(cmd, timeout=180, cwd=REPO, env=None):
    """Run ``cmd`` in its own session; on timeout kill its whole process group (mpirun's
    ranks included) and report return code 124. ``env``: variables added to
    :func:`clean_env`. Returns (returncode, stdout, stderr)."""
    proc = subprocess.Popen([str(c) for c in cmd], cwd=str(cwd), stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True,
                            start_new_session=True, env={**clean_env(), **(env or {})})
    try:
        out, err = proc.communicate(timeout=timeout)
        return proc.returncode, out, err
    except subprocess.TimeoutExpired:
        try:
            os.killpg(proc.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        out, err = proc.communicate()
        return 124, out, err + f"\n[test harness: killed after {timeout} s timeout]\n"


def stopped_at_checkpoint(args, checkpoint, timeout=120):
    """Run ``python -m solver args`` in a process of its own (the signal goes to it, not to
    pytest; clean_env: without it the child inherits this process's MPI identity, PMIX_*,
    OMPI_MCA_ess), send it SIGTERM once ``checkpoint`` exists, and check its one error line
    (SIGTERM, the restart command) and exit code 4. Returns its stderr."""
    proc = subprocess.Popen([PYTHON, "-m", "solver", *map(str, args)], cwd=REPO,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=clean_env())
    deadline = time.time() + timeout
    while not Path(checkpoint).exists() and time.time() < deadline:
        time.sleep(0.05)
    proc.send_signal(signal.SIGTERM)
    _, stderr = proc.communicate(timeout=timeout)
    assert proc.returncode == 4, stderr
    line = stderr.strip()
    assert "\n" not in line and "SIGTERM" in line and "-mpm_restart" in line
    return stderr


def run_cli(args, out_dir, ranks: int = 1, timeout: float = 180, options_file=None,
            process: bool = False):
    """Run the solver's command line; returns :class:`CliResult` (a 4-tuple
    (returncode, stdout, stderr, summary dict or None)), the same on every rank: rank 0's
    exit code, the output of every rank in rank order (as mpirun shows it).

    ``args``: command-line arguments after ``-m solver``. ``-mpm_output out_dir`` is appended
    unless ``args`` already names an output folder. ``options_file``: a scene name
    (``'eigen-q4'``) or a path, prepended as ``-options_file``. In this process by default:
    ``ranks`` 1 on rank 0 alone (the others receive its result), or on every rank of an
    ``mpi(ranks)`` test. ``process``: as ``python -m solver`` in a subprocess (under
    ``mpirun -n ranks``), killed after ``timeout`` seconds.
    """
    args = [str(a) for a in args]
    if options_file is not None:
        path = CASES / f"{options_file}.opts" if "/" not in str(options_file) else options_file
        args = ["-options_file", str(path), *args]
    if _option_value(args, "-mpm_output") is None:
        args += ["-mpm_output", str(out_dir)]
    if process:
        cmd = mpi_command(ranks, [PYTHON, "-m", "solver", *args])
        code, out, err = run_command(cmd, timeout=timeout)
    else:
        code, out, err = _run_here(args, ranks)
    summary_path = _option_value(args, "-mpm_summary") or os.path.join(
        _option_value(args, "-mpm_output"), "summary.json")
    summary_path = Path(summary_path)
    if not summary_path.is_absolute():
        summary_path = REPO / summary_path
    summary = None
    if summary_path.is_file():
        with open(summary_path) as fh:
            summary = json.load(fh)
    return CliResult(code, out, err, summary)


def _run_here(args, ranks):
    """(exit code, stdout, stderr) of ``solver.__main__.main`` in this process, the same on
    every rank, after every rank has returned (rank 0 writes the files)."""
    from mpi4py import MPI
    from petsc4py import PETSc
    # On every rank: SLEPc started by rank 0 alone would hang PETSc's finalisation.
    from slepc4py import SLEPc  # noqa: F401

    from solver.__main__ import main

    world = MPI.COMM_WORLD
    if ranks not in (1, world.size):
        pytest.fail(f"a run on {ranks} ranks needs the marker mpi({ranks}); "
                    f"this test runs on {world.size}")
    result = None
    if ranks == world.size or world.rank == 0:
        comm = PETSc.COMM_SELF if ranks == 1 else PETSc.COMM_WORLD
        cwd = os.getcwd()
        os.chdir(REPO)              # relative paths as from the repository root
        try:
            with captured() as streams, _warnings_to_stderr():
                code = main(["solver", *args], comm=comm)
        finally:
            os.chdir(cwd)
        result = (code, *streams.text())
    if ranks == 1 and world.size > 1:
        # The other ranks sleep while rank 0 runs alone, rather than spin in the broadcast
        # and take a core from the serial tests running beside them.
        request = world.Ibarrier()
        while not request.Test():
            time.sleep(0.005)
        return world.bcast(result, root=0)
    # As mpirun shows them: rank 0's exit code, every rank's output, rank by rank.
    every = world.allgather(result)
    return (every[0][0], "".join(r[1] for r in every), "".join(r[2] for r in every))


@contextlib.contextmanager
def _warnings_to_stderr():
    """Python's warnings as a fresh interpreter shows them (on stderr, deprecations hidden),
    not recorded by pytest: a one-line error check then sees them, as in a subprocess."""
    def show(message, category, filename, lineno, file=None, line=None):
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))

    with warnings.catch_warnings():
        warnings.resetwarnings()
        for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning,
                         ResourceWarning):
            warnings.simplefilter("ignore", category)
        warnings.showwarning = show
        yield


class _Streams:
    def __init__(self):
        self.files = [tempfile.TemporaryFile(), tempfile.TemporaryFile()]

    def text(self):
        out = []
        for fh in self.files:
            fh.seek(0)
            out.append(fh.read().decode("utf-8", "replace"))
            fh.close()
        return out


@contextlib.contextmanager
def captured():
    """stdout and stderr of the block, C-level (PETSc's printing) and Python's alike."""
    libc = ctypes.CDLL(None)
    streams = _Streams()
    saved = [sys.stdout, sys.stderr]
    for stream in saved:
        stream.flush()
    libc.fflush(None)
    fds = [os.dup(1), os.dup(2)]
    os.dup2(streams.files[0].fileno(), 1)
    os.dup2(streams.files[1].fileno(), 2)
    sys.stdout, sys.stderr = (io.TextIOWrapper(open(fd, "wb", closefd=False),
                                               write_through=True) for fd in (1, 2))
    try:
        yield streams
    finally:
        sys.stdout.flush()
        sys.stderr.flush()
        libc.fflush(None)
        os.dup2(fds[0], 1)
        os.dup2(fds[1], 2)
        for fd in fds:
            os.close(fd)
        sys.stdout, sys.stderr = saved


class _SharedTmp:
    """pytest's tmp_path_factory whose folders rank 0 makes and every rank receives."""

    def __init__(self, factory):
        self._factory = factory

    def mktemp(self, basename, numbered=True):
        from mpi4py import MPI

        world = MPI.COMM_WORLD
        path = self._factory.mktemp(basename, numbered) if world.rank == 0 else None
        return Path(world.bcast(str(path) if path else None, root=0))

    def getbasetemp(self):
        return self._factory.getbasetemp()


@pytest.fixture(scope="session")
def tmp_path_factory(tmp_path_factory):
    """pytest's own; under mpirun the folders are shared by the ranks (so is ``tmp_path``,
    which pytest makes through this factory)."""
    from mpi4py import MPI

    return _SharedTmp(tmp_path_factory) if MPI.COMM_WORLD.size > 1 else tmp_path_factory


# The block drained through its sides (docs/studies.md, "A block drained through its sides"):
# W = H = 1.2 m, 8 x 8 cells with 3 x 3 points, E 8 MPa, nu 0.2, n 0.4, k 2e-4 m/s, K_l 2 GPa,
# 15 kPa on an impermeable top, drained left and right, rollers on the sides, fixed base, the
# rest from the M1 scene's file (T_dr = c_v t / (W/2)^2 = 4 T_v). A test adds the cell type,
# the scheme and the report times.
LATERAL_BLOCK = ["-options_file", "cases/consolidation-m1-q4.opts", "-mpm_ppc", "3",
                 "-mpm_cells", "8,8", "-mpm_size", "1.2,1.2", "-mpm_E", "8e6", "-mpm_nu", "0.2",
                 "-mpm_porosity", "0.4", "-mpm_rho_s", "2650", "-mpm_K_l", "2e9",
                 "-mpm_k", "2e-4", "-mpm_load", "15e3", "-mpm_gravity", "0",
                 "-mpm_drained", "left,right", "-mpm_bc_left", "x", "-mpm_bc_right", "x",
                 "-mpm_bc_bottom", "xy", "-mpm_bc_top", "none", "-mpm_Tv_end", "0.125",
                 "-mpm_figures", "0", "-mpm_progress", "0"]


def scene_options(**given):
    """The solver's options (``options.from_mapping``) of a scene given as keywords
    (``cells="1,10"``), a consolidation scene unless ``analysis`` says otherwise, read as
    from a command line; PETSc's database is not touched."""
    from solver.io import options

    return options.from_mapping({"analysis": "consolidation", **given})


def script_module(name):
    """``scripts/<name>.py`` as a module (importing one runs nothing; its command is the
    symlink ``scripts/<name with hyphens>``)."""
    import importlib

    folder = str(REPO / "scripts")
    if folder not in sys.path:
        sys.path.append(folder)
    return importlib.import_module(name)


def option_entries(help_text):
    """(invocation, help) of each option in argparse's --help output."""
    body = help_text.split("options:", 1)[1].splitlines()
    entries = []
    for line in body:
        if line.startswith("  -"):
            head, _, text = line[2:].partition("  ")
            entries.append([head.strip(), text.strip()])
        elif line.strip() and entries:
            entries[-1][1] += " " + line.strip()
    return entries


def check_ok(res: CliResult):
    """Assert a successful run, showing its output when it is not."""
    assert res.returncode == 0, (f"exit code {res.returncode}\nstdout:\n{res.stdout}\n"
                                 f"stderr:\n{res.stderr[-4000:]}")
    assert res.summary is not None, "no summary.json written"
    return res.summary


@pytest.fixture
def cli(tmp_path):
    """run_cli bound to this test's temporary folder (out_dir = tmp_path / 'out')."""
    def _run(args, ranks=1, timeout=180, options_file=None, out_dir=None, process=False):
        return run_cli(args, out_dir or tmp_path / "out", ranks=ranks, timeout=timeout,
                       options_file=options_file, process=process)
    return _run


@pytest.fixture(scope="session")
def paper_run(tmp_path_factory):
    """``paper_run(element, ranks=1)``: the paper scene cases/eigen-<element>.opts run once
    per session and rank count (with figures), as a CliResult; out folder in ``.out_dir``."""
    cache = {}

    def _get(element, ranks=1):
        key = (element, ranks)
        if key not in cache:
            out = tmp_path_factory.mktemp(f"paper-{element}-n{ranks}") / "out"
            res = run_cli([], out, ranks=ranks, options_file=f"eigen-{element}")
            cache[key] = (res, out)
        return cache[key]

    return _get


# -- independent shape functions ---------------------------------------------------------
def _lagrange_1d(nodes, s):
    """Values and derivatives of the 1D Lagrange polynomials through ``nodes`` at s (scalar),
    from the product formula l_a(s) = prod_{b != a} (s - s_b) / (s_a - s_b)."""
    nodes = list(nodes)
    vals, ders = [], []
    for a, sa in enumerate(nodes):
        others = [sb for b, sb in enumerate(nodes) if b != a]
        den = np.prod([sa - sb for sb in others])
        vals.append(np.prod([s - sb for sb in others]) / den)
        d = 0.0
        for k in range(len(others)):
            d += np.prod([s - sb for m, sb in enumerate(others) if m != k])
        ders.append(d / den)
    return np.array(vals), np.array(ders)


# Natural coordinates of the nodes of each element, in this reference's own order.
REF_NODES = {
    "q4": np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], dtype=float),
    "q8": np.array([(-1, -1), (1, -1), (1, 1), (-1, 1),
                    (0, -1), (1, 0), (0, 1), (-1, 0)], dtype=float),
    "q9": np.array([(-1, -1), (1, -1), (1, 1), (-1, 1),
                    (0, -1), (1, 0), (0, 1), (-1, 0), (0, 0)], dtype=float),
}


def ref_shape(element, xi, eta):
    """N (nen,), dN/d(xi, eta) (nen, 2) at one point, nodes as in REF_NODES[element]."""
    nodes = REF_NODES[element]
    N = np.zeros(len(nodes))
    dN = np.zeros((len(nodes), 2))
    if element == "q4":
        for a, (xa, ya) in enumerate(nodes):
            N[a] = 0.25 * (1 + xa * xi) * (1 + ya * eta)
            dN[a] = 0.25 * xa * (1 + ya * eta), 0.25 * ya * (1 + xa * xi)
    elif element == "q8":
        for a, (xa, ya) in enumerate(nodes):
            if xa != 0 and ya != 0:          # corner
                N[a] = 0.25 * (1 + xa * xi) * (1 + ya * eta) * (xa * xi + ya * eta - 1)
                dN[a, 0] = 0.25 * xa * (1 + ya * eta) * (2 * xa * xi + ya * eta)
                dN[a, 1] = 0.25 * ya * (1 + xa * xi) * (xa * xi + 2 * ya * eta)
            elif xa == 0:                    # mid-side on eta = ya
                N[a] = 0.5 * (1 - xi * xi) * (1 + ya * eta)
                dN[a] = -xi * (1 + ya * eta), 0.5 * ya * (1 - xi * xi)
            else:                            # mid-side on xi = xa
                N[a] = 0.5 * (1 + xa * xi) * (1 - eta * eta)
                dN[a] = 0.5 * xa * (1 - eta * eta), -eta * (1 + xa * xi)
    elif element == "q9":
        vx, dx = _lagrange_1d((-1.0, 0.0, 1.0), xi)
        vy, dy = _lagrange_1d((-1.0, 0.0, 1.0), eta)
        for a, (xa, ya) in enumerate(nodes):
            i, j = int(xa) + 1, int(ya) + 1
            N[a] = vx[i] * vy[j]
            dN[a] = dx[i] * vy[j], vx[i] * dy[j]
    else:
        raise ValueError(element)
    return N, dN


@pytest.fixture(scope="session")
def ref_shapes():
    """(ref_shape, REF_NODES): the independent shape functions."""
    return ref_shape, REF_NODES


def typed(p):
    """The typed values the solver's set-up makes of options ``p`` (solver.io.options.Params):
    soil (a Soil, or a Ground of several layers), body, loading and scheme, as a namespace
    (for tests that build models by hand)."""
    from types import SimpleNamespace

    from solver.stepping.scheme import Scheme
    from solver.model.scene import Body, Loading
    from solver.model.soil import Ground

    soil = Ground.from_options(p).as_material()
    return SimpleNamespace(soil=soil, body=Body.from_options(p),
                           loading=Loading.from_options(p),
                           scheme=Scheme.from_options(p, soil, min(p.Tv_report)))


# -- the README ----------------------------------------------------------------------------
def readme_section(heading: str, path=REPO / "README.md") -> str:
    """The text of the README's section whose ``## `` heading starts with ``heading``, up to
    the next ``## `` heading."""
    text = Path(path).read_text()
    start = text.index(f"\n## {heading}")
    end = text.find("\n## ", start + 1)
    return text[start:end if end >= 0 else len(text)]


def readme_table(heading: str) -> list:
    """The rows of the first table of the README's section ``heading``, each a list of its
    cells (stripped; ``\\|`` stays in a cell), header and separator left out."""
    rows = [line for line in readme_section(heading).splitlines() if line.startswith("|")]
    return [[cell.strip() for cell in re.split(r"(?<!\\)\|", line)[1:-1]] for line in rows[2:]]


def readme_outputs() -> dict:
    """{file name: its row's cells joined} of the README's outputs table."""
    rows = readme_table("Outputs")
    names = {}
    for row in rows:
        found = re.fullmatch(r"`([^`]+)`", row[0])
        assert found, f"outputs table: the first cell names one file in backticks: {row[0]}"
        names[found.group(1)] = " | ".join(row[1:])
    return names


def _readme_name(name: str) -> str:
    """The outputs table's name of a file a run wrote: a figure by its PNG name whatever its
    format, a step's HDF5 file as points_<step>.h5."""
    stem, _, ext = name.rpartition(".")
    if ext in ("png", "pdf", "svg"):
        return f"{stem}.png"
    return re.sub(r"_[0-9]+[.]h5$", "_<step>.h5", name)


def check_readme_outputs(folder):
    """Every file in ``folder`` has a row of the outputs table; a CSV file's row names each
    column of its header (in backticks)."""
    table = readme_outputs()
    written = sorted(p for p in folder.rglob("*") if p.is_file() and not p.name.startswith("."))
    assert written
    for path in written:
        name = _readme_name(path.name)
        assert name in table, f"{path.name}: not in the README's outputs table"
        if path.suffix == ".csv":
            header = path.read_text().splitlines()[0].split(",")
            missing = [col for col in header if f"`{col}`" not in table[name]]
            assert not missing, f"{path.name}: columns {missing} not in its row"
