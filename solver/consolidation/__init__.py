"""The consolidation analysis: the set-up that makes its plan, the model the loop drives,
what it reports and the references set beside it. The explicit step is one of the engines
(``solver.stepping``); the implicit scheme is the room ``implicit`` inside this one.

- ``driver``: the consolidation run, run by the command line: set-up, loop, results;
- ``setup``: the options checked, a target error's pick, a restart, the body and the plan;
- ``schedules``: which time scheme, its critical time steps or graded steps;
- ``plan``: the Plan a set-up returns: the run as typed values;
- ``state``: the run's records besides its points (what a checkpoint stores);
- ``model``: the consolidating body as the loop drives it (either scheme);
- ``results``: the run's keys in the summary and its closing report;
- ``reporting``: the monitor, profiles, tables and CSV files of a run;
- ``plots``: its figures: isochrones, pressure field, degree of consolidation, settlement;
- ``settlement``: the surface settlement and the degree of consolidation;
- ``workprecision``: measured work-precision data and the pick of -mpm_target_error;
- ``fe_reference``: the finite-element reference of a scene without a closed form;
- ``largestrain``: the large-strain column (implicit, moving points): its plan, the model
  the loop drives, its report beside Xie and Leo's closed form;
- ``implicit/``: the implicit quasi-static scheme and the choice between the schemes (its
  own room, before this one).

May import: consolidation.implicit, eigen, stepping, modal, run, io, references, materials, model,
common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
