"""The materials room against the soil tests' closed forms (compression positive)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from solver.materials import soiltest
from solver.materials.cam_clay import CamClay
from solver.materials.drucker_prager import DruckerPrager
from solver.materials.model import Elastic, isotropic, tangent
from solver.materials.mohr_coulomb import MohrCoulomb, tresca


def Kp(phi):
    return math.tan(math.radians(45 + phi / 2)) ** 2


@pytest.mark.parametrize("phi", [0.0, 20.0, 30.0, 40.0])
def test_plane_strain_unconfined_compression_mohr_coulomb(phi):
    """sigma_1 = 2 c tan(45 + phi / 2): the return onto the main plane is exact."""
    m = MohrCoulomb(E=20e6, nu=0.3, cohesion=10e3, phi=phi, psi=phi)
    r = soiltest.run(m, "plane-strain", 0.0, 0.02, 100)
    assert r["q_pa"].max() == pytest.approx(2 * 10e3 * math.sqrt(Kp(phi)), rel=1e-9)


@pytest.mark.parametrize("phi,psi", [(30.0, 30.0), (30.0, 0.0), (35.0, 10.0)])
def test_drained_triaxial_cohesionless(phi, psi):
    """q_f = (K_p - 1) sigma_3 on the edge s2 = s3 (triaxial compression), associated or
    not."""
    m = MohrCoulomb(E=20e6, nu=0.25, cohesion=0.0, phi=phi, psi=psi)
    r = soiltest.run(m, "triaxial-drained", 100e3, 0.05, 100)
    assert r["q_pa"][-1] == pytest.approx((Kp(phi) - 1) * 100e3, rel=1e-9)


def test_tresca_undrained_strength():
    """Tresca on total stress in undrained triaxial compression: q = 2 c_u."""
    r = soiltest.run(tresca(10e6, 0.49, 20e3), "triaxial-undrained", 100e3, 0.02, 50)
    assert r["q_pa"][-1] == pytest.approx(40e3, rel=1e-9)


def test_drucker_prager_matches_mohr_coulomb_in_plane_strain():
    """The plane-strain match: the cone's unconfined plane-strain strength is Mohr-Coulomb's
    2 c tan(45 + phi / 2)."""
    d = DruckerPrager(E=20e6, nu=0.3, cohesion=10e3, phi=30.0, psi=30.0)
    r = soiltest.run(d, "plane-strain", 0.0, 0.05, 200)
    assert r["q_pa"][-1] == pytest.approx(2 * 10e3 * math.sqrt(Kp(30.0)), rel=1e-6)


def test_cam_clay_undrained_and_drained():
    """Normally consolidated from p'_0: undrained p'_f = p'_0 2^(-(lambda - kappa) / lambda)
    and q_f = M p'_f (exact for the ln p' elasticity); drained with sigma_3 held,
    p'_f = 3 p'_0 / (3 - M) (reached asymptotically: within 0.1 % at 100 % axial strain)."""
    c = CamClay(M=1.2, lam=0.2, kappa=0.04, e0=1.0, nu=0.3)
    r = soiltest.run(c, "triaxial-undrained", 100e3, 0.3, 1500)
    pf = 100e3 * 2 ** (-(0.2 - 0.04) / 0.2)
    assert r["p_eff_pa"][-1] == pytest.approx(pf, rel=1e-6)
    assert r["q_pa"][-1] == pytest.approx(1.2 * pf, rel=1e-6)
    # The water takes what the skeleton lets go: u = p_total - p'.
    p_total = 100e3 + r["q_pa"][-1] / 3
    assert r["excess_pore_pressure_pa"][-1] == pytest.approx(p_total - pf, rel=1e-6)
    r = soiltest.run(c, "triaxial-drained", 100e3, 1.0, 2000)
    assert r["p_eff_pa"][-1] == pytest.approx(3 * 100e3 / (3 - 1.2), rel=1e-3)
    assert r["q_pa"][-1] / r["p_eff_pa"][-1] == pytest.approx(1.2, rel=1e-3)


def test_tangent_is_the_elastic_matrix_inside_and_consistent_on_yield():
    """Inside the surface the tangent is D; on it, one Newton step on the stress from the
    tangent predicts the update to second order in the strain change."""
    stress = np.array([[-50e3, -80e3, -50e3, 5e3]])
    e = Elastic(20e6, 0.3)
    D = tangent(e, stress, np.array([[1e-5, -2e-5, 0, 1e-5]]), e.initial_state(stress))
    assert np.allclose(D[0], isotropic(20e6, 0.3), rtol=1e-7)
    m = MohrCoulomb(20e6, 0.3, 5e3, 30.0, 10.0)
    state = m.initial_state(stress)
    d = np.array([[2e-3, -4e-3, 0.0, 1e-3]])
    sig, st = m.update(stress, d, state)
    assert st["plastic"][0]
    T = tangent(m, stress, d, state)[0]
    errors = []
    for h in (1e-5, 5e-6):
        dd = d + h * np.array([[1.0, 0.5, 0.0, -0.3]])
        exact, _ = m.update(stress, dd, state)
        errors.append(np.abs(exact[0] - sig[0] - T @ (dd - d)[0]).max())
    assert errors[1] < errors[0] / 3        # second order: a quarter


def test_points_are_independent():
    """One call over many points gives each point's own update (vectorised returns)."""
    rng = np.random.default_rng(3)
    stress = -rng.uniform(10e3, 200e3, (50, 4))
    stress[:, 3] = rng.normal(0, 20e3, 50)
    d = rng.normal(0, 2e-3, (50, 4))
    for m in (MohrCoulomb(20e6, 0.3, 5e3, 30.0, 5.0), DruckerPrager(20e6, 0.3, 5e3, 25.0, 0.0),
              CamClay(1.1, 0.2, 0.04, 1.0, 0.3, 1.5)):
        state = m.initial_state(stress)
        together, _ = m.update(stress, d, state)
        for k in (0, 17, 49):
            one = {key: v[k:k + 1] for key, v in state.items()}
            alone, _ = m.update(stress[k:k + 1], d[k:k + 1], one)
            assert np.allclose(alone[0], together[k], rtol=1e-12, atol=1e-6)


