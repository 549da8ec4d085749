#!/usr/bin/env python3
"""Time the explicit two-phase step on one soil column, on this process's ranks.

    .venv/bin/python scripts/step-benchmark --element q4 --cells 10,100
    mpirun -n 2 .venv/bin/python scripts/step-benchmark --element q9 --cells 12,120 --steps 50

The column is the paper's soil (Table 2, q = 10 kPa, the solver's defaults otherwise) on
``--cells`` NX,NY cells of ``--element`` with ``--ppc`` points per cell across, ``--size``
W,H m (default 0.1 m wide with square cells). Its model is built as the consolidation run
builds it (``solver.model.scene.two_phase_body``, ``solver.stepping.twophase.TwoPhase`` with
its ``point_fields`` and ``solver.stepping.scheme.Scheme``) and stepped as the run steps it
(``step``, then the points' migration), at a fixed step (1e-6 s, or a quarter of the
undrained wave's transit time across a node spacing when that is smaller; not the run's
critical step, whose eigen analysis is dense). Measured: the set-up, ``--repeats`` timed runs
of ``--steps`` steps after ``--warmup`` untimed ones (wall and CPU seconds of the slowest
rank), the compilation or loading of the compiled kernels, the peak resident memory
(ru_maxrss) above a baseline taken after the imports and the kernels, and two report times
(the profile gathered on rank 0, the monitor and both references' L2 errors). Rank 0 prints
a line and then the figures as one line of JSON after ``BENCH `` (SI units: s, bytes), which
``scripts/benchmark`` reads; it runs this command once per size and rank count, so that each
measurement's peak memory is its own.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

TAG = "BENCH "      # the line of JSON scripts/benchmark reads


# The functions import the solver inside: PETSc must first be initialised with this
# process's own arguments (petsc4py.init in measure).
def maxrss() -> int:
    """Peak resident memory of this process so far (bytes)."""
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024   # KiB on Linux


def column_params(cfg: dict):
    """The solver's options (a ``solver.io.options.Params``) of the column ``cfg`` describes:
    consolidation under q = 10 kPa, cell ``element``, ``cells`` (NX, NY), ``size`` (m) and
    ``ppc`` points per cell across, the rest as the solver's defaults (Table 2 soil)."""
    from solver.io import options

    return options.from_mapping(
        {"analysis": "consolidation", "element": cfg["element"],
         "cells": "%d,%d" % tuple(cfg["cells"]), "size": "%g,%g" % tuple(cfg["size"]),
         "ppc": cfg["ppc"], "load": 1e4})


def build_model(comm, p, scheme):
    """Grid, points and TwoPhase model of ``p``, built by the package's functions as the
    consolidation run builds them, and the seconds (wall) that took. The caller destroys the
    three."""
    from solver.model import scene
    from solver.model.soil import Soil
    from solver.stepping.twophase import TwoPhase, point_fields

    t0 = time.perf_counter()
    soil, body = Soil.from_options(p), scene.Body.from_options(p)
    grid, points = scene.two_phase_body(comm, body, soil, point_fields(scheme))
    model = TwoPhase(grid, points, soil, body, scene.Loading.from_options(p), scheme)
    return grid, points, model, time.perf_counter() - t0


def fixed_dt(p, grid) -> float:
    """The benchmark's time step (s): 1e-6 s, or a quarter of the undrained wave's transit
    time across a node spacing when that is smaller. Not the CLI's critical time step,
    whose eigen analysis is dense: it would dominate the large models."""
    from solver.model.soil import Soil

    spacing = min(p.size[0] / p.cells[0], p.size[1] / p.cells[1]) / grid.order
    return min(1e-6, 0.25 * spacing / Soil.from_options(p).wave_speeds()["c1"])


def time_steps(model, scheme, dt: float, cfg: dict, mpi):
    """Wall and CPU seconds of each of ``cfg['repeats']`` runs of ``cfg['steps']`` steps
    (``step``, then ``migrate``, as the run calls them), after ``cfg['warmup']`` untimed
    steps; both the slowest rank's. ``dt`` in s."""
    from mpi4py import MPI

    def run(nsteps):
        for _ in range(nsteps):
            model.step(dt, 1.0, scheme.damping, scheme.flip)
            model.migrate()

    run(cfg["warmup"])
    times, cpu = [], []
    for _ in range(cfg["repeats"]):
        mpi.Barrier()
        t, c = time.perf_counter(), time.process_time()
        run(cfg["steps"])
        # CPU time of the slowest rank: what the process itself used, which the other jobs
        # on a shared machine disturb less than the wall time (MPI waits spin, so they count).
        c = time.process_time() - c
        mpi.Barrier()
        times.append(mpi.allreduce(time.perf_counter() - t, op=MPI.MAX))
        cpu.append(mpi.allreduce(c, op=MPI.MAX))
    return times, cpu


