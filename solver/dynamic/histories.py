"""What a dynamic run records: histories at depths, peaks with depth, and what is made of
them (``histories.csv``, ``spectra.csv``, ``peaks.csv``, the summary's ``dynamic`` block).

The records are row means: at each recorded depth the mean over a row of the lattice's
nodes (one phase: the state lives on the nodes) or of material points (two phases: the
pore pressure lives on the points), so that a body of any width records as a column. Each
sample holds, per depth, a_x, v_x, u_x, a_y, v_y, u_y (m/s2, m/s, m: accelerations and
velocities absolute, displacements relative to the base) and p (Pa, the excess pore
pressure; NaN without water). Peaks over time are kept for every row (peaks.csv), the
full histories only at the recorded depths. (The strain of a row is that of the interval
below it; the shear strain du_x/dy of x shaking, the axial du_y/dy of y.)
"""

from __future__ import annotations

import math

import numpy as np

from ..io import output
from ..references import site, spectra

COLUMNS = ("a_x", "v_x", "u_x", "a_y", "v_y", "u_y", "p_pa")
PERIODS = np.logspace(-2, 1, 100)     # the pseudo-spectral accelerations' by default (s)
F_MAX = 50.0                               # highest frequency written to spectra.csv (Hz)
PEAK_BAND = 0.01        # resonances are sought where the input has 1 % of its peak amplitude
PROMINENCE = 0.1        # and stand 10 % above the trough beside them


def sample_step(record_dt: float, stable: float) -> tuple:
    """(dt, steps per sample): the largest step at most ``stable`` (s) that divides the
    record interval ``record_dt`` (s), so that every sample falls on a step."""
    every = max(1, math.ceil(record_dt / stable - 1e-9))
    return record_dt / every, every


def record_rows(heights, H: float, depths) -> tuple:
    """(the rows recorded, their depths (m)): the surface, the row nearest each depth of
    ``depths`` (m below the surface) and the base, each once, from the surface down;
    ``heights`` (m, ascending) are the rows' heights above the base."""
    heights = np.asarray(heights, dtype=float)
    wanted = [H] + [H - d for d in depths] + [0.0]
    rows = sorted({int(np.argmin(np.abs(heights - y))) for y in wanted}, reverse=True)
    return np.array(rows), H - heights[rows]


class Recorder:
    """Samples of the row means (:meth:`sample`) at the recorded rows and the running peaks
    of every row: |a| in the shaking direction (m/s2), the strain between neighbouring rows
    (shear du_x/dy for x shaking, axial du_y/dy for y) and the excess pore pressure (Pa)."""

    def __init__(self, heights, H: float, depths, direction: str):
        self.heights = np.asarray(heights, dtype=float)
        self.rows, self.depths = record_rows(self.heights, H, depths)
        self.comp = 0 if direction == "x" else 1
        n = len(self.heights)
        self.t, self.samples = [], []
        self.peak_a, self.peak_p = np.zeros(n), np.zeros(n)
        self.peak_v, self.peak_u = np.zeros(n), np.zeros(n)
        self.peak_strain = np.zeros(max(n - 1, 0))

    def sample(self, t: float, means: np.ndarray) -> None:
        """Add the sample at t (s) of ``means`` (rows x COLUMNS, every row)."""
        self.t.append(float(t))
        self.samples.append(means[self.rows].copy())
        np.maximum(self.peak_a, np.abs(means[:, 3 * self.comp]), out=self.peak_a)
        np.maximum(self.peak_v, np.abs(means[:, 3 * self.comp + 1]), out=self.peak_v)
        u = means[:, 3 * self.comp + 2]
        np.maximum(self.peak_u, np.abs(u), out=self.peak_u)
        np.maximum(self.peak_strain, np.abs(np.diff(u) / np.diff(self.heights)),
                   out=self.peak_strain)
        p = np.nan_to_num(means[:, 6])
        np.maximum(self.peak_p, np.abs(p), out=self.peak_p)

    def history(self, column: str, at: int = 0) -> np.ndarray:
        """The history of ``column`` at recorded row ``at`` (0: the surface, -1: the base)."""
        return np.array([s[at, COLUMNS.index(column)] for s in self.samples])

    def to_dict(self) -> dict:
        return {"t": self.t, "samples": [s.tolist() for s in self.samples],
                "peak_a": self.peak_a, "peak_p": self.peak_p, "peak_strain": self.peak_strain,
                "peak_v": self.peak_v, "peak_u": self.peak_u}

    def restore(self, d: dict) -> None:
        self.t = list(d["t"])
        self.samples = [np.array(s, dtype=float) for s in d["samples"]]
        for name in ("peak_a", "peak_p", "peak_strain", "peak_v", "peak_u"):
            # A checkpoint of an earlier version has no peak_v, peak_u: from the restart on.
            setattr(self, name, np.array(d.get(name, np.zeros(len(self.heights))),
                                         dtype=float))


