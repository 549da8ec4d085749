"""The modal solvers every analysis takes: the generalized Jacobi eigensolver, SLEPc's
generalized eigensolve and the lowest natural frequencies of a body (the eigen analysis
reports them; the consolidation run takes f1, the dynamic run f1 to f3).

- ``jacobi``: the generalized Jacobi eigensolver;
- ``frequency``: SLEPc's generalized eigensolve, the fundamental frequency f1 and the lowest
  frequencies of a body.

May import: run, io, references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
