"""ramp with a load schedule (``values``, ``strict``), Newton's step-relative criterion through
ramp, the work records of steps and predictors, and the thread settings."""

import numpy as np
import ngsolve as ngs
import pytest
import threadpoolctl

from geometries import block
from ngsgel import (EquilibriumProblem, FloryRehnerGel, RampError, Solid3D, ramp, set_threads, using_threads)
from ngsgel.threads import configured_threads

from test_equilibrium import corner_stretch, swelling_problem

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
MU0, MU1 = -0.1, -0.073


def bonded_block():
    """The benchmark's gel block bonded at its base (scripts/bench_newton.py), coarse."""
    mesh = block(lx=1, ly=1, lz=0.5, maxh=1.0, structured=True, nx=3, ny=3, nz=1).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0), mu=MU0, order=2)
    prob.fix("bottom")
    return prob


def test_twenty_value_schedule_is_one_call_hitting_each_value_with_each_steps_work():
    values = np.linspace(MU0, MU1, 21)[1:]
    prob = bonded_block()
    result = ramp(prob, prob.mu, values=values)
    assert result.converged and result.steps == 20 and result.cutbacks == 0
    assert result.values == [float(v) for v in values]  # each listed value exactly, not a sum of increments
    assert prob.mu.Get() == values[-1]
    assert [(v.value, v.steps, v.cutbacks) for v in result.schedule] == [(float(v), 1, 0) for v in values]
    for k, step in enumerate(result.records):
        n = step.newton
        assert n.converged and n.iterations >= 1
        # the first step's tangent predictor assembles and factorises; the secant predictors after it do not
        assert step.predictor.factorisations == (1 if k == 0 else 0)
        assert step.work.factorisations == n.iterations + step.predictor.factorisations
        assert result.schedule[k].factorisations == step.work.factorisations
        assert result.schedule[k].iterations == n.iterations
        for record in n.records[1:]:
            assert record.kind == "newton" and record.assemblies == record.factorisations == record.solves == 1
            assert min(record.assembly, record.factorisation, record.solve, record.residual) > 0
            assert record.total >= record.assembly + record.factorisation + record.solve + record.residual
    assert result.factorisations == sum(s.work.factorisations for s in result.records)
    assert result.solves == sum(s.work.solves for s in result.records)
    assert result.work.total == pytest.approx(sum(v.seconds for v in result.schedule))
    # the same equilibrium as the automatic ramp to the last value
    reference = bonded_block()
    ramp(reference, reference.mu, MU1)
    assert np.max(np.abs(prob.save_state() - reference.save_state())) < 1e-10


def test_a_value_that_fails_in_one_step_is_subdivided_or_with_strict_raises():
    lam0 = GEL.lam_free(-0.01)
    prob = swelling_problem("plane", GEL, lam0, -0.01)
    start = prob.save_state()
    with pytest.raises(RampError, match="strict") as info:
        ramp(prob, prob.mu, values=[-0.5, -3.0], strict=True, newton_options={"maxit": 6})
    failed = info.value.result
    assert failed.values == [-0.5] and prob.mu.Get() == -0.5 and failed.cutbacks == 0
    assert failed.failed_work and failed.work.factorisations > sum(s.work.factorisations for s in failed.records)
    assert not np.array_equal(prob.save_state(), start)  # at the last value reached

    prob = swelling_problem("plane", GEL, lam0, -0.01)
    result = ramp(prob, prob.mu, values=[-0.5, -3.0], newton_options={"maxit": 6})
    first, second = result.schedule
    assert (first.steps, first.cutbacks) == (1, 0)
    assert second.steps > 1 and second.cutbacks > 0 and result.cutbacks == second.cutbacks
    assert result.values[-1] == -3.0 and len(result.values) == 1 + second.steps
    assert all(len(s.failed) == 0 for s in result.records if s.goal == 0)
    assert corner_stretch(prob, lam0)[0] == pytest.approx(GEL.lam_plane_strain(-3.0, lam0), rel=1e-9)


def test_a_repeated_value_is_solved_in_place():
    prob = bonded_block()
    result = ramp(prob, prob.mu, values=[MU0, -0.095, -0.095])
    assert result.values == [MU0, -0.095, -0.095]
    assert [v.steps for v in result.schedule] == [1, 1, 1]
    assert result.newton[0].iterations == 0 and result.newton[2].iterations == 0


def test_step_reference_is_the_previous_equilibriums_residual_under_the_new_load():
    prob = bonded_block()
    prob.mu.Set(-0.095)
    r = prob.state.CreateVector()
    prob.residual(prob.state, r)
    r0 = float(np.linalg.norm(r.FV().NumPy()[prob.free_mask]))
    prob.mu.Set(MU0)
    result = ramp(prob, prob.mu, values=[-0.095], newton_options={"reference": "step", "rtol": 1e-9})
    n = result.newton[0]
    assert n.tolerance == pytest.approx(max(prob.residual_floor, 1e-9 * r0), rel=1e-12)
    assert n.criterion == "residual" and n.residuals[-1] <= n.tolerance < n.residuals[-2]
    # the same predicted start, far better than r0: relative to it (the default) asks for more
    fresh = bonded_block()
    n_max = ramp(fresh, fresh.mu, values=[-0.095], newton_options={"rtol": 1e-9}).newton[0]
    assert n_max.residuals[0] == pytest.approx(n.residuals[0], rel=1e-9)
    assert n.residuals[0] < 0.1 * r0 and n_max.tolerance < 0.1 * n.tolerance
    assert result.records[0].predictor.residual_evaluations >= 1  # r0 counted with the predictor


@pytest.mark.parametrize("kwargs, name", [
    ({"target": -0.09, "values": [-0.09]}, "target"),
    ({}, "target"),
    ({"values": []}, "values"),
    ({"values": [-0.09, float("nan")]}, "values"),
    ({"values": [-0.09], "step": 0.01}, "step"),
    ({"target": -0.09, "threads": 0}, "threads"),
    ({"target": -0.09, "newton_options": {"reference": "last"}}, "reference"),
    ({"target": -0.09, "newton_options": {"rtol": -1.0}}, "rtol"),
    ({"target": -0.09, "newton_options": {"atol": float("nan")}}, "atol"),
])
def test_bad_ramp_and_newton_options_are_named(kwargs, name):
    prob = bonded_block()
    with pytest.raises(ValueError, match=name):
        ramp(prob, prob.mu, **kwargs)


def _blas_threads() -> set[int]:
    return {info["num_threads"] for info in threadpoolctl.threadpool_info() if info["user_api"] == "blas"}


def test_threads_set_ngsolve_and_limit_blas_and_are_restored():
    # NGSolve's count is the one its next TaskManager runs with (configured_threads); 3 differs
    # from every default on this machine, so a setting that did not reach NGSolve shows
    before, blas_before = configured_threads(), _blas_threads()
    assert before != 3
    with using_threads(3):
        assert configured_threads() == 3 and _blas_threads() == {1}
    assert configured_threads() == before and _blas_threads() == blas_before
    prob = bonded_block()
    seen = []
    ramp(prob, prob.mu, values=[-0.095], threads=3,
         on_step=lambda value, result: seen.append((configured_threads(), _blas_threads())))
    assert seen == [(3, {1})] and configured_threads() == before
    try:
        set_threads(3)
        assert configured_threads() == 3 and _blas_threads() == {1}
    finally:
        ngs.SetNumThreads(before)
        threadpoolctl.threadpool_limits(max(blas_before), user_api="blas")
    with pytest.raises(ValueError, match="threads"):
        set_threads(1.5)
