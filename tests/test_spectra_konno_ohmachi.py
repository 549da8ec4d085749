"""Konno-Ohmachi smoothing (solver/references/spectra.py) against the whole window summed
directly here, on the spectrum of a realistic record (cases/motions/three-layers.csv)."""

from __future__ import annotations

import time

import numpy as np
import pytest

from conftest import REPO
from solver.references.spectra import fourier_amplitude, konno_ohmachi


def _record_spectrum(pad: int):
    """(f, |A|) to 50 Hz of the 4000-sample synthetic record, zero-padded ``pad`` times to
    a power of two (the dynamic analysis pads four times; 0: not padded)."""
    data = np.loadtxt(REPO / "cases" / "motions" / "three-layers.csv", delimiter=",",
                      comments="#", skiprows=2)
    a, dt = data[:, 1], data[1, 0] - data[0, 0]
    n = 1 << int(np.ceil(np.log2(pad * len(a)))) if pad else len(a)
    f, amp = fourier_amplitude(a, dt, n)
    band = (f > 0) & (f <= 50.0)
    return f[band], amp[band]


def _direct(f, amp, cut=np.inf):
    """The smoothing summed directly, one centre at a time: weights (sin x / x)^4,
    x = 40 log10(f / fc), those with |x| > ``cut`` left out."""
    out = np.empty(len(f))
    for i, c in enumerate(f):
        x = 40.0 * np.log10(f / c)
        w = np.sinc(x / np.pi) ** 4
        w[np.abs(x) > cut] = 0.0
        out[i] = np.dot(w, amp) / np.sum(w)
    return out


def test_whole_window_on_a_records_spectrum():
    """The 4096 lines of the four times padded record: the direct whole-window sum to 1e-12
    (rounding of sums over 4096 terms), both spectra of a stack smoothed alike; the window
    cut at the third side lobe (|x| > 3 pi, weights up to 7e-5) is off by more than 0.05 %
    (measured 0.09 %): the tail of the window counts."""
    f, amp = _record_spectrum(4)
    assert len(f) == 4096
    start = time.perf_counter()
    both = konno_ohmachi(f, np.stack([amp, 3.0 * amp]))
    print(f"smoothing two spectra of {len(f)} lines: {time.perf_counter() - start:.3f} s")
    whole = _direct(f, amp)
    np.testing.assert_allclose(both[0], whole, rtol=1e-12)
    np.testing.assert_allclose(both[1], 3.0 * whole, rtol=1e-12)
    cut = _direct(f, amp, cut=3 * np.pi)
    assert np.max(np.abs(cut / whole - 1)) > 5e-4


def test_unpadded_record_and_a_centre_at_zero():
    """The record's own 1000 lines to 50 Hz, at centres of its own and others (0 Hz: the
    amplitude of the first line as it is): the direct sum to 1e-12."""
    f, amp = _record_spectrum(0)
    assert len(f) == 1000
    start = time.perf_counter()
    mine = konno_ohmachi(f, amp)
    print(f"smoothing one spectrum of {len(f)} lines: {time.perf_counter() - start:.4f} s")
    np.testing.assert_allclose(mine, _direct(f, amp), rtol=1e-12)
    fc = np.array([0.0, 0.37, 12.345, 80.0])
    at = konno_ohmachi(f, amp, fc)
    assert at[0] == amp[0]
    for c, value in zip(fc[1:], at[1:]):
        w = np.sinc(40.0 * np.log10(f / c) / np.pi) ** 4
        assert value == pytest.approx(np.dot(w, amp) / np.sum(w), rel=1e-12)
