"""Recorded base motions: a CSV of two columns, t (s) and a (m/s2), or a PEER
NGA ``.AT2`` file (accelerations in g, a fixed time step), read and checked."""

from __future__ import annotations

import os
import re

import numpy as np

from ..common.errors import InputError

G_STANDARD = 9.80665     # m/s2 per g, PEER's unit


def read(path: str) -> tuple:
    """(t (s), a (m/s2)) of the record at ``path``; InputError (one line) for a file that
    is missing, unreadable, empty or whose times do not increase."""
    if not os.path.isfile(path):
        raise InputError(f"-mpm_base_motion {path}: no such file")
    try:
        t, a = _at2(path) if path.lower().endswith(".at2") else _csv(path)
    except (OSError, ValueError, IndexError, UnicodeDecodeError) as exc:
        raise InputError(f"-mpm_base_motion {path}: not a readable record "
                         f"({type(exc).__name__})") from None
    if len(t) < 2 or not (np.all(np.isfinite(t)) and np.all(np.isfinite(a))):
        raise InputError(f"-mpm_base_motion {path}: fewer than two finite samples")
    if np.any(np.diff(t) <= 0):
        k = int(np.flatnonzero(np.diff(t) <= 0)[0])
        raise InputError(f"-mpm_base_motion {path}: time does not increase at sample "
                         f"{k + 2} (t = {t[k + 1]:g} s after {t[k]:g} s)")
    return t, a


def _csv(path):
    rows = []
    with open(path, encoding="utf-8") as fh:
        for line in fh:
            line = line.split("#", 1)[0].strip()
            if not line:
                continue
            words = [w for w in re.split(r"[,;\s]+", line) if w]
            try:
                rows.append((float(words[0]), float(words[1])))
            except ValueError:
                if rows:           # a header may only come first
                    raise
    data = np.array(rows, dtype=float).reshape(-1, 2)
    return data[:, 0], data[:, 1]


def _at2(path):
    with open(path, encoding="utf-8", errors="strict") as fh:
        lines = fh.read().splitlines()
    head = lines[3].upper()
    npts = int(re.search(r"NPTS\s*=\s*([0-9]+)", head).group(1))
    dt = float(re.search(r"DT\s*=\s*([0-9.Ee+-]+)", head).group(1))
    values = np.array(" ".join(lines[4:]).split(), dtype=float)[:npts]
    if len(values) < npts or dt <= 0:
        raise ValueError("short record")
    return dt * np.arange(npts), values * G_STANDARD
