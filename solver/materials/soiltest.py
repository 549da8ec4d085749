"""One material point through a laboratory test's path (compression positive in what the
tests report, tension positive inside, as the materials take it).

Each test prescribes the axial strain (yy) in equal steps and holds the other components
as the apparatus does:

- ``triaxial-drained``: the radial stress at the confining pressure; the radial strain (xx,
  and zz the same: axisymmetric) found by Newton on the point's tangent;
- ``triaxial-undrained``: no volume change (radial strain -axial / 2); the excess pore
  pressure is what keeps the total radial stress at the confining pressure;
- ``plane-strain``: eps_zz = 0, sigma_xx at the confining pressure (Newton on eps_xx);
- ``oedometer``: eps_xx = eps_zz = 0;
- ``simple-shear``: eps_yy = 0 and the shear strain 2 eps_xy prescribed instead;
- ``simple-shear-cyclic``: the same, the shear strain taken to the amplitude and then
  through full cycles between -amplitude and +amplitude (the steps per cycle given);
  :func:`last_cycle` measures the last one's secant modulus and damping ratio.
"""

from __future__ import annotations

import numpy as np

from .model import XX, XY, YY, ZZ, invariants, tangent

TESTS = ("triaxial-drained", "triaxial-undrained", "plane-strain", "oedometer",
         "simple-shear", "simple-shear-cyclic")


def shear_path(amplitude: float, steps: int, cycles: int) -> np.ndarray:
    """The cyclic test's shear strains after each step: to ``amplitude`` in a quarter of
    ``steps`` (the steps per cycle, a multiple of 4 at least), then ``cycles`` full cycles
    down to -amplitude and back."""
    q = max(1, steps // 4)
    parts = [np.linspace(0.0, amplitude, q + 1)[1:]]
    for _ in range(cycles):
        parts += [np.linspace(amplitude, -amplitude, 2 * q + 1)[1:],
                  np.linspace(-amplitude, amplitude, 2 * q + 1)[1:]]
    return np.concatenate(parts)


def run(material, test: str, confining: float, strain_end: float, steps: int,
        cycles: int = 1) -> dict:
    """The path of ``material`` through ``test`` from the isotropic effective stress
    ``confining`` (Pa, compression positive) to the axial (or shear) strain ``strain_end``
    (compression positive) in ``steps`` steps (the cyclic test: ``strain_end`` its
    amplitude, ``steps`` per cycle, :func:`shear_path`): arrays per step (the start
    included) of the axial and volumetric strain, p', q (Pa; plane strain: sigma_1 -
    sigma_3), the excess pore pressure (Pa) and the stresses (np, 4) (compression
    positive)."""
    stress = np.full((1, 4), -float(confining))
    stress[0, XY] = 0.0
    state = material.initial_state(stress)
    strain = np.zeros(4)
    rows = [_row(stress, strain, 0.0, test)]
    if test == "simple-shear-cyclic":
        # As simple shear, the increment of each step its own (the sign below undone).
        ds = -np.diff(np.concatenate([[0.0], shear_path(strain_end, steps, cycles)]))
    else:
        ds = np.full(steps, -strain_end / steps)
    u = 0.0
    for d in ds:
        inc = _increment(material, stress, state, test, d, confining)
        stress, state = material.update(stress, inc[None, :], state)
        strain = strain + inc
        if test == "triaxial-undrained":
            # The total radial stress sigma' - u (tension positive) held at -confining.
            u = confining + stress[0, XX]
        rows.append(_row(stress, strain, u, test))
    keys = rows[0].keys()
    return {k: np.array([r[k] for r in rows]) for k in keys}


def _increment(material, stress, state, test, d, confining) -> np.ndarray:
    """The step's strain increment (xx, yy, zz, 2 xy)."""
    inc = np.zeros(4)
    if test.startswith("simple-shear"):
        inc[XY] = -d                                # shear strain, positive
        return inc
    inc[YY] = d
    if test == "triaxial-undrained":
        inc[XX] = inc[ZZ] = -d / 2
        return inc
    if test == "oedometer":
        return inc
    # Drained triaxial (xx = zz) or plane strain (xx alone): Newton on the radial strain
    # for sigma_xx = -confining.
    radial = [XX, ZZ] if test == "triaxial-drained" else [XX]
    for _ in range(50):
        new, _ = material.update(stress, inc[None, :], state)
        r = new[0, XX] + confining
        if abs(r) <= 1e-10 * (abs(confining) + abs(new[0]).max()):
            return inc
        Dt = tangent(material, stress, inc[None, :], state)[0]
        inc[radial] -= r / Dt[XX, radial].sum()
    raise ArithmeticError(f"soil test {test}: the radial stress did not converge")


def _row(stress, strain, u, test) -> dict:
    p, q = invariants(stress)
    s = -stress[0]
    if test == "plane-strain":
        principal = np.sort(np.linalg.eigvalsh([[s[XX], s[XY], 0], [s[XY], s[YY], 0],
                                                [0, 0, s[ZZ]]]))
        q = [principal[-1] - principal[0]]
    return {"axial_strain": strain[XY] if test.startswith("simple-shear") else -strain[YY],
            "volumetric_strain": -(strain[XX] + strain[YY] + strain[ZZ]),
            "p_eff_pa": float(p[0]), "q_pa": float(q[0]), "excess_pore_pressure_pa": u,
            "stress_pa": s.copy()}


def last_cycle(path, steps: int) -> dict:
    """The last cycle of a cyclic simple-shear ``path`` (:func:`run`; ``steps`` per cycle):
    the shear strain amplitude, the shear stress amplitude tau_a (half the range, Pa), the
    secant modulus tau_a / gamma_a (Pa), and the damping ratio of the loop, its area over
    4 pi times the strain energy tau_a gamma_a / 2 (the loop closed, trapezoids)."""
    n = 4 * max(1, steps // 4)
    gamma = path["axial_strain"][-n - 1:]
    tau = -path["stress_pa"][-n - 1:, XY]           # tension positive: with gamma
    amplitude = 0.5 * (gamma.max() - gamma.min())
    tau_a = 0.5 * (tau.max() - tau.min())
    area = abs(float(np.sum(0.5 * (tau[1:] + tau[:-1]) * np.diff(gamma))))
    return {"strain_amplitude": float(amplitude), "stress_amplitude_pa": float(tau_a),
            "secant_modulus_pa": float(tau_a / amplitude),
            "damping_ratio": area / (4 * np.pi * 0.5 * tau_a * amplitude)}
