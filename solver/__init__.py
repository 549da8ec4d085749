"""MPI-parallel Material Point Method for geotechnics on PETSc and SLEPc.

Run as ``python -m solver -options_file cases/<scene>.opts``. PETSc is initialised by the
entry point (``solver.__main__``) with the command line, so importing this package does not
touch PETSc.
"""

__version__ = "0.1.0"
