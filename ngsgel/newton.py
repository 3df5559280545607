"""Newton's method with an admissible-step line search, for any discretised nonlinear system.

The solver knows nothing of gels. It sees a ``NonlinearSystem``: a state vector it updates in
place, the free dofs, a residual, a tangent, the prescribed values on the constrained dofs and an
admissibility test. Prescribed values are reached by the Newton increment itself (its constrained
part is ``g - x``), so a load step that moves a boundary never creates an inverted start.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from numbers import Real
from typing import Protocol

import numpy as np
import ngsolve as ngs

from . import linalg

__all__ = ["NonlinearSystem", "NewtonResult", "NewtonError", "newton", "LinearSolver", "FreeDofReductions", "Work",
           "WorkCounts", "total_work"]


class NonlinearSystem(Protocol):
    """``free_mask``: this process's free dofs. A system on a distributed mesh also has
    ``reductions`` (``ngsgel.parallel.DistributedReductions``): the norms and tests over all
    processes; without it ``newton`` uses ``FreeDofReductions(free_mask)``."""

    state: ngs.BaseVector
    free_mask: np.ndarray

    def residual(self, x: ngs.BaseVector, out: ngs.BaseVector) -> None: ...

    def tangent(self, x: ngs.BaseVector) -> ngs.BaseMatrix: ...

    def prescribed(self, out: ngs.BaseVector) -> None:
        """Target values on the constrained dofs (entries on free dofs are ignored)."""

    def admissible(self, x: ngs.BaseVector) -> bool: ...


@dataclass
class Work:
    """What one Newton iteration, chord step or predictor cost: wall time (s) per part and the
    number of each operation.

    ``kind``: "start" (admissibility and residual of the starting state), "newton" (assembly,
    factorisation, solve, line search), "chord" (a kept step with an earlier factorisation),
    "rejected chord" (a chord step tried and dropped), "predictor" (``ramp``'s tangent
    predictor), "total" (a sum, ``total_work``). The times are disjoint: ``residual`` and
    ``admissibility`` are those of the point kept, ``line_search`` everything spent on trial
    points the line search rejected (an energy evaluation, ``merit="energy"``, counts with the
    residual of its point); ``total`` is the record's wall time (the parts plus bookkeeping). ``solve`` includes the product with the tangent that carries prescribed motion.
    ``residual_norm``: the free residual at the point kept (NaN for a rejected chord step)."""

    kind: str
    total: float = 0.0
    assembly: float = 0.0
    factorisation: float = 0.0
    solve: float = 0.0
    residual: float = 0.0
    admissibility: float = 0.0
    line_search: float = 0.0
    assemblies: int = 0
    factorisations: int = 0
    solves: int = 0
    residual_evaluations: int = 0
    residual_norm: float = math.nan

    TIMES = ("total", "assembly", "factorisation", "solve", "residual", "admissibility", "line_search")
    COUNTS = ("assemblies", "factorisations", "solves", "residual_evaluations")


def total_work(records) -> Work:
    """The sum of ``records`` (``Work``), as one record of kind "total"."""
    out = Work("total")
    for record in records:
        for name in Work.TIMES + Work.COUNTS:
            setattr(out, name, getattr(out, name) + getattr(record, name))
    return out


class WorkCounts:
    """Total factorisations and solves of a result whose ``work`` sums its records."""

    @property
    def factorisations(self) -> int:
        return self.work.factorisations

    @property
    def solves(self) -> int:
        return self.work.solves


@dataclass
class NewtonResult(WorkCounts):
    converged: bool
    iterations: int
    residuals: list[float] = field(default_factory=list)
    line_search_cuts: int = 0
    message: str = ""
    chord_steps: int = 0  # steps with a reused factorisation (not counted in ``iterations``)
    records: list[Work] = field(default_factory=list)  # the start, then one per iteration or chord step
    criterion: str = ""  # what ended a converged solve: "residual", "floor" or "increment"
    tolerance: float = math.nan  # the residual target at the end, max(atol, rtol * reference)

    @property
    def work(self) -> Work:
        """Times and counts of the whole solve (``total_work`` of ``records``)."""
        return total_work(self.records)


class NewtonError(RuntimeError):
    """Newton did not converge; ``result`` holds the history. The system's state was restored."""

    def __init__(self, message: str, result: NewtonResult):
        super().__init__(message)
        self.result = result


