"""What goes in and out of a run: the options read from the command line and the scene files;
the results on disk (summaries, fields, figures, checkpoints, provenance); the memory check
before anything is allocated; the start-up of the executables. It knows nothing of the
analyses: they call it.

- ``spec``: every -mpm_ option declared once (type, default, check, help);
- ``options``: the -mpm_ options read once from PETSc's database, checked;
- ``scenefile``: a scene file (cases/*.opts), checked line by line and read as pairs;
- ``output``: JSON, VTU, XDMF + HDF5 series and figures written whole; where results go;
- ``fields``: the point fields of a run as a time series on disk;
- ``checkpoint``: checkpoints of stepping runs, written and read whole;
- ``restart``: what a restart takes from its checkpoint (the options) and may not touch;
- ``provenance``: versions, git commit and options for the summary;
- ``memory``: the memory a model needs, checked before anything is allocated;
- ``launch``: the Python the executables run under (one that imports PETSc);
- ``records``: recorded base motions (a CSV of t and a, a PEER .AT2 file), read and checked;
- ``checks``: the checks of the options' values (each a problem in words, or None).

May import: references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
