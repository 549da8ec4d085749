"""An independent dense reference of the whole eigen model.

The test assembles K and M itself with a plain loop over material points, its own shape
functions (conftest.ref_shape), its own plane-strain D, point placement, node numbering and
boundary conditions, solves K x = lambda M x densely with numpy, and compares frequencies, the
free-DOF count and the written mode shapes with the command line's results.
"""

import math

import meshio
import numpy as np
import pytest

from conftest import check_ok

E, NU = 2.0e7, 0.25
RHO_S, RHO_L, POROSITY = 2650.0, 1000.0, 0.4
RHO = (1 - POROSITY) * RHO_S + POROSITY * RHO_L
CELLS, SIZE = (3, 4), (0.3, 0.4)
NMODES = 8
PPC = {"q4": 2, "q8": 3, "q9": 3}


def plane_strain(E_, nu):
    c = E_ / ((1 + nu) * (1 - 2 * nu))
    return c * np.array([[1 - nu, nu, 0.0], [nu, 1 - nu, 0.0], [0.0, 0.0, (1 - 2 * nu) / 2]])


def dense_model(ref_shapes, element, cells, size, ppc, E_, nu, rho, placement="uniform",
                bcs=None):
    """K, M over the free DOFs, the free DOFs as (lattice i, lattice j, component) and the
    lattice size. bcs: side -> fixed components (default: rollers on the sides, fixed base)."""
    ref_shape, ref_nodes = ref_shapes
    bcs = bcs or {"left": "x", "right": "x", "bottom": "xy", "top": ""}
    p = 1 if element == "q4" else 2
    nx, ny = cells
    hx, hy = size[0] / nx, size[1] / ny
    if placement == "uniform":
        s = np.array([-1 + (2 * k + 1) / ppc for k in range(ppc)])
        w = np.full(ppc, 2.0 / ppc)
    else:
        s, w = np.polynomial.legendre.leggauss(ppc)
    D = plane_strain(E_, nu)
    node_id = {}
    entries = []
    for cx in range(nx):
        for cy in range(ny):
            lattice = [(p * cx + int(round((a + 1) * p / 2)), p * cy + int(round((b + 1) * p / 2)))
                       for a, b in ref_nodes[element]]
            ids = [node_id.setdefault(ij, len(node_id)) for ij in lattice]
            dofs = [2 * n + c for n in ids for c in (0, 1)]
            for a in range(ppc):
                for b in range(ppc):
                    vol = w[a] * w[b] * hx * hy / 4
                    N, dN = ref_shape(element, s[a], s[b])
                    dNdx = dN[:, 0] * 2 / hx
                    dNdy = dN[:, 1] * 2 / hy
                    B = np.zeros((3, 2 * len(N)))
                    B[0, 0::2] = dNdx
                    B[1, 1::2] = dNdy
                    B[2, 0::2] = dNdy
                    B[2, 1::2] = dNdx
                    Nm = np.zeros((2, 2 * len(N)))
                    Nm[0, 0::2] = N
                    Nm[1, 1::2] = N
                    entries.append((dofs, B.T @ D @ B * vol, rho * vol * Nm.T @ Nm))
    ndof = 2 * len(node_id)
    K = np.zeros((ndof, ndof))
    M = np.zeros((ndof, ndof))
    for dofs, ke, me in entries:
        K[np.ix_(dofs, dofs)] += ke
        M[np.ix_(dofs, dofs)] += me
    ni, nj = p * nx + 1, p * ny + 1
    fixed = np.zeros(ndof, dtype=bool)
    where = {}
    for (i, j), n in node_id.items():
        where[2 * n] = (i, j, 0)
        where[2 * n + 1] = (i, j, 1)
        sides = {"left": i == 0, "right": i == ni - 1, "bottom": j == 0, "top": j == nj - 1}
        for side, comps in bcs.items():
            if sides[side]:
                fixed[2 * n] |= "x" in comps
                fixed[2 * n + 1] |= "y" in comps
    free = ~fixed & (np.diag(M) > 0)
    idx = np.flatnonzero(free)
    return K[np.ix_(idx, idx)], M[np.ix_(idx, idx)], [where[k] for k in idx], (ni, nj)


def dense_eigen(K, M):
    """Ascending eigenvalues and M-orthonormal eigenvectors (columns) via Cholesky of M."""
    L = np.linalg.cholesky(M)
    Li = np.linalg.inv(L)
    lam, Y = np.linalg.eigh(Li @ K @ Li.T)
    return lam, Li.T @ Y


def hz(lam):
    return np.sqrt(np.asarray(lam)) / (2 * math.pi)


def scene_args(element, ppc=None, extra=()):
    return ["-mpm_element", element, "-mpm_cells", f"{CELLS[0]},{CELLS[1]}",
            "-mpm_size", f"{SIZE[0]},{SIZE[1]}", "-mpm_ppc", ppc or PPC[element],
            "-mpm_E", E, "-mpm_nu", NU, "-mpm_rho_s", RHO_S, "-mpm_rho_l", RHO_L,
            "-mpm_porosity", POROSITY, "-mpm_nmodes", NMODES, "-mpm_figures", "0", *extra]


@pytest.fixture(scope="module")
def reference_runs(tmp_path_factory):
    from conftest import run_cli

    cache = {}

    def _get(element):
        if element not in cache:
            out = tmp_path_factory.mktemp(f"ref-{element}") / "out"
            res = run_cli(scene_args(element), out, options_file="eigen-q4")
            cache[element] = (res, out)
        return cache[element]

    return _get


