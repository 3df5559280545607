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
from typing import Protocol

import numpy as np
import ngsolve as ngs

__all__ = ["NonlinearSystem", "NewtonResult", "NewtonError", "newton", "LinearSolver"]


class NonlinearSystem(Protocol):
    state: ngs.BaseVector
    free_mask: np.ndarray

    def residual(self, x: ngs.BaseVector, out: ngs.BaseVector) -> None: ...

    def tangent(self, x: ngs.BaseVector) -> ngs.BaseMatrix: ...

    def prescribed(self, out: ngs.BaseVector) -> None:
        """Target values on the constrained dofs (entries on free dofs are ignored)."""

    def admissible(self, x: ngs.BaseVector) -> bool: ...


@dataclass
class NewtonResult:
    converged: bool
    iterations: int
    residuals: list[float] = field(default_factory=list)
    line_search_cuts: int = 0
    message: str = ""
    chord_steps: int = 0  # steps with a reused factorisation (not counted in ``iterations``)
    iteration_times: list[float] = field(default_factory=list)  # wall time of each full iteration, s
    chord_times: list[float] = field(default_factory=list)  # wall time of each kept chord step, s


class NewtonError(RuntimeError):
    """Newton did not converge; ``result`` holds the history. The system's state was restored."""

    def __init__(self, message: str, result: NewtonResult):
        super().__init__(message)
        self.result = result


class LinearSolver:
    """Sparse direct solve on the free dofs that keeps its symbolic factorisation between calls
    as long as the matrix object stays the same."""

    def __init__(self, freedofs: ngs.BitArray, *, inverse: str = "sparsecholesky"):
        self.freedofs = freedofs
        self.inverse = inverse
        self._matrix = None
        self._inv = None

    @property
    def current(self):
        """The last factorisation (None before the first ``factor``)."""
        return self._inv

    def factor(self, matrix: ngs.BaseMatrix):
        if self._inv is not None and matrix is self._matrix:
            self._inv.Update()
        else:
            self._inv = matrix.Inverse(self.freedofs, inverse=self.inverse)
            self._matrix = matrix
        return self._inv