class FreeDofReductions:
    """Newton's norms and tests of one process's vectors: the free-dof norm, the largest entry,
    whether any entry is nonzero, a sum and a maximum (of one number: the identity), the free-dof
    count."""

    def __init__(self, free_mask: np.ndarray):
        self.free_mask = free_mask

    @property
    def free_count(self) -> int:
        return int(self.free_mask.sum())

    def sum(self, value: float) -> float:
        return value

    def max(self, value: float) -> float:
        return value

    def free_norm(self, v: ngs.BaseVector) -> float:
        return float(np.linalg.norm(v.FV().NumPy()[self.free_mask]))

    def max_abs(self, values: np.ndarray) -> float:
        return float(np.max(np.abs(values), initial=0.0))

    def any(self, values: np.ndarray) -> bool:
        return bool(values.any())


class LinearSolver:
    """Sparse direct solve on the free dofs that keeps its symbolic factorisation between calls
    as long as the matrix object stays the same.

    ``inverse``: ``"auto"`` (MKL PARDISO if installed, else NGSolve's ``"sparsecholesky"``; the
    choice and its reason are logged once per process by the ``ngsgel.linalg`` logger),
    ``"pardiso"`` (``ngsgel.linalg.PardisoLDLT``: the optional extra ``ngsgel[pardiso]``; its
    factorisations also give the inertia of the free tangent) or any NGSolve inverse by name
    (``"sparsecholesky"``, ``"umfpack"``, ...)."""

    def __init__(self, freedofs: ngs.BitArray, *, inverse: str = "sparsecholesky"):
        self.freedofs = freedofs
        self.inverse = linalg.resolve_inverse(inverse)
        self._matrix = None
        self._inv = None
        self._pardiso = None
        # seconds of the last full Newton iteration that used this solver (assembly, factorisation,
        # solve, residual): what a chord step's saving is weighed against
        self.iteration_seconds: float | None = None
        # (parameter, state) whose tangent the last factorisation is, where a caller that knows
        # says so (a path's stability check); every ``factor`` clears it
        self.factorised_at: tuple[float, np.ndarray] | None = None

    def factorisation_at(self, parameter: float, state: np.ndarray):
        """The last factorisation if a caller tagged it as the tangent at ``parameter`` and
        ``state`` (``factorised_at``), else None."""
        tag = self.factorised_at
        if tag is None or tag[0] != parameter or not np.array_equal(tag[1], state):
            return None
        return self._inv

    @property
    def current(self):
        """The last factorisation (None before the first ``factor``)."""
        return self._inv

    @property
    def inertia(self) -> tuple[int, int, int] | None:
        """``(positive, negative, zero)`` eigenvalue counts of the free block of the last
        factorised matrix, where the backend gives them (``"pardiso"``, pivots unperturbed);
        else None."""
        return self._inv.inertia if isinstance(self._inv, linalg.FreeDofInverse) else None

    @property
    def ldlt(self) -> linalg.PardisoLDLT | None:
        """The last factorisation as a free-block LDL^T with a known inertia (``inertia`` not
        None), for solves on free-dof vectors (``stability.spectrum``'s ``factorisation``)."""
        return self._pardiso if self.inertia is not None else None

    def factor(self, matrix: ngs.BaseMatrix):
        if self.inverse == "pardiso":
            if self._pardiso is None:
                self._pardiso = linalg.PardisoLDLT(np.array(list(self.freedofs), dtype=bool))
            self._inv = linalg.FreeDofInverse(self._pardiso.factor(matrix))
        elif self._inv is not None and matrix is self._matrix:
            self._inv.Update()
        else:
            self._inv = matrix.Inverse(self.freedofs, inverse=self.inverse)
        self._matrix = matrix
        self.factorised_at = None
        return self._inv


REFERENCES = ("max", "start")
# Relative energy change below which the energy does not judge a step. The gel energy is a sum of
# cancelling terms, but its rounding is far below this: the microlens shell's (-1.55e-3) followed
# its quadratic model along a Newton direction to 5e-18 (3e-15 of it).
ENERGY_ROUND_OFF = 1e-12
BACKTRACKS = ("halving", "quadratic")
MERITS = ("residual", "energy")


