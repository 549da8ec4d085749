"""Layered soils in the eigen analysis: the options, the ground, the per-point
material of the model, the layered-rod reference, and the scene cases/eigen-layered.opts.

The reference of the done-when test is the layered 1D rod of :mod:`solver.references.layered` (a
transfer-matrix solution, itself tested against closed forms in tests/test_references.py),
fed with moduli and densities worked out here from the scene's inputs."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import CASES, check_ok, scene_options

SCENE = "eigen-layered"
# The scene's inputs, from the surface down (cases/eigen-layered.opts).
THICKNESS = (10.0, 10.0, 10.0)
E, NU, RHO_S, RHO_L, POROSITY = (20e6, 60e6, 150e6), 0.3, 2650.0, 1000.0, (0.5, 0.4, 0.35)


def _scene_rod(nmodes):
    """The layered rod of the scene: E_c = E (1 - nu) / ((1 + nu)(1 - 2 nu)) and the
    saturated density (1 - n) rho_s + n rho_l per layer."""
    from solver.references import layered

    E_c = [e * (1 - NU) / ((1 + NU) * (1 - 2 * NU)) for e in E]
    rho = [(1 - n) * RHO_S + n * RHO_L for n in POROSITY]
    return layered.rod_frequencies(THICKNESS, E_c, rho, nmodes)


def _read(values):
    from solver.io import options

    return options.from_mapping(values)


# -- options -------------------------------------------------------------------------------
def test_one_value_stays_a_float_and_several_give_a_tuple():
    p = _read({"E": "2e7", "nu": "0.25"})
    assert type(p.E) is float and p.E == 2e7 and type(p.nu) is float
    assert p.layers == () and p.porosity == 0.3
    q = _read({"layers": "0.5,0.5", "E": "1e7,3e7", "porosity": "0.3, 0.4"})
    assert q.layers == (0.5, 0.5) and q.E == (1e7, 3e7) and q.porosity == (0.3, 0.4)
    # The default scenes' parameters (signatures, provenance) keep their floats.
    from solver.consolidation import workprecision

    sig = workprecision.scene_signature(_read({}))
    assert all(type(sig[k]) is float for k in ("E", "nu", "rho_s", "porosity", "k"))


@pytest.mark.parametrize("values, message", [
    ({"E": "1e7,-2e7"}, "-mpm_E 10000000.0,-20000000.0: layer 2: must be > 0"),
    ({"nu": "0.2,0.5"}, "-mpm_nu 0.2,0.5: layer 2: must lie in [0, 0.5)"),
    ({"porosity": "1.2,0.3"}, "-mpm_porosity 1.2,0.3: layer 1: must lie in (0, 1)"),
    ({"layers": "0.5,0"}, "-mpm_layers 0.5,0.0: every entry must be > 0"),
    ({"E": "1e7,nan"}, "-mpm_E: '1e7,nan': not a finite number"),
])
def test_per_layer_values_are_checked_entry_by_entry(values, message):
    from solver.common.errors import InputError

    with pytest.raises(InputError) as info:
        _read(values)
    assert str(info.value) == message


# -- the ground ----------------------------------------------------------------------------
def _ground(values):
    from solver.model.soil import Ground

    return Ground.from_options(_read(values))


def test_ground_of_the_options():
    from solver.model.soil import Soil

    g = _ground({"layers": "0.2,0.3,0.5", "E": "1e7,2e7,3e7", "porosity": "0.5,0.4,0.3"})
    assert g.count == 3 and g.thickness == (0.2, 0.3, 0.5) and g.height == pytest.approx(1)
    assert [s.E for s in g.soils] == [1e7, 2e7, 3e7] and g.soils[1].nu == 0.0
    np.testing.assert_allclose(g.bottoms, [0.8, 0.5, 0.0], atol=1e-15)
    y = np.array([0.99, 0.81, 0.79, 0.51, 0.49, 0.01])
    assert list(g.layer_of(y)) == [0, 0, 1, 1, 2, 2]
    assert g.layer_of(np.zeros((0,))).shape == (0,)
    rho = [(1 - n) * 2700 + n * 1000 for n in (0.5, 0.4, 0.3)]
    np.testing.assert_allclose(g.density_at(y), np.array(rho)[[0, 0, 1, 1, 2, 2]], rtol=1e-15)
    D = g.elasticity_at(y)
    assert D.shape == (6, 3, 3) and D[2, 2, 2] == 2e7 / 2 and D[5, 0, 0] == 3e7
    # No -mpm_layers: one layer of the body's height, the soil of the options as it is.
    one = _ground({"E": "2e7", "nu": "0.3"})
    assert one.count == 1 and one.thickness == (1.0,)
    assert one.soils[0] == Soil(E=2e7, nu=0.3)


# -- bad input: exit 2, one line naming the option, nothing written --------------------------
BAD = [
    (["-mpm_layers", "0.5,0.4"], "-mpm_layers 0.5,0.4: the thicknesses sum to 0.9 m, not "
                                 "the body's height 1 m (-mpm_size)"),
    (["-mpm_layers", "0.5,0.5", "-mpm_E", "1e7,2e7,3e7"],
     "-mpm_E 1e+07,2e+07,3e+07: 3 values for 2 layer(s) of -mpm_layers; give one value or "
     "one per layer"),
    (["-mpm_porosity", "0.3,0.4"], "-mpm_porosity 0.3,0.4: 2 values for 1 layer(s) (a list "
                                   "needs -mpm_layers, one thickness per layer)"),
    (["-mpm_layers", "0.95,0.05"], "-mpm_layers 0.95,0.05: layer 2 (0.05 m) is thinner than "
                                   "a cell (h_y = 0.1 m, -mpm_cells)"),
    (["-mpm_layers", "0.55,0.45"], "-mpm_layers 0.55,0.45: the interface at depth 0.55 m is "
                                   "not on a cell boundary (cells 0.1 m high, -mpm_cells); "
                                   "interfaces inside a cell are not supported"),
    (["-mpm_analysis", "consolidation", "-mpm_layers", "0.5,0.3"],
     "-mpm_layers 0.5,0.3: the thicknesses sum to 0.8 m, not the body's height 1 m "
     "(-mpm_size)"),
    (["-mpm_analysis", "consolidation", "-mpm_layers", "0.5,0.5", "-mpm_k", "1e-4,1e-5,1e-6"],
     "-mpm_k 0.0001,1e-05,1e-06: 3 values for 2 layer(s) of -mpm_layers; give one value or "
     "one per layer"),
    (["-mpm_analysis", "consolidation", "-mpm_layers", "0.45,0.55"],
     "-mpm_layers 0.45,0.55: the interface at depth 0.45 m is not on a cell boundary (cells "
     "0.1 m high, -mpm_cells); interfaces inside a cell are not supported"),
    (["-mpm_analysis", "consolidation", "-mpm_E", "1e7,2e7"],
     "-mpm_E 1e+07,2e+07: 2 values for 1 layer(s) (a list needs -mpm_layers, one thickness "
     "per layer)"),
]


@pytest.mark.parametrize("args, message", BAD, ids=range(len(BAD)))
def test_bad_layers_exit_2_with_one_line(cli, tmp_path, args, message):
    out = tmp_path / "out"
    res = cli(args + ["-mpm_figures", "0"], out_dir=out)
    assert res.returncode == 2, res.stderr
    assert res.stderr.strip().splitlines() == [f"solver: error: {message}"]
    assert not out.exists() and res.summary is None


def test_single_layer_consolidation_is_accepted():
    """-mpm_layers H alone is the column as without it: consolidation's checks pass."""
    from solver.consolidation.setup import validate

    p = scene_options(layers="1")
    assert validate(p)[0] == p


