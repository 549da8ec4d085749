"""What the study scripts in scripts/ share, their run frame: their start-up, where their
results go, and their solver runs, each a ``python -m solver`` process.

- ``study``: the scripts' start-up (``start``), their destinations (``--out``,
  ``--publish``), their solver runs (batches that keep what finished, fresh timed runs) and
  what the benchmark commands share (the machine, the report).

May import: static, soiltest, dynamic, consolidation, consolidation.implicit, eigen, stepping, modal, run, io,
references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
