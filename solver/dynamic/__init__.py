"""Dynamics of a soil body shaken at its base (issue 30; the analysis is being built): the
explicit one-phase step on the material points under a base motion.

- ``column``: the shaken body (rigid or compliant base, Rayleigh damping), stepped in time.

May import: consolidation, consolidation.implicit, consolidation.explicit, eigen, io,
references, model, common.

The rooms, lowest first: common, model, references, io, eigen, consolidation.explicit,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
