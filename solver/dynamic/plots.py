"""Figures of a dynamic run: the histories at the recorded depths, the transfer function
with the column's natural frequencies marked, the Fourier and response spectra, and the
peaks with depth. Times in s, accelerations in m/s2, frequencies in Hz, depths in m."""

from __future__ import annotations

import numpy as np

from ..io import output
from . import histories


def draw(plan, rec, spec, exact, water: bool) -> dict:
    """Every figure of the run, saved in the output folder; the files {key: path}."""
    plt = output.pyplot()
    folder, formats = plan.outputs.folder, plan.outputs.formats
    files = {}
    files.update(output.save_figures(_histories(plt, plan, rec, exact, water), folder,
                                     "histories", formats))
    files.update(output.save_figures(_peaks(plt, plan, rec, water), folder, "peaks",
                                     formats))
    if spec is not None:
        files.update(output.save_figures(_spectra(plt, plan, spec), folder, "spectra",
                                         formats))
    return files


def _histories(plt, plan, rec, exact, water):
    t = np.array(rec.t)
    name = histories.COLUMNS[3 * rec.comp]
    n = len(rec.depths)
    rows = n + (1 if water else 0)
    fig, axes = plt.subplots(rows, 1, figsize=(8, 1.6 * rows + 0.8), sharex=True,
                             squeeze=False)
    for i, depth in enumerate(rec.depths):
        ax = axes[i, 0]
        ax.plot(t, rec.history(name, i), lw=0.9, color="tab:blue", label="MPM")
        if i == 0 and exact is not None:
            ax.plot(t, exact, lw=0.9, ls="--", color="k", label="exact (1D column)")
        if i == n - 1 and plan.motion.form[0] != "none":
            ax.plot(t, plan.motion.acceleration(t), lw=0.8, color="tab:orange",
                    label="input" + (" (outcrop)" if plan.shaking.base == "compliant"
                                     else ""))
        ax.set_ylabel(f"{name} (m/s$^2$)\n{depth:.3g} m", fontsize=8)
        ax.grid(alpha=0.3)
        if i in (0, n - 1):
            ax.legend(fontsize=7, loc="upper right")
    if water:
        ax = axes[-1, 0]
        for i, depth in enumerate(rec.depths[:-1]):
            ax.plot(t, rec.history("p_pa", i) / 1e3, lw=0.9, label=f"{depth:.3g} m")
        ax.set_ylabel("excess p (kPa)", fontsize=8)
        ax.legend(fontsize=7, ncol=3, loc="upper right")
        ax.grid(alpha=0.3)
    axes[-1, 0].set_xlabel("t (s)")
    axes[0, 0].set_title("Histories at the recorded depths (row means)")
    fig.tight_layout()
    return fig


def _spectra(plt, plan, spec):
    fig, (ax1, ax2, ax3) = plt.subplots(1, 3, figsize=(14, 4))
    f = spec["f"]
    ax1.plot(f, spec["transfer"], lw=0.6, color="0.6", label="surface / input")
    ax1.plot(f, spec["smoothed"], lw=1.4, color="tab:blue", label="Konno-Ohmachi (b = 40)")
    if "exact_transfer" in spec:
        ax1.plot(f, spec["exact_transfer"], lw=1.0, ls="--", color="k", label="exact")
    marks, label = (plan.eigen_hz, "natural frequencies (Jacobi" + (", small strain)" if
                    plan.materials is not None else ")")) if len(plan.eigen_hz) \
        else (plan.analytic_hz, "natural frequencies (layered rod, undrained)")
    for i, fe in enumerate(marks):
        ax1.axvline(fe, color="tab:red", lw=0.8, ls=":", label=label if i == 0 else None)
    top = 2.2 * max(marks[-1], spec["peaks"][-1] if len(spec["peaks"]) else 0)
    ax1.set_xlim(0, min(f[-1], top))
    ax1.set_ylim(0, 1.15 * np.max(spec["smoothed"][f <= top]))
    ax1.set_xlabel("f (Hz)")
    ax1.set_ylabel("transfer function")
    ax1.legend(fontsize=7)
    ax2.loglog(f, spec["input"], lw=0.8, label="input")
    ax2.loglog(f, spec["surface"], lw=0.8, label="surface")
    ax2.set_xlabel("f (Hz)")
    ax2.set_ylabel("Fourier amplitude (m/s)")
    ax2.legend(fontsize=7)
    ax3.semilogx(spec["periods"], spec["psa_input"], label="input")
    ax3.semilogx(spec["periods"], spec["psa_surface"], label="surface")
    if "at_depths" in spec:             # the recorded depths below the surface
        d = spec["at_depths"]
        for depth, psa in list(zip(d["depths"], d["psa"]))[1:]:
            ax3.semilogx(d["periods"], psa, lw=0.8, ls="--", label=f"{depth:.3g} m")
    ax3.set_xlabel("period (s)")
    ax3.set_ylabel(f"PSA, {100 * spec['psa_damping']:g} % damping (m/s$^2$)")
    ax3.legend(fontsize=7)
    for ax in (ax1, ax2, ax3):
        ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    return fig


