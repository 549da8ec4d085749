"""The soil-test analysis (``-mpm_analysis soiltest``): one material point of the materials
room through a laboratory test, what every user runs before a boundary value problem.

- ``driver``: the analysis: the material from the options, the path, ``soiltest.csv``, the
  figure and the summary's ``soiltest`` block.

May import: dynamic, consolidation, consolidation.implicit, eigen, stepping, modal, run, io,
references, materials, model, common.
"""
