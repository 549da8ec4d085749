"""MPI-parallel Material Point Method for geotechnics on PETSc and SLEPc.

Run as ``python -m solver -options_file cases/<scene>.opts``. PETSc is initialised by the
entry point (``solver.__main__``) with the command line, so importing this package does not
touch PETSc.

The package is the command line (``__main__``) and its rooms, lowest first: ``common``,
``model``, ``references``, ``io``, ``run`` (the frame every analysis runs in), ``modal``
(the eigensolvers), ``stepping`` (the engines that step a body in time), the analyses
``eigen``, ``consolidation`` (with ``consolidation.implicit``) and ``dynamic``, and
``studies``. A module imports its own room and the rooms before it, never one after it, no
analysis imports another's, and the analyses' drivers (``eigen.driver``,
``consolidation.driver``, ``dynamic.driver``) are run by the command line alone
(tests/test_rooms.py). Each room's ``__init__`` says what it holds.
"""

__version__ = "0.1.0"
