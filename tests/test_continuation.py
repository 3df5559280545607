"""Path following, stability and branch switching on coarse classical models: Euler columns, a
snapping shallow arch, pseudo-viscous stabilisation, records and restarts, the demo script."""

import csv
import math

import numpy as np
import ngsolve as ngs
import pytest
from ngsolve.meshes import MakeStructured2DMesh

from ngsgel import EquilibriumProblem, NeoHookeanFilm, PlaneStrain
from ngsgel.continuation import Checkpoint, ContinuationError, StabilityOptions, Stabilization, follow_path
from ngsgel.output import History
from ngsgel import stability
from ngsgel.stability import linear_buckling, random_field, seed_imperfection

from ngsgel.scenes import buckling_demo

E, NU = 1.0, 0.3
E_PLANE = E / (1 - NU**2)  # bending and axial modulus of a plane-strain strip with free faces


def column(ny, *, length=20.0, control="force", order=3):
    """Plane-strain column of thickness 1 centred on x = 0 (a mirror-symmetric quad mesh),
    clamped at the bottom. ``force``: dead compressive traction ``lambda * sigma_cr`` on the free
    top, sigma_cr the clamped-free Euler stress ``pi^2 E' h^2 / (48 L^2)``, so lambda_cr -> 1 as
    L/h -> infinity. ``displacement``: top shortened by ``lambda * delta`` with its lateral motion
    free (clamped-guided, P_cr = pi^2 E' I / L^2), delta = the matching Euler shortening."""
    mesh = MakeStructured2DMesh(quads=True, nx=2, ny=ny, mapping=lambda x, y: (x - 0.5, y * length))
    load = ngs.Parameter(0.0)
    # LU with pivoting: the tangent is indefinite past the bifurcation
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=NeoHookeanFilm(E=E, nu=NU), lam0=2.0,
                              order=order, inverse="umfpack")
    prob.fix("bottom")
    sigma_cr = math.pi**2 * E_PLANE / (48 * length**2)
    if control == "force":
        prob.add_traction("top", ngs.CF((0, -load * sigma_cr)))
    else:
        prob.prescribe("top", "y", -load * 4 * sigma_cr * length / E_PLANE)
    top = mesh(0.0, length)
    return prob, load, lambda: prob.displacement(top)[0]


def test_euler_column_critical_load_and_stable_post_buckling():
    L = 20.0
    critical = {}
    for ny in (10, 20):
        prob, load, tip = column(ny, length=L)
        result = follow_path(prob, load, step=0.3, max_step=20.0, target=1.2, qoi={"tip": tip},
                             stability=StabilityOptions(eigenvalues=2, tol=1e-6, switch=ny == 20,
                                                        amplitude=0.05, length=1.0),
                             stop=lambda p: abs(p.qoi["tip"]) > 1.0 or (ny == 10 and bool(p.events)),
                             max_steps=40)
        bifurcations = [e for e in result.events if e.kind == "bifurcation"]
        assert len(bifurcations) == 1 and result.events[0] is bifurcations[0], [e.kind for e in result.events]
        event = bifurcations[0]
        assert (event.negative_before, event.negative_after) == (0, 1)
        assert event.parameter_error <= 1e-6
        critical[ny] = event.parameter
    # measured: 1.00291 (ny = 10), 1.00182 (ny = 20); large-slenderness value 1
    assert abs(critical[20] - 1.0) < 0.01
    assert abs(critical[20] - 1.0) < abs(critical[10] - 1.0)
    assert event.load_projection < 1e-6  # the mode does no work with the axial load

    # the nonlinear critical load agrees with the *Buckle analogue from the unloaded state
    # (they differ only by the pre-buckling shortening, ~1e-4 here)
    fresh, fresh_load, _ = column(20, length=L)
    fresh.solve()
    buckling = linear_buckling(fresh, fresh_load, increment=1.0, count=2)
    assert abs(buckling.parameters[0] - critical[20]) < 1e-3
    assert buckling.parameters[1] > 5  # second mode (three-quarter wave) ~ 9 lambda_cr

    # branch switching: stable post-buckled branch, rising as the elastica says:
    # P/P_cr = 1 + pi^2 d^2 / (32 L^2) + O(d^4) for tip deflection d of a clamped-free column
    switch = [e for e in result.events if e.kind == "branch switch"]
    assert len(switch) == 1
    assert switch[0].negative_after == 0
    after = [p for p in result.points if p.step >= switch[0].step and not p.events]
    assert len(after) >= 3 and all(p.negative == 0 for p in after)
    tips = np.abs([p.qoi["tip"] for p in after])
    assert np.all(np.diff(tips) > 0) and tips[-1] > 1.0
    last = after[-1]
    slope = (last.parameter / critical[20] - 1) / last.qoi["tip"] ** 2
    assert slope == pytest.approx(math.pi**2 / (32 * L**2), rel=0.02)  # measured 0.4 % low at d = 1.2


