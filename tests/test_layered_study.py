"""scripts/layered-convergence on its smallest Q4 grid (1 x 10 cells, 40 points): the run's
profiles against the layered column the script builds from the summary's layers alone, and
the command's table row.

The bounds hold with margin: on 1 x 10 Q4 cells the largest error is 2.9 % of q at
T_v = 0.05 (the steep front just below the interface), 0.74 and 0.57 % at T_v = 0.2 and 0.5,
and the L2 error 0.88 % (docs/studies.md, "Layered consolidation under refinement"); Q4
converges at order 2 from there. The script's reference is built independently of the
solver's (solver/consolidation/plan.py References._of_layers), so their agreement checks
that the run compares what the scene is."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PYTHON, REPO, check_ok, run_command, script_module


@pytest.fixture(scope="module")
def study():
    return script_module("layered_convergence")


def test_coarsest_q4_grid_within_bounds_of_the_layered_column(study, cli, tmp_path):
    out = tmp_path / "out"
    summary = check_ok(cli(study.options("q4", "1x10", str(out)), out_dir=out))
    assert (
        summary["consolidation"]["n_points"] == 40 and summary["consolidation"]["element"] == "q4"
    )
    assert [s["thickness_m"] for s in summary["consolidation"]["layers"]] == [0.5, 0.5]
    assert [s["E"] for s in summary["consolidation"]["layers"]] == [40e6, 10e6]
    assert [s["k"] for s in summary["consolidation"]["layers"]] == [2.5e-3, 2.5e-4]
    summary, rows = study.read(out)
    reports, worst, l2_each, l2 = study.errors(summary, rows)
    assert reports == [0.05, 0.2, 0.5]
    # The script's column and the solver's own compressible-water reference agree: the
    # same L2 error of the profile at each report time, where the solver evaluates its
    # reference at the nominal time of T_v (c_v from the summary), not at the time of the
    # step that reports, t_s, as the script does (within half a step of it).
    column, H = study.column(summary), 1.0
    for Tv, l2_t, solver_l2 in zip(reports, l2_each, summary["profile_l2"]["consistent"]):
        at = [r for r in rows if r["Tv"] == pytest.approx(Tv)]
        nominal = Tv * H * H / summary["c_v"]
        assert abs(at[0]["t_s"] - nominal) <= 0.5 * summary["dt"] * (1 + 1e-9)
        y = np.array([r["y0_m"] for r in at])
        e = (np.array([r["p_over_q_compression_positive"] for r in at])
             - column.pressure(y, nominal) / study.Q)
        V = np.array([r["volume_m3"] for r in at])
        assert np.sqrt(V @ e ** 2 / V.sum()) == pytest.approx(solver_l2, rel=1e-9)
        assert l2_t == pytest.approx(100 * solver_l2, rel=1e-2)
    assert worst[0] < 5.0 and max(worst[1:]) < 2.0, worst
    assert l2 < 2.0 and max(l2_each) < 2.0, l2_each
    # Not trivially small either: the coarse grid's error is there to converge.
    assert l2 > 0.1


def test_the_command_prints_the_row_of_the_grid(study):
    code, out, err = run_command([PYTHON, REPO / "scripts" / "layered_convergence.py",
                                  "--elements", "q4", "--cells", "1x10"], timeout=120)
    assert code == 0, err
    rows = [line.split() for line in out.splitlines() if line.split()[:1] == ["q4"]]
    assert len(rows) == 1
    element, cells, points, *pct, wall = rows[0]
    assert (element, cells, points) == ("q4", "1x10", "40")
    assert len(pct) == 4 and all(p.endswith("%") for p in pct)
    worst, l2 = [float(p[:-1]) for p in pct[:3]], float(pct[3][:-1])
    assert worst[0] < 5.0 and max(worst[1:]) < 2.0 and 0.1 < l2 < 2.0
    assert float(wall) > 0
    code, _, err = run_command([PYTHON, REPO / "scripts" / "layered_convergence.py",
                                "--cells", "1x5"], timeout=60)
    assert code == 2 and "NY even" in err
