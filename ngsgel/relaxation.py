"""Where a structure lands after it loses stability at a fixed load: the stable equilibrium
reached by the implicit gradient flow ``M dx/dtau = -R(x)`` from a (perturbed) unstable state.

Under load (or ``mu``) control a limit point has no equilibrium nearby beyond it, and a
subcritical bifurcation none on the followed branch: the structure snaps. ``settle`` follows the
overdamped motion at the fixed load by backward-Euler steps in pseudo-time, each the minimiser
of ``E(x) + |x - x_n|_M^2 / (2 tau)``, so the energy never rises; ``tau`` grows while the steps
are easy, and the flow ends at a state whose undamped Newton solve converges with no negative
eigenvalue (exact count). Which minimum is reached depends on the start (the caller's
perturbation, usually along the critical mode): it is the one the overdamped dynamics selects,
not necessarily the one of lowest energy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import ngsolve as ngs

from .newton import LinearSolver, NewtonError, NewtonResult, newton
from .stability import free_matrix, mass_matrix, negative_count, spectrum

__all__ = ["ViscousSystem", "SettleResult", "SettleError", "settle", "settle_past"]


class ViscousSystem:
    """``problem`` plus the viscous force ``rate() * M (x - x_n)`` (``M`` the problem's mass
    matrix, ``x_n`` the last accepted state; ``rate()`` returns ``viscosity`` unless a subclass
    says otherwise) as a ``NonlinearSystem`` for ``newton``."""

    def __init__(self, problem, *, viscosity: float = 0.0):
        self.problem = problem
        self.free_mask = problem.free_mask
        self.mass = mass_matrix(problem)
        if self.mass.nze != problem.tangent(problem.state).nze:
            raise RuntimeError("the mass matrix and the tangent have different sparsity; cannot add them")
        self.solver = LinearSolver(problem.space.FreeDofs(), inverse=problem.inverse)
        self.viscosity = viscosity
        self.x_n = problem.save_state()
        self._dx = problem.state.CreateVector()
        self._Mdx = problem.state.CreateVector()

    def rate(self) -> float:
        return self.viscosity

    @property
    def state(self):
        return self.problem.state

    def residual(self, x, out) -> None:
        self.problem.residual(x, out)
        self._dx.FV().NumPy()[:] = x.FV().NumPy() - self.x_n
        self._Mdx.data = self.mass * self._dx
        out.data += self.rate() * self._Mdx

    def tangent(self, x):
        K = self.problem.tangent(x)
        K.AsVector().data += self.rate() * self.mass.AsVector()
        return K

    def prescribed(self, out) -> None:
        self.problem.prescribed(out)

    def admissible(self, x) -> bool:
        return self.problem.admissible(x)

    def save_state(self) -> np.ndarray:
        return self.problem.save_state()

    def restore_state(self, saved: np.ndarray) -> None:
        self.problem.restore_state(saved)

    def work(self, dx: np.ndarray) -> float:
        """``dx_f . (M dx)_f``."""
        self._dx.FV().NumPy()[:] = dx
        self._Mdx.data = self.mass * self._dx
        return float(dx[self.free_mask] @ self._Mdx.FV().NumPy()[self.free_mask])


@dataclass
class SettleResult:
    """``energy_drop``: energy at the start minus at the end (>= 0 up to round-off);
    ``distance``: ``|x_end - x_start|_M / sqrt(volume)`` (root-mean-square displacement);
    ``steps``/``rejected``: pseudo-time steps kept and cut back; ``iterations``: Newton
    iterations (tangent assemblies) of all solves; ``lowest_eigenvalue``: of the
    end state; ``energies``: after every kept step (non-increasing)."""

    energy_start: float
    energy_end: float
    distance: float
    steps: int
    rejected: int
    negative: int
    lowest_eigenvalue: float
    iterations: int = 0
    energies: list[float] = field(default_factory=list)

    @property
    def energy_drop(self) -> float:
        return self.energy_start - self.energy_end


class SettleError(RuntimeError):
    def __init__(self, message: str, result: SettleResult):
        super().__init__(message)
        self.result = result


def settle(problem, *, max_steps: int = 400, grow: float = 2.0, easy_iterations: int = 6,
           newton_options: dict | None = None,
           progress: Callable[[str], None] | None = None) -> SettleResult:
    """Relax ``problem`` at its current load from its current state to a stable equilibrium.

    The first pseudo-time step is ``tau = 0.5 / |omega_min|`` (``omega_min`` the lowest
    eigenvalue of ``K phi = omega M phi``; ``K + M / tau`` is then positive definite, so the step
    is well posed) or ``1 / omega_min`` at a stable start; it is multiplied by ``grow`` after a
    step of at most ``easy_iterations`` Newton iterations and divided by 4 when a step fails or
    would raise the energy (by more than round-off). Once a step moves the state by less than
    1e-2 of the distance travelled, the undamped problem is solved from there; a converged solve
    that does not raise the energy ends the flow if the tangent has no negative eigenvalue
    (an unstable one, which the flow reaches only from an exactly symmetric start, raises
    ``SettleError``: perturb the start). ``newton_options`` go to every Newton solve. Raises ``SettleError`` after
    ``max_steps`` steps or when ``tau`` falls below 1e-12 of its start.
    """
    if not grow > 1:
        raise ValueError(f"grow must be > 1, got {grow!r}")
    newton_options = dict(newton_options or {})
    system = ViscousSystem(problem)
    free = problem.free_mask
    volume = problem.integrate(ngs.CF(1.0))
    start = problem.save_state()
    energy = problem.energy()
    first = spectrum(problem, count=1)
    omega = float(first.eigenvalues[0])
    tau0 = 0.5 / abs(omega) if omega < 0 else 1.0 / omega
    tau = tau0
    result = SettleResult(energy_start=energy, energy_end=energy, distance=0.0, steps=0, rejected=0,
                          negative=first.negative, lowest_eigenvalue=omega)
    round_off = 1e-12 * max(abs(energy), 1.0)

    def rms(dx: np.ndarray) -> float:
        return math.sqrt(max(system.work(dx), 0.0) / volume)

    def counted(solve: Callable[[], NewtonResult]) -> NewtonResult:
        try:
            solved = solve()
        except NewtonError as err:
            result.iterations += err.result.iterations
            raise
        result.iterations += solved.iterations
        return solved

    def report(message: str) -> None:
        if progress is not None:
            progress(message)

    if first.negative == 0:  # a stable start: an undamped solve may already end it
        try:
            counted(lambda: problem.solve(**newton_options))
        except NewtonError:
            problem.restore_state(start)
        else:
            if problem.energy() <= energy + round_off:
                spec = spectrum(problem, count=1)
                if spec.negative == 0:
                    result.energy_end, result.negative = problem.energy(), 0
                    result.lowest_eigenvalue = float(spec.eigenvalues[0])
                    result.distance = rms(problem.save_state() - start)
                    return result
            problem.restore_state(start)

    while True:
        if result.steps >= max_steps:
            raise SettleError(f"no stable equilibrium after {max_steps} pseudo-time steps "
                              f"(energy drop {energy - result.energy_start:.3e}, tau {tau:.3e})", result)
        if tau < 1e-12 * tau0:
            raise SettleError(f"pseudo-time step fell to {tau:.3e} (start {tau0:.3e})", result)
        x_n = problem.save_state()
        system.x_n = x_n
        system.viscosity = 1.0 / tau
        try:
            solved = counted(lambda: newton(system, system.solver, **newton_options))
        except NewtonError:
            problem.restore_state(x_n)
            result.rejected += 1
            tau /= 4
            continue
        new_energy = problem.energy()
        if new_energy > energy + round_off:
            problem.restore_state(x_n)
            result.rejected += 1
            tau /= 4
            continue
        x = problem.save_state()
        energy = new_energy
        result.steps += 1
        result.energies.append(energy)
        moved = rms(x - x_n)
        result.distance = rms(x - start)
        report(f"settle step {result.steps}: {solved.iterations} iterations, tau {tau:.3e}, energy {energy:.12e}, "
               f"moved {moved:.3e}, distance {result.distance:.3e}")
        if solved.iterations <= easy_iterations:
            tau *= grow
        if moved > 1e-2 * result.distance:
            continue
        try:  # the flow has nearly stopped: is this a (stable) equilibrium?
            counted(lambda: problem.solve(**newton_options))
        except NewtonError:
            problem.restore_state(x)
            continue
        if problem.energy() > energy + round_off:
            problem.restore_state(x)
            continue
        K = free_matrix(problem.tangent(problem.state), free)
        negative = negative_count(K)
        if negative == 0:
            result.energy_end = problem.energy()
            result.negative = 0
            result.lowest_eigenvalue = float(spectrum(problem, count=1, K=K).eigenvalues[0])
            result.distance = rms(problem.save_state() - start)
            return result
        result.negative = negative
        raise SettleError(f"the flow ended on an unstable equilibrium ({negative} negative eigenvalues): "
                          "perturb the start (e.g. along its lowest mode)", result)


def settle_past(problem, parameter: ngs.Parameter, event, *, overshoot: float, amplitude: float,
                **settle_options) -> SettleResult:
    """Where the structure goes after the located loss of stability ``event`` (an
    ``ngsgel.continuation.Event`` with its state and critical mode): the load parameter is moved
    ``overshoot`` beyond the critical value (signed: the direction the path was going), the
    critical state is pushed by root-mean-square ``amplitude`` along the mode, with the sign of
    lower energy, and ``settle`` relaxes it to a stable equilibrium at that load."""
    if event.state is None or event.mode is None:
        raise ValueError("the event has no state or no critical mode (was it located?)")
    if overshoot == 0:
        raise ValueError("overshoot must be non-zero: at the critical load the flow has no direction")
    if not amplitude > 0:
        raise ValueError(f"amplitude must be positive, got {amplitude!r}")
    parameter.Set(event.parameter + overshoot)
    mode = event.mode.vec.FV().NumPy().copy()
    candidates = []
    for sign in (1.0, -1.0):
        pushed = event.state + sign * amplitude * mode
        problem.restore_state(pushed)
        candidates.append((problem.energy() if problem.admissible(problem.state) else math.inf, sign, pushed))
    energy, sign, pushed = min(candidates, key=lambda c: c[0])
    if energy == math.inf:
        raise ValueError(f"amplitude {amplitude:g} along the critical mode leaves the admissible set (J <= 0)")
    problem.restore_state(pushed)
    return settle(problem, **settle_options)