def newton(system: NonlinearSystem, solver: LinearSolver, *, rtol: float = 1e-11, atol: float = 0.0,
           xtol: float = 1e-13, reference: str | float = "max", maxit: int = 30, min_step: float = 2.0**-12,
           raise_on_failure: bool = True, reuse_factorisation: bool = False, chord_start: bool = False,
           chord_rate: float = 0.25, chord_pacing: bool = False, stall_window: int | None = None,
           stall_trend: int | None = None, backtrack: str = "halving", merit: str = "residual") -> NewtonResult:
    """Solve ``residual(x) = 0`` on the free dofs with ``x = prescribed`` on the constrained ones.

    Converged, once the prescribed values are met, when one of these holds (``criterion`` of the
    result names it; norms are Euclidean norms of the free residual):

    - ``residual``: the residual is at most ``rtol`` times the ``reference`` residual:
      ``"max"`` (default) the largest residual seen in this solve (the start's, unless the line
      search let it grow first), ``"start"`` the residual of the starting state, or a number the
      caller measured (``ramp``'s ``reference="step"`` passes the residual of the previous
      equilibrium under the new load, before the predictor: the textbook
      ``|r| <= rtol |r0|`` of a load step);
    - ``floor``: the residual is at most ``atol``, an absolute floor (the problems' ``solve``
      put their round-off level here unless given, see ``EquilibriumProblem.residual_floor``):
      a solve that starts next to its solution cannot reduce a residual at round-off by a
      relative factor;
    - ``increment``: a full step changes no entry by more than ``xtol`` (the problem's length
      unit).

    So the defaults (``rtol=1e-11``, ``reference="max"``, ``xtol=1e-13``) ask for eleven digits
    of the residual the solve started with, wherever the caller started it (``ramp``: at its
    predicted state). Every trial point must be admissible with a finite residual; while the
    prescribed values are met the step is also cut until the residual norm decreases (Armijo). On
    failure the state is restored and ``NewtonError`` raised (or the result returned with
    ``converged=False``); its message gives the residual, the target and both of its parts.

    With ``reuse_factorisation`` an iteration first tries a chord step with the solver's last
    factorisation (of an earlier tangent, possibly from an earlier solve), which costs a solve and
    a residual instead of an assembly and a factorisation; the step is kept only if it is
    admissible and cuts the free residual norm by at least ``chord_rate``, otherwise the iteration
    is a full Newton one (assembly, factorisation, line search). With ``chord_pacing`` a kept
    chord step is followed by another only while chord steps pay: their observed contraction and
    time, projected to the tolerance, against as many full iterations as needed (each roughly
    squaring the relative residual) at the time the solver's last full iteration took
    (``LinearSolver.iteration_seconds``), so a slowly contracting chord hands over to Newton. The
    iterations then depend on measured times: a run does not repeat bit for bit. Only a full step can meet
    ``xtol``. Tried while the prescribed values are met, and not again after a rejected chord
    step until the next factorisation. ``iterations`` (and ``maxit``) count the full Newton
    iterations, ``chord_steps`` the kept chord steps; their number is bounded since each cuts the
    residual by ``chord_rate``. ``chord_start``: the same chord steps before the first full
    iteration only (until one is rejected), for a caller that has just factorised the tangent at
    the previous solution, e.g. for a stability check: the next solve starts with it.

    ``stall_window``: give up early when ``stall_window`` full iterations have not halved the
    free residual (Newton wandering where there is no solution nearby, e.g. a load step past a
    limit point): a caller that cuts its step on failure then does so after that many
    iterations instead of ``maxit``. ``None``: only ``maxit`` ends a solve.
    ``stall_trend`` (with ``stall_window``): give up as soon as the last ``stall_trend`` full
    iterations contracted the residual so little that, kept up, they would not halve it within
    ``stall_window`` iterations (each cut by less than ``2^(-1/stall_window)`` on average). Next to
    a fold the line search then cuts every step many times over, and a try that cannot converge
    costs a few iterations instead of the whole window (microlens shell: 0.3-0.7 % per iteration
    with six cuts each, 20 s a try; a slow phase that converges drops 10 % per iteration or more).

    ``backtrack``: how the line search shortens a refused step: ``"halving"``, or ``"quadratic"``
    (while the prescribed values are met and the trial point is admissible: the minimiser of the
    parabola in ``alpha`` through ``|r|^2`` at the start, with the Newton direction's slope
    ``-2 |r|^2``, and at the refused point, kept within a tenth and a half of the refused step),
    which reaches the step Armijo accepts in fewer residuals where the full step overshoots by far
    (next to a fold or a singular tangent, where halving takes five or six residuals an iteration).

    ``merit``: what the line search asks of a step once the prescribed values are met:
    ``"residual"`` (the Armijo decrease of the free residual norm above), or ``"energy"`` (for a
    system with ``energy(x)``): where the factorisation shows the tangent positive definite (its
    inertia, PARDISO's), a step the residual refuses is also kept if it lowers the energy by the
    Armijo fraction of ``r . dx`` (the Newton direction descends there), while that change lies above
    the energy's rounding (``ENERGY_ROUND_OFF``). In a flat, curved valley of a stable state the full
    Newton step often lowers the energy as its quadratic model says while the residual norm grows,
    and halving it to please the residual makes the convergence linear (the microlens shell after a
    snap: 19 iterations, 8 cuts, 17 s with the residual; 13, no cut, 11 s with the energy, the same
    state). At a saddle, or without an inertia, the solve is the residual one. The stall tests
    follow the lowest residual so far (a step kept by its energy may raise the residual).

    ``records`` of the result hold the time and operation counts of the start and of every
    iteration and chord step (``Work``); ``work``, ``factorisations`` and ``solves`` sum them.
    """
    if stall_window is not None and not (isinstance(stall_window, int) and stall_window >= 1):
        raise ValueError(f"stall_window must be an integer >= 1 or None, got {stall_window!r}")
    if backtrack not in BACKTRACKS:
        raise ValueError(f"backtrack must be one of {BACKTRACKS}, got {backtrack!r}")
    if merit not in MERITS:
        raise ValueError(f"merit must be one of {MERITS}, got {merit!r}")
    if merit == "energy" and not callable(getattr(system, "energy", None)):
        raise ValueError("merit='energy' needs a system with an energy(x) method")
    if stall_trend is not None and not (isinstance(stall_trend, int) and stall_trend >= 1 and stall_window is not None):
        raise ValueError(f"stall_trend must be an integer >= 1 (with a stall_window) or None, got {stall_trend!r}")
    for name, value in (("rtol", rtol), ("atol", atol), ("xtol", xtol)):
        if not (isinstance(value, Real) and 0 <= value < math.inf):
            raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    if not (reference in REFERENCES or (isinstance(reference, Real) and not isinstance(reference, bool)
                                        and 0 <= reference < math.inf)):
        raise ValueError(f"reference must be 'max', 'start' or a finite number >= 0, got {reference!r}")
    x = system.state
    free = system.free_mask
    reductions = getattr(system, "reductions", None) or FreeDofReductions(free)
    x0 = x.CreateVector()
    x0.data = x
    r = x.CreateVector()
    dx = x.CreateVector()
    trial = x.CreateVector()
    target = x.CreateVector()
    r_trial = x.CreateVector()
    result = NewtonResult(converged=False, iterations=0)
    clock = time.perf_counter

    def fail(message: str) -> NewtonResult:
        x.data = x0
        result.message = message
        if raise_on_failure:
            raise NewtonError(message, result)
        return result

    def evaluate(point: ngs.BaseVector, out: ngs.BaseVector, work: Work) -> float:
        """Admissibility, then (if admissible) residual and its free norm (NaN if inadmissible)."""
        start = clock()
        ok = system.admissible(point)
        work.admissibility += clock() - start
        if not ok:
            return math.nan
        start = clock()
        system.residual(point, out)
        work.residual += clock() - start
        work.residual_evaluations += 1
        return reductions.free_norm(out)

    def apply_inverse(inv, rhs: ngs.BaseVector, out: ngs.BaseVector, work: Work) -> None:
        start = clock()
        out.data = inv * rhs
        work.solve += clock() - start
        work.solves += 1

    def close(work: Work, started: float, rnorm: float) -> None:
        work.total = clock() - started
        work.residual_norm = rnorm
        result.records.append(work)

    def chord_pays(rate: float, chord_seconds: float) -> bool:
        """Whether more chord steps at the observed ``rate`` reach the tolerance sooner than full
        iterations would: the chord converges linearly, Newton roughly squares the relative
        residual per iteration (both counted from here to ``tolerance()``)."""
        if solver.iteration_seconds is None or rate <= 0.0 or not 0.0 < tolerance() < rnorm:
            return True  # nothing measured yet, or nothing left to estimate
        digits_left = math.log(rnorm / tolerance())
        chord_steps = math.ceil(digits_left / -math.log(rate))
        relative_now = min(rnorm / max(r_max, rnorm), 0.5)  # Newton's progress needs a residual < r_max
        newton_iterations = max(1, math.ceil(math.log2(math.log(tolerance() / max(r_max, rnorm))
                                                       / math.log(relative_now))))
        # the slowest process's times (one process: its own), so all processes decide alike
        return (chord_steps * reductions.max(chord_seconds)
                <= newton_iterations * reductions.max(solver.iteration_seconds))

    def relative() -> float:
        return rtol * (r_max if reference == "max" else r_start if reference == "start" else reference)

    def tolerance() -> float:
        return max(atol, relative())

    def converge(criterion: str) -> NewtonResult:
        result.converged, result.criterion, result.tolerance = True, criterion, tolerance()
        return result

    started = clock()
    system.prescribed(target)
    mismatch = target.FV().NumPy() - x.FV().NumPy()
    mismatch[free] = 0.0
    work = Work("start")
    rnorm = evaluate(x, r, work)
    if math.isnan(rnorm) and work.residual_evaluations == 0:
        return fail("the starting state is not admissible")
    close(work, started, rnorm)
    r_max = r_start = rnorm
    result.residuals.append(rnorm)
    energy_here = None  # the energy at x, where known (merit "energy")
    chord_ok = (reuse_factorisation or chord_start) and solver.current is not None
    # free residual norm after every full iteration since the prescribed values are met
    after_iteration = [] if reductions.any(mismatch) else [rnorm]
    for it in range(maxit + 1):
        while True:  # convergence test, then chord steps while they pay
            if not math.isfinite(rnorm):
                return fail(f"residual is not finite at iteration {it}")
            met = not reductions.any(mismatch)
            if met and rnorm <= tolerance():
                return converge("residual" if rnorm <= relative() else "floor")
            if not (chord_ok and met):
                break
            started, work = clock(), Work("chord")
            apply_inverse(solver.current, r, dx, work)
            trial.data = x - dx
            rn_trial = evaluate(trial, r_trial, work)
            if not (math.isfinite(rn_trial) and rn_trial <= chord_rate * rnorm):
                work.kind = "rejected chord"
                close(work, started, math.nan)
                chord_ok = False  # until the next factorisation
                break
            rate = rn_trial / rnorm if rnorm > 0 else 0.0
            x.data = trial
            energy_here = None
            r.data = r_trial
            rnorm = rn_trial
            result.residuals.append(rnorm)
            result.chord_steps += 1
            close(work, started, rnorm)
            chord_ok = not chord_pacing or chord_pays(rate, work.total)
        if it == maxit:
            break
        started, work = clock(), Work("newton")
        t = clock()
        K = system.tangent(x)
        work.assembly, work.assemblies = clock() - t, 1
        t = clock()
        inv = solver.factor(K)
        work.factorisation, work.factorisations = clock() - t, 1
        chord_ok = reuse_factorisation
        # Constrained part of the step: reach the prescribed values; free part: linearised
        # equilibrium including the coupling to that constrained motion.
        dx.FV().NumPy()[:] = mismatch
        t = clock()
        if met:  # no constrained motion: skip the product with K
            trial.data = r
        else:
            trial.data = K * dx
            trial.data += r
        work.solve += clock() - t
        apply_inverse(inv, trial, r_trial, work)
        dx.data -= r_trial
        step_max = reductions.max_abs(dx.FV().NumPy())
        alpha = 1.0
        slope = math.nan
        # the energy judges only a descent direction to a minimum: the tangent positive definite
        # (an inertia the factorisation gives); a saddle (a location past a critical point) or a
        # backend without inertia keeps the residual
        inertia = solver.inertia if merit == "energy" and met else None
        if inertia is not None and inertia[1] == 0 and inertia[2] == 0:
            slope = reductions.sum(float(r.FV().NumPy()[free] @ dx.FV().NumPy()[free]))
        while True:
            trial.data = x + alpha * dx
            attempt = Work("trial")
            rn_trial = evaluate(trial, r_trial, attempt)
            accepted = math.isfinite(rn_trial) and (not met or alpha * step_max <= xtol
                                                    or rn_trial <= (1 - 1e-4 * alpha) * rnorm
                                                    or rn_trial <= tolerance())
            if not accepted and math.isfinite(rn_trial) and slope < 0:
                t = clock()
                if energy_here is None:
                    energy_here = system.energy(x)
                # Armijo on the energy, where its change is above its rounding
                if -alpha * slope > ENERGY_ROUND_OFF * abs(energy_here):
                    accepted = system.energy(trial) <= energy_here + 1e-4 * alpha * slope
                attempt.residual += clock() - t
            if accepted:
                work.residual, work.admissibility = attempt.residual, attempt.admissibility
                work.residual_evaluations += attempt.residual_evaluations
                break
            work.line_search += attempt.residual + attempt.admissibility
            work.residual_evaluations += attempt.residual_evaluations
            if backtrack == "quadratic" and met and math.isfinite(rn_trial):
                # |r(x + a dx)|^2 ~ phi0 (1 - 2 a) + c a^2: the Newton direction's slope, through the
                # trial point; its minimiser, kept within [alpha / 10, alpha / 2]
                phi0 = rnorm**2
                curvature = (rn_trial**2 - phi0 * (1 - 2 * alpha)) / alpha**2
                alpha = min(max(phi0 / curvature, 0.1 * alpha), 0.5 * alpha)
            else:
                alpha *= 0.5
            result.line_search_cuts += 1
            if alpha < min_step:
                close(work, started, rnorm)
                return fail(f"line search failed at iteration {it + 1} (residual {rnorm:.3e}): "
                            "no admissible step decreases the residual")
        x.data = trial
        energy_here = None
        mismatch *= 1.0 - alpha
        r.data = r_trial
        rnorm = rn_trial
        r_max = max(r_max, rnorm)
        result.residuals.append(rnorm)
        result.iterations = it + 1
        close(work, started, rnorm)
        solver.iteration_seconds = work.total - work.line_search
        if alpha == 1.0 and step_max <= xtol and not reductions.any(mismatch):
            return converge("increment")
        # an energy-accepted step may raise the residual: progress is then the lowest one so far
        progress = min(rnorm, after_iteration[-1]) if merit == "energy" and after_iteration else rnorm
        if not reductions.any(mismatch):
            after_iteration.append(progress)
        if (stall_window is not None and len(after_iteration) > stall_window
                and progress > 0.5 * after_iteration[-1 - stall_window]):
            return fail(f"stalled: {stall_window} iterations did not halve the residual (now {rnorm:.3e}, "
                        f"iteration {it + 1})")
        if (stall_trend is not None and len(after_iteration) > stall_trend
                and progress > 0.5 ** (stall_trend / stall_window) * after_iteration[-1 - stall_trend]):
            return fail(f"stalled: the last {stall_trend} iterations cut the residual by "
                        f"{1 - progress / after_iteration[-1 - stall_trend]:.2%} (now {rnorm:.3e}, iteration {it + 1}): "
                        f"at that rate {stall_window} would not halve it")
    described = {"max": "the largest residual", "start": "the start residual"}.get(reference, "the reference")
    return fail(f"no convergence in {maxit} iterations (residual {rnorm:.3e}, target {tolerance():.3e}: "
                f"the larger of the floor atol = {atol:.3e} and rtol = {rtol:.3g} x {described} "
                f"{relative() / rtol if rtol else math.nan:.3e})")
