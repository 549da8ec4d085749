"""Every PETSc object the set-up makes has an owner that destroys it."""

from __future__ import annotations

import pytest
from conftest import ONE_AND_TWO_RANKS, scene_options, typed
from petsc4py import PETSc

from solver.stepping.twophase import TwoPhase, point_fields
from solver.model import assembly, scene
from solver.model.grid import Grid


def _body_soil(p):
    t = typed(p)
    return t.body, t.soil


@ONE_AND_TWO_RANKS
def test_build_returns_what_destroy_destroys(ranks):
    assert PETSc.COMM_WORLD.getSize() == ranks
    made = scene.build(PETSc.COMM_WORLD, *_body_soil(scene_options()))
    grid, points, K, M, free = made
    assert K.handle and M.handle and free.handle and grid.da.handle
    scene.destroy(*reversed(made))
    assert not (K.handle or M.handle or free.handle or grid.da.handle or points.swarm.handle)


@ONE_AND_TWO_RANKS
def test_a_failed_build_destroys_what_it_made(monkeypatch, ranks):
    assert PETSc.COMM_WORLD.getSize() == ranks
    made = []
    real = Grid.destroy

    def destroy(self):
        made.append(self)
        real(self)

    def fail(*args, **kwargs):
        raise RuntimeError("assembly failed")

    monkeypatch.setattr(Grid, "destroy", destroy)
    monkeypatch.setattr(assembly, "stiffness_and_mass", fail)
    with pytest.raises(RuntimeError, match="assembly failed"):
        scene.build(PETSc.COMM_WORLD, *_body_soil(scene_options()))
    assert len(made) == 1 and not made[0].da.handle


@ONE_AND_TWO_RANKS
def test_two_phase_body_and_model_as_with_blocks(ranks):
    assert PETSc.COMM_WORLD.getSize() == ranks
    p = scene_options()
    t = typed(p)
    grid, points = scene.two_phase_body(PETSc.COMM_WORLD, t.body, t.soil,
                                        point_fields(t.scheme))
    with grid, points, TwoPhase(grid, points, t.soil, t.body, t.loading, t.scheme) as model:
        x, x0, J, ids = points.get("x", "x0", "J", "id")
        assert (x == x0).all() and (J == 1).all()
        # ids number the points 0 .. n - 1 over all ranks, once each.
        every = sorted(int(i) for part in PETSc.COMM_WORLD.tompi4py().allgather(list(ids))
                       for i in part)
        assert every == list(range(points.n_global))
        model.step(1e-7, 1.0, p.damping, t.scheme.flip)
    assert not grid.da.handle and not points.swarm.handle
    assert model._C is None


def test_stage_is_popped_when_its_block_raises():
    # A stage left pushed would nest every later stage under it in -log_view; the with
    # block pops it, and a second with block of the same stage then works as the first.
    stage = PETSc.Log.Stage("test_lifetimes")
    for _ in range(2):
        with pytest.raises(ValueError):
            with stage:
                raise ValueError
    with stage:
        pass


def test_slepc_solver_is_destroyed_when_the_solve_fails(monkeypatch):
    from solver.common.errors import NumericalError
    from solver.modal import frequency

    made = scene.build(PETSc.COMM_WORLD, *_body_soil(scene_options(analysis="eigen")))
    _, _, K, M, _ = made
    solvers = []
    configure = frequency._configure

    def keep(eps, *args):
        solvers.append(eps)
        configure(eps, *args)

    monkeypatch.setattr(frequency, "_configure", keep)
    try:
        # More modes than the model has: SLEPc converges fewer than asked.
        with pytest.raises(NumericalError, match="SLEPc converged"):
            frequency.slepc_solve(K, M, K.getSize()[0] + 5)
    finally:
        scene.destroy(*reversed(made))
    assert len(solvers) == 1 and not solvers[0].handle


def test_f1_solve_takes_its_own_options_prefix(cli):
    # f1 by SLEPc (-mpm_eigen_solver slepc): -f1_eps_view shows its solver, and -eps_view,
    # an eigen analysis's option, is not the f1 solve's.
    args = ["-mpm_Tv_end", "0.001", "-mpm_Tv_report", "0.001", "-mpm_figures", "0",
            "-mpm_eigen_solver", "slepc"]
    res = cli(args + ["-f1_eps_view"], options_file="consolidation-m1-q4")
    assert res.returncode == 0 and "EPS Object: (f1_)" in res.stdout
    res = cli(args + ["-eps_view"], options_file="consolidation-m1-q4")
    assert res.returncode == 0 and "EPS Object" not in res.stdout
