"""The engines that step a body in time, which the consolidation and the dynamic analyses both
take: the explicit two-phase v-w step and what sizes it, and the one-phase nodal step. They
know nothing of the run around them (the plan, the loop, the reporting).

- ``twophase``: the explicit single-point two-phase (v-w) step; ``python -m
  solver.stepping.twophase`` compiles its kernels;
- ``kernels``: its compiled loops (numba, cached in this folder's __pycache__);
- ``scheme``: the step's Scheme, ``auto`` resolved;
- ``timestep``: critical time steps, and the step they allow;
- ``darcy``: Q4's compact Darcy stencil as the stability analysis sees it (its cap, its
  operator on the corner pressures);
- ``inertia``: the inertia regime and mass scaling;
- ``waves``: the undrained modes a sudden load sets swinging (the wave estimate);
- ``onephase``: one phase on the nodes: the shaken body (the eigen model's K, lumped M,
  Rayleigh damping), a rigid or compliant base, periodic or absorbing sides;
- ``pointforces``: the internal forces of a hysteretic soil from its points' stresses
  (B as a PETSc Mat, the compiled Iwan update), which the shaken body steps with;
- ``flow``: one phase whose points flow across the cells: the explicit updated-Lagrangian
  step (Hencky's elasticity with the materials' returns, B-splines, walls, a Coulomb
  floor), the dynamic analysis's flowing body;
- ``footing``: a rigid strip footing pushed into it, a kinematic constraint on the grid;
- ``transfer``: its compiled transfers between the points and the grid (numba).

May import: modal, run, io, references, materials, model, common.

The rooms, lowest first: common, model, references, io, run, modal, stepping, eigen,
consolidation.implicit, consolidation, dynamic, studies; then the command line
(solver/__main__.py). A module imports its own room and the rooms before it, never one after
it (tests/test_rooms.py).
"""