def test_a_tension_cutoff_caps_the_largest_principal_stress():
    """Mohr-Coulomb (c 10 kPa, phi = psi = 30) with a cutoff t = 2 kPa: pulled in plane
    strain (d eps_xx > 0 alone) sigma_xx stops at t exactly, the others at the elastic
    share nu / (1 - nu) t of it; over 20,000 random trial stresses every return lies within
    every plane (to 1e-9 of the stresses), and where the cutoff does not act it is the
    return without one (to 1e-9)."""
    m = MohrCoulomb(10e6, 0.3, 10e3, 30.0, 30.0, tension=2e3)
    stress, state = np.zeros((1, 4)), m.initial_state(np.zeros((1, 4)))
    for _ in range(100):
        stress, state = m.update(stress, np.array([[2e-5, 0, 0, 0]]), state)
    assert stress[0, 0] == pytest.approx(2e3, rel=1e-12)
    assert stress[0, 1] == pytest.approx(0.3 / 0.7 * 2e3, rel=1e-9) and state["plastic"][0]
    rng = np.random.default_rng(1)
    s = np.sort(rng.normal(0, 60e3, (20000, 3)), axis=1)[:, ::-1]
    cut, _ = m.principal_return(s)
    plain, _ = MohrCoulomb(10e6, 0.3, 10e3, 30.0, 30.0).principal_return(s)
    n, _, k, _ = m._planes()
    scale = np.abs(s).max()
    assert (cut @ n.T - k).max() <= 1e-9 * scale
    free = plain[:, 0] <= 2e3
    assert np.abs(cut[free] - plain[free]).max() <= 1e-9 * scale


def test_a_tension_cutoff_on_other_models_is_refused():
    from solver.common.errors import InputError
    from solver.materials import catalog

    with pytest.raises(InputError, match="only tresca and mohr-coulomb"):
        catalog.make("drucker-prager", 10e6, 0.3, 1e3, 30.0, tension=1e3)
    assert catalog.make("tresca", 10e6, 0.49, 5e3, tension=0.0).tension == 0.0
