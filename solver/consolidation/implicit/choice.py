"""``-mpm_scheme auto``: the explicit step or the implicit scheme, per scene, in one line.

Consolidation is quasi-static: every reference of this solver (Terzaghi, the layered and
self-weight columns, the FE of :mod:`solver.references.biot`) leaves inertia out. The
explicit v-w step is a wave solver: it pays for every wave period the scene's time holds,
and until the waves die its answer carries them, an error against the quasi-static
answer. The implicit scheme is quasi-static: its cost grows with the number of unknowns and
hardly with time. ``auto`` takes the explicit step only where

- an explicit-only option is given on the command line (the user asked for the step), or
- it is estimated both within TOLERANCE of q of the quasi-static answer at the first report
  (its own inertia estimate there, :func:`solver.stepping.inertia.regime`:
  the wave and the drag lag under its damping and mass scaling) and cheaper than the
  implicit scheme,

and the implicit scheme everywhere else. A scene about inertia itself (the stiff column)
names the explicit step. The costs are estimates from constants measured on this
project's 2-core machine (:data:`EXPLICIT_S`, :data:`IMPLICIT_S`; docs/studies.md,
"Explicit or implicit"): only their ratio matters.
"""

from __future__ import annotations

from dataclasses import dataclass

from ...common.errors import InputError
from ...io.options import EXPLICIT_ONLY, IMPLICIT_ONLY
from ...stepping import inertia
from .quasistatic import graded_steps, named_times

TOLERANCE = inertia.TOLERANCE
# Seconds per material point and explicit step (the v-w kernels, one rank: M3-Q4, 136,250
# steps of 640 points in 6.5 s) and per unknown and implicit solve, the factorizations
# included (one rank: the strip on 32 x 16 Q4 cells, 353 solves of 1,683 unknowns and 20
# factorizations in 0.36 s), measured on this project's 2-core machine.
EXPLICIT_S = 7.5e-8
IMPLICIT_S = 6.0e-7


@dataclass(frozen=True)
class Request:
    """What the options ask of the time scheme, read once at the edge: ``scheme`` (auto,
    explicit, implicit), the option names given on the command line (``given``) and in a
    scene file (``from_file``), the end and report times (T_v), the implicit scheme's
    ``implicit_steps`` and the load's ``ramp`` (s); the explicit step's ``dt`` (s, NaN:
    from the limits), ``dt_safety``, ``stability_analysis``, ``f1_solver`` (solver,
    tolerance, sweeps of the fundamental frequency) and ``allow_unstable``; the cadence of
    fields, checkpoints and progress (output_every, checkpoint_every, checkpoint_seconds,
    progress)."""

    scheme: str
    given: tuple
    from_file: tuple
    Tv_end: float
    Tv_report: tuple
    implicit_steps: int
    ramp: float
    dt: float
    dt_safety: float
    stability_analysis: bool
    f1_solver: tuple
    allow_unstable: bool
    cadence: tuple
    material: tuple = ("elastic",)     # per layer

    @classmethod
    def from_options(cls, p) -> "Request":
        return cls(p.scheme, tuple(n for n in p.given if n not in p.from_file),
                   tuple(p.from_file), p.Tv_end, tuple(p.Tv_report), p.implicit_steps,
                   p.load_ramp, p.dt, p.dt_safety, p.stability_analysis,
                   (p.eigen_solver[0], p.jacobi_tol, p.jacobi_max_sweeps), p.allow_unstable,
                   (p.output_every, p.checkpoint_every, p.checkpoint_seconds, p.progress),
                   p.material if isinstance(p.material, tuple) else (p.material,))


def check(req: Request) -> None:
    """InputError when the command line gives an option of the other scheme than the one
    ``-mpm_scheme`` names (options of a scene file are only noted: :func:`notes`)."""
    other = EXPLICIT_ONLY if req.scheme == "implicit" else \
        IMPLICIT_ONLY if req.scheme == "explicit" else ()
    if req.scheme == "explicit" and "mcc" in req.material:
        # The step's critical time step is -mpm_E's; Cam Clay's stiffness grows with p'.
        raise InputError("-mpm_material mcc: the explicit step's time step follows -mpm_E, "
                         "which Cam Clay's stiffness outgrows (use -mpm_scheme implicit)")
    # The implicit scheme reads -mpm_kinematics too: small is its own, large the large-strain
    # column (solver.consolidation.largestrain).
    clash = [n for n in other if n in req.given
             and not (n == "kinematics" and req.scheme == "implicit")]
    if clash:
        raise InputError(f"-mpm_{clash[0]}: an option of the "
                         f"{'explicit' if req.scheme == 'implicit' else 'implicit'} scheme, "
                         f"not read with -mpm_scheme {req.scheme}")


