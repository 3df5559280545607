"""Newton's ``stall_window``: a solve with no equilibrium nearby gives up after the window instead
of ``maxit`` iterations, and solves that converge are not touched."""

import numpy as np
import pytest

from ngsgel import ramp
from ngsgel.newton import NewtonError

from test_continuation import arch

ARCH_LIMIT = 0.0300719  # the arch's first limit load (located by arclength in test_relaxation)


def _arch_on_the_near_branch():
    prob, load, w = arch()
    ramp(prob, load, 0.95 * ARCH_LIMIT, step=0.01)
    return prob, load, w


def test_a_solve_past_the_limit_load_stalls_after_the_window_with_the_state_restored():
    prob, load, _ = _arch_on_the_near_branch()
    before = prob.save_state()
    load.Set(1.1 * ARCH_LIMIT)
    with pytest.raises(NewtonError, match="no convergence in 30 iterations"):
        prob.solve()
    with pytest.raises(NewtonError, match="stalled: 5 iterations") as stalled:
        prob.solve(stall_window=5)
    residuals = stalled.value.result.residuals
    assert stalled.value.result.iterations == 5
    assert residuals[-1] > 0.5 * residuals[0]  # what the window tests
    assert np.array_equal(prob.save_state(), before)


def test_converging_steps_are_the_same_with_a_stall_window():
    states, iterations = [], []
    for window in (None, 3):
        prob, load, _ = arch()
        result = ramp(prob, load, 0.95 * ARCH_LIMIT, step=0.01, newton_options={"stall_window": window})
        states.append(prob.save_state())
        iterations.append([n.iterations for n in result.newton])
    assert iterations[0] == iterations[1]
    assert np.array_equal(states[0], states[1])


@pytest.mark.parametrize("window", [0, 2.5, -1])
def test_bad_stall_window_is_named(window):
    prob, _, _ = arch()
    with pytest.raises(ValueError, match="stall_window"):
        prob.solve(stall_window=window)


def test_a_stalling_trend_gives_up_before_the_window_with_the_state_restored():
    prob, load, _ = _arch_on_the_near_branch()
    before = prob.save_state()
    load.Set(1.1 * ARCH_LIMIT)
    with pytest.raises(NewtonError, match="stalled: the last 3 iterations") as stalled:
        prob.solve(stall_window=10, stall_trend=3)
    result = stalled.value.result
    assert result.iterations < 10
    residuals = result.residuals
    # what the trend tests: three iterations that, kept up, would not halve the residual in ten
    assert residuals[-1] > 0.5 ** 0.3 * residuals[-4]
    assert all(r > 0.5 ** 0.3 * s for r, s in zip(residuals[3:-1], residuals[:-4]))  # not before the last
    assert np.array_equal(prob.save_state(), before)


def test_converging_steps_are_the_same_with_a_stall_trend():
    runs = []
    for options in ({"stall_window": 10}, {"stall_window": 10, "stall_trend": 3}):
        prob, load, _ = arch()
        result = ramp(prob, load, 0.95 * ARCH_LIMIT, step=0.01, newton_options=options)
        runs.append((prob.save_state(), [n.iterations for n in result.newton]))
    assert runs[0][1] == runs[1][1]
    assert np.array_equal(runs[0][0], runs[1][0])


@pytest.mark.parametrize("options", [{"stall_trend": 3}, {"stall_window": 10, "stall_trend": 0},
                                     {"stall_window": 10, "stall_trend": 1.5}])
def test_bad_stall_trend_is_named(options):
    prob, _, _ = arch()
    with pytest.raises(ValueError, match="stall_trend"):
        prob.solve(**options)


def test_quadratic_backtracking_reaches_the_same_states_and_names_bad_input():
    runs = []
    for backtrack in ("halving", "quadratic"):
        prob, load, _ = arch()
        ramp(prob, load, 0.95 * ARCH_LIMIT, step=0.01, newton_options={"backtrack": backtrack})
        runs.append(prob.save_state())
    assert np.max(np.abs(runs[0] - runs[1])) < 1e-10
    with pytest.raises(ValueError, match="backtrack"):
        prob.solve(backtrack="cubic")


def test_quadratic_backtracking_keeps_armijo_and_gives_up_past_the_limit_load_in_fewer_residuals():
    evaluations = {}
    for backtrack in ("halving", "quadratic"):
        prob, load, _ = _arch_on_the_near_branch()
        before = prob.save_state()
        load.Set(1.1 * ARCH_LIMIT)
        with pytest.raises(NewtonError, match="stalled") as stalled:
            prob.solve(stall_window=5, backtrack=backtrack)
        result = stalled.value.result
        residuals = result.residuals
        assert all(b < a for a, b in zip(residuals, residuals[1:]))  # each kept point lowers it (Armijo)
        evaluations[backtrack] = result.work.residual_evaluations
        assert np.array_equal(prob.save_state(), before)
    assert evaluations["quadratic"] < evaluations["halving"], evaluations
