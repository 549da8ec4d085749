"""The consolidation analysis's figures, shared by the solver and
``scripts/reproduce-paper``: isochrones against both Terzaghi references (classic and
compressible water), and the pore-pressure field.

Heights and widths in m, pore pressure in kPa or normalised by the load q (p / q), the time
factor T_v dimensionless. The caller makes the figure (``output.pyplot()``) and saves it
(``output.save_figure``).
"""

from __future__ import annotations

import numpy as np

from ..io import output
from ..references import analytic

# Perceptually uniform and readable in grey and by colour-blind readers; a rainbow map such
# as "jet" shows bands that are not in the data.
PRESSURE_CMAP = "viridis"
CLASSIC = dict(ls="-", lw=1.2)
COMPRESSIBLE = dict(ls=":", lw=1.2)


def tv_colors(plt, n: int):
    """One colour per report time, early (dark) to late (light), from the same map."""
    return plt.get_cmap(PRESSURE_CMAP)(np.linspace(0.0, 0.85, max(n, 1)))


def isochrone_references(ax, Tvs, colors, H: float, ratio: float, p0: float,
                         pressure=None):
    """Draw, per T_v, classic Terzaghi (solid) and compressible-water Terzaghi (dotted,
    T_v scaled by ``ratio`` = c2 / c_v, start ``p0`` = p0 / q) as p / q against height (m),
    in the T_v's colour, with its T_v written beside the classic curve; legend entries for
    the two line styles. ``H``: the layer thickness (m). ``pressure(y, T_v, form)``: another
    reference's p / q at heights y (m) in place of Terzaghi's."""
    name = "Terzaghi" if pressure is None else "reference"
    if pressure is None:
        def pressure(y, Tv, form):
            return (analytic.terzaghi(H - y, Tv, H) if form == "classic"
                    else analytic.terzaghi(H - y, Tv * ratio, H, p0))
    depth = np.linspace(0.0, H, 300)
    n = len(Tvs)
    for i, (Tv, col) in enumerate(zip(Tvs, colors)):
        ax.plot(pressure(H - depth, Tv, "classic"), H - depth, color=col, **CLASSIC)
        ax.plot(pressure(H - depth, Tv, "consistent"), H - depth, color=col, **COMPRESSIBLE)
        # Labels beside their curves at staggered heights, early times high: there the
        # later curves (to the left) are far away. Left of the curve, unless it runs close
        # to the axis.
        y = H * (0.06 + 0.8 * (n - i - 0.5) / n)
        x = float(pressure(y, Tv, "classic"))
        left = x > 0.25
        ax.annotate(f"T_v = {Tv:g}", (x, y), xytext=(-4 if left else 4, 0),
                    textcoords="offset points", ha="right" if left else "left",
                    va="center", fontsize=7, color=col, zorder=5,
                    bbox=dict(boxstyle="round,pad=0.15", fc="white", ec="none", alpha=0.85))
    ax.plot([], [], color="k", label=f"{name}, classic", **CLASSIC)
    ax.plot([], [], color="k", label=f"{name}, compressible water", **COMPRESSIBLE)
    ax.set_xlabel("excess pore pressure p / q (-)")
    ax.set_ylabel("height above the base (m)")
    ax.set_xlim(0, 1.1)
    ax.set_ylim(0, H)
    ax.grid(alpha=0.3)


def legend_below(ax, ncol: int = 2):
    """The axes' legend under its x label, where it covers no curve."""
    ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=ncol,
              frameon=False)


MAX_DRAWN = 20000    # points per series in a figure: more only cost time and memory


