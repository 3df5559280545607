"""The problem's absolute residual floor (Newton's default ``atol``): a tiny load step next to a
critical state converges with default options instead of crawling at round-off."""

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
    # without the floor the same step cannot meet 1e-11 of a residual that starts at round-off:
    # 30 iterations at ~3e-16, then cut back
    prob.restore_state(start)
    load.Set(0.999)
    assert ramp(prob, load, 0.999 + 1e-6, newton_options={"atol": 0.0}).cutbacks > 0


def test_a_failed_solve_names_the_floor():
    prob, load, _ = column(12)
    load.Set(0.5)
    with pytest.raises(NewtonError, match=f"floor atol = {prob.residual_floor:.3e} and rtol = 1e-11 x the largest"):
        prob.solve(maxit=1)
