"""The eigenfrequency analysis: the column's natural frequencies and mode shapes by the modal
solvers (``solver.modal``), cross-checked and set beside their references.

- ``driver``: the eigen analysis, run by the command line;
- ``compare``: what it sets beside the solvers: the rod, the FE model, the paper's Table 3,
  the cross-check of Jacobi and SLEPc, the table printed;
- ``plots``: the mode-shape figure, and how a frequency is printed.

May import: stepping, modal, run, io, references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