def arch(**kwargs):
    options = dict(rise=0.055, thickness=0.03, elements=16, order=3, load_scale=1e-4)
    options.update(kwargs)
    return buckling_demo.arch_problem(**options)


def test_arch_snap_through_with_arc_length():
    prob, load, deflection = arch()
    result = follow_path(prob, load, step=0.01, max_step=0.02, target=0.05, qoi={"w": deflection},
                         stability=StabilityOptions(eigenvalues=2, tol=1e-4), max_steps=60)
    assert result.stop_reason == "target" and result.points[-1].parameter == 0.05
    kinds = [e.kind for e in result.events]
    assert kinds == ["limit point", "limit point"]
    first, second = result.events
    assert (first.negative_before, first.negative_after) == (0, 1)
    assert (second.negative_before, second.negative_after) == (1, 0)
    assert first.load_projection > 0.1 and second.load_projection > 0.1
    # negative count: 0 before the first limit point, 1 between, 0 after (back to positive stiffness)
    marks = [i for i, p in enumerate(result.points) if p.events]
    for i, p in enumerate(result.points):
        if not p.events:
            assert p.negative == (1 if marks[0] < i < marks[1] else 0), (p.step, p.parameter, p.negative)
    assert first.parameter > second.parameter
    w = result.column("w")
    assert w[-1] > 1.5 and result.points[-1].negative == 0

    # the limit load against an independent estimate: the vertex of a parabola through a dense
    # arc-length sampling of the path around its maximum
    prob2, load2, deflection2 = arch()
    dense = follow_path(prob2, load2, step=0.002, max_step=0.002, min_step=0.002, qoi={"w": deflection2},
                        stop=lambda p: p.qoi["w"] > 0.7, max_steps=200)
    lam = dense.column("parameter")
    i = int(np.argmax(lam))
    s = np.arange(len(lam), dtype=float)[i - 2:i + 3]
    coef = np.polyfit(s, lam[i - 2:i + 3], 2)
    reference = coef[2] - coef[1] ** 2 / (4 * coef[0])
    assert abs(first.parameter - reference) < 1e-4, (first.parameter, reference)  # measured 4e-7
    assert first.parameter_error <= 1e-4


def test_symmetric_column_bifurcation_is_detected_and_switched_to_lower_energy():
    prob, load, tip = column(12, control="displacement")
    result = follow_path(prob, load, step=0.3, max_step=2.0, target=1.3, qoi={"tip": tip}, keep_states=True,
                         stability=StabilityOptions(eigenvalues=2, tol=1e-5, switch=True, amplitude=0.05))
    kinds = [e.kind for e in result.events]
    assert kinds == ["bifurcation", "branch switch"], kinds
    bif, switch = result.events
    assert bif.load_projection < 1e-6
    assert abs(bif.parameter - 1.0) < 0.01  # clamped-guided Euler value 1; measured 0.99961
    assert switch.details["energy_gain"] < 0
    end = result.points[-1]
    assert end.parameter == 1.3 and end.negative == 0 and abs(end.qoi["tip"]) > 0.5
    # the symmetric (straight) state at the same end shortening, re-converged from before the bifurcation
    straight = [p for p in result.points if p.step < bif.step][-1]
    prob.restore_state(straight.state)
    load.Set(end.parameter)
    prob.solve()
    assert abs(tip()) < 1e-8
    assert end.energy < prob.energy() * (1 - 0.02), (end.energy, prob.energy())  # measured 5.3 % lower


