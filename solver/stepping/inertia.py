"""How much inertia a consolidation scene carries, and mass scaling (``-mpm_mass_scaling``).

Consolidation is quasi-static; the v-w scheme is dynamic. Two time scales meet:
- the period T_w of the slowest wave that a sudden load excites (``slowest_period``):
  - in a laterally uniform column (rollers on both sides, drained through the top or the
    base, the load over the whole top) the undrained compression wave, T_w = 4 H / c1;
  - in any other body (a strip footing, drainage through a side, other supports) the body's
    lowest mode, T_w = 1 / f1, f1 that of the drained skeleton with the saturated density
    (an eigen solve of the body). A partial load sets the skeleton's shear and compression
    going under and beside it: modes far slower than 4H/c1, since the water stiffens only
    the volume change (the strip footing of cases/consolidation-strip.opts: 22 Hz
    undrained, 16.9 Hz drained, against 108 Hz for 4H/c1). The water's stiffness adds to
    every mode's, so each undrained mode lies at or above f1, and a body that drains within
    a period vibrates at the drained modes themselves;
- the consolidation time, T_c = H^2 / c2 (c2: diffusivity with compressible water);
and their ratio Pi = T_c / T_w (a column: H c1 / (4 c2)) says how much inertia matters (the
paper's column: Pi = 435). Scaling both phases' densities in the inertia by S (not the drag,
not the weight) leaves c2 and the quasi-static solution as they are and gives
T_w,S = T_w sqrt(S), Pi_S = Pi / sqrt(S): S > 1 makes slow scenes feasible, S < 1 makes
fast ones accurate.

Two inertia errors at the earliest report time t_r (tau_r = c2 t_r / H^2), in units of q:
- the wave (:mod:`solver.stepping.waves`). The sudden load sets the body's undrained modes
  swinging about its undrained state, each by what it holds of that state; at t_r each
  has decayed by its own rate under the step's damping, and the estimate is the largest
  sum of what is left, over the points (``load_swings``, ``_wave_error``). Measured
  against the same runs with S / 100 (docs/studies.md, "The inertia estimate"), it bounds
  the effect within a factor of 10 on columns, laterally drained blocks and strip
  footings. Without the body's modes (a closed form for a column) it takes one mode of
  amplitude q at the slowest wave's period, which decays per damped period T_d by r:
  - local damping alpha turns a free oscillation into quarter-periods of stiffness
    (1 + alpha) k outwards and (1 - alpha) k back: r = (1 - alpha) / (1 + alpha) exactly
    (a single mode), T_d = T_w (1 / sqrt(1 + alpha) + 1 / sqrt(1 - alpha)) / 2;
  - fast-part damping zeta (-mpm_fast_damping; rate c = 2 zeta w1 on v - v_slow, v_slow
    low-passed at w1 = 2 pi / T_w, the scaled slowest wave's: the damper is tuned to it,
    ``twophase``): the slowest mode x'' = -w1^2 x - c (x' - s),
    s' = w1 (x' - s) has the characteristic equation (lambda^2 + w1^2)(lambda + w1)
    + c lambda^2 = 0, whose complex pair gives r = exp(2 pi Re / Im) and T_d = 2 pi / Im
    (zeta = 0.5: r = 0.36, T_d = 1.34 T_w). A mode at w > w1 decays faster in time (rate
    0.12 w1 at w1, 0.25 w1 at 1.5 w1, towards zeta w1); one below w1 hardly at all: the
    filter passes it and the damper acts as an added mass 2 zeta (tuned to 4H/c1, the strip
    footing's 22 Hz mode became 16 Hz and kept swinging);
  - both: the product of the two r, the local T_d;
- the drag lag. The relative velocity relaxes to Darcy's at the rate lambda_S = lambda / S
  (``Soil.drag_rate``): the flow, hence p, lags the quasi-static one by about 1/lambda_S,
  an error of about LAG / (lambda_S t_r) = LAG S / (lambda t_r). LAG = 2 is measured: on the
  paper's column (Pi = 435) S = 10.7 moved p at T_v = 0.1 by 0.34 % of q, 1.7 times the
  bare 1 / (lambda_S t_r) (the larger step that S allows adds to it). (lambda T_c is a
  material constant times Pi^2, so this too is a function of Pi_S.) On a body (drained
  through its sides, or under a strip) the lag is larger: LAG_BODY = 6.5, measured on the
  laterally drained block of docs/studies.md ("The inertia estimate": p moved by 0.065 %
  of q at S = 1 and 0.263 % at S = 4 against S = 0.01 at T_dr 0.2, 6.3 and 6.4 times the
  bare estimate).
A third bound is measured, not derived: a slow residual oscillation outlives the wave
estimate. On the stiff column (cases/consolidation-stiff.opts, 1 x 40 Q4 cells) p at T_v = 1
was off by 0.17 % of q (1.7 % of p) with Pi_S = 80; on the paper's column p at T_v = 0.1
moved by 0.33, 0.10, 0.04 and 0.01 % of q with Pi_S = 200, 250, 300 and 400 (against
Pi_S = 435), so ``auto`` also keeps Pi_S >= PI_MIN = 300 on a column (NaN ``period``). On a
body the modal estimate and LAG_BODY bound the effect without it (the block: the floor
took S = 0.137 where S = 1 moved p by 0.065 % of q).
``auto`` takes the largest S with both estimates at most TOLERANCE and Pi_S >= PI_MIN
(the wave's by bisection in S over the body's modes; the closed form's is
t_r / T_d >= ln(1 / TOLERANCE) / ln(1 / r)) and S <= TOLERANCE lambda t_r / LAG.
Measured (tests/test_inertia.py, docs/studies.md, scripts/strip-inertia --bound): the modal
estimate over the effect against S / 100, at its first report, 1.3 on the paper's column at
S = 10, 5.2 on the laterally drained block at S = 1 (the closed form said 34 % of q there,
60 times the 0.58 % measured), 5.9 on the strip footing at S = 0.1.
``auto`` depends on the earliest report time: reported later, a run gets a larger S; since
the bound holds at every later time, the answer at any report moves by less than twice
TOLERANCE when the report times move (the strip at T_v = 0.05 and 0.1: 4 digits).
A run warns when either estimate exceeds VISIBLE at its own S.
"""

