"""The explicit two-phase step and what sizes it: the v-w step, its compiled kernels, its
scheme, the critical time steps, the inertia regime. It knows nothing of the run around it
(the plan, the reporting).

- ``twophase``: the explicit single-point two-phase (v-w) step; ``python -m
  solver.consolidation.explicit.twophase`` compiles its kernels;
- ``kernels``: its compiled loops (numba, cached in this folder's __pycache__);
- ``scheme``: the step's Scheme, ``auto`` resolved;
- ``timestep``: critical time steps;
- ``inertia``: the inertia regime and mass scaling.

May import: eigen, io, references, model, common.

The rooms, lowest first: common, model, references, io, eigen, consolidation.explicit,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
