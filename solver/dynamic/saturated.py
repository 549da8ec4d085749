"""Two phases in time: the saturated body under a sudden load and/or shaken on a rigid base,
stepped by the explicit v-w step of the consolidation analysis (:class:`TwoPhase`) without
its dampers (no local, bulk or fast-part damping, no mass scaling: the waves are the answer
here), the drag implicit. A base motion is taken in the frame of the base: every mass feels
-a_b(t) (``TwoPhase.step``'s ``base``), and the records add the base's acceleration and
velocity back.

The loop drives it as it drives the one-phase body (:mod:`solver.dynamic.driver`):
the records are the means over the rows of material points (the pore pressure lives on
the points); the solid's acceleration of a sample is its velocity change over the step.
:meth:`SaturatedColumn.references` sets a run under a sudden load beside the references of
:mod:`solver.references.waves`: the front's arrival at each recorded depth (the undrained
speed), the pressure jump B q behind it, and Terzaghi's compressible-water pressure at the
end, once the waves have died.
"""

from __future__ import annotations

import math

import numpy as np

from ..common import signals
from ..stepping import timestep
from ..stepping.scheme import Scheme
from ..stepping.twophase import TwoPhase, point_fields
from ..io import checkpoint
from ..model import scene
from ..model.scene import Loading
from ..references import analytic, waves
from .histories import COLUMNS, StepSpectra, sample_step

SAFETY = 0.5        # of the smallest critical time step, as the consolidation analysis
DIED = 6            # decay times after which the waves count as gone (e^-6: 0.25 %)
RESOLVED = 20       # samples at least before the front reaches the shallowest depth


def plan_resolves(rec, depths, c_u: float) -> bool:
    """Whether the samples resolve the front's arrival at the recorded ``depths`` (m)."""
    return len(rec.t) > 1 and len(depths) and \
        rec.t[1] - rec.t[0] <= min(depths) / c_u / RESOLVED