def test_stabilised_snap_agrees_with_arc_length_and_stays_under_the_cap():
    prob, load, deflection = arch()
    with pytest.raises(ContinuationError, match="min_step"):  # undamped, natural stepping stalls at the limit
        follow_path(prob, load, method="natural", step=0.001, max_step=0.001, min_step=5e-4, target=0.05,
                    newton_options={"maxit": 10})
    prob, load, deflection = arch()
    cap = 0.05
    damped = follow_path(prob, load, method="natural", step=0.001, max_step=0.001, target=0.05,
                         qoi={"w": deflection}, stabilization=Stabilization(cap=cap), max_steps=500)
    fractions = damped.column("dissipated_fraction")
    assert np.all(fractions <= cap) and fractions.max() > 0.01  # measured max 0.044: the damping did work
    prob2, load2, deflection2 = arch()
    path = follow_path(prob2, load2, step=0.002, max_step=0.002, target=0.05, qoi={"w": deflection2},
                       max_steps=500)
    lam, w = path.column("parameter"), path.column("w")
    top = int(np.argmax(np.diff(lam) < 0))  # first limit point
    bottom = top + int(np.argmax(np.diff(lam[top:]) > 0))  # second limit point
    lower, upper = slice(0, top + 1), slice(bottom, None)  # the two stable branches
    limit_up = lam[top]
    w_damped, lam_damped = damped.column("w"), damped.column("parameter")
    jump = int(np.argmax(np.diff(w_damped)))
    before = lam_damped[:jump + 1] < 0.9 * limit_up
    after = (np.arange(len(lam_damped)) > jump) & (lam_damped > 1.2 * limit_up)
    assert before.sum() > 5 and after.sum() > 5
    ref_before = np.interp(lam_damped[:jump + 1][before], lam[lower], w[lower])
    ref_after = np.interp(lam_damped[after], lam[upper], w[upper])
    # measured 1.5e-4 and 5e-5 (mostly the linear interpolation of the reference), 4e-8 at the end load
    assert np.max(np.abs(w_damped[:jump + 1][before] - ref_before)) < 1e-3
    assert np.max(np.abs(w_damped[after] - ref_after)) < 1e-3
    assert abs(w_damped[-1] - w[-1]) < 1e-6


def test_history_and_restart_reproduce_an_uninterrupted_run(tmp_path):
    prob, load, deflection = arch(elements=8, order=2)
    whole = follow_path(prob, load, step=0.005, max_step=0.005, max_steps=10, qoi={"w": deflection})
    prob, load, deflection = arch(elements=8, order=2)
    with History(tmp_path / "history.csv") as history:
        first = follow_path(prob, load, step=0.005, max_step=0.005, max_steps=6, qoi={"w": deflection},
                            history=history, stability=StabilityOptions(eigenvalues=2),
                            checkpoint_file=tmp_path / "checkpoint.npz")
    # the per-step checkpoint file holds the end of the run, as the returned checkpoint does
    kept = Checkpoint.load(tmp_path / "checkpoint.npz")
    assert kept.parameter == first.checkpoint.parameter and np.array_equal(kept.state, first.checkpoint.state)
    assert np.array_equal(kept.previous_state, first.checkpoint.previous_state)
    assert not (tmp_path / "checkpoint.partial.npz").exists()
    rows = list(csv.DictReader(open(tmp_path / "history.csv")))
    assert len(rows) == len(first.points) == 7
    assert set(rows[0]) >= {"step", "parameter", "w", "energy", "iterations", "negative", "eig0", "eig1",
                            "events", "dissipated_fraction"}
    assert float(rows[-1]["parameter"]) == pytest.approx(first.points[-1].parameter, rel=1e-12)
    prob, load, deflection = arch(elements=8, order=2)
    second = follow_path(prob, load, step=0.005, max_step=0.005, max_steps=4, qoi={"w": deflection},
                         restart=Checkpoint.load(tmp_path / "checkpoint.npz"))
    resumed = [p.parameter for p in first.points] + [p.parameter for p in second.points[1:]]
    assert np.allclose(resumed, whole.column("parameter"), rtol=0, atol=1e-10)


