"""The consolidation analysis: the set-up that makes its plan, the time loop, what it reports
and the references set beside it. The schemes are the rooms ``explicit`` and ``implicit``
inside it.

- ``driver``: the consolidation run (set-up and time loop), run by the command line;
- ``schedules``: which time scheme, its critical time steps or graded steps;
- ``plan``: the Plan a set-up returns: the run as typed values;
- ``reporting``: the monitor, profiles, tables, CSV files and figures of a run;
- ``settlement``: the surface settlement and the degree of consolidation;
- ``workprecision``: measured work-precision data and the pick of -mpm_target_error;
- ``fe_reference``: the finite-element reference of a scene without a closed form;
- ``explicit/``: the explicit two-phase step and what sizes it (its own room, before this
  one);
- ``implicit/``: the implicit quasi-static scheme and the choice between the schemes (its
  own room, before this one).

May import: consolidation.implicit, consolidation.explicit, eigen, io, references, model,
common.

The rooms, lowest first: common, model, references, io, eigen, consolidation.explicit,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
