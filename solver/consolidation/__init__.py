"""The consolidation analysis: the set-up that makes its plan, the time loop, what it reports
and the references set beside it. The explicit step is the
engines' (``solver.stepping``); the implicit scheme is the room ``implicit`` inside this one.

- ``driver``: the consolidation run (set-up and time loop), run by the command line;
- ``schedules``: which time scheme, its critical time steps or graded steps;
- ``plan``: the Plan a set-up returns: the run as typed values;
- ``reporting``: the monitor, profiles, tables, CSV files and figures of a run;
- ``settlement``: the surface settlement and the degree of consolidation;
- ``workprecision``: measured work-precision data and the pick of -mpm_target_error;
- ``fe_reference``: the finite-element reference of a scene without a closed form;
- ``implicit/``: the implicit quasi-static scheme and the choice between the schemes (its
  own room, before this one).

May import: consolidation.implicit, eigen, stepping, modal, run, io, references, model,
common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