from __future__ import annotations

import math

import numpy as np

from ..common.errors import InputError
from ..modal import frequency
from . import timestep, waves

TOLERANCE = 0.002   # inertia error that -mpm_mass_scaling auto allows (fraction of q)
VISIBLE = 0.01      # inertia error that biases a comparison with Terzaghi visibly
LAG = 2.0           # measured drag-lag error over the bare 1 / (lambda_S t_r), columns
LAG_BODY = 6.5      # the same on bodies (the laterally drained block)
PI_MIN = 300.0      # measured: Pi_S below which a residual oscillation exceeds 0.05 % of q
MAX_STEPS = 1e8     # steps of a run that finishes (about a day at 1 ms per step)


def decay(alpha: float, zeta: float) -> tuple:
    """(r, T_d / T_w): amplitude factor per damped period of the fundamental mode, and that
    period over the undamped one, under local damping ``alpha`` and fast-part damping
    ``zeta`` (module docstring)."""
    r, stretch = 1.0, 1.0
    if zeta > 0:
        # In units of w1: (l^2 + 1)(l + 1) + 2 zeta l^2 = l^3 + (1 + 2 zeta) l^2 + l + 1.
        pair = max(np.roots([1.0, 1.0 + 2 * zeta, 1.0, 1.0]), key=lambda z: abs(z.imag))
        r, stretch = math.exp(2 * math.pi * pair.real / abs(pair.imag)), 1 / abs(pair.imag)
    if alpha > 0:
        r *= (1 - alpha) / (1 + alpha)
        stretch = (1 / math.sqrt(1 + alpha) + 1 / math.sqrt(1 - alpha)) / 2
    return r, stretch


def laterally_uniform(body, loading) -> bool:
    """Whether the scene is a column that moves in y alone: rollers on both sides, the water
    out through the top or the base only, a load (if any) over the whole top. A sudden load
    then excites the undrained compression wave alone."""
    bcs = body.supports
    return (bcs.get("left") == "x" and bcs.get("right") == "x"
            and set(body.drained) <= {"top", "bottom"} and not loading.partial(body.size[0]))