def notes(req: Request, method: str) -> list:
    """Notes on a scene file's options that the chosen scheme does not read."""
    other = EXPLICIT_ONLY if method == "implicit" else IMPLICIT_ONLY
    unread = sorted(n for n in other if n in req.from_file)
    if not unread:
        return []
    return [f"{len(unread)} option(s) of the {'explicit' if method == 'implicit' else 'implicit'}"
            f" scheme not read by the {method} scheme: "
            + " ".join(f"-mpm_{n}" for n in unread)]


def costs(req: Request, soil, body, scheme, refs, isochrones=()) -> dict:
    """The work of each scheme for the scene, and its estimated seconds on one rank: the
    explicit step's steps (the closed-form criteria's, a lower bound: its discrete limit can
    only shorten dt) and points; the implicit scheme's solves (one for the undrained start,
    two per step of its schedule: exactly the run's), unknowns (three per node of the
    DMDA)."""
    n_points = body.cells[0] * body.cells[1] * body.ppc ** 2
    steps = inertia.estimated_steps(soil, body, req.dt, req.dt_safety, req.Tv_end, scheme.drag,
                                    scheme.mass_scaling)
    order = 1 if body.element == "q4" else 2
    unknowns = 3 * (order * body.cells[0] + 1) * (order * body.cells[1] + 1)
    named = named_times(refs.time, req.Tv_report, req.Tv_end, isochrones)
    solves = 2 * len(graded_steps(named, req.implicit_steps, req.ramp)) + 1
    return {"explicit_steps": steps, "points": n_points, "implicit_solves": solves,
            "unknowns": unknowns, "explicit_s": steps * n_points * EXPLICIT_S,
            "implicit_s": solves * unknowns * IMPLICIT_S}


def choose(req: Request, soil, body, scheme, refs, isochrones=()) -> tuple:
    """(explicit | implicit, the line that says why)."""
    if req.scheme != "auto":
        return req.scheme, f"Scheme: {req.scheme} (-mpm_scheme {req.scheme})"
    if set(req.material) != {"elastic"}:
        return "implicit", (f"Scheme: implicit (-mpm_scheme auto: the soil yields, "
                            f"-mpm_material {','.join(req.material)}: Newton at each stage to 1e-10 of "
                            "the load, where the explicit step carries inertia)")
    given = [n for n in EXPLICIT_ONLY if n in req.given]
    if given:
        return "explicit", (f"Scheme: explicit (-mpm_scheme auto: -mpm_{given[0]} is an "
                            "option of the explicit step)")
    reg = inertia.regime(soil, body.height, min(req.Tv_report), scheme.damping,
                         scheme.fast_damping, scheme.mass_scaling, scheme.wave_period,
                         scheme.swings)
    error = max(reg["wave_error"], reg["drag_lag_error"])
    work = costs(req, soil, body, scheme, refs, isochrones)
    explicit_s, implicit_s = work["explicit_s"], work["implicit_s"]
    cost = f"estimated {explicit_s:.3g} s explicit against {implicit_s:.3g} s implicit"
    if error <= TOLERANCE and explicit_s < implicit_s:
        return "explicit", (f"Scheme: explicit (-mpm_scheme auto: its inertia within "
                            f"{100 * TOLERANCE:g} % of q at the first report, Pi_S = "
                            f"{reg['Pi_S']:.3g}, and {cost})")
    why = (f"the explicit step's inertia about {100 * min(error, 1):.3g} % of q at the first "
           f"report (Pi_S = {reg['Pi_S']:.3g})" if error > TOLERANCE else cost)
    return "implicit", f"Scheme: implicit (-mpm_scheme auto: {why})"
