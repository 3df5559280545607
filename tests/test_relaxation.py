"""``settle``: the stable state a structure lands on after losing stability at a fixed load,
against the states found by arclength continuation and branch switching on the same models."""

import numpy as np
import pytest

from ngsgel import follow_path, ramp
from ngsgel.continuation import StabilityOptions
from ngsgel.continuation import ContinuationError
from ngsgel.relaxation import SettleError, settle, settle_after, settle_past
from ngsgel.stability import spectrum

from test_continuation import arch, column


def test_snapping_arch_settles_on_the_far_branch_that_arclength_reaches():
    prob, load, w = arch()
    path = follow_path(prob, load, step=0.01, max_step=0.02, target=0.05, qoi={"w": w},
                       stability=StabilityOptions(eigenvalues=2, tol=1e-4), max_steps=60)
    assert [e.kind for e in path.events] == ["limit point", "limit point"]
    far = prob.save_state()
    limit = path.events[0].parameter

    snapping, snap_load, snap_w = arch()
    ramp(snapping, snap_load, 0.95 * limit, step=0.01)
    assert snap_w() < 0.5  # still on the near branch
    snap_load.Set(0.05)  # beyond the limit load: no equilibrium nearby
    result = settle(snapping)
    assert result.negative == 0 and result.lowest_eigenvalue > 0
    assert np.all(np.diff(result.energies) <= 1e-10 * abs(result.energy_start))
    assert result.energy_drop > 0
    scale = np.max(np.abs(far))
    assert np.max(np.abs(snapping.save_state() - far)) < 1e-8 * scale  # measured 4e-16 absolute
    assert snap_w() == pytest.approx(path.points[-1].qoi["w"], rel=1e-10)
    assert snapping.energy() == pytest.approx(path.points[-1].energy, rel=1e-9)


def test_arch_past_its_located_limit_point_settles_where_arclength_goes_on():
    prob, load, w = arch()
    first = follow_path(prob, load, step=0.01, max_step=0.02, qoi={"w": w},
                        stability=StabilityOptions(eigenvalues=2, tol=1e-6),
                        stop=lambda p: p.negative == 1, max_steps=60)
    limit = first.events[-1]
    assert limit.kind == "limit point" and (limit.negative_before, limit.negative_after) == (0, 1)
    result = settle_past(prob, load, limit, overshoot=1e-3, amplitude=1e-3)
    assert load.Get() == limit.parameter + 1e-3
    assert result.negative == 0 and result.energy_drop > 0

    reference, reference_load, reference_w = arch()
    follow_path(reference, reference_load, step=0.01, max_step=0.02, target=limit.parameter + 1e-3, max_steps=80)
    assert reference_w() > 1.0  # the path first reaches this load again on the far branch
    assert w() == pytest.approx(reference_w(), rel=1e-9)
    with pytest.raises(ValueError, match="overshoot"):
        settle_past(prob, load, limit, overshoot=0.0, amplitude=1e-3)


def test_natural_steps_that_stall_at_the_limit_settle_on_the_far_branch():
    prob, load, w = arch()
    with pytest.raises(ContinuationError) as stalled:
        follow_path(prob, load, method="natural", step=0.005, min_step=1e-4, target=0.05,
                    stability=StabilityOptions(eigenvalues=1, tol=1e-5))
    path = stalled.value.result
    assert path.stop_reason == "min_step" and all(p.negative == 0 for p in path.points)
    result = settle_after(prob, load, path, overshoot=1.0, target=0.05, amplitude=1e-3)  # clipped at the target
    assert load.Get() == 0.05 and result.negative == 0

    reference, reference_load, reference_w = arch()
    follow_path(reference, reference_load, step=0.01, max_step=0.02, target=0.05, max_steps=80)
    assert w() == pytest.approx(reference_w(), rel=1e-9)


def test_straight_column_past_euler_settles_on_the_buckled_branch():
    prob, load, tip = column(12, control="displacement")
    path = follow_path(prob, load, step=0.3, max_step=2.0, target=1.3, qoi={"tip": tip},
                       stability=StabilityOptions(eigenvalues=2, tol=1e-5, switch=True, amplitude=0.05))
    buckled = path.points[-1]
    assert buckled.negative == 0 and abs(buckled.qoi["tip"]) > 0.5

    straight, straight_load, straight_tip = column(12, control="displacement")
    straight_load.Set(1.3)
    straight.solve()  # the symmetric state: an exact, unstable equilibrium
    assert abs(straight_tip()) < 1e-8
    with pytest.raises(SettleError, match="unstable equilibrium"):  # round-off alone does not leave it
        settle(straight)
    lowest = spectrum(straight, count=1)
    assert lowest.negative == 1
    kicked = straight.save_state()
    kicked[straight.free_mask] += 1e-3 * lowest.modes[:, 0]  # root-mean-square 1e-3 along the mode
    straight.restore_state(kicked)
    result = settle(straight)
    assert result.negative == 0 and result.distance > 0.1
    assert np.all(np.diff(result.energies) <= 1e-10 * abs(result.energy_start))
    assert abs(straight_tip()) == pytest.approx(abs(buckled.qoi["tip"]), rel=1e-8)
    assert straight.energy() == pytest.approx(buckled.energy, rel=1e-9)