def test_natural_run_keeps_a_checkpoint_of_every_step(tmp_path):
    # a run stopped after any step can go on from the file: here stopped by max_steps, the file
    # then holds the last converged state, and the resumed run lands where an uninterrupted one does
    prob, load, deflection = column(8, control="displacement", order=2)
    whole = follow_path(prob, load, method="natural", step=0.2, max_step=0.2, target=0.8)
    prob, load, deflection = column(8, control="displacement", order=2)
    first = follow_path(prob, load, method="natural", step=0.2, max_step=0.2, target=0.8, max_steps=2,
                        checkpoint_file=tmp_path / "path.npz")
    kept = Checkpoint.load(tmp_path / "path.npz")
    assert first.stop_reason == "max_steps" and kept.parameter == pytest.approx(0.4)
    assert np.array_equal(kept.state, first.checkpoint.state)
    prob, load, deflection = column(8, control="displacement", order=2)
    second = follow_path(prob, load, method="natural", step=0.2, max_step=0.2, target=0.8, restart=kept)
    assert second.points[-1].parameter == pytest.approx(0.8)
    assert np.allclose(prob.save_state(), whole.checkpoint.state, rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="checkpoint_file"):
        follow_path(prob, load, method="natural", step=0.2, target=0.8, checkpoint_file=tmp_path / "path.txt")


def test_seeded_mode_imperfection_grows_as_southwell_says():
    prob, load, tip = column(10)
    prob.solve()
    buckling = linear_buckling(prob, load, increment=1.0, count=1)
    lam_cr, mode = buckling.parameters[0], buckling.modes[0]
    prob, load, tip = column(10)
    top = prob.mesh(0.0, 20.0)
    amplitude = 1e-3 / abs(mode(top)[0])  # tip imperfection 1e-3 thicknesses
    seed_imperfection(prob, [mode], [amplitude])
    result = follow_path(prob, load, method="natural", step=0.2, target=0.8, qoi={"tip": tip},
                         stability=StabilityOptions(eigenvalues=1))
    assert not result.events and all(p.negative == 0 for p in result.points)
    # extra deflection a (P/P_cr) / (1 - P/P_cr) for an imperfection a in the first mode
    assert abs(result.points[-1].qoi["tip"]) == pytest.approx(1e-3 * 0.8 / (lam_cr - 0.8), rel=0.01)  # measured 0.1 %
    field = random_field(prob, correlation_length=2.0, seed=1)
    assert np.all(field.vec.FV().NumPy()[~prob.free_mask] == 0.0)
    rms = math.sqrt(prob.integrate(ngs.InnerProduct(field, field)) / prob.integrate(ngs.CF(1.0)))
    assert rms == pytest.approx(1.0, rel=1e-10)
    prob.mesh.UnsetDeformation()


def test_buckling_demo_quick(tmp_path):
    result = buckling_demo.main(["--quick", "--out", str(tmp_path)])
    assert (tmp_path / "curve.png").stat().st_size > 1000
    rows = list(csv.DictReader(open(tmp_path / "history.csv")))
    assert len(rows) == len(result.points)
    assert sum(1 for r in rows if "limit point" in r["events"]) == 2


def test_natural_run_switches_branch_with_the_runs_residual_floor():
    # The branch switch of a natural-parameter run converges its bordered corrector to the run's
    # absolute residual floor: a guess next to the critical state has a residual near round-off,
    # which no relative tolerance can reduce (it failed with "no convergence ... residual 1e-18"
    # on a 50k-unknown shell). Amplitude 3e-4: without the floor the switch still fails ("residual
    # 3e-16"), and the switched state's lowest eigenvalue (7e-12) is 9x further from round-off than
    # at 1e-4, where one run on a loaded machine counted it negative (an extra unlocated change).
    prob, load, tip = column(12, control="displacement")
    result = follow_path(prob, load, method="natural", step=0.3, target=1.3, qoi={"tip": tip},
                         stability=StabilityOptions(eigenvalues=2, tol=1e-5, switch=True, amplitude=3e-4))
    assert [e.kind for e in result.events] == ["bifurcation", "branch switch"]
    switched = next(p for p in result.points if "branch switch" in p.events)
    assert switched.eigenvalues[0] > 1e-12
    end = result.points[-1]
    assert end.parameter == 1.3 and end.negative == 0 and abs(end.qoi["tip"]) > 0.5


