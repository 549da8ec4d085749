#!/usr/bin/env python3
"""A seeded synthetic rock-outcrop acceleration record: Boore's (2003) stochastic method for
a point source (PAGEOPH 160, 635-676), so that a scene can ship a recorded-like base motion.

    scripts/synthetic-motion [--seed 1] [--magnitude 6.5] [--distance 20] [--stress-drop 100]
                             [--kappa 0.03] [--q Q] [--pga 2.0] [--dt 0.005] [--duration 20]
                             [--output cases/motions/three-layers.csv]

Target Fourier amplitude of the acceleration (its level is irrelevant, the PGA sets it):

    A(f) = (2 pi f)^2 M0 / (1 + (f / f0)^2)                 Brune omega-squared source
           * exp(-pi f R / (Q(f) beta)) / R                 1/R spreading, anelastic loss
           * exp(-pi kappa f)                               kappa, no site amplification

with M0 = 10^(1.5 Mw + 16.05) dyne-cm, f0 = 4.906e6 beta (dsigma / M0)^(1/3) Hz (beta = 3.5
km/s, dsigma in bar), R the distance (km), Q(f) = 180 f^0.45 (or a constant --q), kappa (s).
Gaussian white noise (numpy's default_rng(seed)) of length t_eta = 2 Tgm, Tgm = 1 / f0 +
0.05 R s, is shaped by the Saragoni-Hart window (eps = 0.2, eta = 0.05: its peak at 0.2
t_eta, 5 % of it at t_eta; Boore's f_Tgm = 2), placed after a 1 s quiet start, zero-padded,
transformed, normalised to unit mean square amplitude, multiplied by A(f) and transformed
back. Then a cosine taper: to zero over the last 5 % of the record, and from zero over the
quiet second (the zero-phase filter leaks a little into it). The baseline: a constant c,
tapered the same way, is subtracted from the acceleration so that the final velocity
(trapezoidal integral) is exactly zero, i.e. the linear trend c t is removed from the
velocity (the displacement is not corrected). Last, the record is scaled so that max |a| is
exactly the requested PGA (a linear scaling keeps the final velocity zero).

The CSV: a '#' line naming the generator, every parameter and the seed, the header
``t_s,a_m_s2``, then rows t (s, %.4f), a (m/s2, %.6e); written atomically.
"""

import argparse
import os
import sys
import tempfile

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path.insert(0, ROOT)
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

BETA = 3.5                 # km/s, shear-wave speed at the source (Boore 2003)
EPS, ETA, F_TGM = 0.2, 0.05, 2.0   # Saragoni-Hart window (Boore 2003, eq. 10-11)
QUIET = 1.0                # s of rest before the motion starts
TAPER = 0.05               # fraction of the record cosine-tapered at its end


def corner_frequency(magnitude: float, stress_drop_bar: float) -> float:
    """Brune corner frequency f0 (Hz) of moment magnitude Mw and stress drop (bar)."""
    m0 = 10.0 ** (1.5 * magnitude + 16.05)             # dyne-cm
    return 4.906e6 * BETA * (stress_drop_bar / m0) ** (1.0 / 3.0)


def target_spectrum(f, magnitude, distance_km, stress_drop_bar, kappa, q=None):
    """Fourier amplitude shape of the acceleration at frequencies f (Hz), up to a constant:
    Brune source, 1/R spreading, anelastic Q(f) = 180 f^0.45 (or the constant q), kappa (s)."""
    f = np.asarray(f, dtype=float)
    f0 = corner_frequency(magnitude, stress_drop_bar)
    m0 = 10.0 ** (1.5 * magnitude + 16.05)
    # Q(0) is 0 for the power law; A(0) = 0 anyway, so a tiny floor avoids the 0/0.
    qf = np.full_like(f, float(q)) if q else 180.0 * np.maximum(f, 1e-6) ** 0.45
    source = (2.0 * np.pi * f) ** 2 * m0 / (1.0 + (f / f0) ** 2)
    path = np.exp(-np.pi * f * distance_km / (qf * BETA)) / distance_km
    return source * path * np.exp(-np.pi * kappa * f)


def saragoni_hart(t, t_eta):
    """Saragoni-Hart window at times t (s) >= 0: peak 1 at EPS t_eta, ETA at t_eta."""
    b = -EPS * np.log(ETA) / (1.0 + EPS * (np.log(EPS) - 1.0))
    c, a = b / EPS, (np.e / EPS) ** b
    x = np.asarray(t) / t_eta
    return a * x ** b * np.exp(-c * x)


