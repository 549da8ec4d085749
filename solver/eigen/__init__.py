"""The eigenfrequency analysis, and the modal solvers both analyses use (the consolidation run
takes f1 from ``frequency``, never the driver).

- ``driver``: the eigen analysis, run by the command line;
- ``jacobi``: the generalized Jacobi eigensolver;
- ``frequency``: SLEPc's generalized eigensolve and the fundamental frequency f1.

May import: io, references, model, common.

The rooms, lowest first: common, model, references, io, eigen, consolidation.explicit,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