@pytest.mark.parametrize("element", ["q4", "q8", "q9"])
def test_frequencies_match_dense_reference(ref_shapes, reference_runs, element):
    res, _ = reference_runs(element)
    s = check_ok(res)
    K, M, dofs, _ = dense_model(ref_shapes, element, CELLS, SIZE, PPC[element], E, NU, RHO)
    lam, _ = dense_eigen(K, M)
    assert s["eigen"]["ndof"] == len(dofs)
    assert s["eigen"]["n_points"] == CELLS[0] * CELLS[1] * PPC[element] ** 2
    assert s["eigen"]["density_kg_m3"] == pytest.approx(RHO, rel=1e-14)
    ref = hz(lam[:NMODES])
    for solver in ("jacobi", "slepc"):
        f = np.array(s["eigen"]["frequencies_hz"][solver])
        assert f.shape == (NMODES,)
        np.testing.assert_allclose(f, ref, rtol=1e-8, atol=0, err_msg=solver)


@pytest.mark.parametrize("element", ["q4", "q8", "q9"])
def test_fe_gauss_reference_matches_dense_fe(ref_shapes, reference_runs, element):
    """The summary's 'FE Gauss' column: the same mesh with 2 x 2 (Q4) or 3 x 3 (Q8, Q9)
    Gauss points, assembled here independently."""
    res, _ = reference_runs(element)
    s = check_ok(res)
    ng = 2 if element == "q4" else 3
    K, M, _, _ = dense_model(ref_shapes, element, CELLS, SIZE, ng, E, NU, RHO, "gauss")
    lam, _ = dense_eigen(K, M)
    np.testing.assert_allclose(s["eigen"]["references"]["fe_gauss_hz"], hz(lam[:NMODES]), rtol=1e-8)


@pytest.mark.parametrize("element", ["q4", "q8", "q9"])
def test_written_mode_shapes_match_dense_reference(ref_shapes, reference_runs, element):
    """modes.vtu: mode k on the lattice equals the reference eigenvector (MAC), fixed DOFs
    and absent nodes carry zero."""
    res, out = reference_runs(element)
    check_ok(res)
    K, M, dofs, (ni, nj) = dense_model(ref_shapes, element, CELLS, SIZE, PPC[element], E, NU,
                                       RHO)
    lam, X = dense_eigen(K, M)
    mesh = meshio.read(out / "modes.vtu")
    assert mesh.points.shape[0] == ni * nj
    p = 1 if element == "q4" else 2
    h = (SIZE[0] / CELLS[0] / p, SIZE[1] / CELLS[1] / p)
    lattice = np.rint(mesh.points[:, :2] / h).astype(int)
    row = {(i, j): r for r, (i, j) in enumerate(lattice)}
    assert len(row) == ni * nj
    for k in range(NMODES):
        gap = min(abs(lam[k] - lam[m]) / lam[k] for m in range(NMODES + 1) if m != k)
        u = mesh.point_data[f"mode_{k + 1}"]
        assert u.shape == (ni * nj, 3)
        ref = np.zeros((ni * nj, 3))
        for col, (i, j, c) in enumerate(dofs):
            ref[row[(i, j)], c] = X[col, k]
        assert np.all(u[ref == 0] == 0)       # fixed / unsupported DOFs and u_z stay zero
        if gap > 1e-6:                         # a well-separated mode is unique up to scale
            a, b = u.ravel(), ref.ravel()
            assert (a @ b) ** 2 / ((a @ a) * (b @ b)) > 1 - 1e-9, k


@pytest.mark.parametrize("element, ppc, extra, bcs", [
    ("q4", 3, ["-mpm_bc_top", "y", "-mpm_bc_right", "none"],
     {"left": "x", "right": "", "bottom": "xy", "top": "y"}),
    ("q9", 3, ["-mpm_points", "gauss"], None),
    ("q8", 4, ["-mpm_bc_left", "xy"], {"left": "xy", "right": "x", "bottom": "xy", "top": ""}),
])
def test_variants_match_dense_reference(cli, ref_shapes, element, ppc, extra, bcs):
    """Other point counts, Gauss placement and boundary conditions."""
    s = check_ok(cli(scene_args(element, ppc, extra), options_file="eigen-q4"))
    placement = "gauss" if "gauss" in extra else "uniform"
    K, M, dofs, _ = dense_model(ref_shapes, element, CELLS, SIZE, ppc, E, NU, RHO, placement,
                                bcs)
    lam, _ = dense_eigen(K, M)
    assert s["eigen"]["ndof"] == len(dofs)
    for solver in ("jacobi", "slepc"):
        np.testing.assert_allclose(
            s["eigen"]["frequencies_hz"][solver], hz(lam[:NMODES]), rtol=1e-8, err_msg=solver
        )


def test_dense_reference_reproduces_table3_q4(ref_shapes):
    """The reference itself reproduces the paper's Q4 column (guards the reference)."""
    K, M, dofs, _ = dense_model(ref_shapes, "q4", (1, 10), (0.1, 1.0), 2, 10e6, 0.0, 2190.0)
    lam, _ = dense_eigen(K, M)
    assert len(dofs) == 20
    assert [round(f, 2) for f in hz(lam[:5])] == pytest.approx(
        [16.92, 51.27, 87.24, 126.03, 168.95], abs=1e-9)