class SaturatedColumn:
    """The two-phase body of ``plan`` on ``comm`` (see the module's docstring)."""

    water = True
    loops = None            # a linear soil: no stress-strain loops

    def __init__(self, comm, plan):
        signals.stage("set-up: the body")
        self.plan = plan
        self.soil = soil = plan.ground.as_material()
        layered = plan.ground.count > 1
        self.scheme = Scheme.resolve(plan.body.element, {}, 1.0, drag="implicit",
                                     flip="auto")
        self.grid, self.points = scene.two_phase_body(comm, plan.body, soil,
                                                      point_fields(self.scheme, layered))
        self.loading = plan.loading or Loading(load=0.0)
        # The pressure a blow-up is measured against: the load, or the base motion's
        # inertia over the column, rho a_max H.
        a_max = float(np.max(np.abs(plan.motion.acceleration(
            np.linspace(0.0, plan.t_end, 100001)))))
        self.scale = max(self.loading.load, soil.density * a_max * plan.body.height, 1.0)
        self.model = TwoPhase(self.grid, self.points, soil, plan.body, self.loading,
                              self.scheme)
        signals.stage("set-up: the critical time steps")
        limits, _ = timestep.critical_steps(comm, plan.body, soil, self.scheme,
                                             self.grid.h, False, ("jacobi", 1e-15, 50))
        stable = timestep.choose_dt(limits, None, SAFETY)
        self.dt, self.every = sample_step(plan.record_dt, stable)
        self.lag = self.dt          # a sample is of the step's end
        self.mpi = comm.tompi4py()
        y0 = self.points.get("x0")[:, 1]
        self.heights = np.unique(np.round(np.concatenate(self.mpi.allgather(y0)), 12))
        self._rows()
        self.v_before = self.points.get("vs").copy()
        self.spectra = StepSpectra(plan.motion, self.dt, lag=self.dt, frame=True,
                                   psa=plan.psa)

    def _rows(self):
        y0 = self.points.get("x0")[:, 1]
        self.row = np.searchsorted(self.heights, np.round(y0, 12))
        self.count = np.maximum(self.mpi.allreduce(
            np.bincount(self.row, minlength=len(self.heights))), 1)
        # The surface row's points (the records' surface) in the shaking direction.
        self.top = np.flatnonzero(self.row == len(self.heights) - 1)
        self.comp = 0 if self.plan.shaking.direction == "x" else 1

    def step(self, t: float) -> None:
        self.v_before = self.points.get("vs").copy()
        self.t = t
        self.a_b = float(self.plan.motion.acceleration(t))
        base = (self.a_b, 0.0) if self.plan.shaking.direction == "x" else (0.0, self.a_b)
        self.model.step(self.dt, 1.0, 0.0, self.scheme.flip, base)
        dv = self.points.get("vs")[self.top, self.comp] - self.v_before[self.top, self.comp]
        self.spectra.keep(t, float(np.sum(dv)) / (self.dt * self.count[-1]), self.mpi)

    def means(self, t: float) -> np.ndarray:
        """The row means (rows x COLUMNS) at t + dt (the state after the step taken):
        accelerations and velocities absolute (the step runs in the frame of the base)."""
        vs, x, x0, p = self.points.get("vs", "x", "x0", "p")
        a = (vs - self.v_before) / self.dt
        n = len(self.heights)
        sums = np.zeros((n, len(COLUMNS)))
        for col, values in enumerate((a[:, 0], vs[:, 0], x[:, 0] - x0[:, 0],
                                      a[:, 1], vs[:, 1], x[:, 1] - x0[:, 1], p)):
            sums[:, col] = np.bincount(self.row, weights=values, minlength=n)
        out = self.mpi.allreduce(sums) / self.count[:, None]
        comp = 0 if self.plan.shaking.direction == "x" else 3
        out[:, comp] += self.a_b
        out[:, comp + 1] += float(self.plan.motion.velocity(t + self.dt))
        return out

    def check(self, step: int, t: float) -> None:
        self.model.check(step, t, self.scale)

    def state(self) -> dict:
        """The spectra from the steps' state (collective); the points hold the rest."""
        return self.spectra.state(self.mpi)

    def restore(self, ckpt) -> None:
        """Take up the points of a checkpoint (:class:`solver.io.checkpoint.Checkpoint`)."""
        checkpoint.scatter(self.points, self.grid, ckpt, "x0")
        self._rows()
        self.spectra.restore(ckpt.state, ckpt.state["step"])

    def references(self, rec) -> dict:
        """The run beside the saturated column's references (see the module's docstring):
        under a sudden load alone."""
        if self.plan.loading is None or self.plan.motion.form[0] != "none":
            return {}
        s, q, H = self.soil, self.plan.loading.load, self.plan.body.height
        E_c = s.constrained_modulus
        c_u = waves.undrained_speed(E_c, s.K_l, s.porosity, s.rho_s, s.rho_l)
        jump = analytic.undrained_pressure(q, E_c, s.K_l, s.porosity)
        c_fast = waves.phase_speeds(E_c, s.K_l, s.porosity, s.rho_s, s.rho_l, s.k,
                                    math.inf)[0]
        t = np.array(rec.t)
        depths = rec.depths[1:-1] if len(rec.depths) > 2 else rec.depths[-1:]
        arrivals, plateaus = [], []
        for i, depth in enumerate(rec.depths):
            if depth not in depths:
                continue
            p = rec.history("p_pa", i)
            k = int(np.argmax(p >= jump / 2))
            arrivals.append(float(np.interp(jump / 2, p[k - 1:k + 1], t[k - 1:k + 1]))
                            if k > 0 else math.nan)
            # Behind the front, before the wave comes back from the base and the top.
            back = (2 * H - depth) / c_fast
            window = (t > depth / c_u + 0.25 * (back - depth / c_u)) & (t < back)
            plateaus.append(float(np.mean(p[window])) if window.any() else math.nan)
        out = {}
        if plan_resolves(rec, depths, c_u):
            expected = [float(d / c_u) for d in depths]
            out["front"] = {"depths_m": list(map(float, depths)), "arrival_s": arrivals,
                            "undrained_s": expected, "speed_m_s": c_u,
                            "words": ", ".join(f"{d:g} m at {a:.5g} s (undrained {e:.5g} s)"
                                               for d, a, e in zip(depths, arrivals,
                                                                  expected))}
            out["jump"] = {"p_pa": plateaus, "B_q_pa": jump,
                           "words": ", ".join(f"{v:.5g} Pa" for v in plateaus)
                           + f" behind the front (B q = {jump:.5g} Pa)"}
        tau = waves.decay_time(E_c, s.K_l, s.porosity, s.rho_s, s.rho_l, s.k,
                               self.plan.analytic_hz[0])
        if t[-1] >= DIED * tau:
            c2 = analytic.consistent_coefficient(s.k, E_c, s.unit_weight_water, s.K_l,
                                                 s.porosity)
            Tv = c2 * t[-1] / (H * H)
            last = rec.samples[-1][:, COLUMNS.index("p_pa")]
            exact = jump * analytic.column_pressure(H - rec.depths, Tv, H,
                                                    self.plan.body.drained)
            late = float(np.max(np.abs(last - exact)) / q)
            out["late"] = {"Tv": Tv, "error_pct_of_q": 100 * late, "decay_time_s": tau,
                           "words": f"at T_v = {Tv:.4g} the pore pressure within "
                                    f"{100 * late:.3g} % of q of Terzaghi's (compressible "
                                    "water) at the recorded depths"}
        else:
            out["late"] = {"decay_time_s": tau,
                           "words": f"not compared with Terzaghi: the waves lose a factor e "
                                    f"in {tau:.3g} s by drag and have not died by "
                                    f"-mpm_t_end (give {DIED * tau:.3g} s or more)"}
        return out

    def destroy(self):
        scene.destroy(self.model, self.points, self.grid)
