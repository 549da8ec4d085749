"""A soil that softens with strain and dissipates by hysteresis: the hyperbolic backbone with
Masing's unloading and reloading, as a multi-surface (Iwan) J2 model in total stress.

In simple shear the backbone is

    tau = G gamma / (1 + gamma / gamma_r)          (gamma engineering shear strain)

and the model is Iwan's (1967) parallel one: N elastic-perfectly-plastic J2 elements side
by side, element i of shear modulus G_i and yield stress tau_i in shear, the stress their
sum (the deviator; the mean stress is elastic, bulk modulus K). Each element updates its
deviatoric stress s_i by 2 G_i de and returns radially to its surface |s_i| = sqrt(2) tau_i
(|s| = sqrt(s : s), tensor shear components), which is exact for a perfectly plastic J2
element. In simple shear element i yields at gamma_i = tau_i / G_i, so the model's backbone
is piecewise linear through the points (gamma_i, tau(gamma_i)): the slope between gamma_(i-1)
and gamma_i is the sum of the G_j still elastic, G_i the drop of the backbone's chord
slope at gamma_i (positive: the hyperbola is concave), and beyond the last point the stress
stays at tau(gamma_N). Unloading from any state, every element first unloads elastically
and yields again at twice its own strain: the unloading branch is the backbone scaled by 2
(Masing's rules, in any direction of the deviatoric plane), and the loops' area is the
hysteresis that the closed form (:func:`solver.references.analytic.masing_damping`) gives
for the smooth backbone.

The points gamma_i: ``surfaces`` of them, log-spaced from 1e-3 gamma_r to 1e2 gamma_r, a
multiple of 5 so that 0.01, 0.1, 1, 10 and 100 gamma_r are among them (the backbone is exact
there). The small-strain modulus is the first chord's, G / (1 + gamma_1 / gamma_r): 0.13 %
below G with 40 surfaces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .model import XX, XY, YY, ZZ, Elastic

DECADES = (-3.0, 2.0)       # the surfaces' strains span gamma_r 10^-3 .. 10^2


@dataclass(frozen=True)
class Hyperbolic(Elastic):
    """E (Pa), nu (-) of the small strains, the reference shear strain gamma_r (-,
    engineering) and the number of surfaces."""

    reference_strain: float = 1e-3
    surfaces: int = 40

    @property
    def G(self) -> float:
        return self.E / (2 * (1 + self.nu))

    @property
    def K(self) -> float:
        return self.E / (3 * (1 - 2 * self.nu))

    def backbone(self, gamma) -> np.ndarray:
        """The hyperbola tau (Pa) at engineering shear strains gamma (-)."""
        gamma = np.asarray(gamma, dtype=float)
        return self.G * gamma / (1 + np.abs(gamma) / self.reference_strain)

    def elements(self) -> tuple:
        """(G_i (N,) (Pa), tau_i (N,) (Pa)): the elements' shear moduli and yield stresses."""
        lo, hi = DECADES
        gamma = self.reference_strain * np.logspace(lo, hi, self.surfaces + 1)[1:]
        tau = self.backbone(gamma)
        chords = np.diff(np.concatenate([[0.0], tau])) / np.diff(np.concatenate([[0.0],
                                                                                gamma]))
        G = chords - np.concatenate([chords[1:], [0.0]])
        return G, G * gamma

    def initial_state(self, stress) -> dict:
        """Points at ``stress`` (np, 4): the deviator shared among the elements as their
        stiffnesses share it (elastically), each within its surface."""
        G, tau = self.elements()
        mean = (stress[:, XX] + stress[:, YY] + stress[:, ZZ]) / 3
        dev = stress.copy()
        dev[:, :3] -= mean[:, None]
        s = dev[:, None, :] * (G / G.sum())[None, :, None]
        return {"elements": _to_surfaces(s, tau), "plastic": np.zeros(len(stress), dtype=bool)}

    def update(self, stress, d_strain, state):
        G, tau = self.elements()
        vol = d_strain[:, XX] + d_strain[:, YY] + d_strain[:, ZZ]
        de = d_strain.copy()
        de[:, :3] -= vol[:, None] / 3
        de[:, XY] *= 0.5                                # tensor shear
        trial = state["elements"] + 2 * G[None, :, None] * de[:, None, :]
        s = _to_surfaces(trial, tau)
        mean = (stress[:, XX] + stress[:, YY] + stress[:, ZZ]) / 3 + self.K * vol
        out = s.sum(axis=1)
        out[:, :3] += mean[:, None]
        # Yielding: the stiffest element (the first to yield, at gamma_1) on its surface.
        return out, {"elements": s, "plastic": ~np.all(s == trial, axis=(1, 2))}


def _to_surfaces(s, tau) -> np.ndarray:
    """The element deviators s (np, N, 4) returned radially onto their surfaces
    |s| = sqrt(2) tau_i where beyond them."""
    norm = np.sqrt(s[..., XX] ** 2 + s[..., YY] ** 2 + s[..., ZZ] ** 2 + 2 * s[..., XY] ** 2)
    radius = np.sqrt(2.0) * tau[None, :]
    scale = np.where(norm > radius, radius / np.where(norm > 0, norm, 1.0), 1.0)
    return s * scale[..., None]
