"""The waves a consolidation scene's load sets going, and how much of them is left at a time:
the wave part of the inertia estimate (:mod:`solver.stepping.inertia`).

Before any water has moved the saturated body is one undrained solid: the skeleton's shear
modulus G and its bulk modulus K raised by the water's K_l / n, with the mixture's density.
A load q F applied suddenly (over ``ramp`` s: a linear rise) moves it from rest towards its
undrained static state u_s = K_u^-1 F; with its modes (K_u phi_i = w_i^2 M phi_i, M-normal, M the step's lumped masses)
the motion about that state is

    u - u_s = -sum_i c_i phi_i cos(w_i t),    c_i = phi_i^T F / w_i^2

(times |sinc(w_i ramp / 2)| for a ramp), and each mode's pore pressure is p_i = -(K_l / n)
div phi_i. At a point x the pressure then swings about the undrained state by at most

    E(x, t) = sum_i |c_i p_i(x)| d_i(t),

d_i the share of mode i left at t under the step's damping (``decay``). E(x, 0) >= |p_s(x)|,
the undrained excess itself: on a laterally uniform column the first compression mode
holds 8 / pi^2 of it, and the estimate falls back to the former one (p0 = B q at the period
4 H / c1). A body whose load cannot compress the water suddenly without moving it (a strip
footing: shear under the load) carries slower, larger swings; a laterally drained block
under a load over its whole top only compression modes, fast and small after a few periods.
The water's drag and the drainage itself damp every mode further; they are left out (the
estimate is on the safe side of them), as is the slow transfer of the load to the skeleton
while the water drains, whose own excitation is measured to stay below the estimate on the
scenes of docs/studies.md ("The inertia estimate").

The modes come from a dense generalized eigensolve (SciPy) of the body's undrained model on
a grid of at most MAX_DOFS free DOFs (coarsened by whole factors, as f1's): the swings that
matter are the slow ones, which a coarse grid carries.
"""

from __future__ import annotations

import dataclasses
import math
from typing import NamedTuple

import numpy as np
from petsc4py import PETSc

from ..model import assembly, shapes
from ..model.scene import build, destroy, top_forces
from ..model.soil import Ground

MAX_DOFS = 1500   # dense eigensolve: 1,500 DOFs take about 1 s


class Swings(NamedTuple):
    """The undrained modes a scene's load excites: ``omega`` (rad/s, physical inertia) and
    ``amplitude`` (points x modes): |c_i p_i| at the model's points in units of the
    scene's pressure scale (q, or without a load the column's weight: Loading.scale)."""
    omega: np.ndarray
    amplitude: np.ndarray


def undrained(soil):
    """The undrained solid of ``soil`` (a Soil, or a Ground of layers): each layer's G
    with the bulk modulus K + K_l / n (3D, the plane-strain D's), as E and nu."""
    def one(s):
        G = s.E / (2 * (1 + s.nu))
        K_u = s.E / (3 * (1 - 2 * s.nu)) + s.K_l / s.porosity
        nu = (3 * K_u - 2 * G) / (2 * (3 * K_u + G))
        return dataclasses.replace(s, E=2 * G * (1 + nu), nu=nu)

    layers = tuple(one(s) for s in soil.soils)
    return layers[0] if len(layers) == 1 else Ground(soil.thickness, layers)