def _peaks(plt, plan, rec, water):
    H = plan.body.height
    depth = H - rec.heights
    mid = H - (rec.heights[1:] + rec.heights[:-1]) / 2
    panels = 3 if water else 2
    fig, axes = plt.subplots(1, panels, figsize=(3.4 * panels, 4.5), sharey=True)
    axes[0].plot(rec.peak_a, depth)
    axes[0].set_xlabel("peak |a| (m/s$^2$)")
    axes[1].plot(100 * rec.peak_strain, mid)
    axes[1].set_xlabel(("peak shear strain" if rec.comp == 0 else "peak axial strain")
                       + " (%)")
    if water:
        axes[2].plot(rec.peak_p / 1e3, depth)
        axes[2].set_xlabel("peak excess p (kPa)")
    axes[0].set_ylabel("depth (m)")
    axes[0].invert_yaxis()
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.tight_layout()
    return fig


def deposit(plan, model, final, profile, toe) -> dict:
    """The flowing body's figure: the deposit's points (coloured by their plastic
    multiplier) and free surface over the initial shape, with the scene's experiment (its
    surface and failure line) where it has one, the footing where one is pushed in; beside
    it the kinetic energy against time.
    ``final``: the points' gathered arrays (x, x0, eps_p), ``profile`` (x, surface) (m)."""
    plt = output.pyplot()
    fig, (ax, ax_e) = plt.subplots(2, 1, figsize=(8, 5.2),
                                   gridspec_kw={"height_ratios": [2.2, 1]})
    W, H = plan.size
    ax.plot([0, W, W], [H, H, 0], "k--", lw=1, label="initial shape")
    # The floor's few sliding points reach far higher multipliers: the scale ends at the
    # 98th percentile so the shear bands show.
    top = max(float(np.percentile(final["eps_p"], 98)), 1e-12)
    dots = ax.scatter(final["x"][:, 0], final["x"][:, 1], c=final["eps_p"], s=2,
                      cmap="viridis", vmin=0, vmax=top, rasterized=True)
    fig.colorbar(dots, ax=ax, label="plastic multiplier (-)", shrink=0.6, extend="max")
    ax.plot(*profile, "C3-", lw=1.2, label="computed surface" + (
        "" if plan.footing else f" (toe {toe:.3g} m)"))
    if plan.footing:
        (x0, x1), base = plan.footing["x"], H - model.curve.footing.settlement(
            model.curve.footing.t)
        ax.fill([x0, x1, x1, x0], [base, base, H * 1.15, H * 1.15], color="0.6",
                alpha=0.6, label="footing")
    e = plan.experiment
    if e is not None:
        ax.plot(*e.surface.T, "ko", ms=3.5, mfc="none",
                label=f"experiment: surface (toe {e.toe:.3g} m)")
        (x0, y0), (x1, y1) = e.failure_line
        ax.plot([x0, x1], [y0, y1], "k-.", lw=1.2, label="experiment: failure line")
    ax.set_xlim(0, max(toe, W, e.toe if e else 0) * 1.05)
    ax.set_ylim(0, H * 1.15)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(fontsize=8, loc="upper right")
    energy = np.array(model.energy).reshape(-1, 2)
    ax_e.plot(energy[:, 0], energy[:, 1], "C0-")
    ax_e.set_xlabel("t (s)")
    ax_e.set_ylabel("kinetic energy (J/m)")
    ax_e.grid(alpha=0.3)
    return output.save_figures(fig, plan.outputs.folder, "deposit", plan.outputs.formats)
