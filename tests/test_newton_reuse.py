"""Newton with a reused factorisation (chord steps) reaches the same equilibria as full Newton."""

import numpy as np
import pytest
from ngsolve.meshes import MakeStructured2DMesh

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, PlaneStrain, Solid3D, ramp
from ngsgel import problem

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)


def _problem():
    mesh = block(lx=1, ly=1, lz=0.5, maxh=1.0, structured=True, nx=3, ny=3, nz=1).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(-0.1), mu=-0.1, order=2)
    prob.fix("bottom")
    return prob


def test_chord_steps_reach_the_full_newton_state():
    states, results = [], []
    # no floor: both converge by the relative criterion, which is what the comparison is about
    for options in ({"atol": 0.0, "reuse_factorisation": False}, {"atol": 0.0, "reuse_factorisation": True}):
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


def test_auto_reuse_is_chord_steps_on_large_3d_problems_only(monkeypatch):
    monkeypatch.setattr(problem, "CHORD_MIN_FREE_DOFS", 5000)  # the rule, on a mesh that meshes fast
    small = _problem()
    assert small.space.ndof < 5000 and small.reuse_factorisation is False
    large = EquilibriumProblem(block(lx=1, ly=1, lz=0.2, maxh=0.08).mesh, kinematics=Solid3D(), materials=GEL,
                               lam0=GEL.lam_free(-0.1), mu=-0.1)
    large.fix("bottom")
    assert large.reuse_factorisation is True and large.free_mask.sum() >= 5000
    large.mu.Set(-0.099)
    assert large.solve().chord_steps > 0  # solve's default
    in_2d = EquilibriumProblem(MakeStructured2DMesh(nx=60, ny=60), kinematics=PlaneStrain(), materials=GEL,
                               lam0=GEL.lam_free(-0.1), mu=-0.1)
    assert in_2d.reuse_factorisation is False and in_2d.free_mask.sum() >= 5000
    forced = EquilibriumProblem(large.mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(-0.1),
                                mu=-0.1, reuse_factorisation=False)
    assert forced.reuse_factorisation is False
    with pytest.raises(ValueError, match="reuse_factorisation must be True, False or 'auto'"):
        EquilibriumProblem(in_2d.mesh, kinematics=PlaneStrain(), materials=GEL, lam0=GEL.lam_free(-0.1),
                           mu=-0.1, reuse_factorisation="yes")


def _first_chord_run(kinds: list[str]) -> int:
    """Chord steps kept before the first full iteration or rejected chord step."""
    run = 0
    for kind in kinds[1:]:  # after the start
        if kind != "chord":
            break
        run += 1
    return run


def test_paced_chord_steps_hand_over_to_newton_when_a_full_iteration_is_cheaper():
    # the same load step from the same factorisation: chord steps unpaced; paced, with the last
    # full iteration priced far above a chord step (the same chord steps); paced, with it priced
    # at nothing (one chord step shows the contraction, then full Newton)
    first_runs, kinds = {}, {}
    for name, price in (("unpaced", None), ("dear", 1e6), ("free", 0.0)):
        prob = _problem()
        prob.mu.Set(-0.0999)
        prob.solve(reuse_factorisation=False)  # leaves the factorisation the chord steps reuse
        prob._solver.iteration_seconds = price
        prob.mu.Set(-0.0998)
        res = prob.solve(reuse_factorisation=True, chord_pacing=name != "unpaced", atol=0.0)
        assert res.converged and res.residuals[-1] <= 1e-11 * max(res.residuals)
        kinds[name] = [w.kind for w in res.records]
        first_runs[name] = _first_chord_run(kinds[name])
    assert first_runs["unpaced"] >= 2
    assert first_runs["dear"] == first_runs["unpaced"]
    assert first_runs["free"] == 1 and kinds["free"][2] == "newton"


def test_auto_reuse_paces_chord_steps_and_an_explicit_choice_does_not(monkeypatch):
    monkeypatch.setattr(problem, "CHORD_MIN_FREE_DOFS", 10)
    options = []
    monkeypatch.setattr(problem, "newton", lambda system, solver, **kw: options.append(kw))
    for reuse in ("auto", True, False):
        prob = EquilibriumProblem(_problem().mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(-0.1),
                                  mu=-0.1, reuse_factorisation=reuse)
        prob.solve()
    assert [(o["reuse_factorisation"], o["chord_pacing"]) for o in options] == [(True, True), (True, False),
                                                                              (False, False)]
