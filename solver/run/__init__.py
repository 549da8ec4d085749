"""The frame every analysis runs in: its record (the summary's head, the wall time by phase, the
one failure path) and, for those that step, the one loop (step, check, sample, fields,
checkpoints, signals, progress) and its cadence.

- ``record``: the run record: ``summary.json``'s head and its failure path;
- ``loop``: the time loop that drives a model, its ``Cadence``.

May import: io, references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
