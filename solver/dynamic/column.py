"""A soil body shaken at its base: explicit one-phase dynamics on the material points (issue
30, the numerical core of the coming ``-mpm_analysis dynamic``).

One phase (the solid with the mixture's density, a dry or total-stress analysis), linear
elastic, small strain: the points stay where they are, so the step is the eigen model's own
K (``scene.build``: the same points, the same integration) and its mass lumped by diagonal
scaling (HRZ, positive for every cell), with Rayleigh damping C = a0 M + a1 K:

    m a = f(t) - K u - a0 m v - a1 K v,     central differences (v at half steps)

The base moves in one direction (``x``: vertically propagating shear waves, the sides held
vertically; ``y``: compression waves, the sides on rollers):
- ``rigid``: the input is the motion of the base itself (a "within" motion). In the frame
  of the base, u_rel = u - u_b, the base is fixed and every mass feels -m a_b(t); the
  absolute acceleration is the relative one plus a_b;
- ``compliant``: an elastic half-space under the soil (rho_r, V_r: Vs_r for x, Vp_r for y),
  a Lysmer-Kuhlemeyer dashpot rho_r V_r on each base node's share of the base, driven by
  the rock's outcrop motion: the incident wave is half of it, applied as the force
  2 rho_r V_r v_inc = rho_r V_r v_outcrop. The dashpot is taken implicitly (explicit, it is
  unstable once dt rho_r V_r A / m exceeds 2, which the wave step reaches).

The step: dt = SAFETY (2 / w_max)(sqrt(1 + xi^2) - xi), w_max^2 <= max_i sum_j |K_ij| / m_i
(Gershgorin: a bound, so the step is stable) and xi = a0 / (2 w_max) + a1 w_max / 2 the
damping of the fastest mode. Vectors are PETSc Vecs over the free DOFs, one MatMult a step.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from petsc4py import PETSc

from ..common.errors import InputError
from ..model import scene
from ..model.scene import Body, Loading, top_forces

SAFETY = 0.9


@dataclasses.dataclass(frozen=True)
class Shaking:
    """How the base moves: ``direction`` x | y, ``base`` rigid | compliant, the rock
    (``rock_rho`` kg/m3, ``rock_speed`` m/s: Vs for x, Vp for y; compliant only) and the
    Rayleigh coefficients (a0 1/s, a1 s)."""

    direction: str = "x"
    base: str = "compliant"
    rock_rho: float = 0.0
    rock_speed: float = 0.0
    a0: float = 0.0
    a1: float = 0.0

    def __post_init__(self):
        if self.direction not in ("x", "y"):
            raise InputError(f"base direction {self.direction!r}: x or y")
        if self.base not in ("rigid", "compliant"):
            raise InputError(f"base {self.base!r}: rigid or compliant")
        if self.base == "compliant" and not (self.rock_rho > 0 and self.rock_speed > 0):
            raise InputError("a compliant base needs the rock's density and wave speed > 0")
        if self.a0 < 0 or self.a1 < 0:
            raise InputError("Rayleigh coefficients must be >= 0")

    def supports(self) -> tuple:
        """The sides' fixed components: the other direction held everywhere on the sides,
        the base fixed in both (rigid) or in the other direction only (compliant)."""
        other = "y" if self.direction == "x" else "x"
        bottom = "xy" if self.base == "rigid" else other
        return (("left", other), ("right", other), ("bottom", bottom), ("top", "none"))


def rayleigh(xi: float, f1: float, f2: float) -> tuple:
    """(a0, a1) of Rayleigh damping with ratio xi at f1 and f2 (Hz)."""
    w1, w2 = 2 * math.pi * f1, 2 * math.pi * f2
    return 2 * xi * w1 * w2 / (w1 + w2), 2 * xi / (w1 + w2)


class ShakenBody:
    """The body of ``body`` (its grid, points, cells; its supports replaced by
    :meth:`Shaking.supports`) made of ``soil`` on ``comm``, shaken as ``shaking`` says.
    :meth:`run` steps it. The caller destroys it."""

    def __init__(self, comm, body: Body, soil, shaking: Shaking):
        self.shaking = shaking
        body = dataclasses.replace(body, bcs=shaking.supports())
        self.body = body
        self.grid, self.points, self.K, M, self.free = scene.build(comm, body, soil)
        self.m = self._lumped(M)
        M.destroy()
        idx = self.free.getIndices()
        comp = 0 if shaking.direction == "x" else 1
        node = idx // 2
        nx = self.grid.nodes[0]
        j, i = node // nx, node % nx
        along = (idx % 2) == comp
        self.top = along & (j == self.grid.nodes[1] - 1)
        self.along = along
        self.base = along & (j == 0)
        self.c = np.zeros(len(idx))
        if shaking.base == "compliant":
            share = top_forces(self.grid, Loading(load=1.0))   # int N ds of each base node
            self.c[self.base] = shaking.rock_rho * shaking.rock_speed * share[i[self.base]]
        self.dt = self._stable_step()

    def _lumped(self, M) -> np.ndarray:
        """HRZ: M's diagonal scaled so that each direction keeps the body's mass."""
        d = M.getDiagonal()
        total = M.createVecLeft()
        ones = M.createVecRight()
        ones.set(1.0)
        M.mult(ones, total)
        diag, rows = d.getArray().copy(), total.getArray().copy()
        comm = self.K.getComm().tompi4py()
        scale = comm.allreduce(float(rows.sum())) / comm.allreduce(float(diag.sum()))
        for v in (d, total, ones):
            v.destroy()
        return diag * scale

    def _stable_step(self) -> float:
        ai, _, av = self.K.getValuesCSR()
        rowsum = np.add.reduceat(np.abs(av), ai[:-1]) if len(av) else np.zeros(0)
        local = float(np.max(rowsum / self.m)) if len(rowsum) else 0.0
        w = math.sqrt(self.K.getComm().tompi4py().allreduce(local, op=_max()))
        sh = self.shaking
        xi = sh.a0 / (2 * w) + sh.a1 * w / 2
        return SAFETY * 2 / w * (math.sqrt(1 + xi * xi) - xi)

    def run(self, t_end: float, velocity, acceleration, dt: float | None = None) -> dict:
        """Step to ``t_end`` (s) under the base motion, given as functions of time (s): its
        ``velocity`` (m/s) and ``acceleration`` (m/s2) (the outcrop's for a compliant base,
        the base's own for a rigid one). Returns {"t": times (s), "surface": the mean
        absolute acceleration of the top nodes in the shaking direction (m/s2), "base": the
        base's}, on every rank."""
        dt = dt or self.dt
        n = int(math.ceil(t_end / dt - 1e-9))
        sh, m, c = self.shaking, self.m, self.c
        u, v, f, Kv = (self.K.createVecRight() for _ in range(4))
        ua, va = u.getArray(), v.getArray()
        mpi = self.K.getComm().tompi4py()
        ntop, nbase = (mpi.allreduce(int(np.sum(mask))) for mask in (self.top, self.base))
        t = dt * np.arange(n + 1)
        surface, base = np.zeros(n + 1), np.zeros(n + 1)
        rigid = sh.base == "rigid"
        for k in range(n + 1):
            # The forces at t_k move v from t_k - dt/2 to t_k + dt/2: the acceleration
            # (v' - v) / dt is that of t_k.
            self.K.mult(u, f)
            fa = -f.getArray()
            if sh.a1:
                self.K.mult(v, Kv)
                fa -= sh.a1 * Kv.getArray()
            if rigid:
                fa[self.along] -= m[self.along] * acceleration(t[k])
            fa += c * velocity(t[k] + dt / 2)
            old = va.copy()
            # The dashpot (c) implicit, the rest explicit: v' = (m v + dt f) / (m + dt c).
            va[:] = (m * (1 - dt * sh.a0) * va + dt * fa) / (m + dt * c)
            ua += dt * va
            a = (va - old) / dt
            a_abs = a + (acceleration(t[k]) if rigid else 0.0)
            surface[k] = mpi.allreduce(float(np.sum(a_abs[self.top]))) / ntop
            base[k] = (acceleration(t[k]) if rigid else
                       mpi.allreduce(float(np.sum(a[self.base]))) / nbase)
        for vec in (u, v, f, Kv):
            vec.destroy()
        return {"t": t, "surface": surface, "base": base, "dt": dt}

    def destroy(self):
        scene.destroy(self.K, self.free, self.points, self.grid)


def _max():
    from mpi4py import MPI

    return MPI.MAX
