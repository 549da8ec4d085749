"""The mpi(N) marker (tests/mpi_pytest.py): a failure on any rank fails the test, and a
hang is reported rather than waited for."""

from __future__ import annotations

from conftest import PYTHON, REPO, run_command

SAMPLE = '''
import pytest
from mpi4py import MPI


@pytest.mark.mpi(2)
def test_passes_on_both(tmp_path):
    # tmp_path is shared: what rank 0 writes, rank 1 reads.
    if MPI.COMM_WORLD.rank == 0:
        (tmp_path / "f").write_text("x")
    MPI.COMM_WORLD.barrier()
    assert MPI.COMM_WORLD.size == 2 and (tmp_path / "f").read_text() == "x"


@pytest.mark.mpi(2)
def test_fails_on_rank_1():
    assert MPI.COMM_WORLD.rank == 0


@pytest.mark.mpi(2)
def test_hangs_on_rank_0():
    if MPI.COMM_WORLD.rank == 0:
        MPI.COMM_WORLD.barrier()


def test_serial():
    assert MPI.COMM_WORLD.size == 1
'''


def test_failures_and_hangs_on_one_rank_are_reported(tmp_path):
    folder = tmp_path / "suite"
    folder.mkdir()
    for name in ("conftest.py", "mpi_pytest.py"):
        (folder / name).write_text((REPO / "tests" / name).read_text())
    (folder / "test_sample.py").write_text(SAMPLE)
    code, out, err = run_command(
        ["env", f"PYTHONPATH={REPO}", "MPM_TEST_MPI_TIMEOUT=8", PYTHON, "-m", "pytest",
         "-q", "-p", "no:cacheprovider", "--color=no", str(folder)], timeout=120, cwd=folder)
    assert code == 1, out + err
    assert "2 failed, 2 passed" in out, out
    assert "FAILED test_sample.py::test_fails_on_rank_1" in out
    assert "failed on rank 1 of 2" in out
    assert "FAILED test_sample.py::test_hangs_on_rank_0" in out
    assert "killed after its timeout of 8 s" in out
