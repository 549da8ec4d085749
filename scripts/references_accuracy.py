#!/usr/bin/env python3
"""Accuracy of the references that follow the scene (docs/method.md, "References that
follow the scene"), the numbers quoted there:

1. analytic.column_pressure / column_mean (a uniform column, every drainage, initial excess
   uniform, triangular either way, or both) against a long-double mode series whose
   coefficients come from long-double Gauss quadrature (not the closed forms): max error in
   units of |p_top| + |p_base - p_top|, Tv from 1e-5 to 2;
2. layered.LayeredColumn (two layers, contrast 4 in E_c and 10 in k, compressible water)
   against the linear finite elements of tests/test_references.py (exact in time) at 100
   to 800 cells per metre and their Richardson extrapolation: max |dp| / q;
3. layered.rod_frequencies against the twice-extrapolated finite elements of the tests.

    scripts/references-accuracy        (serial, about half a minute)
"""

import argparse
import os
import sys

# realpath: the command scripts/NAME is a symlink to this file.
ROOT = os.path.dirname(os.path.dirname(os.path.realpath(__file__)))
if __name__ == "__main__":      # a command, not an import: see solver.studies.study.start
    sys.path[:0] = [ROOT, os.path.join(ROOT, "tests")]
    from solver.studies.study import start

    start()

import numpy as np  # noqa: E402

from solver.references import analytic, layered  # noqa: E402
from test_references import (DRAINAGES, GAMMA_W, Q, fe_diffusion, richardson,  # noqa: E402
                             rod_reference, two_layers)

L = np.longdouble
PI = L("3.14159265358979323846264338327950288")


def long_series(xi, T, base, top, f0, f1):
    """The mode series in long double, coefficients by 32 x 200-point Gauss panels."""
    xg, wg = np.polynomial.legendre.leggauss(200)
    xg, wg = (L(1) + xg.astype(L)) / 2, wg.astype(L) / 2
    xq = np.concatenate([(s + xg) / 32 for s in range(32)])
    wq = np.tile(wg / 32, 32)
    xi = np.asarray(xi, dtype=L)
    acc, mean = np.zeros_like(xi), L(0)
    for j in range(4000):
        M = (j + L(0.5)) * PI if base != top else ((j + 1) * PI if base else j * PI)
        X = np.sin if base else np.cos
        decay = np.exp(-M * M * L(T))
        if decay < 1e-30:
            break
        Xq = X(M * xq)
        c = (wq * (f0 + f1 * xq) * Xq).sum() / (wq * Xq * Xq).sum() * decay
        acc += c * X(M * xi)
        mean += c * (wq * Xq).sum()
    return acc, mean


def uniform_column():
    y = np.linspace(0.0, 1.0, 41)
    worst = 0.0
    for drained in DRAINAGES:
        base, top = "bottom" in drained, "top" in drained
        for f0, f1 in ((1.0, 0.0), (1.0, -1.0), (0.0, 1.0), (0.3, 0.7)):
            for T in (1e-5, 1e-3, 0.0069, 0.0071, 0.05, 0.5, 2.0):
                ref, mean = long_series(y, T, base, top, L(f0), L(f1))
                p = analytic.column_pressure(y, T, 1.0, drained, f0 + f1, f0)
                m = analytic.column_mean(T, drained, f0 + f1, f0)
                scale = abs(f0) + abs(f1)
                worst = max(worst, float(np.abs(p - ref).max()) / scale,
                            float(abs(m - mean)) / scale)
    print(f"uniform column: max error {worst:.1e} of |p_top| + |p_base - p_top| "
          f"(promised {analytic.TOLERANCE:.0e})")


def layered_column():
    t = np.array([0.5, 2.0, 8.0, 30.0])
    for drained, g in ((("top",), 0.0), (("top", "bottom"), 9.81), (("bottom",), 9.81)):
        s = two_layers(drained=drained, g=g)
        col = layered.LayeredColumn(**s)
        a = np.array(s["k"][::-1]) / GAMMA_W
        fe = {c: fe_diffusion(col.modes.d, a, col.m_v, col.alpha, col.beta,
                              "bottom" in drained, "top" in drained, c, t)
              for c in (100, 200, 400, 800)}
        got = col.pressure(fe[100][0], t)
        err = [np.abs(fe[c][1][:, ::c // 100] - got).max() / Q for c in fe]
        rich = [np.abs(richardson(fe[2 * c][1][:, ::2 * c // 100], fe[c][1][:, ::c // 100])
                       - got).max() / Q for c in (200, 400)]
        print(f"layered column {'+'.join(drained)}, g = {g}: FE 100/200/400/800 cells per m "
              + " ".join(f"{e:.2e}" for e in err)
              + f"; extrapolated 200-400 {rich[0]:.1e}, 400-800 {rich[1]:.1e} (of q); "
              f"U = {', '.join(f'{u:.3f}' for u in col.degree(t))} at t = {t.tolist()} s")


def layered_rod():
    for thick, E, rho, n in (([3.0, 5.0, 4.0], [2.0e7, 8.0e7, 3.0e8], [1700.0, 1900.0, 2100.0],
                              5), ([2.0, 8.0], [1.0e6, 3.2e9], [1000.0, 2.0e5], 8)):
        f = layered.rod_frequencies(thick, E, rho, n)
        rel = np.abs(f / rod_reference(thick, E, rho, n) - 1).max()
        print(f"layered rod {thick}: f = {np.round(f, 4).tolist()} Hz, "
              f"max relative difference from FE {rel:.1e}")


def main():
    argparse.ArgumentParser(description=__doc__.split("\n\n")[0]).parse_args()
    uniform_column()
    layered_column()
    layered_rod()


if __name__ == "__main__":
    main()
