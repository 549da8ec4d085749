"""Modified Cam Clay (Roscoe and Burland 1968) with a pressure-dependent bulk modulus.

With p' and q (compression positive) and the preconsolidation pressure p_c:

    f = q^2 / M^2 + p' (p' - p_c)

Elastic volume change follows kappa in e - ln p' (p' = p'_n exp((1 + e0) d eps_v^e / kappa),
exactly: the bulk modulus (1 + e0) p' / kappa), the shear modulus G = 3 K (1 - 2 nu) /
(2 (1 + nu)) with K at the step's start; p_c hardens with the plastic volume change,
p_c = p_c,n exp((1 + e0) d eps_v^p / (lambda - kappa)) (small strain: the specific volume
1 + e0 throughout). The return is implicit (Borja and Lee 1990): with the multiplier
dgamma, d eps_v^p = dgamma (2 p' - p_c) and q = q_tr / (1 + 6 G dgamma / M^2) (radial in
the deviatoric plane); Newton on (p', p_c, dgamma) until f = 0 to 1e-12 relative.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import XY, invariants


@dataclass(frozen=True)
class CamClay:
    """M (-), lam and kappa (-, slopes in e - ln p'), e0 (-), nu (-), ocr (-: p_c over the
    initial mean effective stress)."""

    M: float
    lam: float
    kappa: float
    e0: float
    nu: float = 0.3
    ocr: float = 1.0

    def initial_state(self, stress) -> dict:
        """p_c is ``ocr`` times that of the yield surface through the stress (a geostatic
        start's q > 0 lies on the normally consolidated surface, not outside it)."""
        p, q = invariants(stress)
        through = p + np.divide(q * q, self.M ** 2 * p, out=np.zeros_like(p), where=p > 0)
        return {"plastic": np.zeros(len(stress), dtype=bool), "p_c": self.ocr * through,
                "eps_p": np.zeros(len(stress))}

    def update(self, stress, d_strain, state):
        v = 1 + self.e0
        p_n, _ = invariants(stress)
        K = v * p_n / self.kappa
        G = 3 * K * (1 - 2 * self.nu) / (2 * (1 + self.nu))
        dv = -(d_strain[:, 0] + d_strain[:, 1] + d_strain[:, 2])       # compression +
        p_tr = p_n * np.exp(v * dv / self.kappa)
        dev = stress.copy()
        dev[:, :3] += p_n[:, None]
        e = d_strain.copy()
        e[:, :3] += dv[:, None] / 3
        s_tr = dev + 2 * G[:, None] * e * np.array([1, 1, 1, 0.5])
        q_tr = np.sqrt(1.5 * np.sum(s_tr[:, :3] ** 2, axis=1) + 3 * s_tr[:, XY] ** 2)
        pc_n = state["p_c"]
        M2 = self.M ** 2
        f = q_tr ** 2 / M2 + p_tr * (p_tr - pc_n)
        yielding = f > 1e-12 * pc_n ** 2
        p, pc, dg = p_tr.copy(), pc_n.copy(), np.zeros_like(p_tr)
        if yielding.any():
            p[yielding], pc[yielding], dg[yielding] = self._return(
                p_tr[yielding], q_tr[yielding], pc_n[yielding], 6 * G[yielding] / M2)
        q = q_tr / (1 + 6 * G * dg / M2)
        ratio = np.divide(q, q_tr, out=np.zeros_like(q), where=q_tr > 0)
        out = s_tr * ratio[:, None]
        out[:, :3] -= p[:, None]
        return out, {"plastic": yielding, "p_c": pc,
                     "eps_p": state["eps_p"] + dg * np.abs(2 * p - pc)}

    def _return(self, p_tr, q_tr, pc_n, c):
        """(p', p_c, dgamma) of the yielding points: Newton on the three equations of the
        module docstring (c = 6 G / M^2)."""
        te, tp = (1 + self.e0) / self.kappa, (1 + self.e0) / (self.lam - self.kappa)
        M2 = self.M ** 2
        p, pc, dg = p_tr.copy(), pc_n.copy(), np.zeros_like(p_tr)
        for _ in range(60):
            a = dg * (2 * p - pc)
            E1, E2 = p_tr * np.exp(-te * a), pc_n * np.exp(tp * a)
            q = q_tr / (1 + c * dg)
            r = np.stack([p - E1, pc - E2, q * q / M2 + p * (p - pc)], axis=1)
            if np.all(np.abs(r) <= 1e-12 * pc_n[:, None] * np.array([1, 1, pc_n.max()])):
                break
            da = np.stack([2 * dg, -dg, 2 * p - pc], axis=1)          # d a / d (p, pc, dg)
            J = np.empty((len(p), 3, 3))
            J[:, 0] = te * E1[:, None] * da
            J[:, 0, 0] += 1
            J[:, 1] = -tp * E2[:, None] * da
            J[:, 1, 1] += 1
            J[:, 2] = np.stack([2 * p - pc, -p, -2 * q * q * c / (M2 * (1 + c * dg))], axis=1)
            step = np.linalg.solve(J, -r[..., None])[..., 0]
            p, pc, dg = p + step[:, 0], pc + step[:, 1], np.maximum(dg + step[:, 2], 0.0)
        else:
            raise ArithmeticError("Modified Cam Clay: the return did not converge")
        return p, pc, dg
