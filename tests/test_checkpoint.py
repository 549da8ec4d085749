"""Checkpoint and restart of consolidation runs; SIGTERM writes a checkpoint and stops."""

from __future__ import annotations

import json
import os

import numpy as np
import pytest
from conftest import REPO, check_ok, stopped_at_checkpoint

SCENE = ["-mpm_progress", "0", "-mpm_figures", "0"]


def _same(a, b, rtol=1e-12):
    np.testing.assert_allclose(
        b["consolidation"]["monitor"]["p_over_q"],
        a["consolidation"]["monitor"]["p_over_q"],
        rtol=rtol,
    )
    # The profile errors are norms of p/q differences: a summation order that changes
    # with the rank count moves them by round-off of p/q (1e-15), not of the error itself.
    for key in ("terzaghi", "consistent"):
        np.testing.assert_allclose(
            b["consolidation"]["profile_l2"][key],
            a["consolidation"]["profile_l2"][key],
            rtol=rtol,
            atol=1e-13,
        )
    assert a["steps"] == b["steps"] and a["consolidation"]["dt"] == b["consolidation"]["dt"]


@pytest.mark.mpi(2)
@pytest.mark.parametrize("first,second,extra", [
    (1, 2, []), (2, 1, []), (2, 1, ["-mpm_kinematics", "large"]),
    (1, 2, ["-mpm_element", "q8", "-mpm_ppc", "3"])])
def test_restart_on_other_rank_count_matches_uninterrupted(cli, tmp_path, first, second,
                                                           extra):
    """With either kinematics (points located by x0 or by x) and the Q8 scheme."""
    end = ["-mpm_Tv_end", "0.05", "-mpm_Tv_report", "0.02,0.05", *extra]
    full = check_ok(cli(SCENE + end, ranks=1, options_file="consolidation-m2-q4",
                        out_dir=tmp_path / "full"))
    part = cli(SCENE + extra + ["-mpm_Tv_end", "0.02", "-mpm_Tv_report", "0.02",
                                "-mpm_checkpoint_every", "700"],
               ranks=first, options_file="consolidation-m2-q4", out_dir=tmp_path / "part")
    ckpt = tmp_path / "part" / "checkpoint.npz"
    assert part.returncode == 0 and ckpt.is_file()
    res = cli(SCENE + end + ["-mpm_restart", ckpt], ranks=second,
              options_file="consolidation-m2-q4", out_dir=tmp_path / "rest")
    rest = check_ok(res)
    assert "Restart from" in res.stdout
    _same(full, rest)


def test_sigterm_checkpoints_and_the_restart_matches(cli, tmp_path):
    end = ["-mpm_Tv_end", "0.3", "-mpm_Tv_report", "0.02,0.3"]
    out = tmp_path / "killed"
    stopped_at_checkpoint(["-options_file", REPO / "cases" / "consolidation-m1-q4.opts",
                           *SCENE, *end, "-mpm_checkpoint_every", "1000", "-mpm_output", out],
                          out / "checkpoint.npz")
    import json

    with open(out / "summary.json") as fh:
        summary = json.load(fh)
    assert summary["error"]["kind"] == "interrupted" and summary["completed"] is False
    assert 0 < summary["steps"]
    assert not [f for f in os.listdir(out) if f.startswith(".partial")]

    full = check_ok(cli(SCENE + end, options_file="consolidation-m1-q4",
                        out_dir=tmp_path / "full"))
    assert summary["steps"] < full["steps"]
    # End-to-end on 2 ranks: as an mpi(2) test every rank would start and kill its own run.
    rest = check_ok(cli(SCENE + end + ["-mpm_restart", out / "checkpoint.npz"], ranks=2,
                        options_file="consolidation-m1-q4", out_dir=out, process=True))
    _same(full, rest)


def _checkpoint(cli, tmp_path):
    res = cli(SCENE + ["-mpm_Tv_end", "0.002", "-mpm_Tv_report", "0.002",
                       "-mpm_checkpoint_every", "20"],
              options_file="consolidation-m1-q4", out_dir=tmp_path / "ck")
    assert res.returncode == 0
    return tmp_path / "ck" / "checkpoint.npz"


@pytest.mark.parametrize("damage", ["missing", "truncated", "garbage", "other_physics"])
def test_bad_restart_file_is_an_input_error(cli, tmp_path, damage):
    ckpt = _checkpoint(cli, tmp_path)
    args = ["-mpm_restart", ckpt]
    if damage == "missing":
        args = ["-mpm_restart", tmp_path / "nothing.npz"]
    elif damage == "truncated":
        data = ckpt.read_bytes()
        ckpt.write_bytes(data[: len(data) // 2])
    elif damage == "garbage":
        ckpt.write_bytes(b"not a checkpoint at all\n" * 100)
    else:
        args += ["-mpm_E", "2e7"]
    out = tmp_path / "never"
    res = cli(SCENE + args, options_file="consolidation-m1-q4", out_dir=out)
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    if damage == "other_physics":     # the option that would change the run, named first
        assert len(lines) == 1 and lines[0].startswith("solver: error: -mpm_E 20000000.0: ")
        assert f"the run of -mpm_restart {ckpt} has 10000000.0" in lines[0]
    else:
        assert len(lines) == 1 and lines[0].startswith("solver: error: -mpm_restart")
    assert not out.exists()


def test_checkpoint_without_a_field_of_the_scheme_is_an_input_error(cli, tmp_path):
    """A checkpoint of Q9 cells written before their default pressure projection became
    'corner' (whose points keep the pressure's gradient, gradp) cannot continue as the
    scheme its options now give: one line, exit 2, nothing written."""
    res = cli(SCENE + ["-mpm_element", "q9", "-mpm_ppc", "3", "-mpm_cells", "1,5",
                       "-mpm_Tv_end", "0.002", "-mpm_Tv_report", "0.002",
                       "-mpm_checkpoint_every", "20"],
              options_file="consolidation-m1-q4", out_dir=tmp_path / "ck")
    check_ok(res)
    ckpt = tmp_path / "ck" / "checkpoint.npz"
    with np.load(ckpt) as z:
        members = {k: z[k] for k in z.files}
    layout = json.loads(str(members["layout"]))
    assert "gradp" in layout
    start = sum(bs for name, bs in list(layout.items())[:list(layout).index("gradp")])
    keep = [c for c in range(members["fields"].shape[1]) if not start <= c < start + 2]
    members["fields"] = members["fields"][:, keep]
    del layout["gradp"]
    members["layout"] = np.array(json.dumps(layout))
    np.savez(ckpt, **members)
    out = tmp_path / "never"
    res = cli(SCENE + ["-mpm_restart", ckpt], out_dir=out)
    assert res.returncode == 2, res.stderr
    assert res.stderr.count("\n") == 1 and "lack the field 'gradp'" in res.stderr
    assert not out.exists()