class Loops:
    """The stress-strain loops of a hysteretic soil at the recorded depths and the peak
    stress of every interval between node rows, from its points (``forces``:
    :class:`solver.stepping.pointforces.PointForces`): at each sample the mean strain and
    stress of the points of an interval (shear gamma_xy and tau_xy for x shaking, axial
    eps_yy and sigma_yy for y), recorded for the interval above each recorded row (ending
    at its depth: at an interface, the upper layer's base; the surface: the one below it).
    Strains and stresses are the points' own: the peak stress of an interval sits beside
    the strain of peaks.csv, of the row above it."""

    def __init__(self, forces, heights, H: float, depths, mpi, direction: str = "x"):
        self.forces, self.mpi = forces, mpi
        heights = np.asarray(heights, dtype=float)
        rows, self.depths = record_rows(heights, H, depths)
        n = len(heights) - 1
        self.interval = np.clip(np.searchsorted(heights, forces.x[:, 1]) - 1, 0, n - 1)
        self.picked = np.minimum(rows, n - 1)
        self.count = np.maximum(mpi.allreduce(np.bincount(self.interval, minlength=n)), 1)
        self.comp = (2, 3) if direction == "x" else (1, 1)   # (strain, stress) columns
        self.t, self.samples = [], []
        self.peak_stress = np.zeros(n)

    def sample(self, t: float) -> None:
        """The loops' points and the peaks at t (s): the points' state (collective)."""
        f, n = self.forces, len(self.count)
        sums = np.stack([np.bincount(self.interval, weights=f.strain[:, self.comp[0]],
                                     minlength=n),
                         np.bincount(self.interval, weights=f.stress[:, self.comp[1]],
                                     minlength=n)])
        means = self.mpi.allreduce(sums) / self.count
        np.maximum(self.peak_stress, np.abs(means[1]), out=self.peak_stress)
        self.t.append(float(t))
        self.samples.append(means[:, self.picked].T.copy())

    def history(self, at: int) -> np.ndarray:
        """(samples, 2): strain (-) and stress (Pa) of recorded depth ``at``."""
        return np.array([s[at] for s in self.samples])

    def to_dict(self) -> dict:
        return {"t": self.t, "samples": [s.tolist() for s in self.samples],
                "peak_stress": self.peak_stress}

    def restore(self, d: dict) -> None:
        self.t = list(d["t"])
        self.samples = [np.array(s, dtype=float) for s in d["samples"]]
        self.peak_stress = np.array(d["peak_stress"], dtype=float)


def write_loops(path, loops: Loops, kind: str) -> None:
    """loops.csv (long format): t_s, depth_m, the interval's mean strain and stress."""
    lines = [f"t_s,depth_m,{kind}_strain,{kind}_stress_pa"]
    for t, s in zip(loops.t, loops.samples):
        for depth, (g, tau) in zip(loops.depths, s):
            lines.append(f"{t:.10g},{depth:.6g},{g:.10e},{tau:.10e}")
    output.write_text(path, "\n".join(lines) + "\n")


