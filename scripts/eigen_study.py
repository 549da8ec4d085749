#!/usr/bin/env python3
"""Work-precision study of the eigen solvers: Jacobi, SLEPc and dense LAPACK on growing models.

Refines the paper's soil column (0.1 m x 1 m, E = 10 MPa, nu = 0, 2190 kg/m3; Q4 with 2 x 2
points per cell, Q8/Q9 with 3 x 3) and, for each model, times
- Jacobi: ``solver.modal.jacobi.solve``, all n eigenvalues and the 5 lowest modes;
- SLEPc: ``solver.modal.frequency.slepc_solve``, the 5 lowest eigenpairs (shift-and-invert, MUMPS);
- LAPACK: numpy on rank 0, L = cholesky(M), C = L^-1 K L^-T, eigh(C), X = L^-T Y: all n
  eigenpairs (the dense reference the Jacobi goal is measured against);
and the relative error of modes 1 to 5 against the analytic 1D rod with the constrained
modulus. Writes eigen-study.csv, eigen-work-precision.png (error of modes 1 and 5 against
time) and eigen-jacobi-scaling.png (Jacobi sweeps and times, LAPACK times, against n, with
fitted slopes) into output/studies/eigen/, or with --publish into docs/results/ (the
tracked copy the docs show).

    scripts/eigen-study                  # the study, about 3 minutes
    mpirun -n 2 scripts/eigen-study      # the same on 2 ranks
    scripts/eigen-study --benchmark      # the table: n = 250 ... 3000

``--benchmark`` prints only a plain table (one header line, one line per model, Q9
columns of 1 x N cells, n = 8 N DOFs), about 8 minutes on 2 busy cores. Times are wall
seconds on rank 0 after a barrier, the best of ``--repeats`` runs; while rank 0 runs LAPACK
the other ranks wait without spinning.
"""

import argparse
import csv
import os
import sys
import time

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

from solver.studies import study as harness  # noqa: E402  (study() below is the eigen study)

STUDY = {"q4": [(1, 10), (1, 20), (2, 40), (2, 80), (4, 160)],
         "q8": [(1, 10), (1, 20), (2, 40), (2, 80)],
         "q9": [(1, 10), (1, 20), (2, 40), (2, 80)]}
BENCHMARK_CELLS = [32, 63, 125, 250, 375]         # Q9 1 x N: n = 250 ... 3000 DOFs
NMODES = 5
SOLVERS = ("jacobi", "slepc", "lapack")


def scene(element, cells):
    """The -mpm_ options of a refined paper column, read like the command line does."""
    from solver.io import options

    return options.from_mapping(
        {"element": element, "cells": cells, "size": (0.1, 1.0),
         "ppc": 2 if element == "q4" else 3, "E": 10e6, "nu": 0.0, "rho_s": 2700.0,
         "rho_l": 1000.0, "porosity": 0.3, "nmodes": NMODES})


def gather_dense(A):
    """The parallel Mat A as a dense array on rank 0 (None elsewhere)."""
    from mpi4py import MPI

    comm = A.getComm().tompi4py()
    n = A.getSize()[0]
    lo, hi = A.getOwnershipRange()
    indptr, cols, vals = A.getValuesCSR()
    rows = np.zeros((hi - lo, n))
    rows[np.repeat(np.arange(hi - lo), np.diff(indptr)), cols] = vals
    counts = np.array(comm.allgather((hi - lo) * n))
    full = np.empty((n, n)) if comm.Get_rank() == 0 else None
    comm.Gatherv(rows, [full, counts, MPI.DOUBLE], root=0)
    return full


def lapack(K, M):
    """Dense generalized solve: eigenvalues (ascending) and M-orthonormal eigenvectors."""
    L = np.linalg.cholesky(M)
    Li = np.linalg.inv(L)
    lam, Y = np.linalg.eigh(Li @ K @ Li.T)
    return lam, Li.T @ Y


def quiet_wait(comm, work=None):
    """Rank 0 runs ``work`` and returns its result; the others wait for it without spinning
    (an MPI barrier polled with sleeps), so that rank 0 has the cores to itself."""
    req = None
    result = None
    if comm.Get_rank() == 0:
        result = work()
        comm.Ibarrier().Wait()
        return result
    req = comm.Ibarrier()
    while not req.Test():
        time.sleep(0.002)
    return result


def timed(comm, fn, repeats):
    """Best wall time (rank 0's clock, after a barrier) of ``repeats`` collective calls."""
    best, out = np.inf, None
    for _ in range(repeats):
        comm.Barrier()
        t = time.perf_counter()
        out = fn()
        comm.Barrier()
        best = min(best, time.perf_counter() - t)
    return best, out


