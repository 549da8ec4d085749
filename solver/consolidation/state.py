"""The state of a consolidation run besides its points: what its checkpoint stores and a
restart takes up, and the check that a restart's end comes after it."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ..common.errors import InputError


@dataclasses.dataclass
class RunState:
    """The state of a run besides its points: exactly what a checkpoint stores
    (:meth:`to_dict`, the ``state`` of :func:`write`) and a restart loads
    (:meth:`from_dict`). ``step`` is the last step whose points and records agree."""

    step: int = 0
    dt: float = math.nan
    mass_scaling: float = 1.0
    history: list = dataclasses.field(default_factory=list)     # (t, Tv, p/q at the monitor)
    reports: list = dataclasses.field(default_factory=list)     # report() at the report times
    profiles: list = dataclasses.field(default_factory=list)    # (Tv, t, profile()), rank 0
    series: list = dataclasses.field(default_factory=list)      # the field series' entries
    settlement: list = dataclasses.field(default_factory=list)  # (t, Tv, s (m), mean p (Pa))
    degree: list = dataclasses.field(default_factory=list)      # degree of consolidation
    troughs: list = dataclasses.field(default_factory=list)     # (Tv, x (m), s (m)), rank 0
    method: str = "explicit"                                    # the time scheme
    times: list = dataclasses.field(default_factory=list)       # implicit: the step ends (s)
    nodal: list = dataclasses.field(default_factory=list)       # implicit: (u, p_e), natural

    def to_dict(self) -> dict:
        """The state as a checkpoint stores it (JSON after :func:`output._jsonable`)."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, st: dict, mass_scaling: float) -> "RunState":
        """The state of a checkpoint's ``st``; ``mass_scaling`` where it holds none (auto
        depends on the earliest report time, which a restart may change: a restart keeps
        the factor the run started with)."""
        return cls(step=st["step"], dt=st["dt"],
                   mass_scaling=st.get("mass_scaling", mass_scaling),
                   history=[tuple(h) for h in st["history"]], reports=st["reports"],
                   profiles=[(a, b, np.array(c)) for a, b, c in st["profiles"]],
                   series=st["series"], settlement=[tuple(r) for r in st.get("settlement", [])],
                   degree=st.get("degree", []), troughs=st.get("troughs", []),
                   method=st.get("method", "explicit"), times=st.get("times", []),
                   nodal=st.get("nodal", []))


def check_end(path, state: dict, refs, Tv_end: float) -> None:
    """InputError when -mpm_Tv_end ends the run before the step of the checkpoint ``path``
    (its ``state``): a restart goes on from there, and would report a run it never made
    as completed. ``refs``: the scene's :class:`plan.References` (T_v and time)."""
    step, dt = state["step"], state["dt"]
    if int(math.ceil(refs.time(Tv_end) / dt - 1e-9)) < step:
        t = step * dt
        raise InputError(f"-mpm_Tv_end {Tv_end:g}: before the state of -mpm_restart {path} "
                         f"(step {step}, t = {t:.6g} s, T_v = {refs.time_factor(t):.4g}); a "
                         "restart goes on from there: give a later -mpm_Tv_end, or run "
                         "anew without -mpm_restart")
