"""The materials of a body's points, one per layer, and their history in point fields.

A body's points carry their in-plane effective stress in the field ``stress`` (xx, yy, xy;
Pa, tension positive), which every scheme writes. A yielding material also needs the stress
out of plane and its state variables: they live in point fields of their own
(``stress_zz`` and ``state_NAME``, :func:`fields`), so the points carry them across ranks
and a checkpoint stores them with everything else.
"""

from __future__ import annotations

import numpy as np

from .model import Elastic, tangent

PLANE = [0, 1, 3]          # the (xx, yy, xy) rows of the materials' four components


def fields(recipe) -> dict:
    """The point fields a material's history takes (none for an elastic soil): the
    committed stress's zz (Pa) and each state variable (``state_NAME``)."""
    if recipe is None or recipe.elastic:
        return {}
    names = {"plastic", "eps_p"} | ({"p_c"} if "mcc" in recipe.names else set())
    return {"stress_zz": 1, **{f"state_{n}": 1 for n in sorted(names)}}


def layer_of(points) -> np.ndarray:
    """The points' layer indices (0 for one soil)."""
    return np.ravel(points.get("layer")).astype(int) if "layer" in points.layout else \
        np.zeros(points.n_local, dtype=int)


class Layered:
    """One material per layer (``materials``), applied to the points of each (``layer``,
    (np,) their indices)."""

    def __init__(self, materials, layer):
        self.materials = tuple(materials)
        self.groups = [(np.flatnonzero(layer == i), m) for i, m in enumerate(materials)]
        self.groups = [(idx, m) for idx, m in self.groups if len(idx)]

    def initial(self, stress) -> dict:
        """The history of points starting from ``stress`` (np, 4) (Pa)."""
        out = {}
        for idx, m in self.groups:
            for k, v in m.initial_state(stress[idx]).items():
                out.setdefault(k, np.zeros(len(stress), dtype=v.dtype))[idx] = v
        return out

    def update(self, stress, d_strain, state) -> tuple:
        """(stress, state) after the strain increments ``d_strain`` (np, 4)."""
        new = np.empty_like(stress)
        # Copies: a layer's model leaves the variables of the others' as they were.
        out = {k: v.copy() for k, v in state.items()}
        for idx, m in self.groups:
            s, st = m.update(stress[idx], d_strain[idx], {k: v[idx] for k, v in state.items()})
            new[idx] = s
            for k, v in st.items():
                out[k][idx] = v
        return new, out

    def tangent(self, stress, d_strain, state) -> np.ndarray:
        """The in-plane algorithmic tangent (np, 3, 3) (Pa) on (xx, yy, 2 xy)."""
        out = np.empty((len(stress), 3, 3))
        for idx, m in self.groups:
            out[idx] = tangent(m, stress[idx], d_strain[idx], {k: v[idx] for k, v in
                                                               state.items()}
                               )[:, PLANE][:, :, PLANE]
        return out


def in_plane(stress3, zz) -> np.ndarray:
    """The (np, 4) stress of the in-plane (xx, yy, xy) and the out-of-plane parts (Pa)."""
    out = np.empty((len(stress3), 4))
    out[:, PLANE] = stress3
    out[:, 2] = np.ravel(zz)
    return out


def start(points, layered) -> None:
    """A fresh body's history: zz as xx (K0 in both horizontal directions) and each
    material's initial state from the points' stress."""
    stress = in_plane(points.get("stress"), points.get("stress")[:, 0])
    write(points, stress, layered.initial(stress))


def read(points, stress3=None) -> tuple:
    """(stress (np, 4), state) of the points' fields (the state variables: every
    ``state_NAME`` field), the in-plane stress ``stress3`` (np, 3) (Pa) in place of theirs
    where given."""
    stress = in_plane(points.get("stress") if stress3 is None else stress3,
                      points.get("stress_zz"))
    return stress, {name[len("state_"):]: np.ravel(points.get(name))
                    for name in points.layout if name.startswith("state_")}


def write(points, stress, state) -> None:
    """The points' stress (np, 4) and state into their fields."""
    with points.fields("stress", "stress_zz") as (st, zz):
        st[:] = stress[:, PLANE]
        zz[...] = stress[:, 2].reshape(zz.shape)
    for k, v in state.items():
        with points.fields(f"state_{k}") as f:
            f[...] = v.reshape(f.shape)


def elasticity_of(soil):
    """The linear analyses' stiffness from the elastic law of this room (Elastic.plane): one
    3 x 3 D (Pa) for one soil, or for a soil.Ground of layers a function of heights y (m)
    giving each point's, (len(y), 3, 3)."""
    layers = [Elastic(s.E, s.nu).plane() for s in soil.soils]
    if len(layers) == 1:
        return layers[0]
    stacked = np.stack(layers)
    return lambda y: stacked[soil.layer_of(y)]
