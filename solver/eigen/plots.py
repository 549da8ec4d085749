"""The eigen analysis's figure: the mode shapes like the paper's Figure 2, and how a frequency
is printed and recognised as a rigid-body mode."""

from __future__ import annotations

import numpy as np

from ..io import output
from ..references import analytic, layered

# A mode below this fraction of the rod's first frequency counts as a zero-energy mode.
ZERO_HZ = 1e-3


def rigid(freq, scale) -> np.ndarray:
    """Which of the frequencies ``freq`` (Hz) are rigid-body modes: below ZERO_HZ x ``scale``
    (the rod's first frequency c / 4H, the column's own frequency scale, Hz)."""
    return np.asarray(freq) < ZERO_HZ * scale


def hz(value, width: int = 0) -> str:
    """A frequency (Hz) as printed: at least four significant digits (two decimals from
    10 Hz up), so that a tall column's 0.03387 Hz does not read 0.03; "-" for None."""
    if value is None:
        return f"{'-':>{width}s}"
    v = float(value)
    decimals = 2 if v == 0 or abs(v) >= 10 else 3 - int(np.floor(np.log10(abs(v))))
    return f"{v:{width}.{decimals}f}"


def rod_shapes(ground, nmodes, y) -> np.ndarray:
    """The rod's mode shapes (nmodes x heights, 1 at the top) at heights ``y`` (m)."""
    if ground.count == 1:
        return np.array([analytic.rod_mode(y, ground.height, k + 1) for k in range(nmodes)])
    return layered.rod_modes(ground.thickness, ground.per_layer("constrained_modulus"),
                             ground.per_layer("density"), nmodes, y)


def mode_figure(grid, coords, modes, freqs, rod, ground, scale):
    """Mode shapes like the paper's Figure 2: deformed grids coloured by the displacement
    magnitude (a colour bar: |u| over the mode's largest) and u_y along the column, beside
    the rod's mode where the rod is the scene (``rod`` None: not), of the column of
    ``ground`` (soil.Ground: its layer interfaces are drawn); the caller saves it."""
    plt = output.pyplot()
    nm, H = len(modes), ground.height
    yy = np.linspace(0, H, 200)
    shapes = None
    if rod is not None:        # scaled as the MPM's u_y: the largest |u_y| is 1
        shapes = rod_shapes(ground, nm, yy)
        shapes /= np.abs(shapes).max(axis=1, keepdims=True)
    fig, axes = plt.subplots(2, nm, figsize=(2.2 * nm + 0.8, 7), squeeze=False,
                             gridspec_kw={"height_ratios": [3, 2]})
    W = grid.size[0]
    conn = output.grid_cells(grid)[1]
    corners = conn[:, :4]
    for k, u in enumerate(modes):
        scale_u = 0.25 * max(W, 0.1 * H) / max(np.abs(u).max(), 1e-300)
        xy = coords + scale_u * u
        ax = axes[0, k]
        for cell in corners:
            ring = np.append(cell, cell[0])
            ax.plot(coords[ring, 0], coords[ring, 1], color="0.85", lw=0.6)
            ax.plot(xy[ring, 0], xy[ring, 1], color="tab:blue", lw=0.9)
        mag = np.hypot(u[:, 0], u[:, 1])
        dots = ax.scatter(xy[:, 0], xy[:, 1], c=mag / max(mag.max(), 1e-300), s=6,
                          cmap="viridis", vmin=0.0, vmax=1.0, zorder=3)
        what = "rigid" if rigid(freqs[k], scale) else f"{hz(freqs[k])} Hz"
        ax.set_title(f"mode {k + 1}\n{what}", fontsize=9)
        ax.set_aspect("equal")
        ax.axis("off")
        ax = axes[1, k]
        centre = np.isclose(coords[:, 0], coords[np.argmin(np.abs(coords[:, 0] - W / 2)), 0])
        y = coords[centre, 1]
        order = np.argsort(y)
        uy = u[centre, 1][order]
        ax.plot(uy / max(np.abs(uy).max(), 1e-300), y[order], "o-", ms=3, label="MPM")
        if shapes is not None:
            shape = shapes[k] * (np.sign(np.dot(np.interp(y[order], yy, shapes[k]), uy)) or 1.0)
            ax.plot(shape, yy, "k--", lw=0.8,
                    label=f"rod {hz(rod[k])} Hz" if k < len(rod) else "rod")
        output.layer_interfaces(ax, ground)
        ax.set_xlabel("u_y (normalised)", fontsize=8)
        if k == 0:
            ax.set_ylabel("height y (m)")
        ax.legend(fontsize=6, loc="lower left")
        ax.tick_params(labelsize=7)
    fig.colorbar(dots, ax=list(axes[0]), fraction=0.04, pad=0.02,
                 label="|u| / largest |u| of the mode")
    fig.suptitle(f"Mode shapes, {grid.element.upper()} background grid")
    return fig
