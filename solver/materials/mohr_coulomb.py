"""Mohr-Coulomb plasticity, and Tresca as its frictionless case.

In principal stresses s1 >= s2 >= s3 (tension positive) the yield function and the plastic
potential are

    f = (s1 - s3) + (s1 + s3) sin(phi) - 2 c cos(phi),    g = (s1 - s3) + (s1 + s3) sin(psi)

(phi the friction angle, psi the dilation angle, c the cohesion). The elastic predictor
keeps its principal directions, and every face of the pyramid is a plane, so the return
(de Souza Neto, Peric and Owen 2008, section 8.2) is exact and closed-form:

- onto the main plane: dgamma = f(s_tr) / (n_f . D n_g), s = s_tr - dgamma D n_g, where the
  ordering survives it;
- else onto the edge the returned stress crossed (s1 = s2, or s2 = s3): the two planes
  meeting there, a 2 x 2 linear system for the two multipliers;
- else (phi > 0) onto the apex, s1 = s2 = s3 = c cot(phi).

D is the principal elasticity lambda 1 1^T + 2 G I. Tresca (phi = psi = 0, c the undrained
strength c_u, on total stress) has no apex; its edges always hold.

A tension cutoff t (``tension``, Pa; Rankine planes s_i <= t, associated) adds three planes
to the sector's three. Every surface is still a plane, so the return is still exact: the
first active set, in the order of ACTIVE (faces, edges, corners), whose multipliers are
all non-negative and whose stress lies within every plane and the sector (Koiter's rule
for a corner: s = s_tr - sum_i dgamma_i D m_i over the active planes, A dgamma = f_tr with
A[i, j] = n_i . D m_j). The corner where s1 = s2 = t meets Mohr-Coulomb belongs to four
planes; any three of them with non-negative multipliers give it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .model import Frictional, from_principal, principal


@dataclass(frozen=True)
class MohrCoulomb(Frictional):
    """E (Pa), nu (-), cohesion c (Pa), friction and dilation angles phi, psi (degrees), the
    tension cutoff (Pa; inf: none)."""

    tension: float = math.inf

    def update(self, stress, d_strain, state):
        trial = self.predictor(stress, d_strain)
        s, theta, order = principal(trial)
        new, dgamma = self.principal_return(s)
        yielded = dgamma > 0
        out = trial.copy()
        out[yielded] = from_principal(new[yielded], theta[yielded], order[yielded])
        return out, _history(state, dgamma)

    def update_principal(self, values, state):
        """(the returned stresses, the new state) of trial principal stresses ``values``
        (np, 3) (Pa, in any order; returned in the same): the return without the frame,
        for a caller that has the principal axes already (Hencky's finite strain)."""
        order = np.argsort(-values, axis=1, kind="stable")
        new, dgamma = self.principal_return(np.take_along_axis(values, order, axis=1))
        out = np.empty_like(values)
        np.put_along_axis(out, order, new, axis=1)
        return out, _history(state, dgamma)

    # -- the return in principal stresses -------------------------------------------------
    def principal_return(self, s) -> tuple:
        """(the returned principal stresses (np, 3), the total plastic multiplier (np,))
        of trial principal stresses ``s`` (np, 3), descending."""
        if math.isfinite(self.tension):
            return self._with_cutoff(s)
        sf, cf = math.sin(math.radians(self.phi)), math.cos(math.radians(self.phi))
        sg = math.sin(math.radians(self.psi))
        G = self.E / (2 * (1 + self.nu))
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        D = lam * np.ones((3, 3)) + 2 * G * np.eye(3)
        k = 2 * self.cohesion * cf
        # The three planes that meet the sorted sector: main (1, 3), edge s1 = s2 adds
        # (2, 3), edge s2 = s3 adds (1, 2); their normals n and flow directions m.
        n = np.array([[1 + sf, 0, -1 + sf], [0, 1 + sf, -1 + sf], [1 + sf, -1 + sf, 0]])
        m = np.array([[1 + sg, 0, -1 + sg], [0, 1 + sg, -1 + sg], [1 + sg, -1 + sg, 0]])
        Dm = m @ D                                  # rows: D m_i (D symmetric)
        A = n @ Dm.T                                # A[i, j] = n_i . D m_j
        f = s @ n.T - k                             # (np, 3): each plane at the trial
        scale = np.max(np.abs(s), axis=1) + k
        out, dgamma = s.copy(), np.zeros(len(s))
        yielding = f[:, 0] > 1e-12 * scale
        if not yielding.all():
            # The return of the points that yield alone (in a flow, most do not).
            some = np.flatnonzero(yielding)
            if len(some):
                out[some], dgamma[some] = self.principal_return(s[some])
            return out, dgamma
        # Main plane.
        g = f[:, 0] / A[0, 0]
        main = s - g[:, None] * Dm[0]
        done = yielding & (main[:, 0] >= main[:, 1]) & (main[:, 1] >= main[:, 2])
        out[done], dgamma[done] = main[done], g[done]
        left = yielding & ~done
        # An edge: the plane the main return crossed beside the main one.
        for edge, crossed in ((1, main[:, 1] > main[:, 0]), (2, main[:, 2] > main[:, 1])):
            pick = left & crossed
            if not pick.any():
                continue
            M = A[np.ix_([0, edge], [0, edge])]
            gam = np.linalg.solve(M, f[pick][:, [0, edge]].T).T          # (k, 2)
            cand = s[pick] - gam[:, :1] * Dm[0] - gam[:, 1:] * Dm[edge]
            ok = (gam >= 0).all(axis=1) & (cand[:, 0] >= cand[:, 1] - 1e-9 * scale[pick]) \
                & (cand[:, 1] >= cand[:, 2] - 1e-9 * scale[pick])
            idx = np.flatnonzero(pick)[ok]
            out[idx], dgamma[idx] = cand[ok], gam[ok].sum(axis=1)
            left[idx] = False
        if left.any():
            if sf <= 0:
                raise ArithmeticError("Mohr-Coulomb: a frictionless return left its edges")
            apex = self.cohesion * cf / sf
            p_tr = s[left].mean(axis=1)
            out[left] = apex
            # The multiplier of the volumetric return (for the plastic strain measure).
            K = lam + 2 * G / 3
            dgamma[left] = (p_tr - apex) / (K * 2 * sg) if sg > 0 else \
                np.abs(s[left] - apex).max(axis=1) / (2 * G)
        return out, dgamma


    def _planes(self) -> tuple:
        """(normals n (6, 3), flow directions m (6, 3), constants k (6,), the principal
        elasticity D): the Mohr-Coulomb planes of the sector (main, edge s1 = s2, edge
        s2 = s3) and the tension planes s1, s2, s3 <= t."""
        sf, cf = math.sin(math.radians(self.phi)), math.cos(math.radians(self.phi))
        sg = math.sin(math.radians(self.psi))
        G = self.E / (2 * (1 + self.nu))
        lam = self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))
        D = lam * np.ones((3, 3)) + 2 * G * np.eye(3)
        mc = np.array([[1 + sf, 0, -1 + sf], [0, 1 + sf, -1 + sf], [1 + sf, -1 + sf, 0]])
        flow = np.array([[1 + sg, 0, -1 + sg], [0, 1 + sg, -1 + sg], [1 + sg, -1 + sg, 0]])
        n = np.vstack([mc, np.eye(3)])
        m = np.vstack([flow, np.eye(3)])
        k = np.array([2 * self.cohesion * cf] * 3 + [self.tension] * 3)
        return n, m, k, D

    def _with_cutoff(self, s) -> tuple:
        """principal_return with the tension planes (the module docstring)."""
        n, m, k, D = self._planes()
        Dm = m @ D
        A = n @ Dm.T
        f = s @ n.T - k                                      # (np, 6)
        scale = np.max(np.abs(s), axis=1) + abs(k[0]) + abs(self.tension)
        out, dgamma = s.copy(), np.zeros(len(s))
        left = (f > 1e-12 * scale[:, None]).any(axis=1)
        for active in ACTIVE:
            if not left.any():
                break
            idx = np.flatnonzero(left)
            M = A[np.ix_(active, active)]
            if abs(np.linalg.det(M)) < 1e-12 * np.abs(M).max() ** len(active):
                continue
            gam = np.linalg.solve(M, f[idx][:, active].T).T              # (k, |active|)
            cand = s[idx] - gam @ Dm[active]
            tol = 1e-9 * scale[idx]
            ok = (gam >= -tol[:, None] / np.abs(A).max()).all(axis=1) \
                & ((cand @ n.T - k) <= tol[:, None]).all(axis=1) \
                & (cand[:, 0] >= cand[:, 1] - tol) & (cand[:, 1] >= cand[:, 2] - tol)
            out[idx[ok]], dgamma[idx[ok]] = cand[ok], gam[ok].sum(axis=1)
            left[idx[ok]] = False
        if left.any():
            raise ArithmeticError("Mohr-Coulomb with a tension cutoff: no active set held")
        return out, dgamma


def _history(state, dgamma) -> dict:
    """A point's history after a return of plastic multiplier dgamma (np,)."""
    return {"plastic": dgamma > 0, "eps_p": state["eps_p"] + dgamma}


# The active sets of the return with a tension cutoff, in the order tried: indices into
# _planes (0 main, 1 edge s1 = s2, 2 edge s2 = s3; 3, 4, 5 the tension planes s1, s2, s3).
ACTIVE = ([0], [3], [0, 1], [0, 2], [3, 4], [0, 3], [0, 2, 3], [0, 3, 4], [1, 3, 4],
          [0, 1, 3], [3, 4, 5])


def tresca(E: float, nu: float, c_u: float) -> MohrCoulomb:
    """Tresca: undrained strength c_u (Pa) on total stress, Mohr-Coulomb with phi = psi = 0."""
    return MohrCoulomb(E, nu, c_u, 0.0, 0.0)