def test_a_branch_switch_whose_corrector_fails_is_solved_just_past_the_critical_load(monkeypatch):
    # The bordered corrector fails (as on the coarse graded disk, whose bifurcated branch reaches
    # the switch amplitude only far past the critical load): the same guess solved at a load past
    # the critical one (half the way from the last stable point) lands on the buckled branch, and
    # the path follows it.
    from ngsgel import continuation
    from ngsgel.newton import NewtonError, NewtonResult

    def failing_solve(self, guess, origin, normal, s, **options):
        raise NewtonError("no convergence in 20 iterations (residual 6.3e-03)", NewtonResult(False, 20))

    monkeypatch.setattr(continuation.BorderedCorrector, "solve", failing_solve)
    prob, load, tip = column(12, control="displacement")
    result = follow_path(prob, load, method="natural", step=0.3, target=1.3, qoi={"tip": tip},
                         stability=StabilityOptions(eigenvalues=2, tol=1e-5, switch=True, amplitude=3e-4))
    assert [e.kind for e in result.events] == ["bifurcation", "branch switch"]
    switch = result.events[1]
    assert all(m.startswith("natural at") for m in switch.details["methods"])
    critical = result.events[0].parameter
    before = max(p.parameter for p in result.points if p.parameter < critical)
    assert switch.parameter == pytest.approx(critical + 0.5 * (critical - before), abs=1e-12)
    assert switch.negative_after == 0
    end = result.points[-1]
    assert end.parameter == 1.3 and end.negative == 0 and abs(end.qoi["tip"]) > 0.5


def test_a_failed_branch_switch_is_reported_and_the_path_goes_on_unstable(monkeypatch):
    from ngsgel import continuation
    from ngsgel.newton import NewtonError, NewtonResult

    def failing_switch(self, a, critical, converge):
        raise NewtonError("no convergence in 20 iterations (residual 1.9e-06)", NewtonResult(False, 20))

    monkeypatch.setattr(continuation._Driver, "branch_switch", failing_switch)
    prob, load, tip = column(12, control="displacement")
    result = follow_path(prob, load, method="natural", step=0.3, max_step=0.3, target=1.3, qoi={"tip": tip},
                         stability=StabilityOptions(eigenvalues=2, tol=1e-5, switch=True))
    assert result.stop_reason == "target" and result.points[-1].parameter == 1.3
    (event,) = result.events
    assert event.kind == "bifurcation" and "no convergence" in event.details["switch_failed"]
    assert event.parameter == pytest.approx(1.0, abs=2e-3)  # Euler load of the column (as located above)
    marked = [p for p in result.points if p.events]
    assert len(marked) == 1 and set(marked[0].events) == {"bifurcation", "switch failed"}
    assert result.points[-1].negative == 1 and abs(tip()) < 1e-8  # still straight, now unstable


def test_a_change_whose_location_fails_is_reported_unlocated_and_the_path_goes_on(monkeypatch):
    from ngsgel import continuation
    from ngsgel.newton import NewtonError, NewtonResult

    def failing_locate(self, a, b, segment):
        segment(0.5)  # a solve inside the bracket, then the failure a crawling Newton gives
        raise NewtonError("no convergence in 20 iterations (residual 4.6e-08)", NewtonResult(False, 20))

    monkeypatch.setattr(continuation._Driver, "_locate", failing_locate)
    prob, load, tip = column(12, control="displacement")
    result = follow_path(prob, load, method="natural", step=0.3, max_step=0.3, target=1.3, qoi={"tip": tip},
                         stability=StabilityOptions(eigenvalues=2, switch=True))
    assert result.stop_reason == "target" and result.points[-1].parameter == 1.3
    (event,) = result.events
    assert event.kind == "stability change" and "no convergence" in event.details["locate_failed"]
    assert (event.negative_before, event.negative_after) == (0, 1)
    marked = [p for p in result.points if p.events]
    assert len(marked) == 1 and marked[0].negative == 1 and marked[0].parameter == event.parameter
    assert abs(tip()) < 1e-8  # not switched: still the straight (now unstable) branch


def test_second_crossing_is_located_when_one_eigenvalue_is_recorded():
    """A path past the first critical load (no switch) meets the second one: the crossing
    eigenvalue is then the second lowest, which a one-eigenvalue record does not hold at the
    state before it; the driver's spectra cover every negative eigenvalue and the next one."""
    prob, load, _ = column(10)
    result = follow_path(prob, load, step=0.5, max_step=2.0, target=10.0,
                         stability=StabilityOptions(eigenvalues=1, tol=1e-4, switch=False), max_steps=60)
    bifurcations = [e for e in result.events if e.kind == "bifurcation"]
    assert [(e.negative_before, e.negative_after) for e in bifurcations] == [(0, 1), (1, 2)]
    fresh, fresh_load, _ = column(10)
    fresh.solve()
    buckling = linear_buckling(fresh, fresh_load, increment=1.0, count=2)
    for event, linear in zip(bifurcations, buckling.parameters):
        # they differ only by the pre-buckling shortening (~1e-4 at the first, ~1e-3 at the second)
        assert event.parameter == pytest.approx(linear, rel=5e-3)
    assert all(p.negative == (p.parameter > bifurcations[0].parameter) + (p.parameter > bifurcations[1].parameter)
               for p in result.points if not p.events)


