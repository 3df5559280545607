"""Load stepping in one parameter with automatic cut-back and regrowth of the step."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import ngsolve as ngs

from .newton import NewtonError, NewtonResult

__all__ = ["ramp", "RampResult", "RampError"]


@dataclass
class RampResult:
    converged: bool
    values: list[float] = field(default_factory=list)
    newton: list[NewtonResult] = field(default_factory=list)
    cutbacks: int = 0
    message: str = ""

    @property
    def steps(self) -> int:
        return len(self.values)


class RampError(RuntimeError):
    """The step fell below ``min_step``; the problem holds the last converged state."""

    def __init__(self, message: str, result: RampResult):
        super().__init__(message)
        self.result = result


def ramp(problem, parameter: ngs.Parameter, target: float, *, step: float | None = None,
         min_step: float | None = None, max_step: float | None = None, grow: float = 1.5,
         easy_iterations: int = 4, on_step: Callable[[float, NewtonResult], None] | None = None,
         newton_options: dict | None = None) -> RampResult:
    """Move ``parameter`` to ``target`` through converged equilibria of ``problem``.

    The first guess of each step extrapolates the last two converged states (a secant
    predictor) when that guess is admissible. A failed step is undone and halved; a step that
    converged in at most ``easy_iterations`` lets the next one grow by ``grow``. ``on_step`` is
    called after every converged step (recording, output).
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
    direction = np.sign(span)
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
        parameter.Set(new)
        if previous is not None:
            guess = state + (new - value) / (value - previous[0]) * (state - previous[1])
            problem.restore_state(guess)
            if not problem.admissible(problem.state):
                problem.restore_state(state)
        try:
            newton_result = problem.solve(**(newton_options or {}))
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
        if on_step is not None:
            on_step(new, newton_result)
        step = h * grow if newton_result.iterations <= easy_iterations else h
