"""``-mpm_scheme auto``: the explicit step or the implicit scheme, per scene, in one line.

The explicit v-w step is a wave solver: it pays for every wave period the scene's time
holds, and its answer carries the inertia that the quasi-static references leave out. The
implicit scheme is quasi-static: its cost grows with the number of unknowns and hardly with
time. ``auto`` takes the explicit step where

- an explicit-only option is given on the command line (the user asked for the step), or
- inertia shows at the first report: the explicit step's own inertia estimate there
  (:func:`solver.consolidation.explicit.inertia.regime`, the wave and the drag lag under
  its damping, without mass scaling) exceeds TOLERANCE of q, or the regime Pi (consolidation
  time over the slowest wave's period) is below inertia.PI_MIN, where a residual oscillation
  was measured: the dynamics are then part of the answer and the quasi-static scheme would
  leave them out, or
- its estimated cost is below the implicit scheme's,

and the implicit scheme everywhere else. The costs are estimates from constants measured
on this project's 2-core machine (:data:`EXPLICIT_S`, :data:`IMPLICIT_S`; docs/studies.md,
"Explicit or implicit"): only their ratio matters.
"""

from __future__ import annotations

from ...common.errors import InputError
from ...io.options import EXPLICIT_ONLY, IMPLICIT_ONLY
from ..explicit import inertia
from .quasistatic import step_ends

TOLERANCE = inertia.TOLERANCE
# Seconds per material point and explicit step (the v-w kernels, one rank), and per unknown
# and implicit solve (MUMPS' triangular solves and the operators' products, one rank; the
# factorizations add about as much again): measured on the strips and columns here.
EXPLICIT_S = 0.4e-6
IMPLICIT_S = 3.0e-6


def check(p) -> None:
    """InputError when the command line gives an option of the other scheme than the one
    ``-mpm_scheme`` names (options of a scene file are only noted: :func:`notes`)."""
    given = set(p.given) - set(p.from_file)
    other = EXPLICIT_ONLY if p.scheme == "implicit" else \
        IMPLICIT_ONLY if p.scheme == "explicit" else ()
    clash = [n for n in other if n in given]
    if clash:
        raise InputError(f"-mpm_{clash[0]}: an option of the "
                         f"{'explicit' if p.scheme == 'implicit' else 'implicit'} scheme, "
                         f"not read with -mpm_scheme {p.scheme}")


def notes(p, method: str) -> list:
    """Notes on a scene file's options that the chosen scheme does not read."""
    other = EXPLICIT_ONLY if method == "implicit" else IMPLICIT_ONLY
    unread = sorted(n for n in other if n in p.from_file)
    if not unread:
        return []
    return [f"{len(unread)} option(s) of the {'explicit' if method == 'implicit' else 'implicit'}"
            f" scheme not read by the {method} scheme: "
            + " ".join(f"-mpm_{n}" for n in unread)]


def costs(soil, body, p, scheme, refs) -> tuple:
    """(explicit, implicit) estimated seconds of the scene's steps on one rank."""
    n_points = body.cells[0] * body.cells[1] * body.ppc ** 2
    steps = inertia.estimated_steps(soil, body, p.dt, p.dt_safety, p.Tv_end, scheme.drag,
                                    scheme.mass_scaling)
    order = 1 if body.element == "q4" else 2
    nodes = (order * body.cells[0] + 1) * (order * body.cells[1] + 1)
    corners = (body.cells[0] + 1) * (body.cells[1] + 1)
    unknowns = 2 * nodes + corners
    asked = [refs.time(t) for t in p.Tv_report] + [refs.time(p.Tv_end)]
    solves = 2 * len(step_ends(asked, p.implicit_steps))
    return steps * n_points * EXPLICIT_S, 2 * solves * unknowns * IMPLICIT_S


def choose(p, soil, body, scheme, refs) -> tuple:
    """(explicit | implicit, the line that says why) for the options ``p``."""
    if p.scheme != "auto":
        return p.scheme, f"Scheme: {p.scheme} (-mpm_scheme {p.scheme})"
    given = [n for n in EXPLICIT_ONLY if n in set(p.given) - set(p.from_file)]
    if given:
        return "explicit", (f"Scheme: explicit (-mpm_scheme auto: -mpm_{given[0]} is an "
                            "option of the explicit step)")
    reg = inertia.regime(soil, body.height, min(p.Tv_report), scheme.damping,
                         scheme.fast_damping, 1.0, scheme.wave_period)
    shown = max(reg["wave_error"], reg["drag_lag_error"])
    explicit_s, implicit_s = costs(soil, body, p, scheme, refs)
    cost = f"estimated {explicit_s:.3g} s explicit against {implicit_s:.3g} s implicit"
    if shown > TOLERANCE or reg["Pi"] < inertia.PI_MIN:
        return "explicit", (f"Scheme: explicit (-mpm_scheme auto: inertia shows at the first "
                            f"report, about {100 * shown:.2g} % of q with Pi = "
                            f"{reg['Pi']:.3g} > the quasi-static scheme's reach; {cost})")
    if explicit_s < implicit_s:
        return "explicit", f"Scheme: explicit (-mpm_scheme auto: {cost})"
    return "implicit", (f"Scheme: implicit (-mpm_scheme auto: inertia below "
                        f"{100 * TOLERANCE:g} % of q at the first report, Pi = "
                        f"{reg['Pi']:.3g}; {cost})")
