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

The points gamma_i: ``surfaces`` of them from 1e-3 gamma_r to 1e2 gamma_r, spaced so that
every chord errs alike: a chord over [x, r x] (x = gamma / gamma_r) lies below the hyperbola
by about x (r - 1)^2 / (4 (1 + x)^2) of it, so the spacing d(ln x) goes as (1 + x) /
sqrt(x), dense about gamma_r and sparse at both ends; the points are those where
arctan(sqrt(x)) steps evenly, within each decade (so that 0.01, 0.1, 1, 10 and 100 gamma_r
are among them: the backbone exact there). 25 surfaces keep the whole backbone within 0.5 %
(40 log-spaced ones within 0.5 %, at 1.6 times the cost a step). The small-strain modulus is the
first chord's, G / (1 + 1e-3): 0.1 % below G.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit

from .model import XX, XY, YY, ZZ, Elastic

SPAN = (1e-3, 1e2)          # the surfaces' strains span gamma_r 10^-3 .. 10^2
DECADES = 5


@dataclass(frozen=True)
class Hyperbolic(Elastic):
    """E (Pa), nu (-) of the small strains, the reference shear strain gamma_r (-,
    engineering) and the number of surfaces."""

    reference_strain: float = 1e-3
    surfaces: int = 25

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
        gamma = self.reference_strain * strains(self.surfaces)
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
        out, s = stress.copy(), state["elements"].copy()
        plastic = iwan(out, d_strain, s, G[None], np.sqrt(2.0) * tau[None],
                       np.array([self.K]), np.zeros(len(stress), dtype=np.int64))
        return out, {"elements": s, "plastic": plastic}


def strains(count: int) -> np.ndarray:
    """The ``count`` (>= 6) yield strains x_i = gamma_i / gamma_r: 1e-3 and the decades up to
    1e2, the rest shared among the decades as the width of arctan(sqrt(x)) over each
    (largest remainders), evenly in arctan(sqrt(x)) within its decade."""
    ends = np.logspace(np.log10(SPAN[0]), np.log10(SPAN[1]), DECADES + 1)
    theta = np.arctan(np.sqrt(ends))
    share = (count - 1) * np.diff(theta) / (theta[-1] - theta[0])
    each = np.maximum(np.floor(share).astype(int), 1)
    for k in np.argsort(each - share)[:count - 1 - each.sum()]:
        each[k] += 1
    inner = [np.linspace(theta[d], theta[d + 1], n + 1)[1:] for d, n in enumerate(each)]
    return np.concatenate([[SPAN[0]], np.tan(np.concatenate(inner)) ** 2])


def tables(materials) -> tuple:
    """(G_i (L, N), the surfaces' radii sqrt(2) tau_i (L, N), the bulk moduli (L,)) (Pa) of
    the hyperbolic ``materials`` of L layers, all of N surfaces: what :func:`iwan` takes."""
    if len({m.surfaces for m in materials}) != 1:
        raise ValueError("the layers' hyperbolic soils differ in their surfaces")
    G, tau = (np.array(a) for a in zip(*(m.elements() for m in materials)))
    return G, np.sqrt(2.0) * tau, np.array([m.K for m in materials])


@njit(cache=True)
def iwan(stress, d_strain, elements, G, radius, K, layer):
    """The Iwan update of every point in place: ``stress`` (np, 4) (Pa), ``elements`` (np,
    N, 4) the elements' deviators (Pa), under ``d_strain`` (np, 4) (engineering shear);
    point p's layer ``layer[p]`` picks its row of ``G``, ``radius`` (L, N) and ``K`` (L,)
    (:func:`tables`). Returns whether a point's elements yielded (np,)."""
    plastic = np.zeros(stress.shape[0], dtype=np.bool_)
    for p in range(stress.shape[0]):
        plastic[p] = _point(stress[p], d_strain[p, 0], d_strain[p, 1], d_strain[p, 2],
                            d_strain[p, 3], elements[p], G[layer[p]], radius[layer[p]],
                            K[layer[p]])
    return plastic


@njit(cache=True)
def iwan_plane(eps, strain, stress, elements, G, radius, K, layer, volume, out):
    """:func:`iwan` of points in plane strain moved to the strains ``eps`` (np, 3) (xx, yy,
    2 xy) from ``strain`` (np, 3), which takes them; ``out`` (np, 3) the in-plane stresses
    times the points' volumes ``volume`` (np,) (N m per m depth: what B^T spreads). One
    pass, no temporaries: the shaken body's step calls it every step."""
    for p in range(stress.shape[0]):
        lay = layer[p]
        _point(stress[p], eps[p, 0] - strain[p, 0], eps[p, 1] - strain[p, 1], 0.0,
               eps[p, 2] - strain[p, 2], elements[p], G[lay], radius[lay], K[lay])
        for k in range(3):
            strain[p, k] = eps[p, k]
        out[p, 0] = stress[p, 0] * volume[p]
        out[p, 1] = stress[p, 1] * volume[p]
        out[p, 2] = stress[p, 3] * volume[p]


@njit(cache=True, inline="always")
def _point(stress, dxx, dyy, dzz, gxy, elements, G, radius, K):
    """One point's update (its stress (4,), elements (N, 4), its layer's G, radius (N,)
    and K): each element takes 2 G_i de and returns radially onto |s_i| <= radius_i; the
    deviator is their sum, the mean stress elastic. Whether an element yielded."""
    vol = dxx + dyy + dzz
    e0, e1, e2, e3 = dxx - vol / 3, dyy - vol / 3, dzz - vol / 3, 0.5 * gxy
    mean = (stress[0] + stress[1] + stress[2]) / 3 + K * vol
    s0 = s1 = s2 = s3 = 0.0
    yielded = False
    for i in range(elements.shape[0]):
        g2 = 2.0 * G[i]
        a = elements[i, 0] + g2 * e0
        b = elements[i, 1] + g2 * e1
        c = elements[i, 2] + g2 * e2
        d = elements[i, 3] + g2 * e3
        norm = np.sqrt(a * a + b * b + c * c + 2.0 * d * d)
        if norm > radius[i]:
            f = radius[i] / norm
            a, b, c, d = a * f, b * f, c * f, d * f
            yielded = True
        elements[i, 0], elements[i, 1], elements[i, 2], elements[i, 3] = a, b, c, d
        s0, s1, s2, s3 = s0 + a, s1 + b, s2 + c, s3 + d
    stress[0], stress[1], stress[2], stress[3] = s0 + mean, s1 + mean, s2 + mean, s3
    return yielded


def _to_surfaces(s, tau) -> np.ndarray:
    """The element deviators s (np, N, 4) returned radially onto their surfaces
    |s| = sqrt(2) tau_i where beyond them."""
    norm = np.sqrt(s[..., XX] ** 2 + s[..., YY] ** 2 + s[..., ZZ] ** 2 + 2 * s[..., XY] ** 2)
    radius = np.sqrt(2.0) * tau[None, :]
    scale = np.where(norm > radius, radius / np.where(norm > 0, norm, 1.0), 1.0)
    return s * scale[..., None]