def measure(comm, element, cells, repeats, with_jacobi=True):
    """One model: a dict per solver with seconds, frequencies (Hz) and errors vs the rod."""
    from solver.modal import jacobi
    from solver.modal.frequency import frequencies, slepc_solve
    from solver.model.scene import Body, build, destroy
    from solver.model.soil import Soil
    from solver.references import analytic

    p = scene(element, cells)
    soil = Soil.from_options(p)
    made = build(_petsc_comm(), Body.from_options(p), soil)
    _, _, K, M, _ = made
    n = K.getSize()[0]
    rod = analytic.rod_frequencies(soil.constrained_modulus, soil.density, p.size[1], NMODES)
    rows = {}
    if with_jacobi:
        sec, res = timed(comm, lambda: jacobi.solve(K, M, NMODES), repeats)
        rows["jacobi"] = {"seconds": sec, "sweeps": res.sweeps, "hz":
                          frequencies(res.eigenvalues[:NMODES]),
                          "block": "x".join(map(str, res.block))}
    sec, res = timed(comm, lambda: slepc_solve(K, M, NMODES), repeats)
    rows["slepc"] = {"seconds": sec, "hz": frequencies(res[0])}
    Kd, Md = gather_dense(K), gather_dense(M)

    def dense():
        best, lam = np.inf, None
        for _ in range(repeats):
            t = time.perf_counter()
            lam = lapack(Kd, Md)[0]
            best = min(best, time.perf_counter() - t)
        return best, lam

    sec, lam = comm.bcast(quiet_wait(comm, dense), root=0)
    rows["lapack"] = {"seconds": sec, "hz": frequencies(lam[:NMODES])}
    for r in rows.values():
        r["error"] = np.abs(r["hz"] / rod - 1)
    destroy(*reversed(made))
    return n, rows


def _petsc_comm():
    from petsc4py import PETSc

    return PETSc.COMM_WORLD


def benchmark(comm, cells_list, repeats):
    """The plain table the benchmark script prints."""
    say = print if comm.Get_rank() == 0 else (lambda *a, **k: None)
    say(f"{'n':>6} {'jacobi_s':>10} {'sweeps':>6} {'lapack_s':>10} {'ratio':>7} "
        f"{'slepc5_s':>9}", flush=True)
    for ny in cells_list:
        n, rows = measure(comm, "q9", (1, ny), repeats)
        j, la, sl = rows["jacobi"], rows["lapack"], rows["slepc"]
        say(f"{n:>6d} {j['seconds']:>10.3f} {j['sweeps']:>6d} {la['seconds']:>10.3f} "
            f"{j['seconds'] / la['seconds']:>7.1f} {sl['seconds']:>9.3f}", flush=True)


def study(comm, repeats, out, formats=("png",)):
    rank0 = comm.Get_rank() == 0
    records = []
    for element, cells_list in STUDY.items():
        for cells in cells_list:
            n, rows = measure(comm, element, cells, repeats)
            for solver in SOLVERS:
                r = rows[solver]
                records.append({"element": element, "cells": f"{cells[0]}x{cells[1]}", "n": n,
                                "solver": solver, "seconds": r["seconds"],
                                "sweeps": r.get("sweeps", ""), "block": r.get("block", ""),
                                **{f"f{k + 1}_hz": r["hz"][k] for k in range(NMODES)},
                                **{f"err{k + 1}": r["error"][k] for k in range(NMODES)}})
            if rank0:
                j = rows["jacobi"]
                print(f"{element} {cells[0]:>2} x {cells[1]:<4} n = {n:5d}: Jacobi "
                      f"{j['seconds']:8.3f} s ({j['sweeps']} sweeps), LAPACK "
                      f"{rows['lapack']['seconds']:7.3f} s, SLEPc "
                      f"{rows['slepc']['seconds']:6.3f} s; error of mode 1 "
                      f"{j['error'][0]:.2e}, mode 5 {j['error'][4]:.2e}", flush=True)
    if not rank0:
        return
    from solver.io import output

    os.makedirs(out, exist_ok=True)
    path = os.path.join(out, "eigen-study.csv")
    with output.atomic(path) as tmp:
        with open(tmp, "w", newline="") as fh:
            w = csv.DictWriter(fh, fieldnames=list(records[0]))
            w.writeheader()
            for r in records:
                w.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v)
                            for k, v in r.items()})
    print("wrote", path)
    work_precision_figure(records, os.path.join(out, "eigen-work-precision.png"),
                          comm.Get_size(), formats)
    scaling_figure(records, os.path.join(out, "eigen-jacobi-scaling.png"), comm.Get_size(),
                   formats)


STYLE = {"jacobi": "-", "slepc": "--", "lapack": ":"}
MARK = {"q4": "o", "q8": "s", "q9": "^"}
COLOR = {"jacobi": "tab:blue", "slepc": "tab:orange", "lapack": "tab:green"}


