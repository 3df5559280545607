"""``ramp``'s quadratic predictor: the parabola through the last two converged states with the
path's tangent at the last one. Its guess error falls like h^3 where the secant's falls like h^2,
for a dead load and for a prescribed displacement; without a tagged factorisation it is the
secant."""

import numpy as np
import ngsolve as ngs
import pytest

from ngsgel import StabilityOptions, follow_path, linalg, ramp
from ngsgel.scenes import buckling_demo
from ngsgel.newton import Work
from ngsgel.stability import load_rate
from ngsgel.stepping import _quadratic_guess


def arch(controlled: str, inverse: str = "umfpack"):
    """The half arch of the continuation tests, loaded by a dead traction or pushed down at its
    crown (the symmetry plane moved by ``-load``)."""
    prob, load, _ = buckling_demo.arch_problem(rise=0.055, thickness=0.03, elements=16, order=3,
                                               load_scale=1e-4 if controlled == "load" else 0.0)
    prob.inverse = inverse
    if controlled == "displacement":
        prob.prescribe("left", "y", -load)
    return prob, load


def converged(prob, load, value: float) -> np.ndarray:
    load.Set(value)
    prob.solve()
    return prob.save_state()


def guess_errors(controlled: str, at: float, h: float) -> tuple[float, float]:
    """Max-norm errors of the quadratic and the secant guess at ``at + h`` from the converged states
    at ``at - h`` and ``at``."""
    prob, load = arch(controlled)
    ramp(prob, load, at - h, step=h)
    previous = (at - h, prob.save_state())
    current = (at, converged(prob, load, at))
    exact = converged(prob, load, at + h)
    prob.restore_state(current[1])
    load.Set(at)
    solver = prob._solver
    solver.factor(prob.tangent(prob.state))
    solver.factorised_at = (at, current[1].copy())
    quadratic = _quadratic_guess(prob, load, current, previous, at + h, work=Work("predictor"))
    secant = current[1] + (current[1] - previous[1])
    return float(np.max(np.abs(quadratic - exact))), float(np.max(np.abs(secant - exact)))


@pytest.mark.parametrize("controlled,at,h", [("load", 0.02, 2e-3), ("displacement", 0.04, 4e-3)])
def test_the_quadratic_guess_is_third_order_where_the_secant_is_second(controlled, at, h):
    coarse, fine = guess_errors(controlled, at, h), guess_errors(controlled, at, h / 2)
    quadratic_rate, secant_rate = np.log2(coarse[0] / fine[0]), np.log2(coarse[1] / fine[1])
    assert 2.7 < quadratic_rate < 3.3, (coarse, fine)
    assert 1.8 < secant_rate < 2.2, (coarse, fine)
    assert coarse[0] < 0.5 * coarse[1]


def test_without_a_tagged_factorisation_the_quadratic_predictor_is_the_secant():
    runs = []
    for predictor in ("secant", "quadratic"):
        prob, load = arch("load")
        result = ramp(prob, load, 0.025, step=0.004, predictor=predictor)
        runs.append((prob.save_state(), [n.iterations for n in result.newton], result.values))
    assert np.array_equal(runs[0][0], runs[1][0]) and runs[0][1:] == runs[1][1:]


def test_a_stale_tag_is_not_used():
    prob, load = arch("load")
    state = converged(prob, load, 0.01)
    prob._solver.factor(prob.tangent(prob.state))
    prob._solver.factorised_at = (0.01, state.copy())
    assert prob._solver.factorisation_at(0.01, state) is not None
    assert prob._solver.factorisation_at(0.011, state) is None
    assert prob._solver.factorisation_at(0.01, state + 1e-12) is None
    prob._solver.factor(prob.tangent(prob.state))  # a new factorisation clears the tag
    assert prob._solver.factorisation_at(0.01, state) is None


@pytest.mark.parametrize("bad", ["cubic", None])
def test_bad_predictor_is_named(bad):
    prob, load = arch("load")
    with pytest.raises(ValueError, match="predictor"):
        ramp(prob, load, 0.01, step=0.005, predictor=bad)
    with pytest.raises(ValueError, match="predictor"):
        follow_path(prob, load, method="natural", step=0.005, target=0.01, predictor=bad)


@pytest.mark.skipif(not linalg.pardiso_available(), reason="MKL PARDISO not installed (pip install ngsgel[pardiso])")
def test_a_checked_path_takes_its_guesses_from_the_check_factorisation():
    # the crown pushed down: every step after the first two guesses from the stability check's
    # factorisation (one solve, two residuals), reaches the secant path's states, in fewer iterations
    runs = {}
    for predictor in ("secant", "quadratic"):
        prob, depth = arch("displacement", inverse="pardiso")
        result = follow_path(prob, depth, method="natural", step=0.01, max_step=0.01, target=0.05,
                             stability=StabilityOptions(), predictor=predictor)
        assert result.stop_reason == "target"
        guesses = [r for s in result.steps[2:] for r in s.records if r.kind == "predictor"]
        assert guesses and all(g.solves == (1 if predictor == "quadratic" else 0) for g in guesses)
        runs[predictor] = (prob.save_state(), sum(p.iterations for p in result.points))
    assert np.max(np.abs(runs["quadratic"][0] - runs["secant"][0])) < 1e-9
    assert runs["quadratic"][1] < runs["secant"][1], runs


def test_the_load_rate_along_the_prescribed_motion_is_the_tangent_coupled_one():
    prob, depth = arch("displacement")
    converged(prob, depth, 0.03)
    with_tangent = load_rate(prob, depth, relative_step=1e-6)
    moved = load_rate(prob, depth, relative_step=1e-6, move_prescribed=True)
    assert np.array_equal(moved.prescribed, with_tangent.prescribed)
    scale = np.max(np.abs(with_tangent.residual))
    # measured 2.3e-12: the two differ by the central difference's O(h^2) along the motion
    assert scale > 0 and np.max(np.abs(moved.residual - with_tangent.residual)) < 1e-9 * scale