class StepSpectra:
    """The pseudo-spectral accelerations (PERIODS, 5 %) of the recorded depths (the surface
    first) and of the input from every step, not from the records: at the default
    -mpm_record_dt (0.005 s) an oscillator of 0.01 s sees two samples a period, and what
    the surface does between the samples is lost (the samples' PSA was 0.92 % off on the
    uniform layer under a Ricker, 4.4 % on the 30 m deposit's record; docs/method.md). The
    engine gives each step's acceleration in the shaking direction at ``depths`` rows, this
    rank's share of each row mean (:meth:`keep`); the oscillators
    (:class:`spectra.Oscillators`) take the steps up in pieces of at most CHUNK steps, at a
    checkpoint and at the end (collective), so that memory stays CHUNK floats a depth and a
    checkpoint stores their state (five numbers a period), not the history.

    The value of the step from t (s) is of t + ``lag`` (the engine's samples'); the
    motion's acceleration at t is added to it where the engine steps in the frame of the
    base (``frame``), and the input is the motion's acceleration at t + lag."""

    CHUNK = 1 << 16

    def __init__(self, motion, dt: float, lag: float = 0.0, frame: bool = False,
                 psa=(PERIODS, 0.05), depths: int = 1):
        self.motion, self.dt, self.lag, self.frame = motion, dt, lag, frame
        self.values = np.zeros((self.CHUNK, depths))
        self.fed = self.done = 0          # steps the oscillators have, steps kept
        self.rows = [spectra.Oscillators(psa[0], dt, psa[1]) for _ in range(depths)]
        self.input = spectra.Oscillators(psa[0], dt, psa[1])
        self.lost = False                 # restarted from a checkpoint without them

    @property
    def surface(self):
        return self.rows[0]

    def keep(self, t: float, value, mpi) -> None:
        """The step from t (s): ``value`` (m/s2) this rank's share of each recorded row's
        mean, the surface first (the ranks' shares sum to it). Collective every CHUNK
        steps."""
        j = int(round(t / self.dt))
        if j - self.fed >= self.CHUNK:
            self._take_up(mpi)
        self.values[j - self.fed] = value
        self.done = j + 1

    def _take_up(self, mpi) -> None:
        new = mpi.allreduce(self.values[:self.done - self.fed])
        t = np.arange(self.fed, self.done) * self.dt
        if self.frame:
            new = new + self.motion.acceleration(t)[:, None]
        for i, row in enumerate(self.rows):
            row.feed(new[:, i])
        self.input.feed(self.motion.acceleration(t + self.lag))
        self.fed = self.done

    def psa(self, mpi):
        """(input, surface) PSA (m/s2) over PERIODS of every step kept (collective), or None
        after a restart from a checkpoint that had not kept them."""
        self._take_up(mpi)
        return None if self.lost else (self.input.psa, self.surface.psa)

    def at_depths(self, mpi):
        """The PSA (m/s2) of every recorded row (rows, periods), the surface first
        (collective), or None (as :meth:`psa`)."""
        self._take_up(mpi)
        return None if self.lost else np.array([row.psa for row in self.rows])

    def state(self, mpi) -> dict:
        """What a checkpoint keeps of them (collective)."""
        self._take_up(mpi)
        return {"psa": {"steps": self.fed, "surface": self.surface.state(),
                        "depths": [row.state() for row in self.rows[1:]],
                        "input": self.input.state(), "lost": self.lost}}

    def restore(self, state: dict, steps: int) -> None:
        """Go on after ``steps`` steps from a checkpoint's ``state``."""
        self.fed = self.done = steps
        d = state.get("psa")
        self.lost = d is None or d["lost"] or d["steps"] != steps or \
            len(d.get("depths", ())) != len(self.rows) - 1
        if not self.lost:
            for row, kept in zip(self.rows, [d["surface"]] + d["depths"]):
                row.restore(kept)
            self.input.restore(d["input"])


def write_histories(path, rec: Recorder, water: bool) -> None:
    """histories.csv: one row per time and recorded depth (long format)."""
    cols = COLUMNS if water else COLUMNS[:-1]
    lines = ["t_s,depth_m," + ",".join(cols)]
    for t, s in zip(rec.t, rec.samples):
        for depth, values in zip(rec.depths, s):
            # 11 digits: two runs that agree to 1e-10 (other rank counts) show it.
            lines.append(f"{t:.10g},{depth:.6g}," + ",".join(f"{v:.10e}" for v in
                                                            values[:len(cols)]))
    output.write_text(path, "\n".join(lines) + "\n")