# -- the model: per-point material -----------------------------------------------------------
def _model(values, ranks_comm=None):
    from petsc4py import PETSc

    from solver.model.scene import Body, build
    from solver.model.soil import Ground

    p = _read(values)
    return build(ranks_comm or PETSc.COMM_SELF, Body.from_options(p), Ground.from_options(p))


def _dense(A):
    from scipy.sparse import csr_matrix

    return csr_matrix(A.getValuesCSR()[::-1], shape=A.getSize()).toarray()


def test_identical_layers_give_the_one_layer_model():
    from solver.model.scene import destroy

    base = {"element": "q9", "cells": "1,8", "ppc": "3", "nu": "0.3"}
    one = _model(base)
    three = _model({**base, "layers": "0.5,0.25,0.25", "E": "1e7,1e7,1e7"})
    try:
        for a, b in ((one[2], three[2]), (one[3], three[3])):
            A, B = _dense(a), _dense(b)
            np.testing.assert_allclose(B, A, rtol=0, atol=1e-14 * np.abs(A).max())
    finally:
        destroy(*reversed(three))
        destroy(*reversed(one))


def test_points_carry_their_layers_mass_and_stiffness():
    """Mass: sum of m_p = W sum(t_i rho_i); stiffness: a uniform vertical strain eps of a
    column on rollers stores energy W sum(t_i E_c,i) eps^2 / 2 (per metre of depth)."""
    from solver.model.scene import destroy

    values = {"element": "q4", "cells": "1,10", "ppc": "2", "nu": "0.25",
              "layers": "0.3,0.7", "E": "1e7,4e7", "rho_s": "2000,2800"}
    made = _model(values)
    grid, points, K, M, free = made
    try:
        n = 0.3
        rho = [(1 - n) * rs + n * 1000 for rs in (2000, 2800)]
        assert points.get("mass").sum() == pytest.approx(0.1 * (0.3 * rho[0] + 0.7 * rho[1]),
                                                         rel=1e-12)
        # u_y = eps y on the free DOFs; on one rank the DMDA's order is the natural one.
        u = K.createVecRight()
        nat = free.getIndices()
        y = grid.lattice_coordinates()[nat // 2, 1]
        u.setArray(np.where(nat % 2 == 1, 1e-3 * y, 0.0))
        Ku = K.createVecLeft()
        K.mult(u, Ku)
        E_c = [e * (1 - 0.25) / ((1 + 0.25) * (1 - 0.5)) for e in (1e7, 4e7)]
        energy = 0.1 * (0.3 * E_c[0] + 0.7 * E_c[1]) * 1e-6 / 2
        assert 0.5 * u.dot(Ku) == pytest.approx(energy, rel=1e-10)
        destroy(u, Ku)
    finally:
        destroy(*reversed(made))


# -- the scene: the layered scene's checks ------------------------------------------------------
def test_three_layer_column_matches_the_layered_rod(cli, monkeypatch):
    """Q9, 1 x 30 cells: the first three frequencies within 0.5 % of the layered rod,
    Jacobi and SLEPc alike; the figure draws the interfaces and the layered rod's modes."""
    from solver.eigen import plots as eigen

    figs = []
    real = eigen.mode_figure

    def keep(*args, **kwargs):
        figs.append(real(*args, **kwargs))
        return figs[-1]
    monkeypatch.setattr(eigen, "mode_figure", keep)
    s = check_ok(cli([], options_file=SCENE))
    rod = _scene_rod(5)
    np.testing.assert_allclose(s["eigen"]["references"]["rod_hz"], rod, rtol=1e-12)
    for solver in ("jacobi", "slepc"):
        f = np.array(s["eigen"]["frequencies_hz"][solver][:3])
        assert np.all(np.abs(f / rod[:3] - 1) < 5e-3), (solver, f, rod[:3])
    assert s["eigen"]["layers_m"] == list(THICKNESS) and len(s["eigen"]["density_kg_m3"]) == 3
    assert s["eigen"]["cells"] == [1, 30] and s["eigen"]["element"] == "q9"
    # The FE Gauss reference is the same layered body: as close to the rod.
    fe = np.array(s["eigen"]["references"]["fe_gauss_hz"][:3])
    assert np.all(np.abs(fe / rod[:3] - 1) < 5e-3)
    (fig,) = figs
    levels = sorted({ln.get_ydata()[0] for ax in fig.axes for ln in ax.get_lines()
                     if ln.get_linestyle() == "--" and ln.get_color() == "tab:red"})
    np.testing.assert_allclose(levels, [10.0, 20.0])
    rods = [ln for ax in fig.axes for ln in ax.get_lines() if ln.get_label().startswith("rod")]
    assert len(rods) == 5


@pytest.mark.mpi(2)
def test_layered_scene_one_and_two_ranks_agree(cli, tmp_path):
    args = ["-mpm_figures", "0"]
    s1 = check_ok(cli(args, options_file=SCENE, out_dir=tmp_path / "n1"))
    s2 = check_ok(cli(args, ranks=2, options_file=SCENE, out_dir=tmp_path / "n2"))
    assert (s1["provenance"]["ranks"], s2["provenance"]["ranks"]) == (1, 2) and s1["eigen"][
        "ndof"
    ] == s2["eigen"]["ndof"]
    for solver in ("jacobi", "slepc"):
        np.testing.assert_allclose(
            s2["eigen"]["frequencies_hz"][solver],
            s1["eigen"]["frequencies_hz"][solver],
            rtol=1e-10,
            atol=0,
            err_msg=solver,
        )
    np.testing.assert_allclose(s2["eigen"]["references"]["fe_gauss_hz"],
                               s1["eigen"]["references"]["fe_gauss_hz"], rtol=1e-10)


def test_the_scene_file_is_a_scene():
    text = (CASES / f"{SCENE}.opts").read_text()
    assert text.startswith("# ") and "-mpm_layers 10,10,10" in text
