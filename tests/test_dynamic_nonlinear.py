"""The hyperbolic soil shaken at its base (-mpm_analysis dynamic -mpm_material hyperbolic):
against OpenSees (its surface histories stored in tests/data by scripts/opensees-check),
equal to the linear run under a motion too small to soften it, one and two ranks alike, a
restart that continues exactly, its outputs (loops, the linear twin, the spectra at the
recorded depths) and its bad input."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from conftest import REPO, check_ok, check_readme_outputs
from test_dynamic import assert_same, histories
from test_options import assert_input_error

from solver.references.spectra import pseudo_acceleration

REFERENCE = REPO / "tests" / "data" / "opensees-hyperbolic-column.csv"


def reference() -> tuple:
    """(the solver options of the column, OpenSees' surface (t, a_x, u_x) every 1 ms)."""
    lines = REFERENCE.read_text().splitlines()
    options = next(line for line in lines if line.startswith("# options: "))
    return options[len("# options: "):].split(), np.loadtxt(lines[3:], delimiter=",")


def surface(folder) -> np.ndarray:
    rows = histories(folder)[0.0]
    return np.column_stack([rows["t_s"], rows["a_x"], rows["u_x"]])


def option(args, name, value) -> list:
    """``args`` with ``-mpm_name`` set to ``value``."""
    args = list(args)
    args[args.index(f"-mpm_{name}") + 1] = str(value)
    return args


def without(args, *names) -> list:
    """``args`` without the options ``-mpm_name`` (each with its value)."""
    args = list(args)
    for name in names:
        i = args.index(f"-mpm_{name}")
        del args[i:i + 2]
    return args


def test_the_column_against_opensees(cli, tmp_path):
    """The layered column on a rigid base, softened past gamma_r (peak strain 0.3 %): the
    surface PGA within 1 % of OpenSees' shear beam with the same Iwan springs and damping
    (0.41 % measured), its 5 % PSA within 2.5 % at every period (1.06 %), its displacement
    within 2.5 % of the peak (1.35 %): the differences are the two time integrations'
    (central differences at 1 ms, Newmark at 0.25 ms)."""
    args, ops = reference()
    s = check_ok(cli(args, out_dir=tmp_path / "out"))["dynamic"]
    mpm = surface(tmp_path / "out")
    assert np.allclose(mpm[:, 0], ops[:, 0])
    assert s["material"] == "hyperbolic" and "exact_error_pct_of_peak" not in s
    pga = np.max(np.abs(ops[:, 1]))
    assert np.max(np.abs(mpm[:, 1])) == pytest.approx(pga, rel=1e-2)
    periods = np.logspace(-2, 1, 30)
    ours, theirs = (pseudo_acceleration(x[:, 1], 1e-3, periods) for x in (mpm, ops))
    assert np.max(np.abs(ours / theirs - 1)) < 2.5e-2
    assert np.max(np.abs(mpm[:, 2] - ops[:, 2])) < 2.5e-2 * np.max(np.abs(ops[:, 2]))
    strain = np.loadtxt(tmp_path / "out" / "peaks.csv", delimiter=",", skiprows=2)[:, 4]
    assert np.nanmax(strain) > 1e-3           # well past gamma_r: the soil softened


def test_a_small_motion_is_the_linear_run(cli, tmp_path):
    """Under the record scaled to 1e-3 the column strains below gamma_r / 100: the
    hyperbolic run's histories equal the linear run's (-mpm_rayleigh 0.02: the same
    damping) within 1 % of each quantity's peak, and its linear twin's surface PGA is the
    run's within 1 %. Its outputs: the loops of the recorded depths (the points' shear
    stress over strain there is G within 1 %), the twin's table and figure, the spectra at
    the recorded depths, every file in the README's outputs table."""
    args, _ = reference()
    args = option(option(option(args, "t_end", 3), "linear_twin", 1), "figures", 1)
    args += ["-mpm_base_motion_scale", "1e-3", "-mpm_record_depths", "10"]
    hyp, lin = tmp_path / "hyperbolic", tmp_path / "linear"
    s = check_ok(cli(args, out_dir=hyp))["dynamic"]
    linear = without(option(args, "material", "elastic"), "small_strain_damping",
                     "reference_strain") + ["-mpm_rayleigh", "0.02"]
    check_ok(cli(linear, out_dir=lin))
    peaks = np.loadtxt(hyp / "peaks.csv", delimiter=",", skiprows=2)
    assert np.nanmax(peaks[:, 4]) < 1e-5                    # below gamma_r / 100
    assert_same(histories(lin), histories(hyp), 1e-2, "small motion")
    twin = s["linear_twin"]
    assert twin["hyperbolic"]["pga_surface"] == pytest.approx(twin["linear"]["pga_surface"],
                                                              rel=1e-2)
    with open(hyp / "loops.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if float(r["depth_m"]) == 10.0]
    gamma = np.array([float(r["shear_strain"]) for r in rows])
    tau = np.array([float(r["shear_stress_pa"]) for r in rows])
    k = np.argmax(np.abs(gamma))
    G_top = 76.05e6 / 2.6                                   # the layer above 10 m
    assert tau[k] / gamma[k] == pytest.approx(G_top, rel=1e-2)
    for name in ("loops.png", "twin.png", "twin.csv", "spectra_depths.csv"):
        assert (hyp / name).is_file(), name
    check_readme_outputs(hyp)


def test_the_spectra_at_the_recorded_depths(cli, tmp_path):
    """spectra_depths.csv: on a rigid base the base row moves with the input, so its PSA
    (from every step) is the input's to 1e-9; the surface's rows are spectra.csv's."""
    args, _ = reference()
    out = tmp_path / "out"
    check_ok(cli(option(args, "t_end", 2), out_dir=out))
    with open(out / "spectra_depths.csv") as fh:
        rows = [r for r in csv.DictReader(fh) if r["kind"] == "psa"]
    base = [r for r in rows if float(r["depth_m"]) == 30.0]
    assert base and all(abs(float(r["over_input"]) - 1) < 1e-9 for r in base)
    with open(out / "spectra.csv") as fh:
        top = [float(r["surface"]) for r in csv.DictReader(fh) if r["kind"] == "psa"]
    ours = [float(r["value"]) for r in rows if float(r["depth_m"]) == 0.0]
    np.testing.assert_allclose(ours, top, rtol=1e-6)


@pytest.mark.mpi(2)
def test_one_and_two_ranks_agree(cli, tmp_path):
    """Two columns of cells tied on periodic sides (the tying matrix in B), softened: one
    and two ranks record the same histories and loops within 1e-10 of their peaks."""
    args, _ = reference()
    args = option(option(option(args, "t_end", 1.5), "cells", "2,60"), "size", "2,30")
    args += ["-mpm_bc_sides", "periodic", "-mpm_base_motion_scale", "2"]
    runs = []
    for ranks in (1, 2):
        out = tmp_path / f"r{ranks}"
        check_ok(cli(args, ranks=ranks, out_dir=out))
        runs.append(out)
    assert_same(histories(runs[0]), histories(runs[1]), 1e-10, "ranks")
    a, b = (np.loadtxt(r / "loops.csv", delimiter=",", skiprows=1) for r in runs)
    assert np.all(np.abs(a - b) <= 1e-10 * np.max(np.abs(a), axis=0) + 1e-10 * np.abs(a))


def test_a_restart_continues_exactly(cli, tmp_path):
    """Stopped at a checkpoint in the middle (the points' stresses and elements kept) and
    restarted, the run records what the uninterrupted run records: histories to 1e-12 of
    their peaks, the loops to their printed digits, the PSA at every recorded depth to its
    six."""
    args, _ = reference()
    args = option(args, "t_end", 2)
    whole, half, again = tmp_path / "whole", tmp_path / "half", tmp_path / "again"
    check_ok(cli(args, out_dir=whole))
    check_ok(cli(option(args, "t_end", 1) + ["-mpm_checkpoint_every", "333"], out_dir=half))
    s = check_ok(cli(["-mpm_restart", half / "checkpoint.npz", "-mpm_t_end", "2",
                      "-mpm_output", again, "-mpm_figures", "0"], out_dir=again))
    assert s["completed"]
    assert_same(histories(whole), histories(again), 1e-12, "restart")
    a, b = (np.loadtxt(r / "loops.csv", delimiter=",", skiprows=1) for r in (whole, again))
    assert a.shape == b.shape and np.all(np.abs(a - b) <= 1e-10 * np.abs(a) + 1e-300)
    # The PSA of every recorded depth from every step goes on across the checkpoint.
    a, b = ([r["value"] for r in csv.DictReader((f / "spectra_depths.csv").read_text()
                                                  .splitlines())
             if r["kind"] == "psa"] for f in (whole, again))
    np.testing.assert_allclose(np.array(b, float), np.array(a, float), rtol=2e-6)
    assert json.loads((whole / "summary.json").read_text())["dynamic"]["material"] == \
        "hyperbolic"


@pytest.mark.parametrize("extra, words", [
    (["-mpm_phases", "2", "-mpm_rho_l", "1000"], "one phase"),
    (["-mpm_rayleigh", "0.05"], "give one"),
    (["-mpm_material", "tresca"], "elastic or hyperbolic"),
], ids=["two-phases", "two-dampings", "other-material"])
def test_bad_input(cli, tmp_path, extra, words):
    args, _ = reference()
    out = tmp_path / "out"
    assert_input_error(cli(args + extra, out_dir=out), words, out)


def test_small_strain_damping_is_the_hyperbolic_soils(cli, tmp_path):
    args, _ = reference()
    args = without(option(args, "material", "elastic"), "reference_strain")
    out = tmp_path / "out"
    assert_input_error(cli(args, out_dir=out), "-mpm_rayleigh", out)