def write_peaks(path, rec: Recorder, H: float, water: bool, modulus=None,
                stress=None) -> None:
    """peaks.csv: the peaks over time with depth, one row per row of nodes or points from
    the surface down: |a|, |v| and |u| (relative to the base) in the shaking direction,
    the strain of the interval below the row (none at the base), in % too, the stress it
    carries there (``stress`` (Pa) of each interval, the points' peak (a hysteretic
    soil), else ``modulus`` (Pa) of each interval times the strain: the soil is linear)
    and, with water, the excess pore pressure."""
    kind = "shear" if rec.comp == 0 else "axial"
    head = (f"depth_m,peak_a_m_s2,peak_v_m_s,peak_u_rel_m,peak_strain,peak_{kind}_strain_pct,"
            f"peak_{kind}_stress_pa" + (",peak_p_pa" if water else ""))
    lines = [head]
    for k in range(len(rec.heights) - 1, -1, -1):
        s = rec.peak_strain[k - 1] if k > 0 else math.nan
        tau = math.nan if k == 0 else (stress[k - 1] if stress is not None else
                                       s * modulus[k - 1] if modulus is not None
                                       else math.nan)
        row = (f"{H - rec.heights[k]:.6g},{rec.peak_a[k]:.6e},{rec.peak_v[k]:.6e},"
               f"{rec.peak_u[k]:.6e},{s:.6e},{100 * s:.6e},{tau:.6e}")
        lines.append(row + (f",{rec.peak_p[k]:.6e}" if water else ""))
    output.write_text(path, "\n".join(lines) + "\n")


def padded(samples: int) -> int:
    """The transforms' length: a power of two at least four times the samples."""
    return 1 << max(1, math.ceil(math.log2(4 * samples)))


def spectral(rec: Recorder, a_in: np.ndarray, psa=None, oscillators=(PERIODS, 0.05)) -> dict:
    """The spectra of the surface against the input ``a_in`` (m/s2, at the sample times):
    Fourier amplitudes, the transfer function (raw and Konno-Ohmachi smoothed) up to
    F_MAX where the input has energy, its first three peaks, and the PSA of the
    ``oscillators`` (periods (s), damping ratio): ``psa`` (input, surface) where given
    (:meth:`StepSpectra.psa`, from every step), else from the samples."""
    dt = rec.t[1] - rec.t[0]
    surface = rec.history(COLUMNS[3 * rec.comp])
    n = padded(len(surface))
    f, A_in = spectra.fourier_amplitude(a_in, dt, n)
    _, A_top = spectra.fourier_amplitude(surface, dt, n)
    band = (f > 0) & (f <= F_MAX) & (A_in > 1e-3 * np.max(A_in))
    f, A_in, A_top = f[band], A_in[band], A_top[band]
    ratio = A_top / A_in
    s_in, s_top = spectra.konno_ohmachi(f, np.stack([A_in, A_top]))
    smooth = s_top / s_in
    strong = A_in > PEAK_BAND * np.max(A_in)
    periods, damping = oscillators
    if psa is None:
        psa = (spectra.pseudo_acceleration(a_in, dt, periods, damping),
               spectra.pseudo_acceleration(surface, dt, periods, damping))
    return {"f": f, "input": A_in, "surface": A_top, "transfer": ratio, "smoothed": smooth,
            "peaks": resonances(f[strong], ratio[strong], smooth[strong]),
            "periods": np.asarray(periods), "psa_damping": damping,
            "psa_input": psa[0], "psa_surface": psa[1]}


