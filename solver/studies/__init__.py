"""What the study scripts in scripts/ share: batches of solver runs, each a ``python -m
solver`` process, and where their results go.

- ``study``: batches of solver runs for the scripts, and their destinations.

May import: dynamic, consolidation, consolidation.implicit, eigen, stepping, modal, run, io,
references, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
