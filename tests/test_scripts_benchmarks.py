"""The benchmark commands on their smallest cases (tests of the commands, not timings):
scripts/benchmark, which times each size by scripts/step-benchmark in its own process, and
scripts/footing-benchmark, whose solver runs go through the study harness. The site
benchmark's scene is fixed (about 12 s a run): its harness runs are tests/test_studies.py's
(a finished dynamic run reused, a timed one made afresh)."""

from __future__ import annotations

import json

import pytest
from conftest import PYTHON, REPO, run_command


def test_benchmark_times_the_step_by_the_step_benchmark_command(tmp_path):
    prefix = tmp_path / "bench"
    code, out, err = run_command(
        [PYTHON, REPO / "scripts" / "benchmark", "--sizes", "1e3", "--elements", "q4",
         "--ranks", "1", "--repeats", "1", "--budget", "4e4", "--no-compile", "--no-scenes",
         "--no-jacobi", "--output", prefix], timeout=120)
    assert code == 0, out + err
    result = json.loads(prefix.with_suffix(".json").read_text())
    (row,) = result["step"]
    assert row["element"] == "q4" and row["points"] == 1000 and row["cells"] == [5, 50]
    one = row["by_ranks"]["1"]
    assert one["finite"] and one["ns_per_point_step"] > 0 and one["peak_rss_bytes"] > 0
    assert result["machine"]["cpu"] and "numpy_simd" in result["machine"]
    assert prefix.with_suffix(".png").stat().st_size > 1000
    assert "q4        1,000" in prefix.with_suffix(".txt").read_text()


def test_footing_benchmark_on_a_small_grid_meets_the_fe(tmp_path):
    code, out, err = run_command(
        [PYTHON, REPO / "scripts" / "footing-benchmark", "--cells", "16,8", "--ranks", "1",
         "--explicit-seconds", "0", "--out", tmp_path], timeout=300)
    assert code == 0, out + err
    result = json.loads((tmp_path / "footing-benchmark.json").read_text())
    assert result["implicit"]["points"] == 512 and result["implicit"]["seconds"] > 0
    # 16 x 8 Q4 cells against the FE on as many Q9/Q4 cells: within 1 % at each T_v.
    assert result["errors_pct"] == pytest.approx([0, 0, 0], abs=1.0)
    assert result["explicit"] is None
    assert "Footing benchmark:" in (tmp_path / "footing-benchmark.txt").read_text()
