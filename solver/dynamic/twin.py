"""The linear twin of a hysteretic run: the same deposit, motion, step and damping with the
soil linear at its small-strain stiffness, stepped after the run so that the report can set
what softening did beside what a linear analysis would have said (surface PGA and PSA,
peak strains with depth), and ``twin.csv`` with its figure."""

from __future__ import annotations

import dataclasses

import numpy as np

from ..common import signals
from ..io import output
from . import histories
from .onephase import NodalModel


def run(plan, comm, nsteps: int) -> tuple:
    """(the twin's :class:`histories.Recorder`, its (input, surface) PSA from every step):
    ``nsteps`` steps of the one-phase engine from rest, sampled as the run's loop samples
    (collective)."""
    signals.stage("the linear twin")
    engine = NodalModel(comm, dataclasses.replace(plan, materials=None))
    try:
        rec = histories.Recorder(engine.heights, plan.body.height, plan.depths,
                                 plan.shaking.direction)
        for k in range(1, nsteps + 1):
            t = (k - 1) * engine.dt
            engine.step(t)
            if (k - 1) % engine.every == 0:
                rec.sample(t, engine.means(t))
        engine.check(nsteps, (nsteps - 1) * engine.dt)
        return rec, engine.spectra.psa(engine.mpi)
    finally:
        engine.destroy()


def block(rec, twin, spec, twin_psa) -> dict:
    """The summary's ``linear_twin`` block: the twin's surface PGA and largest strain (and
    where, m below the surface) beside the run's, and their surface PSA at the spectra's
    periods."""
    H = rec.heights[-1]
    out = {}
    for name, r in (("hyperbolic", rec), ("linear", twin)):
        k = int(np.argmax(r.peak_strain))
        out[name] = {"pga_surface": float(r.peak_a[-1]),
                     "peak_strain": float(r.peak_strain[k]),
                     "peak_strain_depth_m": float(H - 0.5 * (r.heights[k]
                                                             + r.heights[k + 1]))}
    if spec is not None and twin_psa is not None:
        out["hyperbolic"]["psa_surface"] = np.asarray(spec["psa_surface"]).tolist()
        out["linear"]["psa_surface"] = np.asarray(twin_psa[1]).tolist()
        out["periods_s"] = np.asarray(spec["periods"]).tolist()
    return out


def words(b: dict, kind: str) -> str:
    """The line the run prints of the twin."""
    h, lin = b["hyperbolic"], b["linear"]
    return (f"Beside its linear twin: surface PGA {h['pga_surface']:.4g} m/s2 (linear "
            f"{lin['pga_surface']:.4g}), peak {kind} strain {100 * h['peak_strain']:.3g} % "
            f"at {h['peak_strain_depth_m']:.4g} m (linear {100 * lin['peak_strain']:.3g} % "
            f"at {lin['peak_strain_depth_m']:.4g} m)")


def write(path, rec, twin, spec, twin_psa) -> None:
    """twin.csv (long format: kind, x, the run's value, the twin's): ``psa`` rows (x the
    period, s; surface PSA, m/s2), ``peak_a`` rows (x the depth, m; peak |a|, m/s2) and
    ``peak_strain`` rows (x the depth of the interval's middle, m; peak strain, -)."""
    H = rec.heights[-1]
    lines = ["kind,x,hyperbolic,linear"]
    if spec is not None and twin_psa is not None:
        for T, a, b in zip(spec["periods"], spec["psa_surface"], twin_psa[1]):
            lines.append(f"psa,{T:.6e},{a:.6e},{b:.6e}")
    for k in range(len(rec.heights) - 1, -1, -1):
        lines.append(f"peak_a,{H - rec.heights[k]:.6g},{rec.peak_a[k]:.6e},"
                     f"{twin.peak_a[k]:.6e}")
    mid = H - 0.5 * (rec.heights[1:] + rec.heights[:-1])
    for k in range(len(mid) - 1, -1, -1):
        lines.append(f"peak_strain,{mid[k]:.6g},{rec.peak_strain[k]:.6e},"
                     f"{twin.peak_strain[k]:.6e}")
    output.write_text(path, "\n".join(lines) + "\n")


def figure(plt, rec, twin, spec, twin_psa, kind: str):
    """The surface PSA of the run, its twin and the input; the peak strains with depth."""
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 4.2))
    if spec is not None and twin_psa is not None:
        ax1.semilogx(spec["periods"], spec["psa_input"], color="0.5", lw=1, label="input")
        ax1.semilogx(spec["periods"], twin_psa[1], color="tab:orange", lw=1.2,
                     label="surface, linear twin")
        ax1.semilogx(spec["periods"], spec["psa_surface"], color="tab:blue", lw=1.4,
                     label="surface, hyperbolic")
        ax1.set_xlabel("period (s)")
        ax1.set_ylabel(f"PSA, {100 * spec['psa_damping']:g} % damping (m/s$^2$)")
        ax1.legend(fontsize=7)
    H = rec.heights[-1]
    mid = H - 0.5 * (rec.heights[1:] + rec.heights[:-1])
    ax2.plot(100 * twin.peak_strain, mid, color="tab:orange", label="linear twin")
    ax2.plot(100 * rec.peak_strain, mid, color="tab:blue", label="hyperbolic")
    ax2.set_xlabel(f"peak {kind} strain (%)")
    ax2.set_ylabel("depth (m)")
    ax2.invert_yaxis()
    ax2.legend(fontsize=7)
    for ax in (ax1, ax2):
        ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    return fig


def loops_figure(plt, loops, kind: str):
    """The stress-strain loops at the recorded depths (the interval below each)."""
    n = len(loops.depths)
    fig, axes = plt.subplots(1, n, figsize=(3.2 * n, 3.4), squeeze=False)
    for i, depth in enumerate(loops.depths):
        h = loops.history(i)
        ax = axes[0, i]
        ax.plot(100 * h[:, 0], h[:, 1] / 1e3, lw=0.7)
        ax.set_title(f"{depth:.3g} m", fontsize=9)
        ax.set_xlabel(f"{kind} strain (%)")
        ax.grid(alpha=0.3)
    axes[0, 0].set_ylabel(f"{kind} stress (kPa)")
    fig.tight_layout()
    return fig