def slowest_period(comm, body, soil, loading) -> float:
    """The period (s, physical inertia) of the slowest wave the scene carries, to which
    ``auto`` and the fast-part damper are tuned: NaN for a laterally uniform column (its
    undrained compression wave 4H/c1); else 1/f1, f1 (Hz) the lowest mode of the body's
    drained skeleton with the saturated density (SLEPc). The water only stiffens the
    skeleton, so every undrained mode, shear or compression, lies at or above f1, and a
    body that drains within a period vibrates at the drained modes themselves (collective)."""
    if laterally_uniform(body, loading):
        return math.nan
    # SLEPc: its shift-invert about 0 factors K alone, so one point per cell (a singular
    # consistent mass, where Jacobi fails) is no obstacle. 6 digits: the last ones of an
    # iterative solve vary with the number of ranks, and S and the damper should not.
    return float(f"{1.0 / frequency.fundamental_frequency(comm, body, soil, 'slepc'):.6g}")


def _times(soil, H: float, first_tv: float, period: float = math.nan):
    """(T, T_c, t_r): the slowest wave's period (``period``, or NaN for the column's
    undrained 4H/c1), the consolidation time H^2 / c2 and the earliest report time (s) of
    a body of height H (m) reported first at T_v = ``first_tv``."""
    s = soil.wave_speeds()
    T = 4 * H / s["c1"] if math.isnan(period) else period
    return T, H * H / s["c2"], first_tv * H * H / soil.c_v


def _shear_period(soil, H: float) -> float:
    """4 H / c_s (s): the period of a shear wave across the layers (their travel times),
    c_s = sqrt(G / rho) with the saturated density."""
    layers = soil.soils
    depths = getattr(soil, "thickness", (H,))
    return 4 * sum(d * math.sqrt(s.density * 2 * (1 + s.nu) / s.E)
                   for d, s in zip(depths, layers))


def load_swings(comm, body, soil, loading):
    """The undrained modes the scene's load excites (:func:`waves.swings`), computed on
    rank 0 and shared (collective)."""
    sw = waves.swings(body, soil, loading) if comm.getRank() == 0 else None
    return comm.tompi4py().bcast(sw, root=0)


def _wave_error(soil, H, first_tv, alpha, zeta, S, period, swings) -> float:
    """The wave estimate at the earliest report (fraction of q): the swings of the
    body's undrained modes left then (:func:`waves.left`), or without them the closed form
    r^(t_r / T_d) of one mode of amplitude q at the slowest wave's period."""
    T_w, _, t_r = _times(soil, H, first_tv, period)
    if swings is not None:
        return waves.left(swings, t_r, S, alpha, zeta, 2 * math.pi / T_w)
    r, stretch = decay(alpha, zeta)
    return r ** (t_r / (T_w * math.sqrt(S) * stretch))


def regime(soil, H: float, first_tv: float, alpha: float, zeta: float,
           S: float = 1.0, period: float = math.nan, swings=None) -> dict:
    """The inertia regime of a body of ``soil``, height H (m), first reported at T_v
    ``first_tv``, under local damping ``alpha`` and fast-part damping ``zeta``, with mass
    scaling S; ``period`` the slowest wave's period (s, :func:`slowest_period`; NaN: the
    column's 4H/c1), ``swings`` the modes the load excites (:func:`load_swings`; None:
    the closed form): time scales (s), Pi, Pi_S, the wave periods before the earliest
    report, both error estimates (fractions of q)."""
    T_w, T_c, t_r = _times(soil, H, first_tv, period)
    Pi = T_c / T_w
    r, stretch = decay(alpha, zeta)
    periods = t_r / (T_w * math.sqrt(S) * stretch)
    speeds = soil.wave_speeds()
    column = math.isnan(period)
    return {"wave": "undrained compression 4H/c1" if column else "the body's lowest mode 1/f1",
            "wave_period_s": T_w, "undrained_period_s": 4 * H / speeds["c1"],
            "drained_period_s": 4 * H / speeds["c"], "shear_period_s": _shear_period(soil, H),
            "consolidation_time_s": T_c, "Pi": Pi,
            "mass_scaling": S, "Pi_S": Pi / math.sqrt(S), "wave_period_scaled_s":
            T_w * math.sqrt(S), "first_report_Tv": first_tv, "first_report_s": t_r,
            "periods_to_first_report": periods,
            "wave_error": _wave_error(soil, H, first_tv, alpha, zeta, S, period, swings),
            "wave_estimate": "modal" if swings is not None else "closed form",
            "drag_lag_error": _lag(period) * S / (soil.drag_rate() * t_r),
            "tolerance": TOLERANCE, "visible": VISIBLE,
            "Pi_S_min": PI_MIN if column else 0.0,
            "criterion": "wave error (the swings of the undrained modes the load excites, "
                         "each decayed under the local or fast-part damping; without them "
                         "r^(t_r / T_d) of the slowest wave's mode) and drag lag "
                         f"{_lag(period):g} S / (lambda t_r) at the earliest report time t_r, "
                         "in units of q"}