def at_depths(rec: Recorder, a_in: np.ndarray, spec: dict, psa=None) -> dict:
    """The spectra of every recorded depth (the surface first) beside the input's: their
    Fourier amplitudes (m/s, from the samples, at the frequencies of ``spec``, the
    surface's :func:`spectral`) and PSA (m/s2, at its periods and damping): ``psa`` (rows,
    periods) from every step where given (:meth:`StepSpectra.at_depths`), else from the
    samples."""
    dt = rec.t[1] - rec.t[0]
    name = COLUMNS[3 * rec.comp]
    n = padded(len(rec.t))
    f_all = np.fft.rfftfreq(n, dt)
    keep = np.isin(f_all, spec["f"])
    fourier, own = [], []
    for i in range(len(rec.depths)):
        a = rec.history(name, i)
        fourier.append(spectra.fourier_amplitude(a, dt, n)[1][keep])
        if psa is None:
            own.append(spectra.pseudo_acceleration(a, dt, spec["periods"],
                                                   spec["psa_damping"]))
    return {"depths": rec.depths, "f": spec["f"], "input": spec["input"],
            "fourier": np.array(fourier), "periods": spec["periods"],
            "psa_input": spec["psa_input"],
            "psa": np.asarray(psa) if psa is not None else np.array(own)}


def write_at_depths(path, d: dict) -> None:
    """spectra_depths.csv (long format): ``fourier`` rows (x: f in Hz; the depth's Fourier
    amplitude in m/s and its ratio to the input's), then ``psa`` rows (x: the period in s;
    the depth's PSA in m/s2 and its ratio to the input's), each for every recorded depth
    (m below the surface)."""
    lines = ["kind,depth_m,x,value,over_input"]
    for i, depth in enumerate(d["depths"]):
        for f, a, ref in zip(d["f"], d["fourier"][i], d["input"]):
            lines.append(f"fourier,{depth:.6g},{f:.6e},{a:.6e},{a / ref:.6e}")
    for i, depth in enumerate(d["depths"]):
        for T, a, ref in zip(d["periods"], d["psa"][i], d["psa_input"]):
            lines.append(f"psa,{depth:.6g},{T:.6e},{a:.6e},"
                         f"{a / ref if ref else math.nan:.6e}")
    output.write_text(path, "\n".join(lines) + "\n")


def resonances(f, raw, smooth, count: int = 3) -> np.ndarray:
    """The frequencies (Hz) of the first ``count`` resonances: the maxima of the raw
    transfer function ``raw`` (refined by a parabola, :func:`site.peaks`) at the maxima of
    the smoothed one ``smooth`` that stand PROMINENCE above the lower of the minima beside
    them, the higher of the two (the raw ratio of two spectra has spurious maxima; the
    smoothed one is biased by its window)."""
    out = []
    top = np.flatnonzero((smooth[1:-1] > smooth[:-2]) & (smooth[1:-1] >= smooth[2:])) + 1
    for k in top:
        if smooth[k] < (1 + PROMINENCE) * max(np.min(smooth[:k + 1]), np.min(smooth[k:])):
            continue
        # The raw maximum within the smoothed peak's half width.
        near = np.flatnonzero(np.abs(np.log(f / f[k])) < 0.15)
        j = near[np.argmax(raw[near])]
        refined = site.peaks(f[j - 1:j + 2], raw[j - 1:j + 2], 1) if 0 < j < len(f) - 1 \
            else ()
        out.append(refined[0] if len(refined) else f[j])
        if len(out) == count:
            break
    return np.array(out)


def write_spectra(path, spec: dict) -> None:
    """spectra.csv (long format): ``fourier`` rows (x: f in Hz; input and surface Fourier
    amplitudes in m/s; their ratio, the transfer function, raw and smoothed), then ``psa``
    rows (x: the period in s; input and surface PSA in m/s2 at -mpm_psa_damping; their
    ratio)."""
    # The ratio's column is named for what it holds in both kinds of rows: the transfer
    # function in the fourier rows, the PSA ratio in the psa rows.
    lines = ["kind,x,input,surface,surface_over_input,surface_over_input_smoothed"]
    for row in zip(spec["f"], spec["input"], spec["surface"], spec["transfer"],
                   spec["smoothed"]):
        lines.append("fourier," + ",".join(f"{v:.6e}" for v in row))
    for T, a, b in zip(spec["periods"], spec["psa_input"], spec["psa_surface"]):
        lines.append(f"psa,{T:.6e},{a:.6e},{b:.6e},{b / a if a else math.nan:.6e},")
    output.write_text(path, "\n".join(lines) + "\n")
