"""The problem's absolute residual floor (Newton's default ``atol``): a tiny load step next to a
critical state converges with default options instead of crawling at round-off."""

import numpy as np
import pytest

from ngsgel import NewtonError, ramp

from test_continuation import column


def _column_next_to_its_critical_load():
    prob, load, _ = column(12, control="displacement")  # clamped-guided, critical at load 1
    ramp(prob, load, 0.999, step=0.1)
    return prob, load


def test_a_tiny_step_next_to_the_critical_load_converges_on_the_floor_with_default_options():
    prob, load = _column_next_to_its_critical_load()
    start = prob.save_state()
    result = ramp(prob, load, 0.999 + 1e-6)
    n = result.newton[0]
    assert result.cutbacks == 0 and result.steps == 1
    assert n.criterion == "floor" and n.residuals[-1] <= prob.residual_floor == n.tolerance
    assert n.iterations <= 2
    one_ulp = last_place_change_of_the_residual(prob)
    # Without the floor the same step asks for rtol x its round-off-sized start residual: far
    # below the change that one unit in the last place of the converged state makes in the
    # residual, so the residual criterion is out of reach and only rounding luck decides what
    # happens (one assembly order crawled 30 iterations at ~3e-16 and was cut back, another
    # stopped on the increment after 12). The floor sits at or above that change.
    prob.restore_state(start)
    load.Set(0.999)
    without = ramp(prob, load, 0.999 + 1e-6, newton_options={"atol": 0.0})
    assert all(m.tolerance < 1e-6 * one_ulp and m.criterion != "residual" for m in without.newton)
    assert one_ulp <= prob.residual_floor
    assert without.cutbacks > 0 or sum(m.iterations for m in without.newton) > n.iterations


def last_place_change_of_the_residual(prob) -> float:
    """Free residual norm after moving every free dof of the state by one unit in its last place
    (alternating up and down), i.e. the residual's resolution at this state."""
    state = prob.state.FV().NumPy()
    free = prob.free_mask
    x = prob.state.CreateVector()
    x.FV().NumPy()[:] = state
    signs = np.where(np.arange(free.sum()) % 2 == 0, np.inf, -np.inf)
    x.FV().NumPy()[free] = np.nextafter(state[free], signs)
    r = x.CreateVector()
    prob.residual(x, r)
    return float(np.linalg.norm(r.FV().NumPy()[free]))

def test_a_failed_solve_names_the_floor():
    prob, load, _ = column(12)
    load.Set(0.5)
    with pytest.raises(NewtonError, match=f"floor atol = {prob.residual_floor:.3e} and rtol = 1e-11 x the largest"):
        prob.solve(maxit=1)