def model_cells(element: str, cells) -> tuple:
    """``cells`` coarsened by a whole factor in both directions until the model has at
    most MAX_DOFS DOFs (at least one cell each way)."""
    factor = 1
    while 2 * shapes.lattice_nodes(element, [max(1, c // factor) for c in cells]) > MAX_DOFS \
            and max(cells) // factor > 1:
        factor += 1
    return tuple(max(1, c // factor) for c in cells)


def swings(body, soil, loading) -> Swings:
    """The modes of ``body`` (scene.Body) of ``soil`` that the load of ``loading``
    (scene.Loading) excites, and their pore-pressure amplitudes (one rank: call on rank 0
    and broadcast)."""
    body = dataclasses.replace(body, cells=model_cells(body.element, body.cells))
    grid, points, K, M, free = build(PETSc.COMM_SELF, body, undrained(soil))
    try:
        import scipy.linalg

        nodes = grid.gxm * grid.gym
        x, volume, mass = points.get("x", "volume", "mass")
        it = assembly.interpolation(grid, x)
        idx = free.getIndices()
        # The lumped masses the explicit step itself has (HRZ on Q8, whose row sums are
        # negative): positive also with one point per cell, where the consistent M is
        # singular.
        w = assembly.lumping_weights(it.N, "hrz" if body.element == "q8" else "rowsum")
        m = np.zeros(2 * nodes)
        for d in range(2):
            np.add.at(m, it.dofs[:, d::2], mass[:, None] * w)
        scale = 1 / np.sqrt(m[idx])
        Kd = K.convert("dense").getDenseArray()
        lam, phi = scipy.linalg.eigh(scale[:, None] * Kd * scale[None, :])
        phi *= scale[:, None]                                  # M-normal
        lam = np.maximum(lam, lam[-1] * 1e-14)
        F = np.zeros(2 * nodes)
        if loading.load:
            top = (grid.nodes[1] - 1) * grid.nodes[0] + np.arange(grid.nodes[0])
            F[2 * top + 1] = -top_forces(grid, loading)
        if loading.self_weight:
            # A fresh deposit's buoyant weight, which the water takes at first.
            rho = _at_points(soil, "density", x[:, 1]) - soil.soils[0].rho_l
            np.add.at(F, it.dofs[:, 1::2], -(loading.gravity * rho * volume)[:, None] * it.N)
        c = phi.T @ F[idx] / lam
        omega = np.sqrt(lam)
        if loading.ramp > 0:
            c *= np.abs(np.sinc(omega * loading.ramp / (2 * np.pi)))
        U = np.zeros((2 * nodes, len(lam)))
        U[idx] = phi
        div = (np.einsum("pa,pam->pm", it.dNdx[..., 0], U[it.dofs[:, 0::2]])
               + np.einsum("pa,pam->pm", it.dNdx[..., 1], U[it.dofs[:, 1::2]]))
        n = _at_points(soil, "porosity", x[:, 1])
        p = -(soil.soils[0].K_l / n)[:, None] * div * c[None, :]
        return Swings(omega, np.abs(p) / loading.scale(soil, body.size[1]))
    finally:
        destroy(free, M, K, points, grid)


def _at_points(soil, name, y) -> np.ndarray:
    if len(soil.soils) == 1:
        return np.full(len(y), getattr(soil.soils[0], name))
    return soil.at(name, y)


def decay_rates(omega, alpha: float, zeta: float, w1: float) -> np.ndarray:
    """The rate (1/s) at which each mode of ``omega`` (rad/s) decays under local damping
    ``alpha`` (a factor (1 - alpha) / (1 + alpha) per period) and fast-part damping
    ``zeta`` tuned to w1 (rad/s): the oscillating pair of (l^2 + w^2)(l + w1) + 2 zeta w1 l^2
    = 0 (:func:`solver.stepping.inertia.decay`, which takes w = w1)."""
    omega = np.asarray(omega, dtype=float)
    rate = np.zeros_like(omega)
    if zeta > 0 and len(omega):
        # Every mode's cubic at once, as the eigenvalues of its companion matrix (what
        # np.roots solves, one polynomial a call).
        C = np.zeros((len(omega), 3, 3))
        C[:, 0] = np.stack([np.full_like(omega, -w1 * (1 + 2 * zeta)), -omega * omega,
                            -omega * omega * w1], axis=1)
        C[:, 1, 0] = C[:, 2, 1] = 1.0
        roots = np.linalg.eigvals(C)
        pair = np.take_along_axis(roots, np.argmax(np.abs(roots.imag), axis=1)[:, None], 1)
        rate = -pair[:, 0].real
    if alpha > 0:
        rate += math.log((1 + alpha) / (1 - alpha)) * omega / (2 * math.pi)
    return rate


def left(sw: Swings, t: float, S: float, alpha: float, zeta: float, w1: float) -> float:
    """The largest swing of p at time t (s) over the points, in units of the reference
    pressure, with the inertia scaled by S (every w and w1 falls as 1 / sqrt(S)); w1 the
    fast-part damper's tuning (rad/s, physical)."""
    s = math.sqrt(S)
    d = np.exp(-decay_rates(sw.omega / s, alpha, zeta, w1 / s) * t)
    return float(np.max(sw.amplitude @ d)) if len(sw.amplitude) else 0.0
