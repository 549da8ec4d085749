"""The implicit consolidation scheme (``-mpm_scheme implicit``): quasi-static u-p Biot on the
material points (operators), its time stepping (quasistatic) and the choice between the
schemes (choice). Imports common/, model/, references/, io/, eigen/ and
consolidation/explicit/ (the inertia regime), never consolidation/ itself."""
