"""What every room uses: how a run fails, is stopped and is timed, and its direct solvers.

- ``errors``: the failures the command line reports in one line, and their exit codes;
- ``signals``: SIGTERM and SIGINT at any stage of a run;
- ``linalg``: direct linear solvers (an LU KSP under an options prefix), Newton on SNES,
  the reciprocal of lumped masses;
- ``clock``: a command's start and the wall time of a run's phases.

May import: nothing of the package.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