def drawn(n: int, most: int = MAX_DRAWN) -> slice:
    """Every k-th of ``n`` points, k the smallest stride that keeps at most ``most``: a
    figure of 1e6 points took minutes and gigabytes and showed nothing more."""
    return slice(None, None, max(1, -(-n // most)))


def pressure_field(plt, snapshots, q: float, title: str, width: float = None,
                   height: float = None, soil=None):
    """A figure of the pore-pressure field, one panel per snapshot (T_v, x (m), height (m),
    p (Pa)) of the points, on one colour scale from 0 to the load ``q`` (Pa), in kPa: side
    by side for a column, one above the other for a body wider than high (``width``,
    ``height`` in m); the layer interfaces of ``soil`` (a soil.Ground) dashed."""
    n = len(snapshots)
    wide = bool(width and height and width > height)
    if wide:
        fig, axes = plt.subplots(n, 1, figsize=(8, 1.0 + n * 5.5 * height / width),
                                 squeeze=False, sharex=True)
        axes = axes.T
    else:
        fig, axes = plt.subplots(1, n, figsize=(2.2 * n + 1.6, 6), squeeze=False,
                                 sharey=True)
    for ax, (Tv, x, y, pp) in zip(axes[0], snapshots):
        k = drawn(len(x))
        sc = ax.scatter(np.asarray(x)[k], np.asarray(y)[k], c=np.asarray(pp)[k] / 1e3, s=12,
                        cmap=PRESSURE_CMAP, vmin=0, vmax=q / 1e3)
        ax.set_title(f"T_v = {Tv:g}", fontsize=9)
        ax.set_aspect("equal")
        output.layer_interfaces(ax, soil)
        if wide:
            ax.set_ylabel("y (m)")
            ax.set_xlim(0, width)
            continue
        ax.set_xlabel("x (m)")
        if width:
            ax.set_xticks([0, width])
            ax.set_xlim(0, width)
    if wide:
        axes[0, -1].set_xlabel("x (m)")
    else:
        axes[0, 0].set_ylabel("height above the base (m)")
    fig.colorbar(sc, ax=list(axes[0]), label="excess pore pressure (kPa)")
    fig.suptitle(title)
    return fig


def _degree(degree, ratio):
    """The reference U(T_v, form): ``degree`` or, when None, Terzaghi's (compressible water:
    T_v scaled by ``ratio`` = c2 / c_v)."""
    if degree is not None:
        return degree
    return lambda T, form: analytic.degree_of_consolidation(
        T * ratio if form == "consistent" else T)


def consolidation_degree(plt, Tv, U_settlement, U_pressure, ratio: float, Tv_end: float,
                         title: str, degree=None, name: str = "Terzaghi"):
    """The degree of consolidation U (-) against the time factor T_v (-, log axis): the
    reference ``name`` classic (solid) and with compressible water (dotted), and the run's U
    from the surface settlement and from the mean pore pressure, each an array at the times
    ``Tv``. Drawn up to ``Tv_end``. ``degree(T, form)``: the reference's U (None:
    Terzaghi's, with ``ratio`` = c2 / c_v)."""
    Tv = np.asarray(Tv, dtype=float)
    degree = _degree(degree, ratio)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    start = min(1e-4, Tv[Tv > 0].min()) if np.any(Tv > 0) else 1e-4
    T = np.geomspace(start, max(Tv_end, start * 10), 400)
    ax.plot(T, degree(T, "classic"), color="k", label=f"{name}, classic", **CLASSIC)
    ax.plot(T, degree(T, "consistent"), color="k", label=f"{name}, compressible water",
            **COMPRESSIBLE)
    ax.plot(Tv, U_settlement, color="tab:blue", lw=1.0,
            label="MPM, from the surface settlement")
    ax.plot(Tv, U_pressure, color="tab:orange", lw=1.0, ls="--",
            label="MPM, from the mean pore pressure (its early swing: the undrained\n"
                  "wave ringing in p after the sudden load, not settlement)")
    ax.set_xscale("log")
    ax.set_xlim(T[0], T[-1])
    ax.set_xlabel("time factor T_v = c_v t / H^2 (-)")
    ax.set_ylabel("degree of consolidation U (-)")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper left")
    return fig


# The scene's own time unit: the run's end in it reads as an engineer would say it.
TIME_UNITS = (("s", 1.0, 2 * 3600.0), ("h", 3600.0, 3 * 86400.0), ("days", 86400.0, np.inf))


def time_unit(t_end: float) -> tuple:
    """(name, seconds) of the unit of a run ending at ``t_end`` (s): seconds up to 2 h,
    hours up to 3 days, days beyond."""
    return next((name, sec) for name, sec, below in TIME_UNITS if t_end < below)


def settlement_time(plt, t, settlement, s0: float, s_inf: float, cv: float, ratio: float,
                    H: float, title: str, degree=None, name: str = "Terzaghi",
                    s0_classic: float = 0.0):
    """The surface settlement (mm, downwards positive) against time (log axis, in the unit
    of :func:`time_unit`): the run's, the classic reference's s0_classic + (s_inf -
    s0_classic) U(T_v) and the compressible water's s0 + (s_inf - s0) U(T_v c2 / c_v), with
    the final settlement s_inf. ``t`` (s), ``settlement``, ``s0``, ``s_inf`` (m), ``cv``
    (m2/s), ``H`` (m); ``degree`` and ``name`` as :func:`consolidation_degree`'s."""
    degree = _degree(degree, ratio)
    t, settlement = np.asarray(t, dtype=float), np.asarray(settlement, dtype=float)
    unit, sec = time_unit(t[-1] if len(t) else 1.0)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    keep = t > 0
    start = t[keep].min() if np.any(keep) else 1e-4
    tt = np.geomspace(start, max(t[-1] if len(t) else 1.0, start * 10), 400)
    Tv = cv * tt / (H * H)
    ax.plot(tt / sec, 1e3 * (s0_classic + (s_inf - s0_classic) * degree(Tv, "classic")),
            color="k", label=f"{name}, classic", **CLASSIC)
    ax.plot(tt / sec, 1e3 * (s0 + (s_inf - s0) * degree(Tv, "consistent")),
            color="k", label=f"{name}, compressible water", **COMPRESSIBLE)
    ax.plot(t[keep] / sec, 1e3 * settlement[keep], color="tab:blue", lw=1.0,
            label="MPM, surface settlement")
    ax.axhline(1e3 * s_inf, color="0.5", lw=0.8, ls="--",
               label=f"final settlement {1e3 * s_inf:.4g} mm")
    _settlement_axes(ax, unit, title)
    ax.set_xlim(tt[0] / sec, tt[-1] / sec)
    return fig


def _settlement_axes(ax, unit: str, title: str) -> None:
    """A settlement-time plot's axes: log time in ``unit``, settlement (mm) downwards."""
    ax.set_xscale("log")
    ax.invert_yaxis()                    # settlement grows downwards, as the ground moves
    ax.set_xlabel(f"time t ({unit})")
    ax.set_ylabel("surface settlement (mm, downwards)")
    ax.set_title(title)
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8, loc="upper right")


def settlement_trough(plt, troughs, extent, ends, title: str, fe=()):
    """The surface settlement (mm, downwards) along x (m) at each report time (``troughs``:
    (T_v, x, s (m)) rows), the loaded part ``extent`` (x0, x1) shaded, the static
    solutions of the undrained and final surface (``ends``: static.Ends, or empty) and the
    FE reference's troughs ``fe`` ((T_v, x, s) rows: dashed, in their T_v's colour)."""
    fig, ax = plt.subplots(figsize=(7, 4.5))
    if extent is not None:
        ax.axvspan(*extent, color="0.9", label="loaded")
    colors = tv_colors(plt, len(troughs))
    by_tv = {Tv: (x, s) for Tv, x, s in fe}
    for (Tv, x, s), col in zip(troughs, colors):
        ax.plot(x, 1e3 * np.asarray(s), "o-", ms=3, lw=1.0, color=col,
                label=f"MPM, T_v = {Tv:g}" if fe else f"T_v = {Tv:g}")
        if Tv in by_tv:
            ax.plot(by_tv[Tv][0], 1e3 * np.asarray(by_tv[Tv][1]), "--", lw=1.2, color=col)
    if by_tv:
        ax.plot([], [], "--", lw=1.2, color="k", label="FE reference, in its T_v's colour")
    if ends:
        ax.plot(ends.x, 1e3 * np.asarray(ends.undrained_top), color="k",
                label="static, undrained", **COMPRESSIBLE)
        ax.plot(ends.x, 1e3 * np.asarray(ends.final_top), color="k", label="static, final",
                **CLASSIC)
    ax.invert_yaxis()                    # settlement grows downwards, as the ground moves
    ax.set_xlabel("x (m)")
    ax.set_ylabel("surface settlement (mm, downwards)")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    return fig


def axis_profiles(plt, snapshots, lines, H: float, title: str, soil=None):
    """The excess pore pressure p / q (-) against height (m) of a column of points at
    each time (``snapshots``: (T_v, heights, p / q) rows; markers in the T_v's colour,
    each named in the legend) and the FE reference's profiles (``lines``: the same rows,
    solid lines in their T_v's colour), up to the height H; the layer interfaces of
    ``soil``."""
    fig, ax = plt.subplots(figsize=(6, 6))
    colors = tv_colors(plt, len(snapshots))
    by_tv = {Tv: (y, p) for Tv, y, p in lines}
    for (Tv, y, p), col in zip(snapshots, colors):
        ax.plot(p, y, "o", ms=3.5, mfc="none", color=col, label=f"T_v = {Tv:g}")
        if Tv in by_tv:
            ax.plot(by_tv[Tv][1], by_tv[Tv][0], color=col, lw=1.0)
    if lines:
        ax.plot([], [], color="k", lw=1.0, label="FE reference")
    ax.plot([], [], "o", ms=3.5, mfc="none", color="k", label="MPM points")
    output.layer_interfaces(ax, soil, label=True)
    ax.set_xlabel("excess pore pressure p / q (-)")
    ax.set_ylabel("height above the base (m)")
    ax.set_ylim(0, H)
    ax.set_xlim(left=min(0.0, *(float(np.min(p)) for _, _, p in snapshots)) if snapshots
                else 0.0)
    ax.grid(alpha=0.3)
    ax.set_title(title, fontsize=10)
    legend_below(ax, ncol=4)
    return fig


def settlement_time_2d(plt, t, axis, mean, x_axis: float, extent, fe, ends, title: str):
    """A scene without a closed form: the settlement (mm, downwards) at the axis x =
    ``x_axis`` (m) and its mean under the load (``extent`` (x0, x1), m; None: the whole
    top) against time (log axis, in the unit of :func:`time_unit`), the run's (``t`` (s),
    ``axis``, ``mean`` (m)) and the FE reference's (``fe``: (t, axis, mean, cells), or
    None), with the static ends of the mean (``ends``: (undrained, final) m, or None)."""
    t, axis, mean = (np.asarray(a, dtype=float) for a in (t, axis, mean))
    keep = t > 0
    unit, sec = time_unit(t[-1] if len(t) else 1.0)
    fig, ax = plt.subplots(figsize=(7, 4.5))
    under = ("the top" if extent is None else f"{extent[0]:g} <= x <= {extent[1]:g} m")
    ax.plot(t[keep] / sec, 1e3 * axis[keep], color="tab:blue", lw=1.0,
            label=f"MPM, at the axis x = {x_axis:g} m")
    ax.plot(t[keep] / sec, 1e3 * mean[keep], color="tab:orange", lw=1.0,
            label=f"MPM, mean under the load ({under})")
    if fe is not None:
        ft, fa, fm, cells = fe
        name = f"FE ({cells[0]} x {cells[1]} Q9/Q4)"
        ax.plot(ft / sec, 1e3 * fa, color="k", marker=".", ms=4,
                label=f"{name}, at the axis", **CLASSIC)
        ax.plot(ft / sec, 1e3 * fm, color="k", marker=".", ms=4,
                label=f"{name}, mean under the load", **COMPRESSIBLE)
    if ends is not None:
        for value, words in zip(ends, ("undrained", "final")):
            ax.axhline(1e3 * value, color="0.5", lw=0.8, ls="--")
            ax.annotate(f"static {words} mean {1e3 * value:.4g} mm", (0.01, 1e3 * value),
                        xycoords=("axes fraction", "data"), fontsize=7, color="0.3",
                        va="bottom")
    _settlement_axes(ax, unit, title)
    return fig


def large_strain(plan, model, history, ref_p, scale=None) -> dict:
    """The large-strain column's figure: the settlement against time (log) beside the small
    strain's and, where the scene is theirs, Xie and Leo's (``history``: t (s), the
    column's, the small strain's and theirs or None (m)); and the excess pore pressure
    against the height before the load at the report times, theirs (``ref_p``, / q, at
    each report time, or None) dotted; the pressures over ``scale`` (Pa, its name: q, or
    p0 under gravity)."""
    scale = scale or (plan.loading.load, "q")
    t, s, small, ref = history
    plt = output.pyplot()
    fig, (a, b) = plt.subplots(1, 2, figsize=(11, 4.2))
    keep = t > 0
    a.semilogx(t[keep], s[keep], "C0-", label="large strain (MPM)")
    a.semilogx(t[keep], small[keep], "C7--", label="small strain (Terzaghi)" if
               plan.loading.gravity == 0 else "small strain (the column's own)")
    if ref is not None:
        a.semilogx(t[keep], ref[keep], "k:", lw=1.6, label="Xie and Leo (2004)")
    a.invert_yaxis()
    a.set_xlabel("t (s)")
    a.set_ylabel("settlement (m)")
    a.grid(alpha=0.3, which="both")
    a.legend(fontsize=8)
    q, name = scale
    colors = tv_colors(plt, len(model.profiles))
    order = np.argsort(model.y0)
    for j, (tv, (_, p), c) in enumerate(zip(plan.reports, model.profiles, colors)):
        b.plot(p[order] / q, model.y0[order], "-", color=c, label=f"T_v = {tv:.4g}")
        if ref_p is not None:
            b.plot(ref_p[j][order], model.y0[order], ":", color="k", lw=1.2)
    b.set_xlabel(f"excess pore pressure / {name}")
    b.set_ylabel("height before the load (m)")
    b.grid(alpha=0.3)
    b.legend(fontsize=8)
    fig.tight_layout()
    return output.save_figures(fig, plan.outputs.folder, "large_strain", plan.outputs.formats)
