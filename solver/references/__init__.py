"""Independent references the analyses are checked against: closed forms, the series of layered
columns, finite-element and static solutions of a scene. They build on the model; the model
never builds on them (a reference the model were made of would check nothing).

- ``analytic``: closed forms: the vibrating rod, Terzaghi's pressure and degree of
  consolidation;
- ``layered``: layered columns: a layered rod's frequencies, consolidation by modes;
- ``biot``: the finite-element reference: quasi-static Biot u-p, Taylor-Hood Q9/Q4;
- ``static``: the undrained and final settlements by static solves;
- ``site``: site response of a layered shear column on a rigid base or elastic rock: its
  exact transfer functions and surface histories;
- ``spectra``: Fourier amplitudes, Konno-Ohmachi smoothing, pseudo-spectral acceleration;
- ``waves``: plane compression waves of the v-w equations: the saturated column's fast and
  slow speeds, the undrained speed, the decay by drag;
- ``experiments``: published experiments of large deformation (a granular column's
  collapse: its final free surface and failure line).

May import: materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
