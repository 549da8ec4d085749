"""The dynamic analysis: ``-mpm_analysis dynamic``, the body shaken at its base or loaded
suddenly, stepped in time; with ``-mpm_kinematics large``, a body flowing under gravity
across a grid larger than itself (a granular column's collapse), or a footing pushed into it.

- ``driver``: the analysis, run by the command line: the model as the loop drives it
  (``Shaken``), its records and field series;
- ``plan``: the options read once (``Request``), checked and planned (motion, supports,
  natural frequencies, Rayleigh damping);
- ``onephase``: one phase on the nodes: the shaken body's step, row means, state and fields;
- ``saturated``: two phases under a sudden load or shaken on a rigid base: the explicit
  v-w step without dampers, with the saturated column's references;
- ``histories``: what a run records (row means at depths, peaks with depth, a hysteretic
  soil's loops) and the histories, peaks and spectra (every recorded depth's) it writes;
- ``reporting``: the lines printed, the exact response of a one-dimensional scene, the
  XDMF series, the summary's ``dynamic`` block;
- ``twin``: a hysteretic run's linear twin, stepped after it and reported beside;
- ``flowing``: the flowing body: its options planned, the model the loop drives;
- ``runout``: its reporting: the deposit's free surface, toe, energy, the experiment
  beside it, the summary's block;
- ``penetration``: a footing pushed into the flowing body: its plan, curve and report;
- ``plots``: the figures.

May import: consolidation, consolidation.implicit, eigen, stepping, modal, run, io,
references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