def newton(system: NonlinearSystem, solver: LinearSolver, *, rtol: float = 1e-11, atol: float = 0.0,
           xtol: float = 1e-13, maxit: int = 30, min_step: float = 2.0**-12,
           raise_on_failure: bool = True, reuse_factorisation: bool = False,
           chord_rate: float = 0.25, stall_window: int | None = None) -> NewtonResult:
    """Solve ``residual(x) = 0`` on the free dofs with ``x = prescribed`` on the constrained ones.

    Converged when the free residual's norm falls below ``max(atol, rtol * r_max)`` (``r_max``
    the largest residual seen in this solve) and the prescribed values are met, or when a full
    step changes no entry by more than ``xtol`` (its scale is the problem's length unit).
    Every trial point must be admissible with a finite residual; while the prescribed values are
    met the step is also cut until the residual norm decreases (Armijo). On failure the state is
    restored and ``NewtonError`` raised (or the result returned with ``converged=False``).

    With ``reuse_factorisation`` an iteration first tries a chord step with the solver's last
    factorisation (of an earlier tangent, possibly from an earlier solve), which costs a solve and
    a residual instead of an assembly and a factorisation; the step is kept only if it is
    admissible and cuts the free residual norm by at least ``chord_rate``, otherwise the iteration
    is a full Newton one (assembly, factorisation, line search). Only a full step can meet
    ``xtol``. Tried while the prescribed values are met, and not again after a rejected chord
    step until the next factorisation. ``iterations`` (and ``maxit``) count the full Newton
    iterations, ``chord_steps`` the kept chord steps; their number is bounded since each cuts the
    residual by ``chord_rate``.

    ``stall_window``: give up early when ``stall_window`` full iterations have not halved the
    free residual (Newton wandering where there is no solution nearby, e.g. a load step past a
    limit point): a caller that cuts its step on failure then does so after that many
    iterations instead of ``maxit``. ``None``: only ``maxit`` ends a solve.
    """
    if stall_window is not None and not (isinstance(stall_window, int) and stall_window >= 1):
        raise ValueError(f"stall_window must be an integer >= 1 or None, got {stall_window!r}")
    x = system.state
    free = system.free_mask
    x0 = x.CreateVector()
    x0.data = x
    r = x.CreateVector()
    dx = x.CreateVector()
    trial = x.CreateVector()
    target = x.CreateVector()
    r_trial = x.CreateVector()
    result = NewtonResult(converged=False, iterations=0)

    def free_norm(v: ngs.BaseVector) -> float:
        return float(np.linalg.norm(v.FV().NumPy()[free]))

    def fail(message: str) -> NewtonResult:
        x.data = x0
        result.message = message
        if raise_on_failure:
            raise NewtonError(message, result)
        return result

    system.prescribed(target)
    mismatch = target.FV().NumPy() - x.FV().NumPy()
    mismatch[free] = 0.0
    if not system.admissible(x):
        return fail("the starting state is not admissible")
    system.residual(x, r)
    rnorm = free_norm(r)
    r_max = rnorm
    result.residuals.append(rnorm)
    chord_ok = reuse_factorisation and solver.current is not None
    # free residual norm after every full iteration since the prescribed values are met
    after_iteration = [] if mismatch.any() else [rnorm]
    clock = time.perf_counter()  # a rejected chord step is charged to the full iteration after it
    for it in range(maxit + 1):
        while True:  # convergence test, then chord steps while they pay
            if not math.isfinite(rnorm):
                return fail(f"residual is not finite at iteration {it}")
            met = not mismatch.any()
            if met and rnorm <= max(atol, rtol * r_max):
                result.converged = True
                return result
            if not (chord_ok and met):
                break
            dx.data = solver.current * r
            trial.data = x - dx
            rn_trial = math.nan
            if system.admissible(trial):
                system.residual(trial, r_trial)
                rn_trial = free_norm(r_trial)
            if not (math.isfinite(rn_trial) and rn_trial <= chord_rate * rnorm):
                chord_ok = False  # until the next factorisation
                break
            x.data = trial
            r.data = r_trial
            rnorm = rn_trial
            result.residuals.append(rnorm)
            result.chord_steps += 1
            now = time.perf_counter()
            result.chord_times.append(now - clock)
            clock = now
        if it == maxit:
            break
        K = system.tangent(x)
        inv = solver.factor(K)
        chord_ok = reuse_factorisation
        # Constrained part of the step: reach the prescribed values; free part: linearised
        # equilibrium including the coupling to that constrained motion.
        dx.FV().NumPy()[:] = mismatch
        if met:  # no constrained motion: skip the product with K
            trial.data = r
        else:
            trial.data = K * dx
            trial.data += r
        dx.data -= inv * trial
        step_max = float(np.max(np.abs(dx.FV().NumPy()), initial=0.0))
        alpha = 1.0
        while True:
            trial.data = x + alpha * dx
            if system.admissible(trial):
                system.residual(trial, r_trial)
                rn_trial = free_norm(r_trial)
                if math.isfinite(rn_trial) and (not met or alpha * step_max <= xtol
                                                or rn_trial <= (1 - 1e-4 * alpha) * rnorm
                                                or rn_trial <= max(atol, rtol * r_max)):
                    break
            alpha *= 0.5
            result.line_search_cuts += 1
            if alpha < min_step:
                return fail(f"line search failed at iteration {it + 1} (residual {rnorm:.3e}): "
                            "no admissible step decreases the residual")
        x.data = trial
        mismatch *= 1.0 - alpha
        r.data = r_trial
        rnorm = rn_trial
        r_max = max(r_max, rnorm)
        result.residuals.append(rnorm)
        result.iterations = it + 1
        now = time.perf_counter()
        result.iteration_times.append(now - clock)
        clock = now
        if alpha == 1.0 and step_max <= xtol and not mismatch.any():
            result.converged = True
            return result
        if not mismatch.any():
            after_iteration.append(rnorm)
        if (stall_window is not None and len(after_iteration) > stall_window
                and rnorm > 0.5 * after_iteration[-1 - stall_window]):
            return fail(f"stalled: {stall_window} iterations did not halve the residual (now {rnorm:.3e}, "
                        f"iteration {it + 1})")
    return fail(f"no convergence in {maxit} iterations (residual {rnorm:.3e}, target "
                f"{max(atol, rtol * r_max):.3e})")

