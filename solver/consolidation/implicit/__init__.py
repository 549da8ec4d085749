"""The implicit quasi-static scheme of consolidation and the choice between the schemes. It
knows nothing of the run around it (the plan, the reporting).

- ``operators``: the u-p operators K, Q, S, H over the material points, the pressure
  projection, the held DOFs;
- ``quasistatic``: the undrained start, TR-BDF2 on graded steps, MUMPS LU, the points' fields;
- ``yielding``: soil that yields: each stage's Newton on SNES with the materials' stresses;
- ``largestrain``: the large-strain column's engine: updated Lagrangian, the grid reset to
  the body at each step, backward Euler, the permeability laws;
- ``choice``: ``-mpm_scheme auto`` (which scheme, and why) and the options of each scheme.

May import: eigen, stepping, modal, run, io, references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
