"""Published experiments the large-deformation analysis is drawn and compared beside, with
the scene each belongs to.

- ``bui-2008``: Bui, Fukagawa, Sako and Ohno (2008), Int. J. Numer. Anal. Meth. Geomech.
  32: the collapse of a column of aluminium bars (1 and 1.5 mm across, 50 mm long, stacked
  in plane strain), 0.2 m long and 0.1 m high against a wall, released at once: its
  final free surface and its failure line, read from the experiment's photograph, in m
  from the wall and the floor. The column's friction angle 19.8 degrees, no cohesion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Collapse:
    """A granular column's collapse: its ``size`` (W, H) (m), friction angle ``phi``
    (degrees) and ``cohesion`` (Pa), the final free surface (n, 2) (x, y in m), its toe
    (m: the last point of the surface) and the failure line's ends ((x, y), (x, y)) (m)."""

    name: str
    citation: str
    size: tuple
    phi: float
    cohesion: float
    surface: np.ndarray
    failure_line: tuple

    @property
    def toe(self) -> float:
        return float(self.surface[-1, 0])


BUI_2008 = Collapse(
    name="bui-2008",
    citation="Bui, Fukagawa, Sako and Ohno (2008), experiment",
    size=(0.2, 0.1), phi=19.8, cohesion=0.0,
    surface=np.array([
        (0.000, 0.0992), (0.0196, 0.0993), (0.0398, 0.0959), (0.0600, 0.0890),
        (0.0803, 0.0844), (0.1001, 0.0776), (0.1203, 0.0722), (0.1401, 0.0665),
        (0.1603, 0.0616), (0.1802, 0.0539), (0.2000, 0.0474), (0.2202, 0.0425),
        (0.2408, 0.0348), (0.2622, 0.0307), (0.2820, 0.0265), (0.3022, 0.0215),
        (0.3221, 0.0189), (0.3423, 0.0136), (0.3622, 0.0109), (0.3824, 0.0079),
        (0.4022, 0.0037), (0.4221, 0.0022), (0.4423, 0.0015)]),
    failure_line=((0.0212, 0.0989), (0.1794, 0.0005)))

COLLAPSES = {c.name: c for c in (BUI_2008,)}
