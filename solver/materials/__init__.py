"""The materials room: the stress of a material point from its strain increment.

Every model takes the points' strain increments and their state (stress and history
variables) and returns the new stress, state and the algorithmic (consistent) tangent,
vectorised over the points (:mod:`solver.materials.model`). Stress and strain carry four
components, (xx, yy, zz, xy) for stress and (xx, yy, zz, 2 xy) for strain, tension
positive (the effective stress of the consolidation analyses): plane strain passes
d eps_zz = 0 and keeps sigma_zz, which plasticity needs; an axisymmetric soil test passes
the radial strain as both xx and zz.

- ``model``: the interface, the elastic law and the tangent by differences of the update;
- ``mohr_coulomb``: Mohr-Coulomb (and Tresca, phi = 0 on total stress) with the exact
  return in principal stresses onto the plane, either edge and the apex;
- ``drucker_prager``: the cone matched to Mohr-Coulomb in plane strain;
- ``cam_clay``: Modified Cam Clay with a pressure-dependent bulk modulus, implicit return;
- ``hyperbolic``: the hyperbolic backbone with Masing's hysteresis, a multi-surface (Iwan)
  J2 model in total stress;
- ``catalog``: a material from its name and parameters, checked;
- ``history``: one material per layer over a body's points, their history in point fields,
  and the linear analyses' stiffness from the elastic law (``elasticity_of``);
- ``soiltest``: one point driven through a laboratory test's path;
- ``hencky``: the same returns at finite strain (Hencky elasticity, principal logarithmic
  strain): the stress update of the flowing body (large deformation).

May import: model, common.
"""
