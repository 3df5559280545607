"""Newton's ``merit="energy"``: where the factorisation says the tangent is positive definite
(PARDISO's inertia), a step the residual norm refuses is kept when it lowers the energy (Armijo
along the Newton direction, a descent direction there). Elsewhere - a saddle, a backend without
inertia - the solve is the residual-merit one, bit for bit."""

import numpy as np
import pytest

from ngsgel import StabilityOptions, follow_path, linalg, ramp
from ngsgel.newton import NewtonError, newton

from test_newton_stall import ARCH_LIMIT
from test_predictor import arch

needs_pardiso = pytest.mark.skipif(not linalg.pardiso_available(),
                                   reason="MKL PARDISO not installed (pip install ngsgel[pardiso]): the energy "
                                          "merit needs the factorisation's inertia")


def test_bad_merit_is_named_and_an_energy_merit_needs_an_energy():
    prob, _ = arch("load")
    with pytest.raises(ValueError, match="merit"):
        prob.solve(merit="work")

    class NoEnergy:  # the protocol without an energy
        state, free_mask = prob.state, prob.free_mask
        residual, tangent, prescribed, admissible = prob.residual, prob.tangent, prob.prescribed, prob.admissible

    with pytest.raises(ValueError, match="energy"):
        newton(NoEnergy(), prob._solver, merit="energy")


def test_without_an_inertia_the_energy_merit_is_the_residual_one_bit_for_bit():
    runs = []
    for merit in ("residual", "energy"):
        prob, load = arch("load", inverse="umfpack")  # no inertia
        result = ramp(prob, load, 0.95 * ARCH_LIMIT, step=0.01, newton_options={"merit": merit})
        runs.append((prob.save_state(), [n.residuals for n in result.newton]))
    assert np.array_equal(runs[0][0], runs[1][0])
    assert runs[0][1] == runs[1][1]


@needs_pardiso
def test_one_solve_from_rest_to_near_the_limit_load_converges_with_the_energy_and_not_with_the_residual():
    # the first full Newton step of the arch under 0.95 of its limit load raises the residual 80-fold
    # and lowers the energy as its model says; kept, the solve converges quadratically onto the
    # state a ramp of small steps reaches, where halving it for the residual crawls
    prob, load = arch("load", inverse="pardiso")
    ramp(prob, load, 0.95 * ARCH_LIMIT, step=0.01)
    ramped = prob.save_state()
    for merit in ("residual", "energy"):
        prob, load = arch("load", inverse="pardiso")
        load.Set(0.95 * ARCH_LIMIT)
        if merit == "residual":
            with pytest.raises(NewtonError, match="no convergence in 60"):
                prob.solve(merit=merit, maxit=60)
            continue
        result = prob.solve(merit=merit, maxit=60)
        assert result.iterations <= 10 and result.line_search_cuts == 0, result.residuals
        assert max(result.residuals) > 10 * result.residuals[0]  # what the residual merit refuses
        assert np.max(np.abs(prob.save_state() - ramped)) < 1e-12  # |state| 0.02: the near branch


@needs_pardiso
def test_next_to_a_saddle_the_energy_merit_is_the_residual_one_bit_for_bit():
    prob, load = arch("load", inverse="pardiso")
    path = follow_path(prob, load, step=0.01, max_step=0.02, target=0.05, keep_states=True, max_steps=60,
                       stability=StabilityOptions(eigenvalues=2, tol=1e-4))
    saddle = next(p for p in path.points if p.negative == 1 and not p.events)
    neighbour = path.points[path.points.index(saddle) + 1]
    runs = []
    for merit in ("residual", "energy"):
        prob.restore_state(saddle.state + 0.1 * (neighbour.state - saddle.state))
        load.Set(saddle.parameter)
        result = prob.solve(merit=merit)
        assert prob._solver.inertia[1] == 1  # the tangent at the end: the saddle's
        runs.append((prob.save_state(), result.residuals, result.line_search_cuts))
    assert np.array_equal(runs[0][0], runs[1][0]) and runs[0][1:] == runs[1][1:]