def auto_factor(soil, H: float, first_tv: float, alpha: float, zeta: float,
                period: float = math.nan, swings=None) -> float:
    """The largest S whose two inertia errors stay within TOLERANCE (module docstring);
    arguments as :func:`regime`'s."""
    r, stretch = decay(alpha, zeta)
    if r >= 1:
        raise InputError("-mpm_mass_scaling auto: needs damping (-mpm_fast_damping or "
                         "-mpm_damping > 0), without which the undrained wave does not decay; "
                         "give a factor S")
    T_w, T_c, t_r = _times(soil, H, first_tv, period)
    if swings is None:
        periods = math.log(1 / TOLERANCE) / math.log(1 / r)
        wave = (t_r / (T_w * stretch * periods)) ** 2   # t_r is `periods` periods
    else:
        wave = _largest_within(lambda S: _wave_error(soil, H, first_tv, alpha, zeta, S,
                                                     period, swings))
    drag = TOLERANCE * soil.drag_rate() * t_r / _lag(period)
    floor = (T_c / T_w / PI_MIN) ** 2 if math.isnan(period) else math.inf
    return float(f"{min(wave, drag, floor):.3g}")   # 3 digits: the same on every rank count


def _lag(period: float) -> float:
    """The drag lag's factor: LAG on a column (NaN ``period``), LAG_BODY on a body."""
    return LAG if math.isnan(period) else LAG_BODY


def _largest_within(error, lo: float = 1e-12, hi: float = 1e12) -> float:
    """The largest S in [lo, hi] with error(S) <= TOLERANCE (error grows with S: slower
    waves have had fewer periods), by bisection in log S to 0.1 %."""
    if error(hi) <= TOLERANCE:
        return hi
    if error(lo) > TOLERANCE:
        return lo
    while hi / lo > 1.001:
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if error(mid) <= TOLERANCE else (lo, mid)
    return lo


def scaling(choice: str, soil, H: float, first_tv: float, alpha: float, zeta: float,
            period: float = math.nan, swings=None) -> float:
    """The factor S of ``-mpm_mass_scaling`` ``choice`` (none: 1; auto: :func:`auto_factor`
    with the other arguments; else the number)."""
    if choice == "none":
        return 1.0
    if choice == "auto":
        return auto_factor(soil, H, first_tv, alpha, zeta, period, swings)
    return float(choice)


def warning(reg: dict):
    """A warning line when inertia visibly biases the comparison at the earliest report
    time (either estimate above VISIBLE), else None."""
    worst = max(reg["wave_error"], reg["drag_lag_error"])
    if worst <= VISIBLE:
        return None
    what = (reg["wave"] if reg["wave_error"] >= reg["drag_lag_error"] else "the drag lag")
    return (f"WARNING: inertia biases p at T_v = {reg['first_report_Tv']:g} by about "
            f"{100 * worst:.2g} % of q ({what}: {reg['periods_to_first_report']:.3g} wave "
            f"periods by then, Pi_S = {reg['Pi_S']:.3g}); -mpm_mass_scaling auto keeps it "
            f"within {100 * TOLERANCE:g} %")


