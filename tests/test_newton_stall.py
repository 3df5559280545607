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
