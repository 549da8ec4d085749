"""Hencky's finite-strain elasticity with the materials' returns in principal logarithmic
strain (solver/materials/hencky.py): exact objectivity under a rigid rotation, the closed
form of a large one-dimensional compression, and a return that stays on Mohr-Coulomb's
surface at finite strain."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.materials.hencky import Hencky
from solver.materials.model import Elastic, invariants, principal
from solver.materials.mohr_coulomb import MohrCoulomb


def rotation(angle: float, n: int = 1) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.tile(np.array([[c, -s], [s, c]]), (n, 1, 1))


@pytest.mark.parametrize("material", [Elastic(10e6, 0.3), MohrCoulomb(10e6, 0.3, 5e3, 30.0,
                                                                        10.0)])
def test_a_rigid_rotation_turns_the_stress_and_keeps_its_invariants(material):
    """A point stretched (1.02, 0.97; Mohr-Coulomb yields there) then turned rigidly by 90
    degrees in 100 steps: p and q stay to 1e-10, and the stress is the first one turned
    (sigma_xx and sigma_yy swap, to 1e-9 of the stress)."""
    h = Hencky(material)
    state = h.initial_state(1)
    sigma0, state = h.update(np.array([[[1.02, 0.0], [0.0, 0.97]]]), state)
    p0, q0 = invariants(sigma0)
    sigma = sigma0
    for _ in range(100):
        sigma, state = h.update(rotation(math.pi / 200), state)
    p, q = invariants(sigma)
    assert p[0] == pytest.approx(p0[0], rel=1e-10) and q[0] == pytest.approx(q0[0], rel=1e-10)
    scale = np.abs(sigma0).max()
    assert abs(sigma[0, 0] - sigma0[0, 1]) < 1e-9 * scale
    assert abs(sigma[0, 1] - sigma0[0, 0]) < 1e-9 * scale
    assert abs(sigma[0, 2] - sigma0[0, 2]) < 1e-9 * scale and abs(sigma[0, 3]) < 1e-9 * scale


def test_a_large_one_dimensional_compression_follows_hencky():
    """Compressed to 0.6 of its height in 40 steps with no lateral strain: the Kirchhoff
    stress is D ln(0.6) exactly (tau_yy = (lambda + 2 G) ln 0.6, the others lambda ln 0.6),
    the Cauchy stress tau / J with J = 0.6 (to 1e-12)."""
    E, nu = 10e6, 0.3
    h = Hencky(Elastic(E, nu))
    state = h.initial_state(1)
    step = 0.6 ** (1 / 40)
    for _ in range(40):
        sigma, state = h.update(np.array([[[1.0, 0.0], [0.0, step]]]), state)
    lam = E * nu / ((1 + nu) * (1 - 2 * nu))
    G = E / (2 * (1 + nu))
    e = math.log(0.6)
    assert state["J"][0] == pytest.approx(0.6, rel=1e-12)
    assert sigma[0, 1] == pytest.approx((lam + 2 * G) * e / 0.6, rel=1e-12)
    assert sigma[0, 0] == pytest.approx(lam * e / 0.6, rel=1e-12)
    assert sigma[0, 2] == pytest.approx(lam * e / 0.6, rel=1e-12)


def test_mohr_coulomb_at_finite_strain_stays_on_its_surface():
    """Simple shear to gamma = 0.5 under a confining stress (first an isotropic compression
    to J = 0.98): the Kirchhoff stress lies on Mohr-Coulomb's surface (f within 1e-9 of
    the stress) once it yields, and the volume ratio is det F."""
    m = MohrCoulomb(10e6, 0.3, 2e3, 30.0, 30.0)
    h = Hencky(m)
    state = h.initial_state(1)
    squeeze = math.sqrt(0.98)
    sigma, state = h.update(np.array([[[squeeze, 0.0], [0.0, squeeze]]]), state)
    for _ in range(50):
        sigma, state = h.update(np.array([[[1.0, 0.01], [0.0, 1.0]]]), state)
    tau = sigma * state["J"][:, None]
    s, _, _ = principal(tau)
    sf, cf = math.sin(math.radians(30)), math.cos(math.radians(30))
    f = (s[:, 0] - s[:, 2]) + (s[:, 0] + s[:, 2]) * sf - 2 * 2e3 * cf
    assert state["plastic"][0] and abs(f[0]) < 1e-9 * np.abs(tau).max()
    assert state["J"][0] == pytest.approx(0.98, rel=1e-12)


def test_the_principal_return_is_the_framed_one():
    """Mohr-Coulomb's return without the frame (update_principal, which Hencky takes) gives
    the stresses and history of its framed update, on points that yield and points that
    do not, in every order of the principal values."""
    mc = MohrCoulomb(1e7, 0.3, 5e3, 30.0, 5.0)
    rng = np.random.default_rng(3)
    n = 400
    f = np.eye(2)[None] + 0.02 * rng.standard_normal((n, 2, 2))
    framed = Hencky(mc)
    state = framed.initial_state(n)

    class Framed:                    # the same material, its update_principal hidden
        def __getattr__(self, name):
            if name == "update_principal":
                raise AttributeError(name)
            return getattr(mc, name)

    plain = Hencky(Framed())
    a, sa = framed.update(f, state)
    b, sb = plain.update(f, state)
    assert 0 < sa["plastic"].sum() < n
    np.testing.assert_allclose(a, b, rtol=0, atol=1e-9 * np.abs(b).max())
    np.testing.assert_array_equal(sa["plastic"], sb["plastic"])
    np.testing.assert_allclose(sa["eps_p"], sb["eps_p"], rtol=1e-12, atol=1e-18)
