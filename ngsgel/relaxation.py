"""Where a structure lands after it loses stability at a fixed load: the stable equilibrium
reached by the overdamped flow ``M dx/dtau = -R(x)`` from a (perturbed) unstable state.

Under load (or ``mu``) control a limit point has no equilibrium nearby beyond it, and a
subcritical bifurcation none on the followed branch: the structure snaps. ``settle`` follows the
overdamped motion at the fixed load by linearly implicit Euler steps in pseudo-time,
``(K + M / tau) dx = -R`` (one tangent per step; ``K`` the tangent, ``M`` the problem's mass
matrix), kept only if the energy does not rise, with ``tau`` adapted to how well the quadratic
model predicted the energy change (a trust region in the metric ``M``). As ``tau`` grows the
steps become Newton steps, and the flow ends at an equilibrium whose tangent has no negative
eigenvalue (exact count). Which minimum is reached depends on the start (the caller's
perturbation, usually along the critical mode): the one the overdamped dynamics selects, not
necessarily the one of lowest energy.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import ngsolve as ngs

from .newton import LinearSolver
from .stability import Spectrum, free_matrix, load_rate, mass_matrix, spectrum

__all__ = ["SettleResult", "SettleError", "settle", "settle_past", "settle_after"]


@dataclass
class SettleResult:
    """``energy_drop``: energy at the start minus at the end (>= 0 up to round-off; at a new
    prescribed displacement counted from the first state that meets it); ``distance``:
    ``|x_end - x_start|_M / sqrt(volume)`` (root-mean-square displacement); ``steps`` /
    ``rejected``: pseudo-time steps kept and refused (a kept step costs a tangent assembly and a
    factorisation, a refused one a factorisation: its state, hence its tangent, is the last one);
    ``lowest_eigenvalue``: of the end state; ``energies``: after every kept step
    (non-increasing); ``residuals``: free residual norm after every kept step."""

    energy_start: float
    energy_end: float
    distance: float
    steps: int
    rejected: int
    negative: int
    lowest_eigenvalue: float
    energies: list[float] = field(default_factory=list)
    residuals: list[float] = field(default_factory=list)

    @property
    def energy_drop(self) -> float:
        return self.energy_start - self.energy_end


class SettleError(RuntimeError):
    def __init__(self, message: str, result: SettleResult):
        super().__init__(message)
        self.result = result


def settle(problem, *, parameter: ngs.Parameter | None = None, tau: float | None = None, rtol: float = 1e-10,
           atol: float | None = None, xtol: float | None = None, max_steps: int = 300, grow: float = 4.0,
           progress: Callable[[str], None] | None = None) -> SettleResult:
    """Relax ``problem`` at its current load from its current state to a stable equilibrium.

    A first step meets the prescribed values, if the current state does not (the free dofs
    follow linearly, cut back until admissible). The first pseudo-time step is ``tau`` or else
    ``0.5 / |omega_min|`` (``omega_min`` the lowest eigenvalue of ``K phi = omega M phi`` at the
    start; ``1 / omega_min`` at a stable start). A step is refused (``tau`` / 4) when its state is
    not admissible or its energy is above the current one by more than round-off; a kept step
    multiplies ``tau`` by ``grow`` when the energy fell by at least half of what the quadratic
    model predicted, and divides it by 2 when by less than a tenth; while the state is unstable it
    stays below ``0.5 / |omega_min|`` of the current state (checked where it would pass that bound),
    so that the flow leaves an unstable equilibrium even where the energy is too flat to measure
    the descent (a small residual there is not convergence). Converged when the free
    residual is below ``max(atol, rtol * r_max)`` (``r_max`` the largest residual seen) or the
    next step changes no entry by more than ``xtol`` (length units; default the problem's
    ``newton_xtol`` if it has one, else 1e-13), at a state whose tangent has
    no negative eigenvalue; given the load ``parameter`` and no ``atol``, the
    floor is ``1e-12 |dR/dlambda|`` (a flow that starts next to an equilibrium has a residual
    near round-off, which no relative tolerance can reduce). An equilibrium with a negative
    eigenvalue (reached only from an exactly symmetric start) raises ``SettleError``, as do
    ``max_steps`` steps and ``tau`` below 1e-12 of its start.
    """
    if not grow > 1:
        raise ValueError(f"grow must be > 1, got {grow!r}")
    if tau is not None and not tau > 0:
        raise ValueError(f"tau must be positive, got {tau!r}")
    with ngs.TaskManager():  # threads the assemblies and factorisations; a no-op when already active
        return _settle(problem, parameter=parameter, tau=tau, rtol=rtol, atol=atol, xtol=xtol, max_steps=max_steps,
                       grow=grow, progress=progress)


def _settle(problem, *, parameter, tau, rtol, atol, xtol, max_steps, grow, progress) -> SettleResult:
    if atol is None:
        atol = 0.0 if parameter is None else 1e-12 * float(np.linalg.norm(load_rate(problem, parameter).residual))
    if xtol is None:
        xtol = getattr(problem, "newton_xtol", 1e-13)
    free = problem.free_mask
    solver = LinearSolver(problem.space.FreeDofs(), inverse=problem.inverse)  # keeps the symbolic factorisation
    volume = problem.integrate(ngs.CF(1.0))
    mass = mass_matrix(problem)
    x = problem.state
    r, dx, rhs, trial = (x.CreateVector() for _ in range(4))

    def free_norm(v) -> float:
        return float(np.linalg.norm(v.FV().NumPy()[free]))

    def rms(d: np.ndarray) -> float:
        rhs.FV().NumPy()[:] = d
        trial.data = mass * rhs
        return math.sqrt(max(float(d[free] @ trial.FV().NumPy()[free]), 0.0) / volume)

    def report(message: str) -> None:
        if progress is not None:
            progress(message)

    tangent = {}  # the last assembled tangent: its state, matrix and unshifted values

    def current_tangent():
        # a refused step leaves the state as it was: reuse its tangent instead of reassembling it
        # (the assembly is most of a step's cost, and refusals are common); the matrix may hold a
        # shifted copy, so its unshifted values are restored
        state = x.FV().NumPy()
        if "state" not in tangent or not np.array_equal(tangent["state"], state):
            K = problem.tangent(x)
            tangent.update(state=state.copy(), matrix=K, values=K.AsVector().FV().NumPy().copy())
        K = tangent["matrix"]
        K.AsVector().FV().NumPy()[:] = tangent["values"]
        return K

    def damped_inverse(tau: float):
        K = current_tangent()
        K.AsVector().data += (1.0 / tau) * mass.AsVector()
        return K, solver.factor(K)

    def current_spectrum(**options) -> Spectrum:
        """``_lowest_spectrum`` of the current tangent."""
        return _lowest_spectrum(problem, solver, current_tangent(), M=free_mass_matrix(), **options)

    free_mass = None

    def free_mass_matrix():
        nonlocal free_mass
        if free_mass is None:
            free_mass = free_matrix(mass, free)
        return free_mass

    first = current_spectrum(past_negative=True)  # with several negative: the lowest first
    omega = float(first.eigenvalues[0])
    tau0 = tau if tau is not None else (0.5 / abs(omega) if omega < 0 else 1.0 / omega)
    tau = tau0
    # While the state is unstable, K + M / tau must stay positive definite (tau below 1 / |omega|
    # of the lowest eigenvalue): then every step descends along the unstable modes, whose
    # amplitude grows by 1 / (1 - tau |omega|) per step. A larger tau turns the steps into Newton
    # steps, which run back onto the unstable equilibrium wherever the energy is too flat to refuse
    # them (measured: a column just past Euler kicked by 1e-5, energy changes of 1e-15).
    tau_cap = 0.5 / abs(omega) if first.negative else math.inf
    tau = min(tau, tau_cap)

    target = x.CreateVector()
    problem.prescribed(target)
    mismatch = target.FV().NumPy() - x.FV().NumPy()
    mismatch[free] = 0.0
    if mismatch.any():  # move the constrained dofs, the free ones follow linearly
        problem.residual(x, r)
        K, inverse = damped_inverse(tau)
        dx.FV().NumPy()[:] = mismatch
        rhs.data = K * dx
        rhs.data += r
        dx.data -= inverse * rhs
        start_state = problem.save_state()
        for _ in range(40):
            problem.restore_state(start_state + dx.FV().NumPy())
            if problem.admissible(x):
                break
            dx.data *= 0.5
        else:
            raise ValueError("no admissible state meets the prescribed values (J <= 0 along the linear step)")
        if not np.allclose(problem.save_state()[~free], target.FV().NumPy()[~free], rtol=0, atol=1e-14):
            raise ValueError("the prescribed values are too far from the current state for one admissible step; "
                             "move them in smaller increments")
    start = problem.save_state()
    energy = problem.energy()
    round_off = 1e-11 * max(abs(energy), 1e-300)  # the energy is a sum of cancelling terms
    result = SettleResult(energy_start=energy, energy_end=energy, distance=0.0, steps=0, rejected=0,
                          negative=first.negative, lowest_eigenvalue=omega)
    problem.residual(x, r)
    rnorm = free_norm(r)
    r_max = rnorm

    def instability_cap() -> float:
        """``0.5 / |omega|`` of the current state's lowest eigenvalue if it is unstable, else inf;
        the tangent is kept for the next step."""
        lowest = current_spectrum(past_negative=True)
        return 0.5 / abs(float(lowest.eigenvalues[0])) if lowest.negative else math.inf

    def stable_end() -> SettleResult:
        lowest = current_spectrum()  # the tangent often just assembled by ``instability_cap``
        result.negative = lowest.negative
        if result.negative:
            raise SettleError(f"the flow ended on an unstable equilibrium ({result.negative} negative eigenvalues): "
                              "perturb the start (e.g. along its lowest mode)", result)
        result.energy_end = energy
        result.lowest_eigenvalue = float(lowest.eigenvalues[0])
        return result

    while True:
        if rnorm <= max(atol, rtol * r_max):
            if tau_cap < math.inf:  # next to an unstable equilibrium a small residual is not the end
                tau_cap = instability_cap()
                tau = min(tau, tau_cap)
            if tau_cap == math.inf:
                return stable_end()
        if result.steps >= max_steps:
            raise SettleError(f"no stable equilibrium after {max_steps} pseudo-time steps (residual {rnorm:.3e}, "
                              f"energy drop {result.energy_start - energy:.3e}, tau {tau:.3e})", result)
        if tau < 1e-12 * tau0:
            raise SettleError(f"pseudo-time step fell to {tau:.3e} (start {tau0:.3e})", result)
        K, inverse = damped_inverse(tau)
        dx.data = -1.0 * (inverse * r)
        step = dx.FV().NumPy()[free]
        if np.max(np.abs(step), initial=0.0) <= xtol:
            return stable_end()
        rhs.data = K * dx  # (K + M/tau) dx
        trial.data = mass * dx
        mdx = float(step @ trial.FV().NumPy()[free])
        kdx = float(step @ rhs.FV().NumPy()[free]) - mdx / tau  # dx.K.dx
        predicted = float(r.FV().NumPy()[free] @ step) + 0.5 * kdx
        saved = problem.save_state()
        trial.data = x + dx
        new_energy = math.inf
        if problem.admissible(trial):
            x.data = trial
            new_energy = problem.energy()
        # The energy decides even where its changes are near round-off (a flat valley, where every
        # other step is refused): accepting by the residual there instead ends the flow on the
        # nearby unstable equilibrium (measured on the graded disk's first snap).
        if not new_energy <= energy + round_off:
            problem.restore_state(saved)
            result.rejected += 1
            tau /= 4
            continue
        # a change below round-off cannot test the model: trust it (the Newton end of the flow)
        ratio = (new_energy - energy) / predicted if predicted < -round_off else 1.0
        energy = new_energy
        problem.residual(x, r)
        rnorm = free_norm(r)
        r_max = max(r_max, rnorm)
        result.steps += 1
        result.energies.append(energy)
        result.residuals.append(rnorm)
        result.distance = rms(problem.save_state() - start)
        report(f"settle step {result.steps}: tau {tau:.3e}, energy {energy:.12e} (model ratio {ratio:.2f}), "
               f"residual {rnorm:.3e}, distance {result.distance:.3e}")
        if ratio >= 0.5:
            tau *= grow
        elif ratio < 0.1:
            tau /= 2
        if tau > tau_cap:  # still unstable here? (the cap goes once the state is stable)
            tau_cap = instability_cap()
            tau = min(tau, tau_cap)


def _lowest_spectrum(problem, solver: LinearSolver, K: ngs.BaseMatrix, *, M=None, **options) -> Spectrum:
    """``spectrum`` (count 1) of the tangent ``K``; with a backend that gives the inertia
    (PARDISO) ``solver``'s one factorisation serves the count and the eigen solve (SuperLU would
    factorise twice: 8 s on the 50k-unknown microlens shell)."""
    ldlt = None
    if solver.inverse == "pardiso":
        solver.factor(K)
        ldlt = solver.ldlt
    return spectrum(problem, count=1, K=free_matrix(K, problem.free_mask), M=M, factorisation=ldlt, **options)


def _push_and_settle(problem, parameter: ngs.Parameter, state: np.ndarray, mode: np.ndarray | None, load: float, *,
                     amplitude: float, **settle_options) -> SettleResult:
    """``state`` at the load ``load``, pushed by root-mean-square ``amplitude`` along ``mode``
    (full-length vector of unit root-mean-square amplitude) with the sign of lower energy, then
    ``settle``."""
    parameter.Set(load)
    if mode is None:
        problem.restore_state(state)
        return settle(problem, parameter=parameter, **settle_options)
    if not amplitude > 0:
        raise ValueError(f"amplitude must be positive, got {amplitude!r}")
    candidates = []
    for sign in (1.0, -1.0):
        pushed = state + sign * amplitude * mode
        problem.restore_state(pushed)
        candidates.append((problem.energy() if problem.admissible(problem.state) else math.inf, sign, pushed))
    energy, sign, pushed = min(candidates, key=lambda c: c[0])
    if energy == math.inf:
        raise ValueError(f"amplitude {amplitude:g} along the critical mode leaves the admissible set (J <= 0)")
    problem.restore_state(pushed)
    return settle(problem, parameter=parameter, **settle_options)


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
    return _push_and_settle(problem, parameter, event.state, event.mode.vec.FV().NumPy().copy(),
                            event.parameter + overshoot, amplitude=amplitude, **settle_options)


def settle_after(problem, parameter: ngs.Parameter, path, *, overshoot: float, amplitude: float,
                 target: float | None = None, **settle_options) -> SettleResult:
    """Settle where the path ``path`` (an ``ngsgel.continuation.PathResult``) could not go on:
    past its last event if that is a located loss of stability in its last step
    (``settle_past``); otherwise from its last state at the load ``overshoot`` further, pushed
    along its lowest mode if that state is unstable (a loss whose location failed), as is if it
    is stable (a path that stalled: no equilibrium next to it, e.g. beyond a limit point under
    load control). The load does not go past ``target`` (e.g. ``mu = 0``, beyond which a gel in
    free swelling has no equilibrium); a path that ended unstable at the target settles there."""
    if overshoot == 0:
        raise ValueError("overshoot must be non-zero")
    last = path.events[-1] if path.events else None
    located = (last is not None and last.mode is not None and last.negative_after > last.negative_before
               and last.step == path.points[-1].step)
    base = last.parameter if located else path.checkpoint.parameter
    load = base + overshoot
    if target is not None and (load - target) * overshoot > 0:
        load = target
    if located and load != base:
        return settle_past(problem, parameter, last, overshoot=load - base, amplitude=amplitude, **settle_options)
    unstable = bool(path.points[-1].negative)
    if load == path.checkpoint.parameter and not unstable:
        raise ValueError(f"the path ended stable at the target {target!r}: nothing to settle")
    state = path.checkpoint.state
    mode = None
    if unstable:  # an unlocated loss, or one exactly at the target: leave along the lowest mode
        problem.restore_state(state)
        parameter.Set(path.checkpoint.parameter)
        solver = LinearSolver(problem.space.FreeDofs(), inverse=problem.inverse)
        with ngs.TaskManager():
            lowest = _lowest_spectrum(problem, solver, problem.tangent(problem.state), past_negative=True)
        mode = np.zeros_like(state)
        mode[problem.free_mask] = lowest.modes[:, 0]  # unit root-mean-square amplitude
    return _push_and_settle(problem, parameter, state, mode, load, amplitude=amplitude, **settle_options)