def generate(seed=1, magnitude=6.5, distance_km=20.0, stress_drop_bar=100.0, kappa=0.03,
             pga=2.0, dt=0.005, duration=20.0, q=None):
    """(t (s), a (m/s2)) of the seeded synthetic record, ``duration`` s long at step ``dt``,
    max |a| = ``pga``. ValueError if the windowed motion does not fit in the record."""
    n = int(round(duration / dt)) + 1
    t_eta = F_TGM * (1.0 / corner_frequency(magnitude, stress_drop_bar) + 0.05 * distance_km)
    start, length = max(int(round(QUIET / dt)), 1), int(round(t_eta / dt)) + 1
    if start + length > n * (1.0 - TAPER):
        raise ValueError(f"the motion ({t_eta:.1f} s after {QUIET:g} s of rest) does not "
                         f"fit before the end taper of a {duration:g} s record")
    noise = np.zeros(2 * n)      # twice the record: the filter does not wrap around
    rng = np.random.default_rng(seed)
    noise[start:start + length] = rng.standard_normal(length) * saragoni_hart(
        dt * np.arange(length), t_eta)
    spectrum = np.fft.rfft(noise)
    spectrum /= np.sqrt(np.mean(np.abs(spectrum) ** 2))     # unit mean square amplitude
    f = np.fft.rfftfreq(2 * n, dt)
    a = np.fft.irfft(spectrum * target_spectrum(f, magnitude, distance_km, stress_drop_bar,
                                                kappa, q), 2 * n)[:n]
    # The zero-phase filter leaks a little (~1 % of the PGA) into the quiet second: a
    # cosine rise over it, from exactly 0, lets a run start from rest without a jump.
    window = np.ones(n)
    window[:start] = 0.5 * (1.0 - np.cos(np.pi * np.arange(start) / start))
    m = max(int(round(TAPER * n)), 2)
    window[n - m:] = 0.5 * (1.0 + np.cos(np.pi * np.arange(1, m + 1) / m))   # ends at 0
    a *= window

    def final_velocity(x):
        return dt * (x.sum() - 0.5 * (x[0] + x[-1]))

    a -= final_velocity(a) / final_velocity(window) * window
    return dt * np.arange(n), a * (pga / np.max(np.abs(a)))


def write(path, t, a, header):
    """Write the CSV atomically: a temporary file in the same folder, then os.replace."""
    folder = os.path.dirname(os.path.abspath(path))
    os.makedirs(folder, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=folder, prefix=".synthetic-", suffix=".csv")
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(f"# {header}\nt_s,a_m_s2\n")
            fh.writelines(f"{ti:.4f},{ai:.6e}\n" for ti, ai in zip(t, a))
        os.chmod(tmp, 0o644)     # mkstemp makes it private
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seed", type=int, default=1, help="of the white noise (numpy default_rng)")
    ap.add_argument("--magnitude", type=float, default=6.5, help="moment magnitude Mw")
    ap.add_argument("--distance", type=float, default=20.0, help="km")
    ap.add_argument("--stress-drop", type=float, default=100.0, help="bar")
    ap.add_argument("--kappa", type=float, default=0.03, help="s")
    ap.add_argument("--q", type=float, default=None, help="constant Q (default 180 f^0.45)")
    ap.add_argument("--pga", type=float, default=2.0, help="m/s2")
    ap.add_argument("--dt", type=float, default=0.005, help="s")
    ap.add_argument("--duration", type=float, default=20.0, help="record length, s")
    ap.add_argument("--output", default="cases/motions/three-layers.csv", help="CSV to write")
    o = ap.parse_args(argv)
    t, a = generate(o.seed, o.magnitude, o.distance, o.stress_drop, o.kappa, o.pga, o.dt,
                    o.duration, q=o.q)
    header = (f"scripts/synthetic-motion (Boore 2003 stochastic point source, rock outcrop, "
              f"numpy {np.__version__} default_rng): seed={o.seed} magnitude={o.magnitude:g} "
              f"distance_km={o.distance:g} stress_drop_bar={o.stress_drop:g} "
              f"kappa_s={o.kappa:g} Q={o.q if o.q else '180f^0.45'} beta_km_s={BETA:g} "
              f"pga_m_s2={o.pga:g} dt_s={o.dt:g} duration_s={o.duration:g} "
              f"quiet_s={QUIET:g} taper={TAPER:g} window=saragoni-hart(eps={EPS:g},"
              f"eta={ETA:g},f_Tgm={F_TGM:g})")
    write(o.output, t, a, header)
    print(f"{o.output}: {len(t)} samples, dt {o.dt:g} s, PGA {np.max(np.abs(a)):.4f} m/s2")
    return 0


if __name__ == "__main__":
    sys.exit(main())