def describe(reg: dict) -> str:
    """Lines for the run's banner."""
    if reg["wave"].startswith("undrained"):     # a column: the one wave a load excites
        wave = f"wave period 4H/c1 = {reg['wave_period_s']:.3g} s"
    else:
        wave = (f"slowest wave {reg['wave']} = {reg['wave_period_s']:.3g} s (4H/c1 "
                f"{reg['undrained_period_s']:.3g} s, drained 4H/c {reg['drained_period_s']:.3g}"
                f" s, shear 4H/c_s {reg['shear_period_s']:.3g} s)")
    return (f"Inertia: {wave}, consolidation time "
            f"H^2/c2 = {reg['consolidation_time_s']:.4g} s, Pi = {reg['Pi']:.4g}; mass "
            f"scaling S = {reg['mass_scaling']:.4g} (Pi_S = {reg['Pi_S']:.4g}): "
            f"{reg['periods_to_first_report']:.3g} periods to T_v = "
            f"{reg['first_report_Tv']:g}, estimated wave error {100 * reg['wave_error']:.2g} %,"
            f" drag lag {100 * reg['drag_lag_error']:.2g} % of q (auto: both <= "
            f"{100 * TOLERANCE:g} %" + (f" and Pi_S >= {reg['Pi_S_min']:g})"
                                       if reg["Pi_S_min"] else ")"))


def estimated_steps(soil, body, dt, safety, Tv_end, drag: str, S: float) -> float:
    """Steps of a run to T_v = ``Tv_end`` from the closed-form criteria alone (a lower
    bound: the discrete limit and the oscillator criterion can only lower dt); ``dt`` the
    given step (s) or NaN for ``safety`` times the governing limit."""
    H = body.height
    limits = timestep.criteria(soil, H, math.nan, math.nan, body.cell_size(), S)
    limits = {k: v for k, v in limits.items() if not math.isnan(v)}
    dt = dt if not math.isnan(dt) else safety * limits[timestep.governing(limits, drag)]
    return Tv_end * H * H / soil.c_v / dt


def check_feasible(req, scheme, soil, body):
    """InputError, before anything is analysed or written, when a new run would take more
    than MAX_STEPS steps; it names the options that bring it down, and to how many.
    ``req``: what the options ask of the time scheme (``dt``, ``dt_safety``, ``Tv_end``,
    ``Tv_report``: :class:`solver.consolidation.implicit.choice.Request`)."""
    drag, S = scheme.drag, scheme.mass_scaling

    def steps(drag, S):
        return estimated_steps(soil, body, req.dt, req.dt_safety, req.Tv_end, drag, S)

    estimate = steps(drag, S)
    if estimate <= MAX_STEPS:
        return
    if not math.isnan(req.dt):
        raise InputError(f"-mpm_dt {req.dt:g}: {estimate:.3g} steps to T_v = {req.Tv_end:g}, "
                         f"more than {MAX_STEPS:.0e}; raise -mpm_dt or lower -mpm_Tv_end")
    ways = []                                   # (what to change, steps with it)
    if drag == "explicit":
        ways.append(("-mpm_drag implicit", steps("implicit", S)))
    first_tv = min(req.Tv_report)
    if scheme.mass_scaling_choice != "auto" and decay(scheme.damping, scheme.fast_damping)[0] < 1:
        S_auto = auto_factor(soil, body.height, first_tv, scheme.damping,
                             scheme.fast_damping, scheme.wave_period, scheme.swings)
        ways.append((("-mpm_drag implicit " if drag == "explicit" else "")
                     + f"-mpm_mass_scaling auto (S = {S_auto:.3g})", steps("implicit", S_auto)))
    if not any(n <= MAX_STEPS for _, n in ways):
        # Neither the drag nor the inertia makes this run finish: it is too long.
        raise InputError(f"-mpm_Tv_end {req.Tv_end:g}: at least {estimate:.3g} steps, more "
                         f"than {MAX_STEPS:.0e} (" + "".join(f"with {w}: {n:.3g}; "
                                                             for w, n in ways)
                         + "shorten the run or coarsen the grid)")
    raise InputError(f"-mpm_mass_scaling {scheme.mass_scaling_choice}: at least "
                     f"{estimate:.3g} steps to T_v = {req.Tv_end:g} with {drag} drag, more "
                     f"than {MAX_STEPS:.0e}; steps with "
                     + "; with ".join(f"{w}: {n:.3g}" for w, n in ways))
