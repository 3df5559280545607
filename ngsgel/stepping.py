"""Load stepping in one parameter with automatic cut-back and regrowth of the step."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import ngsolve as ngs

from .newton import LinearSolver, NewtonError, NewtonResult
from .output import report_progress

__all__ = ["ramp", "tangent_predictor", "RampResult", "RampError", "JumpError"]


@dataclass
class RampResult:
    converged: bool
    values: list[float] = field(default_factory=list)
    newton: list[NewtonResult] = field(default_factory=list)
    cutbacks: int = 0
    message: str = ""
    stopped: bool = False  # ``on_step`` asked to stop before the target

    @property
    def steps(self) -> int:
        return len(self.values)


class JumpError(NewtonError):
    """A step converged too far from its predictor (``ramp``'s ``max_correction``): onto another
    branch. Handled as a failed step."""


class RampError(RuntimeError):
    """The step fell below ``min_step``; the problem holds the last converged state."""

    def __init__(self, message: str, result: RampResult):
        super().__init__(message)
        self.result = result


def ramp(problem, parameter: ngs.Parameter, target: float, *, step: float | None = None,
         min_step: float | None = None, max_step: float | None = None, grow: float = 1.5,
         easy_iterations: int = 4, on_step: Callable[[float, NewtonResult], bool | None] | None = None,
         newton_options: dict | None = None, tangent_start: bool = True,
         max_correction: float | None = None, progress: Callable[[str], None] | None = None) -> RampResult:
    """Move ``parameter`` to ``target`` through converged equilibria of ``problem``.

    The first guess of the first step is the tangent (Euler) predictor from the converged start
    (with ``tangent_start``; otherwise the start itself); later ones extrapolate the last two
    converged states (a secant predictor), dropped if not admissible. The tangent predictor
    saves many iterations when a load applied to the unrelaxed state makes its tangent far from
    the equilibrium one (a change of ``mu`` acts as a pressure of order ``G`` on a nearly
    incompressible gel); it is used only if admissible and better than the start, since a far
    linear prediction can land on a spurious branch (e.g. the body turned over). Better: a
    smaller free residual, or (for problems with an ``energy()``) a lower energy at the new
    load. The energy test matters on a buckled branch with stiff films: the predictor moves
    the film transversally, its membrane strain is wrong at second order and its residual is
    large although it lies much closer to the solution than the start (gears: first step on the
    buckled branch 4 Newton iterations from the predictor against 40+ from the start).

    A failed step is undone and halved; a step that converged in at most ``easy_iterations`` lets the next one grow by ``grow``. ``on_step`` is
    called after every converged step (recording, output); if it returns True the ramp stops
    there with ``stopped`` set (the problem keeps whatever state ``on_step`` left).

    ``max_correction``: a step that converged farther from its predictor than ``max_correction``
    times the predicted increment (free dofs, Euclidean norm) fails as well. Past a fold, or
    where two stable states coexist, Newton can converge onto another branch, which neither end's
    stability tells; along a smooth path the correction is a fraction of the increment and
    shrinks with the step (a snapping arch: 0.05-0.4 along its branch, 1.6 for the step ending
    next to its limit point, 3.3 for the step across it), so halving such a step leads back to the
    path or stalls at the fold (``RampError``).

    ``progress``: called with one line at the start and one per converged step
    (``progress(message)``; a ``ngsgel.output.Progress`` also gets the fraction of the way to
    ``target`` done, for its percent done and time left).
    """
    start = parameter.Get()
    span = target - start
    if span == 0.0:
        result = RampResult(converged=True)
        result.newton.append(problem.solve(**(newton_options or {})))
        result.values.append(start)
        return result
    step = abs(span) if step is None else abs(step)
    max_step = abs(span) if max_step is None else abs(max_step)
    min_step = abs(span) * 1e-6 if min_step is None else abs(min_step)
    if not (min_step <= step) or step <= 0:
        raise ValueError(f"step must be in [min_step, |target - start|], got step={step}, min_step={min_step}")
    if max_correction is not None and not max_correction > 0:
        raise ValueError(f"max_correction must be a number > 0 (or None), got {max_correction!r}")
    direction = np.sign(span)
    report_progress(progress, f"start: parameter {start:.6g}, target {target:.6g}", fraction=0.0)
    result = RampResult(converged=False)
    previous = None  # (value, state) of the converged state before the current one
    current = (start, problem.save_state())
    while True:
        value, state = current
        if value == target:
            result.converged = True
            return result
        h = min(step, max_step, abs(target - value))
        new = target if abs(target - value) <= h * (1 + 1e-12) else value + direction * h
        with ngs.TaskManager():  # threads the predictor's assembly and factorisation (no-op if active)
            if previous is None and tangent_start:
                if not _better_start(problem, tangent_predictor(problem, parameter, new), state):
                    problem.restore_state(state)
            elif previous is None:
                parameter.Set(new)
            else:
                parameter.Set(new)
                problem.restore_state(state + (new - value) / (value - previous[0]) * (state - previous[1]))
                if not problem.admissible(problem.state):
                    problem.restore_state(state)
            predicted = problem.save_state() if max_correction is not None else None
        try:
            newton_result = problem.solve(**(newton_options or {}))
            if max_correction is not None:
                free = problem.free_mask
                _check_correction(problem.save_state()[free], predicted[free], state[free], max_correction,
                                  newton_result)
        except NewtonError as err:
            problem.restore_state(state)
            parameter.Set(value)
            result.cutbacks += 1
            step = h / 2
            if step < min_step:
                result.message = (f"step fell below min_step={min_step:g} at {parameter.Get():g} "
                                  f"towards {target:g}: {err}")
                raise RampError(result.message, result) from err
            continue
        previous, current = current, (new, problem.save_state())
        result.values.append(new)
        result.newton.append(newton_result)
        report_progress(progress, f"step {result.steps}: parameter {new:.6g}, iterations {newton_result.iterations}"
                        + (f", cut-backs so far {result.cutbacks}" if result.cutbacks else ""),
                        fraction=(new - start) / span)
        if on_step is not None and on_step(new, newton_result):
            result.stopped = True
            result.message = f"stopped by on_step at {new:g}"
            return result
        step = h * grow if newton_result.iterations <= easy_iterations else h


def _check_correction(solution: np.ndarray, predicted: np.ndarray, start: np.ndarray, max_correction: float,
                      newton_result: NewtonResult) -> None:
    increment = float(np.linalg.norm(predicted - start))
    correction = float(np.linalg.norm(solution - predicted))
    if correction > max_correction * increment and increment > 0:
        raise JumpError(f"converged {correction / increment:.3g} predicted increments away from the predictor "
                        f"(max_correction {max_correction:g}): onto another branch", newton_result)


def _free_residual_norm(problem) -> float:
    r = problem.state.CreateVector()
    problem.residual(problem.state, r)
    return float(np.linalg.norm(r.FV().NumPy()[problem.free_mask]))


def _better_start(problem, guess: np.ndarray, start: np.ndarray) -> bool:
    """Put ``guess`` in the problem; True if admissible with a smaller free residual than
    ``start`` or, for problems with an ``energy()``, a lower energy (both at the current load)."""
    energy = getattr(problem, "energy", None)
    problem.restore_state(start)
    r_start = _free_residual_norm(problem)
    e_start = energy() if energy is not None else None
    problem.restore_state(guess)
    if not problem.admissible(problem.state):
        return False
    if _free_residual_norm(problem) < r_start:
        return True
    return bool(energy is not None and energy() < e_start)


def tangent_predictor(problem, parameter: ngs.Parameter, new: float) -> np.ndarray:
    """The state after one Newton step towards ``parameter = new`` taken with the tangent of the
    current (converged) state at the current parameter: the Euler predictor, with the
    prescribed values reached exactly. Leaves ``parameter`` at ``new`` and the state unchanged."""
    x = problem.state
    K = problem.tangent(x)
    solver = getattr(problem, "_solver", None)  # the problem's own: symbolic factorisation reused
    if not isinstance(solver, LinearSolver):
        freedofs = ngs.BitArray(problem.free_mask.tolist())
        solver = LinearSolver(freedofs, inverse=getattr(problem, "inverse", "umfpack"))
    inv = solver.factor(K)
    parameter.Set(new)
    r, step, target = x.CreateVector(), x.CreateVector(), x.CreateVector()
    problem.residual(x, r)
    problem.prescribed(target)
    step.FV().NumPy()[:] = np.where(problem.free_mask, 0.0, target.FV().NumPy() - x.FV().NumPy())
    r.data += K * step
    step.data -= inv * r
    return x.FV().NumPy() + step.FV().NumPy()