def test_a_step_with_more_than_one_crossing_is_reported_unlocated(monkeypatch):
    # past the first critical load the path meets the second (1 -> 2 negatives); a state inside
    # that step with no negative eigenvalue at all (two eigenvalues changed sign in the step)
    # cannot be bracketed: the change is reported unlocated, not a crash
    from ngsgel import continuation
    from ngsgel.stability import Spectrum

    locate, converged = continuation._Driver._locate, continuation._Driver.converged

    def locating(self, a, b, segment):
        self.second_crossing = a.spectrum.negative == 1
        try:
            return locate(self, a, b, segment)
        finally:
            self.second_crossing = False

    def converged_with_none_negative_inside(self, iterations=0, **options):
        point = converged(self, iterations, **options)
        if getattr(self, "second_crossing", False):
            point.spectrum = Spectrum(eigenvalues=np.array([1.0]), modes=np.zeros((len(point.state), 1)), negative=0)
        return point

    monkeypatch.setattr(continuation._Driver, "_locate", locating)
    monkeypatch.setattr(continuation._Driver, "converged", converged_with_none_negative_inside)
    prob, load, _ = column(10)
    result = follow_path(prob, load, step=0.5, max_step=2.0, target=10.0,
                         stability=StabilityOptions(eigenvalues=1, tol=1e-4, switch=False), max_steps=60)
    assert result.stop_reason == "target"
    first, second = result.events
    assert first.kind == "bifurcation" and (first.negative_before, first.negative_after) == (0, 1)
    assert second.kind == "stability change" and "more than one eigenvalue" in second.details["locate_failed"]
    assert (second.negative_before, second.negative_after) == (1, 2)


def test_a_natural_step_across_a_limit_point_is_a_jump_that_max_correction_refuses():
    # The arch's limit load lies at 0.0301 (arclength above). Natural steps of 0.01 converge
    # from 0.03 (w = 0.46) straight onto the far branch at 0.04 (w = 1.59) with no event: both
    # ends are stable. That step lands 3.3 predicted increments from its secant predictor, while
    # steps along the branch land within 0.4 (1.6 for the step ending next to the limit): with
    # max_correction = 2 the step is cut back until it stalls at the limit point (here after
    # 0.01 -> 0.005 -> 0.0025, each refused).
    prob, load, w = arch()
    jumped = follow_path(prob, load, method="natural", step=0.01, max_step=0.01, target=0.05, qoi={"w": w},
                         stability=StabilityOptions(eigenvalues=1))
    assert jumped.stop_reason == "target" and jumped.events == []
    assert jumped.column("w")[-2] > 1.5 > 0.5 > jumped.column("w")[-3]

    prob, load, w = arch()
    with pytest.raises(ContinuationError) as stalled:
        follow_path(prob, load, method="natural", step=0.01, max_step=0.01, min_step=2e-3, target=0.05,
                    qoi={"w": w}, stability=StabilityOptions(eigenvalues=1), max_correction=2.0)
    path = stalled.value.result
    assert path.column("w")[-1] < 0.5 and path.points[-1].parameter == pytest.approx(0.03)
    for method, value in (("natural", 0.0), ("arclength", 2.0)):
        with pytest.raises(ValueError, match="max_correction"):
            follow_path(prob, load, method=method, step=0.01, target=0.05, max_correction=value)