def work_precision_figure(records, path, ranks, formats=("png",)):
    from solver.io import output

    plt = output.pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.5), sharey=False)
    for ax, mode in zip(axes, (1, 5)):
        for solver in SOLVERS:
            for element in STUDY:
                rs = sorted((r for r in records if r["solver"] == solver
                             and r["element"] == element), key=lambda r: r["n"])
                ax.loglog([r["seconds"] for r in rs], [r[f"err{mode}"] for r in rs],
                          STYLE[solver], marker=MARK[element], color=COLOR[solver], ms=5,
                          label=f"{solver} {element.upper()}")
        ax.set_xlabel("wall time (s)")
        ax.set_ylabel(f"relative error of mode {mode} vs 1D rod")
        ax.set_title(f"mode {mode}")
        ax.grid(alpha=0.3, which="both")
    axes[0].legend(fontsize=7, ncol=3)
    fig.suptitle(f"Eigen solvers on refined soil columns ({ranks} rank(s)): the error is the "
                 "mesh's, the time the solver's")
    for written in output.save_figure(fig, path, formats=formats):
        print("wrote", written)


def slope(x, y):
    """Least-squares exponent of y ~ x^k over the points with x >= 200 (the blocked range)."""
    x, y = np.asarray(x, float), np.asarray(y, float)
    keep = (x >= 200) & (y > 0)
    if keep.sum() < 2:
        return float("nan")
    return float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])


def scaling_figure(records, path, ranks, formats=("png",)):
    from solver.io import output

    plt = output.pyplot()
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    for solver in ("jacobi", "lapack", "slepc"):
        rs = sorted((r for r in records if r["solver"] == solver), key=lambda r: r["n"])
        n = [r["n"] for r in rs]
        t = [r["seconds"] for r in rs]
        ax1.loglog(n, t, STYLE[solver], marker="o", color=COLOR[solver], ms=4,
                   label=f"{solver}: slope {slope(n, t):.2f}")
    ax1.set_xlabel("free DOFs n")
    ax1.set_ylabel("wall time (s)")
    ax1.set_title("time against model size (slopes fitted for n >= 200)")
    ax1.grid(alpha=0.3, which="both")
    ax1.legend(fontsize=8)
    rs = sorted((r for r in records if r["solver"] == "jacobi"), key=lambda r: r["n"])
    lap = {(r["element"], r["cells"]): r["seconds"] for r in records if r["solver"] == "lapack"}
    n = [r["n"] for r in rs]
    ax2.semilogx(n, [r["sweeps"] for r in rs], "o-", color="tab:blue", label="Jacobi sweeps")
    ax2.set_xlabel("free DOFs n")
    ax2.set_ylabel("sweeps to tolerance 1e-15")
    ax2.set_ylim(0, max(r["sweeps"] for r in rs) + 2)
    ax3 = ax2.twinx()
    ratio = [r["seconds"] / lap[(r["element"], r["cells"])] for r in rs]
    ax3.loglog(n, ratio, "s--", color="tab:red", ms=4, label="time Jacobi / LAPACK")
    ax3.set_ylabel("Jacobi time / LAPACK time")
    h1, l1 = ax2.get_legend_handles_labels()
    h2, l2 = ax3.get_legend_handles_labels()
    ax2.legend(h1 + h2, l1 + l2, fontsize=8, loc="upper left")
    ax2.set_title("Jacobi sweeps and its time relative to LAPACK")
    ax2.grid(alpha=0.3, which="both")
    fig.suptitle(f"Generalized Jacobi scaling ({ranks} rank(s))")
    for written in output.save_figure(fig, path, formats=formats):
        print("wrote", written)


def arguments(argv=None):
    from solver.io import output

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--benchmark", action="store_true",
                    help="print only the table of Jacobi, LAPACK and SLEPc times")
    ap.add_argument("--cells", help="benchmark: comma-separated N of the Q9 1 x N columns "
                    f"(default {','.join(map(str, BENCHMARK_CELLS))})")
    ap.add_argument("--repeats", type=int, default=1, help="timed runs per solver (best)")
    harness.add_destination(ap, "eigen", "the CSV and figures")
    ap.add_argument("--formats", default="png",
                    help="comma-separated figure formats: png, pdf, svg (default png)")
    ap.add_argument("--dry-run", action="store_true",
                    help="print the models and where the results would go, run nothing")
    args = ap.parse_args(argv)
    args.out = harness.destination(ap, args)
    try:
        args.formats = output.figure_formats(args.formats)
    except ValueError as exc:
        ap.error(f"--formats: {exc}")
    return args


def main(argv=None):
    args = arguments(argv)
    cells = ([int(c) for c in args.cells.split(",")] if args.cells else BENCHMARK_CELLS)
    if args.dry_run:
        models = ([("q9", (1, c)) for c in cells] if args.benchmark else
                  [(e, c) for e, sizes in STUDY.items() for c in sizes])
        for e, (nx, ny) in models:
            print(f"  {e.upper()} {nx} x {ny} cells")
        print("results: " + ("printed only" if args.benchmark else args.out))
        return 0

    import petsc4py

    petsc4py.init([sys.argv[0]])
    import slepc4py

    slepc4py.init([sys.argv[0]])
    from petsc4py import PETSc

    comm = PETSc.COMM_WORLD.tompi4py()
    if args.benchmark:
        benchmark(comm, cells, args.repeats)
    else:
        study(comm, args.repeats, args.out, args.formats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
