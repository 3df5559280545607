"""Load stepping in one parameter with automatic cut-back and regrowth of the step."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
import ngsolve as ngs

from .newton import FreeDofReductions, LinearSolver, NewtonError, NewtonResult, Work, WorkCounts, total_work
from .output import report_progress
from .parallel import DistributedSolver
from .stability import load_rate
from .threads import using_threads

__all__ = ["ramp", "PREDICTORS", "tangent_predictor", "RampResult", "RampStep", "ValueReached", "RampError", "JumpError"]


PREDICTORS = ("secant", "quadratic")


@dataclass
class RampStep:
    """One converged step: the parameter ``value`` reached, the index ``goal`` of the value it was
    heading to (``RampResult.goals``), the converged solve, the ``predictor``'s work (tangent
    predictor: assembly, factorisation, solve, residuals; secant: its admissibility check; also the
    step-start residual with ``reference="step"``), the solves of longer tries that ``failed``
    before it (each followed by a cut-back) and ``records``: all the work of this step in order,
    failed tries and their predictors included."""

    value: float
    goal: int
    newton: NewtonResult
    predictor: Work
    failed: list[NewtonResult] = field(default_factory=list)
    records: list[Work] = field(default_factory=list)

    @property
    def work(self) -> Work:
        return total_work(self.records)


@dataclass
class ValueReached:
    """How one value of the schedule was reached: in ``steps`` converged steps from the one before
    (1: directly; more: subdivided after ``cutbacks`` failed tries), with ``iterations`` full Newton
    iterations (failed tries included), ``factorisations`` and ``solves`` (predictors included)
    and ``seconds`` of wall time."""

    value: float
    steps: int
    cutbacks: int
    iterations: int
    factorisations: int
    solves: int
    seconds: float


@dataclass
class RampResult(WorkCounts):
    converged: bool
    goals: list[float] = field(default_factory=list)  # the values to reach: ``values``, or ``[target]``
    records: list[RampStep] = field(default_factory=list)
    cutbacks: int = 0
    message: str = ""
    stopped: bool = False  # ``on_step`` asked to stop before the target
    failed_work: list[Work] = field(default_factory=list)  # tries after the last converged step, failed

    @property
    def steps(self) -> int:
        return len(self.records)

    @property
    def values(self) -> list[float]:
        """The parameter value of every converged step."""
        return [step.value for step in self.records]

    @property
    def newton(self) -> list[NewtonResult]:
        """The converged solve of every step."""
        return [step.newton for step in self.records]

    @property
    def work(self) -> Work:
        """Times and counts of the whole ramp: every step's predictor and solves, failed tries
        included."""
        return total_work([w for step in self.records for w in step.records] + self.failed_work)

    @property
    def schedule(self) -> list[ValueReached]:
        """How each value of ``goals`` reached so far was reached."""
        out = []
        for k, value in enumerate(self.goals):
            steps = [s for s in self.records if s.goal == k]
            if not steps or steps[-1].value != value:
                break
            work = total_work([w for s in steps for w in s.records])
            out.append(ValueReached(value=value, steps=len(steps), cutbacks=sum(len(s.failed) for s in steps),
                                    iterations=sum(n.iterations for s in steps for n in [s.newton, *s.failed]),
                                    factorisations=work.factorisations, solves=work.solves, seconds=work.total))
        return out


class JumpError(NewtonError):
    """A step converged too far from its predictor (``ramp``'s ``max_correction``): onto another
    branch. Handled as a failed step."""


class RampError(RuntimeError):
    """A step failed and could not be cut back (below ``min_step``, or ``strict``); the problem
    holds the last converged state."""

    def __init__(self, message: str, result: RampResult):
        super().__init__(message)
        self.result = result


def ramp(problem, parameter: ngs.Parameter, target: float | None = None, *, values: Sequence[float] | None = None,
         strict: bool = False, step: float | None = None, min_step: float | None = None,
         max_step: float | None = None, grow: float = 1.5, easy_iterations: int = 4,
         on_step: Callable[[float, NewtonResult], bool | None] | None = None, newton_options: dict | None = None,
         tangent_start: bool = True, max_correction: float | None = None, predictor: str = "secant",
         progress: Callable[[str], None] | None = None, threads: int | None = None) -> RampResult:
    """Move ``parameter`` to ``target``, or through the listed ``values``, through converged
    equilibria of ``problem``.

    With ``target`` the step is chosen automatically (``step``, the first, bounded by
    ``min_step`` and ``max_step``; defaults ``|target - start|``, ``|target - start| * 1e-6`` and
    ``|target - start|``). With ``values`` (a load schedule, e.g. 20 equal steps) the parameter
    is set to each listed value in turn, exactly (no sums of increments), each first tried in one
    step; ``step`` and ``max_step`` do not apply, ``min_step`` defaults to 1e-6 of each interval.
    A value equal to the one before (or to the start) is solved again in place (a failure there
    raises ``NewtonError``).

    The first guess of the first step is the tangent (Euler) predictor from the converged start
    (with ``tangent_start``; otherwise the start itself); later ones extrapolate the last two
    converged states (a secant predictor), dropped if not admissible. ``predictor="quadratic"``:
    later guesses follow the parabola through the last two converged states with the path's
    tangent ``dx/dlambda`` at the last one, where the problem's solver holds the factorised tangent
    of that state (tagged ``LinearSolver.factorised_at``, as a path's stability check leaves it):
    one solve and two residuals more than the secant, which lags the path's turn; else, and where
    the parabola is not admissible, the secant (microlens shell: 3 Newton iterations from it
    against 4-5 from the secant, regular steps and next to folds alike). The tangent predictor
    saves many iterations when a load applied to the unrelaxed state makes its tangent far from
    the equilibrium one (a change of ``mu`` acts as a pressure of order ``G`` on a nearly
    incompressible gel); it is used only if admissible and better than the start, since a far
    linear prediction can land on a spurious branch (e.g. the body turned over). Better: a
    smaller free residual, or (for problems with an ``energy()``) a lower energy at the new
    load. The energy test matters on a buckled branch with stiff films: the predictor moves
    the film transversally, its membrane strain is wrong at second order and its residual is
    large although it lies much closer to the solution than the start (gears: first step on the
    buckled branch 4 Newton iterations from the predictor against 40+ from the start).

    A failed step is undone and halved (``cutbacks`` counts them); with ``strict`` it raises
    ``RampError`` instead, so a schedule is either followed as given or not at all. A step that
    converged in at most ``easy_iterations`` lets the next one grow by ``grow`` (with ``values``:
    up to the next listed value). ``on_step`` is called after every converged step (recording,
    output); if it returns True the ramp stops there with ``stopped`` set (the problem keeps
    whatever state ``on_step`` left).

    ``newton_options`` go to every solve (see ``ngsgel.newton.newton``); ``reference="step"``
    there makes Newton's ``rtol`` relative to the residual of the previous equilibrium under the
    new load, measured before the predictor (``|r| <= rtol |r0|`` of the load step; the default,
    ``"max"``, is relative to the residual at the predicted state).

    ``max_correction``: a step that converged farther from its predictor than ``max_correction``
    times the predicted increment (free dofs, Euclidean norm) fails as well. Past a fold, or
    where two stable states coexist, Newton can converge onto another branch, which neither end's
    stability tells; along a smooth path the correction is a fraction of the increment and
    shrinks with the step (a snapping arch: 0.05-0.4 along its branch, 1.6 for the step ending
    next to its limit point, 3.3 for the step across it), so halving such a step leads back to the
    path or stalls at the fold (``RampError``).

    ``progress``: called with one line at the start and one per converged step
    (``progress(message)``; a ``ngsgel.output.Progress`` also gets the fraction of the way to
    ``target`` done, for its percent done and time left). ``threads``: run on this many threads
    (``ngsgel.threads``; the settings before are restored at the end).

    The result's ``records`` (``RampStep``) hold each step's Newton result, its predictor's and
    failed tries' work, ``schedule`` (``ValueReached``) how each listed value was reached, and
    ``work``, ``factorisations`` and ``solves`` the totals.
    """
    if threads is not None:
        arguments = dict(locals())  # only the arguments so far: the same call, on that many threads
        with using_threads(threads):
            return ramp(**{**arguments, "threads": None})
    start = parameter.Get()
    if (target is None) == (values is None):
        raise ValueError("give either target (automatic steps) or values (a schedule), not both or neither")
    if max_correction is not None and not max_correction > 0:
        raise ValueError(f"max_correction must be a number > 0 (or None), got {max_correction!r}")
    if predictor not in PREDICTORS:
        raise ValueError(f"predictor must be one of {PREDICTORS}, got {predictor!r}")
    options = dict(newton_options or {})
    by_step = options.get("reference") == "step"
    if values is not None:
        goals = [float(v) for v in values]
        if not goals or not all(math.isfinite(v) for v in goals):
            raise ValueError(f"values must be a non-empty sequence of finite numbers, got {values!r}")
        if step is not None or max_step is not None:
            raise ValueError("step and max_step are for a target; with values each listed value is tried in one "
                             "step (and subdivided only if that fails)")
        report_progress(progress, f"start: parameter {start:.6g}, {len(goals)} values to {goals[-1]:.6g}",
                        fraction=0.0)
    else:
        goals = [float(target)]
        span = target - start
        if span == 0.0:
            result = RampResult(converged=True, goals=goals)
            _solve_in_place(problem, parameter, start, 0, options, by_step, result)
            return result
        step = abs(span) if step is None else abs(step)
        max_step = abs(span) if max_step is None else abs(max_step)
        min_step = abs(span) * 1e-6 if min_step is None else abs(min_step)
        if not (min_step <= step) or step <= 0:
            raise ValueError(f"step must be in [min_step, |target - start|], got step={step}, min_step={min_step}")
        report_progress(progress, f"start: parameter {start:.6g}, target {target:.6g}", fraction=0.0)
    result = RampResult(converged=False, goals=goals)
    previous = None  # (value, state) of the converged state before the current one
    current = (start, problem.save_state())
    for k, goal in enumerate(goals):
        interval_start = current[0]
        if goal == interval_start:
            if _solve_in_place(problem, parameter, goal, k, options, by_step, result, on_step, progress,
                               (k + 1) / len(goals)):
                return result
            current = (goal, problem.save_state())
            continue
        if values is not None:  # each listed value first in one step
            step = max_step = abs(goal - interval_start)
            smallest = abs(goal - interval_start) * 1e-6 if min_step is None else abs(min_step)
        else:
            smallest = min_step
        direction = math.copysign(1.0, goal - interval_start)
        failed: list[NewtonResult] = []
        tries: list[Work] = []
        while True:
            value, state = current
            if value == goal:
                break
            h = min(step, max_step, abs(goal - value))
            new = goal if abs(goal - value) <= h * (1 + 1e-12) else value + direction * h
            guess_work = Work("predictor")
            started = time.perf_counter()
            with ngs.TaskManager():  # threads the predictor's assembly and factorisation (no-op if active)
                if by_step:  # measured at the previous equilibrium; the predictors start from the old load
                    parameter.Set(new)
                    options["reference"] = _free_residual_norm(problem, guess_work)
                    parameter.Set(value)
                if previous is None and tangent_start:
                    if not _better_start(problem, tangent_predictor(problem, parameter, new, work=guess_work), state,
                                         guess_work):
                        problem.restore_state(state)
                elif previous is None:
                    parameter.Set(new)
                else:
                    secant = state + (new - value) / (value - previous[0]) * (state - previous[1])
                    guess = (_quadratic_guess(problem, parameter, (value, state), previous, new, guess_work)
                             if predictor == "quadratic" else None)
                    parameter.Set(new)
                    for candidate in ([guess] if guess is not None else []) + [secant]:
                        problem.restore_state(candidate)
                        if _admissible(problem, guess_work):
                            break
                    else:
                        problem.restore_state(state)
                predicted = problem.save_state() if max_correction is not None else None
            guess_work.total = time.perf_counter() - started
            tries.append(guess_work)
            try:
                newton_result = problem.solve(**options)
                if max_correction is not None:
                    _check_correction(problem, predicted, state, max_correction, newton_result)
            except NewtonError as err:
                problem.restore_state(state)
                parameter.Set(value)
                failed.append(err.result)
                tries.extend(err.result.records)
                result.failed_work = list(tries)
                if strict:
                    result.message = f"the step from {value:g} to {new:g} failed (strict: no cut-back): {err}"
                    raise RampError(result.message, result) from err
                result.cutbacks += 1
                step = h / 2
                if step < smallest:
                    result.message = (f"step fell below min_step={smallest:g} at {parameter.Get():g} "
                                      f"towards {goal:g}: {err}")
                    raise RampError(result.message, result) from err
                continue
            previous, current = current, (new, problem.save_state())
            result.records.append(RampStep(value=new, goal=k, newton=newton_result, predictor=guess_work, failed=failed,
                                           records=tries + newton_result.records))
            result.failed_work = []
            failed, tries = [], []
            report_progress(progress, f"step {result.steps}: parameter {new:.6g}, iterations "
                            f"{newton_result.iterations}"
                            + (f", cut-backs so far {result.cutbacks}" if result.cutbacks else ""),
                            fraction=(k + (new - interval_start) / (goal - interval_start)) / len(goals))
            if on_step is not None and on_step(new, newton_result):
                result.stopped = True
                result.message = f"stopped by on_step at {new:g}"
                return result
            step = h * grow if newton_result.iterations <= easy_iterations else h
    result.converged = True
    return result


def _solve_in_place(problem, parameter, value, goal, options, by_step, result, on_step=None, progress=None,
                    fraction=None) -> bool:
    """A zero step: solve at ``value`` from the current state and record it. True if ``on_step``
    asked to stop."""
    parameter.Set(value)
    predictor = Work("predictor")
    if by_step:
        options["reference"] = _free_residual_norm(problem, predictor)
    newton_result = problem.solve(**options)
    result.records.append(RampStep(value=value, goal=goal, newton=newton_result, predictor=predictor,
                                   records=[predictor, *newton_result.records]))
    report_progress(progress, f"step {result.steps}: parameter {value:.6g}, iterations {newton_result.iterations}",
                    fraction=fraction)
    if on_step is not None and on_step(value, newton_result):
        result.stopped = True
        result.message = f"stopped by on_step at {value:g}"
        return True
    return False


def _check_correction(problem, predicted: np.ndarray, start: np.ndarray, max_correction: float,
                      newton_result: NewtonResult) -> None:
    """``JumpError`` where the problem's state lies farther from ``predicted`` than ``max_correction``
    times the predicted increment from ``start`` (free dofs, over all ranks of a distributed mesh)."""
    increment = _free_state_norm(problem, predicted - start)
    correction = _free_state_norm(problem, problem.save_state() - predicted)
    if correction > max_correction * increment and increment > 0:
        raise JumpError(f"converged {correction / increment:.3g} predicted increments away from the predictor "
                        f"(max_correction {max_correction:g}): onto another branch", newton_result)


def _timed(work: Work, part: str, fn):
    """``fn()``, its wall time added to ``work``'s ``part``."""
    started = time.perf_counter()
    out = fn()
    setattr(work, part, getattr(work, part) + time.perf_counter() - started)
    return out


def _reductions(problem):
    """The problem's free-dof norms: over all ranks on a distributed mesh (as Newton's)."""
    return getattr(problem, "reductions", None) or FreeDofReductions(problem.free_mask)


def _free_state_norm(problem, values: np.ndarray) -> float:
    """Free-dof norm of a difference of states (the values of every copy of a dof, as a state)."""
    v = problem.state.CreateVector()  # a state's parallel status: each copy holds the dof's value
    v.FV().NumPy()[:] = values
    return _reductions(problem).free_norm(v)


def _free_residual_norm(problem, work: Work) -> float:
    r = problem.state.CreateVector()
    _timed(work, "residual", lambda: problem.residual(problem.state, r))
    work.residual_evaluations += 1
    return _reductions(problem).free_norm(r)


def _quadratic_guess(problem, parameter: ngs.Parameter, current: tuple[float, np.ndarray],
                     previous: tuple[float, np.ndarray], new: float, work: Work) -> np.ndarray | None:
    """The parabola through ``previous`` and ``current`` (parameter, state) whose slope at
    ``current`` is the path's tangent ``dx/dlambda = -K^-1 dR/dlambda``, evaluated at ``new``; None
    where the problem's solver does not hold the factorised tangent at ``current``
    (``LinearSolver.factorisation_at``) or the rate is not finite. ``dR/dlambda``: ``load_rate``
    along the prescribed motion (two residuals, no tangent). Leaves the problem at ``current``."""
    solver = getattr(problem, "_solver", None)
    value, state = current
    inverse = solver.factorisation_at(value, state) if isinstance(solver, LinearSolver) else None
    if inverse is None:
        return None
    parameter.Set(value)
    problem.restore_state(state)
    x = problem.state
    rate_of_load = _timed(work, "residual", lambda: load_rate(problem, parameter, relative_step=1e-6,
                                                              move_prescribed=True))
    work.residual_evaluations += 2
    load = x.CreateVector()
    load.FV().NumPy()[:] = 0.0
    load.FV().NumPy()[problem.free_mask] = rate_of_load.residual
    response = x.CreateVector()

    def solve():
        response.data = inverse * load

    _timed(work, "solve", solve)
    work.solves += 1
    rate = rate_of_load.prescribed.copy()
    rate[problem.free_mask] = -response.FV().NumPy()[problem.free_mask]
    if not np.all(np.isfinite(rate)):
        return None
    back = previous[0] - value
    curvature = (previous[1] - state - back * rate) / back**2
    ahead = new - value
    return state + ahead * rate + ahead**2 * curvature


def _admissible(problem, work: Work) -> bool:
    return _timed(work, "admissibility", lambda: problem.admissible(problem.state))


def _better_start(problem, guess: np.ndarray, start: np.ndarray, work: Work) -> bool:
    """Put ``guess`` in the problem; True if admissible with a smaller free residual than
    ``start`` or, for problems with an ``energy()``, a lower energy (both at the current load)."""
    energy = getattr(problem, "energy", None)
    problem.restore_state(start)
    r_start = _free_residual_norm(problem, work)
    e_start = energy() if energy is not None else None
    problem.restore_state(guess)
    if not _admissible(problem, work):
        return False
    if _free_residual_norm(problem, work) < r_start:
        return True
    return bool(energy is not None and energy() < e_start)


def tangent_predictor(problem, parameter: ngs.Parameter, new: float, *, work: Work | None = None) -> np.ndarray:
    """The state after one Newton step towards ``parameter = new`` taken with the tangent of the
    current (converged) state at the current parameter: the Euler predictor, with the
    prescribed values reached exactly. Leaves ``parameter`` at ``new`` and the state unchanged.
    ``work``: a ``Work`` record that gets its assembly, factorisation, solve and residual."""
    work = Work("predictor") if work is None else work
    x = problem.state
    K = _timed(work, "assembly", lambda: problem.tangent(x))
    # the problem's own: symbolic factorisation reused; on a distributed mesh its parallel solver
    solver = getattr(problem, "_solver", None)
    if not isinstance(solver, (LinearSolver, DistributedSolver)):
        freedofs = ngs.BitArray(problem.free_mask.tolist())
        solver = LinearSolver(freedofs, inverse=getattr(problem, "inverse", "umfpack"))
    inv = _timed(work, "factorisation", lambda: solver.factor(K))
    work.assemblies += 1
    work.factorisations += 1
    parameter.Set(new)
    r, step, target = x.CreateVector(), x.CreateVector(), x.CreateVector()
    _timed(work, "residual", lambda: problem.residual(x, r))
    work.residual_evaluations += 1
    problem.prescribed(target)
    step.FV().NumPy()[:] = np.where(problem.free_mask, 0.0, target.FV().NumPy() - x.FV().NumPy())

    def solve():
        r.data += K * step
        step.data -= inv * r

    _timed(work, "solve", solve)
    work.solves += 1
    return x.FV().NumPy() + step.FV().NumPy()
