"""Newton with a reused factorisation (chord steps) reaches the same equilibria as full Newton."""

import numpy as np

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, Solid3D, ramp

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)


def _problem():
    mesh = block(lx=1, ly=1, lz=0.5, maxh=1.0, structured=True, nx=3, ny=3, nz=1).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(-0.1), mu=-0.1, order=2)
    prob.fix("bottom")
    return prob


def test_chord_steps_reach_the_full_newton_state():
    states, results = [], []
    # no floor: both converge by the relative criterion, which is what the comparison is about
    for options in ({"atol": 0.0}, {"atol": 0.0, "reuse_factorisation": True}):
        prob = _problem()
        res = ramp(prob, prob.mu, -0.09, step=0.0025, max_step=0.0025, grow=1.0, newton_options=options)
        assert res.converged and res.steps == 4
        states.append(prob.save_state())
        results.append(res)
    full, reuse = results
    assert all(n.chord_steps == 0 and n.factorisations == n.iterations for n in full.newton)
    assert sum(n.chord_steps for n in reuse.newton) > 0
    assert sum(n.iterations for n in reuse.newton) < sum(n.iterations for n in full.newton)
    for n in reuse.newton:  # the same honest criterion: residual down to rtol of its largest value
        assert n.converged and n.residuals[-1] <= 1e-11 * max(n.residuals)
        kinds = [w.kind for w in n.records]
        assert kinds.count("chord") == n.chord_steps and kinds.count("newton") == n.iterations == n.factorisations
        assert n.solves == n.iterations + n.chord_steps + kinds.count("rejected chord")
    assert np.max(np.abs(states[0] - states[1])) < 1e-10


def test_rejected_chord_falls_back_to_full_newton():
    prob = _problem()
    prob.solve()
    prob.mu.Set(-0.097)  # the old factorisation cannot cut the residual by 1e-6 in one step
    res = prob.solve(reuse_factorisation=True, chord_rate=1e-6)
    assert res.converged and res.iterations > 0
    assert res.residuals[-1] <= 1e-11 * max(res.residuals)