def test_a_tiny_kick_next_to_a_flat_saddle_leaves_it_for_the_buckled_state():
    # Just past Euler (1 % over, lowest eigenvalue -1.9e-7) a kick of 1e-5 changes the energy by
    # ~1e-15: too little for the energy test to refuse a step back. Before the pseudo-time step
    # was held below 1 / |omega| while the state is unstable, the flow ran back onto the straight
    # state (300 steps without reaching an equilibrium, measured); now it must find the buckled
    # state that a 100x larger kick reaches.
    tips = []
    for amplitude in (1e-3, 1e-5):
        straight, load, tip = column(12, control="displacement")
        load.Set(1.01)
        straight.solve()
        lowest = spectrum(straight, count=1)
        assert lowest.negative == 1 and -1e-6 < lowest.eigenvalues[0] < 0
        kicked = straight.save_state()
        kicked[straight.free_mask] += amplitude * lowest.modes[:, 0]
        straight.restore_state(kicked)
        result = settle(straight)
        assert result.negative == 0 and result.lowest_eigenvalue > 0
        assert np.all(np.diff(result.energies) <= 1e-10 * abs(result.energy_start))
        tips.append(abs(tip()))
    assert tips[0] > 0.1  # buckled (0.118)
    assert tips[1] == pytest.approx(tips[0], rel=1e-8)


def test_a_stable_equilibrium_stays_where_it_is():
    prob, load, w = arch()
    ramp(prob, load, 0.02, step=0.01)
    before = prob.save_state()
    result = settle(prob)
    assert result.steps == 0 and result.negative == 0 and result.distance < 1e-12
    assert np.max(np.abs(prob.save_state() - before)) < 1e-12


def test_bad_growth_factor_is_named():
    prob, _, _ = arch()
    with pytest.raises(ValueError, match="grow"):
        settle(prob, grow=1.0)


def _column_with_unlocated_losses(monkeypatch, *, step: float, target: float):
    """The clamped-guided column shortened to ``target`` by natural steps, every loss of stability
    on the way unlocated (a location that fails), so the path ends on the unstable straight state."""
    from ngsgel import continuation
    from ngsgel.newton import NewtonError, NewtonResult

    def failing_locate(self, a, b, segment):
        raise NewtonError("location failed", NewtonResult(False, 20))

    monkeypatch.setattr(continuation._Driver, "_locate", failing_locate)
    prob, load, tip = column(12, control="displacement")
    path = follow_path(prob, load, method="natural", step=step, max_step=step, target=target,
                       stability=StabilityOptions(eigenvalues=2))
    return prob, load, tip, path


def _switched_column(target: float, *, max_step: float):
    """The column's buckled state at ``target`` reached by located bifurcation and branch switch."""
    reference, load, tip = column(12, control="displacement")
    follow_path(reference, load, step=0.3, max_step=max_step, target=target,
                stability=StabilityOptions(eigenvalues=2, tol=1e-5, switch=True, amplitude=0.05))
    return reference, tip


def test_after_an_unlocated_loss_the_unstable_last_state_is_pushed_along_its_lowest_mode(monkeypatch):
    prob, load, tip, path = _column_with_unlocated_losses(monkeypatch, step=0.3, target=1.3)
    assert path.points[-1].negative == 1 and path.events[-1].kind == "stability change"
    assert path.points[-1].parameter == 1.3  # it ended unstable at the target: settles there
    settle_after(prob, load, path, overshoot=1.0, target=1.3, amplitude=1e-3)
    assert load.Get() == 1.3
    stable_end = follow_path(prob, load, method="natural", step=0.3, target=1.3)
    with pytest.raises(ValueError, match="stable at the target"):
        settle_after(prob, load, stable_end, overshoot=1.0, target=1.3, amplitude=1e-3)

    monkeypatch.undo()
    _, reference_tip = _switched_column(1.3, max_step=2.0)
    assert abs(tip()) == pytest.approx(abs(reference_tip()), rel=1e-8)


def test_a_state_with_two_negative_eigenvalues_is_pushed_along_the_lowest_mode(monkeypatch):
    # Column past its second critical shortening (4.6x the first: two negative eigenvalues),
    # both losses unlocated: the push must follow the lowest mode (one sway), not the negative one
    # nearest zero, along which the flow ends on the unstable second-mode equilibrium.
    prob, load, tip, path = _column_with_unlocated_losses(monkeypatch, step=0.5, target=4.6)
    assert path.points[-1].negative == 2
    result = settle_after(prob, load, path, overshoot=1.0, target=4.6, amplitude=1e-3)
    assert result.negative == 0

    monkeypatch.undo()
    reference, reference_tip = _switched_column(4.6, max_step=1.0)
    assert abs(tip()) == pytest.approx(abs(reference_tip()), rel=1e-8)
    assert prob.energy() == pytest.approx(reference.energy(), rel=1e-9)
