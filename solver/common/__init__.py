"""What every room uses: how a run fails, is stopped and is timed.

- ``errors``: the failures the command line reports in one line, and their exit codes;
- ``signals``: SIGTERM and SIGINT at any stage of a run;
- ``clock``: a command's start and the wall time of a run's phases.

May import: nothing of the package.

The rooms, lowest first: common, model, references, io, eigen, consolidation.explicit,
consolidation.implicit, consolidation, studies; then the command line (solver/__main__.py). A module imports its own
room and the rooms before it, never one after it (tests/test_rooms.py).
"""