def test_count_only_checks_find_the_same_events_and_solve_eigenproblems_only_where_the_count_changes(monkeypatch):
    eigen_solves = []
    arpack = stability.sla.eigsh
    monkeypatch.setattr(stability.sla, "eigsh", lambda *a, **k: eigen_solves.append(1) or arpack(*a, **k))
    results, solves = {}, {}
    for name, options in (("eigenpairs", StabilityOptions(eigenvalues=2, tol=1e-4)), ("count", StabilityOptions(tol=1e-4))):
        prob, load, deflection = arch()
        eigen_solves.clear()
        results[name] = follow_path(prob, load, step=0.01, max_step=0.02, target=0.05, qoi={"w": deflection},
                                    stability=options, max_steps=60)
        solves[name] = len(eigen_solves)
    full, count = results["eigenpairs"], results["count"]
    assert [e.kind for e in count.events] == [e.kind for e in full.events] == ["limit point", "limit point"]
    for a, b in zip(count.events, full.events):
        assert (a.negative_before, a.negative_after) == (b.negative_before, b.negative_after)
        assert a.parameter == pytest.approx(b.parameter, rel=1e-9) and a.eigenvalue == pytest.approx(b.eigenvalue, rel=1e-6)
    assert [p.negative for p in count.points] == [p.negative for p in full.points]
    # count-only: eigenpairs at the located points and at the end of the step each was found in
    with_pairs = [i for i, p in enumerate(count.points) if p.eigenvalues]
    assert with_pairs == [i + d for i, p in enumerate(count.points) if p.events for d in (0, 1)]
    assert all(len(p.eigenvalues) >= 2 for p in full.points)
    # one eigen solve (or more) per point with eigenpairs; count-only: the location's, and one at
    # each end of a step whose count changed
    plain = len(count.points) - len(count.events)
    assert solves["count"] <= solves["eigenpairs"] - plain + 2 * len(count.events)


@pytest.mark.parametrize("method", ["natural", "arclength"])
def test_every_step_reports_its_work_and_its_stability_check_apart(method):
    # a stable column in displacement control (no events): one record of the start and of each
    # step, the Newton iterations of a natural step as its points say, one stability check each
    prob, load, _ = column(8, control="displacement", order=2)
    kwargs = dict(method=method, step=0.2, max_step=0.2, max_steps=3, **({"target": 0.6} if method == "natural" else {}))
    tracked = follow_path(prob, load, stability=StabilityOptions(eigenvalues=2), **kwargs)
    prob, load, _ = column(8, control="displacement", order=2)
    untracked = follow_path(prob, load, **kwargs)
    for result, checks in ((tracked, 1), (untracked, 0)):
        assert [s.step for s in result.steps] == [p.step for p in result.points] == [0, 1, 2, 3]
        for point, step in zip(result.points, result.steps):
            assert step.parameter == point.parameter
            assert sum(r.kind == "stability" for r in step.records) == checks
            assert step.part("stability").assemblies == checks
            if method == "natural" or point.step == 0:
                assert sum(r.kind == "newton" for r in step.records) == point.iterations
            else:
                assert step.part("corrector").factorisations == point.iterations
            assert step.work.total == pytest.approx(sum(r.total for r in step.records))
    assert any(r.kind == "predictor" for r in untracked.steps[1].records) == (method == "natural")


def test_a_switch_corrector_whose_residual_grows_past_its_bound_fails_at_once_and_bad_bounds_are_named():
    from ngsgel import continuation, ramp
    from ngsgel.newton import NewtonError

    prob, load, _ = arch()
    ramp(prob, load, 0.02, step=0.01)
    free = prob.free_mask
    start = prob.save_state()
    corrector = continuation.BorderedCorrector(prob, load)
    mode = np.zeros(int(free.sum()))
    mode[0] = 1.0
    # far along one dof: the corrector's first iterate has a larger residual than the guess
    guess = start.copy()
    guess[free] += 0.05 * mode
    with pytest.raises(NewtonError, match="grew") as grown:
        corrector.solve((guess, 0.02), (start[free], 0.02), (mode, 0.0), 0.05, max_growth=1.5)
    assert grown.value.result.iterations == 1
    assert np.array_equal(prob.save_state(), start) and load.Get() == 0.02
    try:  # unbounded, the same solve goes on past that iterate
        unbounded = corrector.solve((guess, 0.02), (start[free], 0.02), (mode, 0.0), 0.05)
    except NewtonError as error:
        unbounded = error.result
    assert unbounded.iterations > 1
    with pytest.raises(ValueError, match="max_growth"):
        corrector.solve((guess, 0.02), (start[free], 0.02), (mode, 0.0), 0.05, max_growth=1.0)