def time_reports(points, comm, p) -> list:
    """Wall seconds (slowest rank) of two report times as the run has them: the profile
    gathered on rank 0 (isochrones), the monitor and both references' L2 errors."""
    from mpi4py import MPI

    from solver.consolidation import reporting
    from solver.consolidation.plan import References
    from solver.model import scene
    from solver.model.soil import Soil

    mpi = comm.tompi4py()
    refs = References.of(Soil.from_options(p), scene.Loading.from_options(p),
                         scene.Body.from_options(p))
    depths = reporting.Heights()
    depths.refresh(points)                   # at the run's set-up
    with points.fields("monitor") as mon:
        mon[:] = 1.0
    report_s = []
    for _ in range(2):
        mpi.Barrier()
        t = time.perf_counter()
        reporting.profile(points, comm)
        reporting.report(0.1, 0.0, points, mpi, refs, p.size[1] / 2, depths)
        mpi.Barrier()
        report_s.append(mpi.allreduce(time.perf_counter() - t, op=MPI.MAX))
    return report_s


def all_finite(points, mpi) -> bool:
    """Whether every point's pore pressure is finite on every rank (a step that blew up
    would time other work)."""
    import numpy as np
    from mpi4py import MPI

    with points.fields("p") as pp:
        return mpi.allreduce(bool(np.isfinite(pp).all()), op=MPI.LAND)


def measure(cfg: dict) -> dict:
    """Measure the column ``cfg`` describes on this process's ranks: its figures (seconds,
    bytes) on rank 0, None on the others."""
    import petsc4py

    petsc4py.init([sys.argv[0]])
    from petsc4py import PETSc

    from solver.model import scene
    from solver.model.soil import Soil
    from solver.stepping.scheme import Scheme
    from solver.stepping.twophase import compile_kernels

    comm = PETSc.COMM_WORLD
    mpi = comm.tompi4py()
    p = column_params(cfg)
    scheme = Scheme.from_options(p, Soil.from_options(p), min(p.Tv_report))
    # The compiled step (compiled on a machine's first run, else loaded from numba's disk
    # cache) is, like the imports, a per-process constant: made before the baseline.
    imported = maxrss()
    compiled = compile_kernels(p.element, scheme)
    base = maxrss()
    grid, points, model, setup = build_model(comm, p, scheme)
    dt = fixed_dt(p, grid)
    times, cpu = time_steps(model, scheme, dt, cfg, mpi)
    finite = all_finite(points, mpi)
    peak = mpi.gather(maxrss(), root=0)      # the step's, before the report's temporaries
    report_s = time_reports(points, comm, p)
    bases, imports = mpi.gather(base, root=0), mpi.gather(imported, root=0)
    npoints = points.n_global          # collective: every rank
    scene.destroy(model, points, grid)
    if comm.getRank() != 0:
        return None
    return dict(cfg, points=npoints, dt=dt, setup_s=setup, times_s=times, cpu_s=cpu,
                finite=finite, report_s=report_s, peak_rss_bytes=sum(peak),
                base_rss_bytes=sum(bases), peak_rss_per_rank=peak, ranks=comm.getSize(),
                import_rss_bytes=sum(imports),
                compile={k: compiled[k] for k in ("seconds", "compiled", "loaded")})


def _pair(text: str, kind):
    try:
        a, b = (kind(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text}: expected two comma-separated numbers")
    return [a, b]


def arguments(argv=None) -> dict:
    """The column and the timing the command line asks for, as :func:`measure` takes them."""
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--element", default="q4", choices=("q4", "q8", "q9"),
                    help="cell type (default q4)")
    ap.add_argument("--cells", type=lambda t: _pair(t, int), default=[1, 10],
                    help="cells NX,NY (default 1,10)")
    ap.add_argument("--size", type=lambda t: _pair(t, float), default=None,
                    help="width and height W,H in m (default 0.1 m wide, square cells)")
    ap.add_argument("--ppc", type=int, default=None,
                    help="points per cell across (default 2 for Q4, 3 otherwise)")
    ap.add_argument("--steps", type=int, default=100, help="steps per timed run (default 100)")
    ap.add_argument("--warmup", type=int, default=10,
                    help="untimed steps before the timed runs (default 10)")
    ap.add_argument("--repeats", type=int, default=3, help="timed runs (default 3)")
    args = ap.parse_args(argv)
    nx, ny = args.cells
    return {"element": args.element, "cells": [nx, ny],
            "size": args.size or [0.1, 0.1 * ny / nx],
            "ppc": args.ppc or (2 if args.element == "q4" else 3),
            "steps": args.steps, "warmup": args.warmup, "repeats": args.repeats}


def command(cfg: dict) -> list:
    """The arguments of this command that measure ``cfg`` (what :func:`arguments` reads)."""
    return ["--element", cfg["element"], "--cells", "%d,%d" % tuple(cfg["cells"]),
            "--size", "%r,%r" % tuple(cfg["size"]), "--ppc", str(cfg["ppc"]),
            "--steps", str(cfg["steps"]), "--warmup", str(cfg["warmup"]),
            "--repeats", str(cfg["repeats"])]


def main(argv=None) -> int:
    res = measure(arguments(argv))
    if res is not None:
        best = min(res["times_s"]) / res["steps"] / res["points"] * 1e9
        cpu = min(res["cpu_s"]) / res["steps"] / res["points"] * 1e9
        print(f"{res['element'].upper()} {res['cells'][0]} x {res['cells'][1]} cells, "
              f"{res['points']:,} points, {res['ranks']} rank(s): {best:,.0f} ns per point "
              f"per step (CPU {cpu:,.0f}), best of {res['repeats']}; peak memory "
              f"{res['peak_rss_bytes'] / res['points']:,.0f} bytes per point"
              + ("" if res["finite"] else "; the step blew up"), flush=True)
        print(TAG + json.dumps(res), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
