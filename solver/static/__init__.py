"""The static analysis (``-mpm_analysis static``): a body of a material of the materials room
loaded in steps, a rigid footing pushed into it to failure, Newton on PETSc SNES.

- ``problem``: the nonlinear system on the material points (residual, Jacobian, B-bar), the
  state at rest and the external forces;
- ``driver``: the analysis: the plan and the load steps;
- ``restart``: its checkpoints and restarts (the points' stresses and history, the nodal
  state, the stepping's progress);
- ``reporting``: what it writes: the summary's ``static`` block, ``load_displacement.csv``
  and its figure, the plastic zone, the point fields for ParaView.

May import: soiltest, dynamic, consolidation, consolidation.implicit, eigen, stepping, modal,
run, io, references, materials, model, common.
"""
