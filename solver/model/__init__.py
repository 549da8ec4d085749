"""The model: the soil, the body and its background grid, the material points and the shape
functions, and the matrices assembled over them.

- ``shapes``: shape functions of the Q4, Q8 and Q9 cells;
- ``grid``: the background grid, a PETSc DMDA;
- ``points``: the material points, a PETSc DMSwarm;
- ``assembly``: shape functions at the points, stiffness and mass matrices, lumping;
- ``scene``: the scene as data (Body, Loading) and the models built from it;
- ``soil``: the soil (Soil, Ground): its constituents and what follows from them;
- ``motion``: base motions: the Ricker wavelet, a sine, a record, as functions of time;
- ``lattice``: the uniform grid of points that flow across its cells (large
  deformation): hat functions, uGIMP and quadratic B-splines, and its walls.

May import: common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
