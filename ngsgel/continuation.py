"""Path following in one load parameter, with stability monitoring, events and branch switching.

The driver sees a ``NonlinearSystem`` with ``energy()``, ``save_state()/restore_state()``, its
``space`` (for the free dofs and modes) and one load parameter: an NGSolve ``Parameter`` acting on
``mu``, a prescribed displacement or a dead load. Two ways along the path:

- ``method="natural"``: the load parameter is stepped by ``ngsgel.stepping.ramp`` (secant
  predictor, Newton-iteration based growth, cut-back); optional pseudo-viscous stabilisation
  lets it cross a snap-through (Abaqus *Stabilize);
- ``method="arclength"``: pseudo-arclength (Riks) with a secant predictor and a bordered Newton
  corrector on the hyperplane normal to the predictor, which passes limit points in load and
  in displacement. The metric is ``|dz|^2 = |dx_free|^2 / scale^2 + dlambda^2`` with ``scale =
  |dx/dlambda|`` at the start, so arc length is measured in load-parameter units.

The corrector needs ``dR/dlambda``: ``ngsgel.stability.load_rate`` (central difference, exact up
to round-off for the affine loads of ``EquilibriumProblem``). Every converged state can be
checked for stability (exact negative count, lowest eigenvalues); a change of the count between
two steps is located by a secant/bisection search along the step, classified (limit point or
bifurcation by the projection of the critical mode on ``dR/dlambda``) and, at a bifurcation,
optionally followed onto the branch of lower energy.
"""

from __future__ import annotations

import math
import os
import pickle
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Literal

import numpy as np
import ngsolve as ngs

from . import parallel
from .newton import LinearSolver, NewtonError, NewtonResult, Work, newton, total_work
from .output import report_progress, writing_process
from .stability import (Spectrum, free_matrix, load_projection, load_rate, mass_matrix,
                        negative_count, spectrum, state_rate)
from .stepping import PREDICTORS, RampError, ramp

__all__ = ["StabilityOptions", "Stabilization", "PathPoint", "PathStep", "Event", "Checkpoint", "Resumption", "PathResult",
           "ContinuationError", "BorderedCorrector", "follow_path"]

Method = Literal["natural", "arclength"]


@dataclass(frozen=True)
class StabilityOptions:
    """Stability monitoring of every converged state.

    ``eigenvalues``: how many of the lowest to compute and record at every point (at least every
    negative one and the next). 0 (the default): the check at each point is the exact negative
    count alone, from one factorisation of the tangent (with PARDISO the one the next Newton solve
    starts from); the eigenpairs, which an eigen solve costs several factorisations' worth of
    time for, are computed only where the count changes, for the location and the branch switch.
    ``locate``: find the critical
    parameter of a change of the negative count to ``tol`` (load-parameter units).
    ``bifurcation_threshold``: a critical mode whose normalised projection on ``dR/dlambda`` is
    below it marks a bifurcation, otherwise a limit point. ``switch``: at a bifurcation, leave the
    path along ``+-`` the critical mode with root-mean-square amplitude ``amplitude * length`` and
    follow the candidate with fewer negative eigenvalues, then lower energy than the original
    branch at the same load.
    """

    eigenvalues: int = 0
    locate: bool = True
    tol: float = 1e-4
    bifurcation_threshold: float = 1e-2
    switch: bool = False
    amplitude: float = 1e-2
    length: float = 1.0
    max_locate_iterations: int = 60


@dataclass(frozen=True)
class Stabilization:
    """Pseudo-viscous damping ``c M (x - x_n) / |lambda - lambda_n|`` (``M`` the L2 Gram matrix of
    the displacement) for natural-parameter runs. ``c`` is set after the first (undamped) step so
    that it would dissipate ``initial_fraction`` of the stored energy (Abaqus' default 2e-4), and
    is reduced whenever the dissipated energy would exceed ``cap`` times the stored energy.
    ``stored_energy`` defaults to the energy with the load parameter set to zero (the strain energy
    under dead loads or prescribed displacements, the Helmholtz free energy under ``mu``), counted
    from the start of the run."""

    cap: float = 0.05
    initial_fraction: float = 2e-4
    stored_energy: Callable[[], float] | None = None


@dataclass
class PathPoint:
    step: int
    parameter: float
    energy: float
    iterations: int
    qoi: dict[str, float] = field(default_factory=dict)
    eigenvalues: tuple[float, ...] = ()
    negative: int | None = None
    events: tuple[str, ...] = ()
    dissipated_fraction: float | None = None
    state: np.ndarray | None = None

    @property
    def stable(self) -> bool | None:
        return None if self.negative is None else self.negative == 0


@dataclass
class Event:
    """``kind``: "limit point", "bifurcation", "branch switch" or "stability change" (not
    located: a stabilised run, or a location whose solves failed, ``details["locate_failed"]``).
    A bifurcation whose branch switch failed has ``details["switch_failed"]``; its located point
    is recorded with the events "switch failed" and "bifurcation", and the path goes on along the
    original, now unstable branch.
    ``parameter_error`` bounds the error of ``parameter`` (spread of the load parameter over the
    final bracket); ``load_projection`` is the classification measure."""

    kind: str
    step: int
    parameter: float
    negative_before: int
    negative_after: int
    energy: float
    eigenvalue: float | None = None
    load_projection: float | None = None
    parameter_error: float | None = None
    mode: ngs.GridFunction | None = None
    state: np.ndarray | None = None
    details: dict = field(default_factory=dict)


@dataclass
class Checkpoint:
    """What a run needs to go on: the last two states on the path and the step control (``step``:
    the size of the next step, as the run would take it).

    ``follow_path(restart=...)`` starts a new path from it; ``follow_path(resume=...)`` goes on
    with the same path as if it had not stopped, for which it also holds the path so far
    (``points``, ``events``; ``steps`` taken), the Newton floor the run used (``atol``) and, once
    the path has ended, why (``stop_reason``; ``message`` of the ``ContinuationError`` of a path
    that stalled). ``load`` gives the events' critical modes as dof vectors (a GridFunction
    needs the problem's space: ``follow_path`` makes them GridFunctions again).
    ``ranks``: the number of MPI processes that wrote it (1: a serial run); the states are each
    rank's own dofs, so a checkpoint restarts on that many processes only."""

    method: str
    parameter: float
    state: np.ndarray
    previous_parameter: float | None
    previous_state: np.ndarray | None
    step: float
    scale: float | None
    steps: int = 0
    atol: float | None = None
    points: list[PathPoint] = field(default_factory=list)
    events: list[Event] = field(default_factory=list)
    stop_reason: str = ""
    message: str = ""
    ranks: int = 1

    def save(self, path: str | Path, *, comm=None) -> None:
        """Write the ``.npz`` file; with an mpi4py ``comm`` of several ranks (a distributed
        problem's) every rank's states and path (its modes and kept states are its own dofs) are
        gathered and rank 0 writes them, as ``state_rank<r>`` etc."""
        # the path so far as a pickle in a byte array: the file loads without allow_pickle
        events = [replace(e, mode=None if e.mode is None else e.mode.vec.FV().NumPy().copy()) for e in self.events]
        path_so_far = pickle.dumps((self.points, events, self.stop_reason, self.message))
        own = {"state": self.state,
               "previous_state": self.state * np.nan if self.previous_state is None else self.previous_state,
               "path": np.frombuffer(path_so_far, dtype=np.uint8)}
        if comm is not None and comm.size > 1:
            parts = comm.gather(own, root=0)
            if comm.rank != 0:
                return
            own = {f"{key}_rank{rank}": value for rank, part in enumerate(parts) for key, value in part.items()}
            own["ranks"] = comm.size
        np.savez(path, method=self.method, parameter=self.parameter,
                 previous_parameter=np.nan if self.previous_parameter is None else self.previous_parameter,
                 step=self.step, scale=np.nan if self.scale is None else self.scale, steps=self.steps,
                 atol=np.nan if self.atol is None else self.atol, **own)

    @classmethod
    def load(cls, path: str | Path) -> Checkpoint:
        data = np.load(path)
        prev = float(data["previous_parameter"])
        scale = float(data["scale"])
        ranks, own = int(data["ranks"]) if "ranks" in data else 1, ""
        if ranks > 1:  # this rank's part of a distributed run's checkpoint
            comm = parallel.world()
            if comm.size != ranks:
                raise ValueError(f"the checkpoint {path} was written by {ranks} MPI processes, this run has "
                                 f"{comm.size}: a checkpoint restarts on the number of processes that wrote it")
            own = f"_rank{comm.rank}"
        checkpoint = cls(method=str(data["method"]), parameter=float(data["parameter"]), state=data["state" + own],
                         previous_parameter=None if math.isnan(prev) else prev,
                         previous_state=None if math.isnan(prev) else data["previous_state" + own],
                         step=float(data["step"]), scale=None if math.isnan(scale) else scale, ranks=ranks)
        if "path" + own in data:  # older checkpoints hold the states only: enough for restart, not for resume
            atol = float(data["atol"])
            checkpoint.steps, checkpoint.atol = int(data["steps"]), None if math.isnan(atol) else atol
            checkpoint.points, checkpoint.events, checkpoint.stop_reason, checkpoint.message = pickle.loads(
                data["path" + own].tobytes())
        return checkpoint


class Resumption:
    """The checkpoint files of a run folder, taken up in the order the run wrote them.

    A path may come in legs (one ``follow_path`` each, e.g. between snaps) that share one
    checkpoint file ``latest``: when a leg has ended and another follows, ``end_leg`` moves its
    checkpoint to ``<stem>_leg<n>.npz``, so that ``latest`` always holds the leg that runs, or the
    stage's end (what ``restart`` takes), and an absent ``latest`` says that the next leg has not
    begun. ``take(latest, leg)``: the checkpoint of that leg while the run being resumed got that
    far (``follow_path``'s ``resume``), else None - that leg and every later path run afresh; the
    first one taken must exist (the run wrote nothing to go on from otherwise).
    ``reached(latest, leg)``: whether the run got as far as that leg (what comes before it, e.g. a
    relaxation without checkpoint, need not run again). ``active=False`` (a fresh run): always None."""

    def __init__(self, active: bool):
        self.active = active
        self.taken = 0

    @staticmethod
    def leg_file(latest: str | Path, leg: int) -> Path:
        latest = Path(latest)
        return latest.with_name(f"{latest.stem}_leg{leg}{latest.suffix}")

    @classmethod
    def end_leg(cls, latest: str | Path, leg: int) -> None:
        """The leg ``leg`` (whose checkpoint ``latest`` holds, unless a resumed run took it from
        its own file) has ended and another follows."""
        if writing_process() and not cls.leg_file(latest, leg).exists():
            os.replace(latest, cls.leg_file(latest, leg))

    def take(self, latest: str | Path, leg: int = 0) -> Checkpoint | None:
        if not self.reached(latest, leg):
            if self.active and not self.taken:
                raise ValueError(f"no checkpoint {latest}: the run stopped before its first path state "
                                 f"(start it again, without resuming)")
            self.active = False
            return None
        self.taken += 1
        ended = self.leg_file(latest, leg)
        return Checkpoint.load(ended if ended.exists() else latest)

    def reached(self, latest: str | Path, leg: int) -> bool:
        return self.active and (self.leg_file(latest, leg).exists() or Path(latest).exists())


@dataclass
class PathStep:
    """The work of one step of the path (``step`` as in ``PathPoint``; 0: the start's solve and
    check), in order (``ngsgel.newton.Work``): a natural step's ``ramp`` records (predictor, failed
    tries, Newton iterations and chord steps), an arclength step's "corrector" records (the bordered
    corrector: wall time with its assemblies, factorisations and solves; its residuals are not
    counted), "stability" records (each stability check of a converged state: assembly,
    factorisation, eigen solve in ``total``) and the Newton records of the solves that locate a
    change of the negative count or re-converge at the target (a branch switch's solves are not
    recorded)."""

    step: int
    parameter: float
    records: list[Work] = field(default_factory=list)

    @property
    def work(self) -> Work:
        return total_work(self.records)

    def part(self, kind: str) -> Work:
        """The sum of this step's records of one ``kind`` (e.g. "stability")."""
        return total_work(r for r in self.records if r.kind == kind)


@dataclass
class PathResult:
    """``steps``: the work of each step taken by this call (``PathStep``; a resumed run's
    earlier steps are not among them)."""

    points: list[PathPoint]
    events: list[Event]
    stop_reason: str
    checkpoint: Checkpoint
    steps: list[PathStep] = field(default_factory=list)

    def column(self, name: str) -> np.ndarray:
        """``parameter``, ``energy``, ``negative``, ``iterations``, ``dissipated_fraction`` or a
        quantity of interest, over all points."""
        if name in ("parameter", "energy", "negative", "iterations", "dissipated_fraction"):
            return np.array([getattr(p, name) for p in self.points], dtype=float)
        return np.array([p.qoi[name] for p in self.points])


class LocationError(RuntimeError):
    """A change of the negative count that cannot be bracketed to one crossing: more than one
    eigenvalue changes sign inside the step, or the secant does not close the bracket."""


class ContinuationError(RuntimeError):
    """The step fell below ``min_step``; ``result`` holds the path up to the last converged state
    (which the problem holds)."""

    def __init__(self, message: str, result: PathResult):
        super().__init__(message)
        self.result = result


# --------------------------------------------------------------------------- corrector
class BorderedCorrector:
    """Newton on ``R(x, lambda) = 0`` plus one linear constraint
    ``c_x . (x - o_x) + c_l (lambda - o_l) = s`` (free dofs), by bordering: two solves with the
    tangent per iteration. Constrained dofs follow their prescribed values at every iterate.
    The arclength corrector and the branch switch use it; with the constraint on a mode's
    amplitude it finds a state at a prescribed distance along that mode (and its load).

    ``monotone``: fail as soon as an iteration does not lower the residual norm, for callers
    that can retry from a closer guess. Without a line search, an iterate outside Newton's basin
    wanders and may land on another solution after many iterations (gears' quick run from 1 t_f
    along the critical mode: the residual rose 1.3-63x at 3 to 6 of 15 iterations, then fell
    quadratically onto a state 1.45 load spans past the onset, far beyond the run's end, or did
    not converge in 40, as round-off decided)."""

    def __init__(self, problem, parameter: ngs.Parameter, *, rtol: float = 1e-10, atol: float = 0.0,
                 xtol: float = 1e-13, maxit: int = 20, min_step: float = 2.0**-10, monotone: bool = False):
        self.problem = problem
        self.parameter = parameter
        self.free = problem.free_mask
        self.solver = LinearSolver(problem.space.FreeDofs(), inverse=problem.inverse)
        self.rtol, self.atol, self.xtol, self.maxit, self.min_step = rtol, atol, xtol, maxit, min_step
        self.monotone = monotone

    def _set(self, xf: np.ndarray, lam: float) -> bool:
        """Put ``(x_free, lambda)`` into the problem; False if inadmissible."""
        self.parameter.Set(lam)
        target = self.problem.state.CreateVector()
        self.problem.prescribed(target)
        x = self.problem.state.FV().NumPy()
        x[self.free] = xf
        x[~self.free] = target.FV().NumPy()[~self.free]
        return self.problem.admissible(self.problem.state)

    def _residual(self) -> np.ndarray:
        r = self.problem.state.CreateVector()
        self.problem.residual(self.problem.state, r)
        return r.FV().NumPy()[self.free].copy()

    def solve(self, guess: tuple[np.ndarray, float], origin: tuple[np.ndarray, float],
              normal: tuple[np.ndarray, float], s: float, *, max_growth: float | None = None) -> NewtonResult:
        """Converge from ``guess`` (full state, lambda); ``origin`` and ``normal`` as free-dof
        vectors. ``max_growth``: fail as soon as the residual exceeds this many times the guess's
        (an iterate that has left the guess's neighbourhood). On failure the problem's state and
        parameter are restored, NewtonError raised."""
        if max_growth is not None and not max_growth > 1:
            raise ValueError(f"max_growth must be > 1 or None, got {max_growth!r}")
        problem, free = self.problem, self.free
        saved, saved_lam = problem.save_state(), self.parameter.Get()
        cx, cl = normal
        ox, ol = origin
        result = NewtonResult(converged=False, iterations=0)

        def fail(message: str) -> NewtonError:
            problem.restore_state(saved)
            self.parameter.Set(saved_lam)
            result.message = message
            return NewtonError(message, result)

        xf, lam = guess[0][free].copy(), guess[1]
        if not self._set(xf, lam):
            raise fail("the predictor is not admissible")
        r = self._residual()
        rnorm = r_max = float(np.linalg.norm(r))
        result.residuals.append(rnorm)
        a = problem.state.CreateVector()
        rhs = problem.state.CreateVector()
        for it in range(self.maxit + 1):
            if not math.isfinite(rnorm):
                raise fail(f"residual is not finite at iteration {it}")
            if rnorm <= max(self.atol, self.rtol * r_max):
                result.converged, result.iterations = True, it
                return result
            if it == self.maxit:
                break
            K = problem.tangent(problem.state)
            inv = self.solver.factor(K)
            rate = load_rate(problem, self.parameter, K=K)
            solutions = []
            for vec in (r, rate.residual):
                rhs.FV().NumPy()[:] = 0.0
                rhs.FV().NumPy()[free] = vec
                a.data = inv * rhs
                solutions.append(a.FV().NumPy()[free].copy())
            sa, sb = solutions
            N = cx @ (xf - ox) + cl * (lam - ol) - s
            dlam = (cx @ sa - N) / (cl - cx @ sb)
            dx = -sa - sb * dlam
            step_max = max(float(np.max(np.abs(dx), initial=0.0)), abs(dlam))
            alpha = 1.0
            while not self._set(xf + alpha * dx, lam + alpha * dlam) or not math.isfinite(
                    float(np.linalg.norm(r_trial := self._residual()))):
                alpha *= 0.5
                result.line_search_cuts += 1
                if alpha < self.min_step:
                    raise fail(f"no admissible step at iteration {it + 1} (residual {rnorm:.3e})")
            xf, lam, r = xf + alpha * dx, lam + alpha * dlam, r_trial
            previous, rnorm = rnorm, float(np.linalg.norm(r))
            r_max = max(r_max, rnorm)
            result.residuals.append(rnorm)
            result.iterations = it + 1
            if max_growth is not None and rnorm > max_growth * result.residuals[0]:
                raise fail(f"the residual grew {rnorm / result.residuals[0]:.3g}-fold at iteration {it + 1} "
                           f"(to {rnorm:.3e}): the iterates have left the guess")
            if self.monotone and rnorm >= previous and rnorm > max(self.atol, self.rtol * r_max):
                raise fail(f"the residual rose at iteration {it + 1} ({previous:.3e} to {rnorm:.3e}): "
                           "the guess lies outside Newton's basin")
            if alpha == 1.0 and step_max <= self.xtol:
                result.converged = True
                return result
        raise fail(f"no convergence in {self.maxit} iterations (residual {rnorm:.3e})")


# ------------------------------------------------------------------------ damping
class _Damped:
    """The problem plus pseudo-viscous damping, as a NonlinearSystem that ``ramp`` can drive."""

    def __init__(self, problem, parameter: ngs.Parameter, options: Stabilization):
        self.problem = problem
        self.parameter = parameter
        self.options = options
        self.free_mask = problem.free_mask
        self.mass = mass_matrix(problem)
        if self.mass.nze != problem.tangent(problem.state).nze:
            raise RuntimeError("the mass matrix and the tangent have different sparsity; cannot add them")
        self.solver = LinearSolver(problem.space.FreeDofs(), inverse=problem.inverse)
        self.coefficient: float | None = None
        self.x_n = problem.save_state()
        self.lam_n = parameter.Get()
        self.stored_start = self._stored()
        self.dissipated = 0.0
        self.fraction = 0.0
        self._dx = problem.state.CreateVector()
        self._Mdx = problem.state.CreateVector()

    def _stored(self) -> float:
        if self.options.stored_energy is not None:
            return self.options.stored_energy()
        lam = self.parameter.Get()
        self.parameter.Set(0.0)
        try:
            return self.problem.energy()
        finally:
            self.parameter.Set(lam)

    def _rate_coefficient(self) -> float:
        return (self.coefficient or 0.0) / abs(self.parameter.Get() - self.lam_n)

    @property
    def state(self):
        return self.problem.state

    def residual(self, x, out) -> None:
        self.problem.residual(x, out)
        self._dx.FV().NumPy()[:] = x.FV().NumPy() - self.x_n
        self._Mdx.data = self.mass * self._dx
        out.data += self._rate_coefficient() * self._Mdx

    def tangent(self, x):
        K = self.problem.tangent(x)
        K.AsVector().data += self._rate_coefficient() * self.mass.AsVector()
        return K

    def prescribed(self, out) -> None:
        self.problem.prescribed(out)

    def admissible(self, x) -> bool:
        return self.problem.admissible(x)

    def save_state(self) -> np.ndarray:
        return self.problem.save_state()

    def restore_state(self, saved: np.ndarray) -> None:
        self.problem.restore_state(saved)

    def _work(self, dx: np.ndarray) -> float:
        """``dx_f . (M dx)_f``."""
        self._dx.FV().NumPy()[:] = dx
        self._Mdx.data = self.mass * self._dx
        return float(dx[self.free_mask] @ self._Mdx.FV().NumPy()[self.free_mask])

    def solve(self, **newton_options) -> NewtonResult:
        guess = self.problem.save_state()
        while True:
            result = newton(self, self.solver, **newton_options)
            dx = self.problem.save_state() - self.x_n
            h = abs(self.parameter.Get() - self.lam_n)
            stored = abs(self._stored() - self.stored_start)
            if self.coefficient is None:
                self.coefficient = self.options.initial_fraction * stored * h / self._work(dx)
                step_dissipation = 0.0
            else:
                step_dissipation = self.coefficient / h * self._work(dx)
            fraction = (self.dissipated + step_dissipation) / stored
            if fraction <= self.options.cap:
                break
            # too much damping for the cap: less of it, same step again
            self.coefficient *= 0.5 * self.options.cap / fraction
            self.problem.restore_state(guess)
        self.dissipated += step_dissipation
        self.fraction = fraction
        self.x_n = self.problem.save_state()
        self.lam_n = self.parameter.Get()
        return result


# ------------------------------------------------------------------------ the driver
@dataclass
class _Converged:
    """A converged state on the path with its stability."""

    parameter: float
    state: np.ndarray
    spectrum: Spectrum | None
    iterations: int = 0


class _Driver:
    def __init__(self, problem, parameter, *, stability: StabilityOptions | None,
                 qoi: Mapping[str, Callable[[], float]], history, vtk, vtk_every: int,
                 progress: Callable[[str], None] | None, target: float | None, keep_states: bool, stop,
                 max_steps: int, locate: bool, newton_options: dict, checkpoint_file: str | Path | None = None):
        self.problem = problem
        self.checkpoint_file = None if checkpoint_file is None else Path(checkpoint_file)
        self.parameter = parameter
        self.stability = stability
        self.qoi = dict(qoi)
        self.history = history
        self.vtk = vtk
        self.vtk_every = vtk_every
        self.progress = progress
        self.target = target
        self.start = parameter.Get()
        self._reached = 0.0  # largest share of the way from start to target so far
        self.keep_states = keep_states
        self.stop = stop
        self.max_steps = max_steps
        self.newton_options = newton_options
        self.locate_events = locate and stability is not None and stability.locate
        self.points: list[PathPoint] = []
        self.events: list[Event] = []
        self.steps = 0
        self.stop_reason = ""
        self.message = ""  # of the ContinuationError of a path that stalled
        self._pending: tuple[str, ...] = ()  # events of the next recorded point
        # on a distributed mesh the stability checks go through ngsgel.parallel (over all ranks)
        self._distributed = parallel.runs_distributed(problem)
        self._mass = None if not stability else mass_matrix(problem) if self._distributed else free_matrix(
            mass_matrix(problem), problem.free_mask)
        self.step_work: list[PathStep] = []
        self._work: list[Work] = []  # of the step under way
        solver = getattr(problem, "_solver", None)
        # a backend with the inertia: the stability check factorises with the problem's own solver,
        # and that factorisation at the converged state also starts the next solve (``chord_start``)
        self.solver = solver if stability and isinstance(solver, LinearSolver) and solver.inverse == "pardiso" else None

    # ------------------------------------------------------------------ stability
    def spectrum(self, *, eigenpairs: bool = False) -> Spectrum | None:
        """Stability of the current state: the exact negative count, with the lowest eigenpairs
        (up to the first non-negative one) if the options record them or ``eigenpairs`` asks."""
        if self.stability is None:
            return None
        # on NGSolve's threads (assembly, PARDISO factorisation, eigen solve: all deterministic),
        # like the solves: outside a TaskManager the check ran on one thread and PARDISO redid its
        # analysis for that thread count at every check. The path's energies and outputs stay
        # outside, where their sums do not depend on the threads' order.
        with ngs.TaskManager():
            return self._spectrum(eigenpairs)

    def _spectrum(self, eigenpairs: bool) -> Spectrum:
        clock = time.perf_counter
        started, work = clock(), Work("stability")
        matrix = self.problem.tangent(self.problem.state)
        work.assembly, work.assemblies = clock() - started, 1
        ldlt = None
        if self.solver is not None:
            t = clock()
            self.solver.factor(matrix)
            self.solver.factorised_at = (self.parameter.Get(), self.problem.save_state())
            work.factorisation, work.factorisations = clock() - t, 1
            ldlt = self.solver.ldlt  # None where pivots were perturbed: SuperLU counts instead
        if self._distributed:  # the count over all ranks; eigenpairs solved on rank 0, modes globally numbered
            found = parallel.spectrum(self.problem, matrix=matrix, mass=self._mass, count=self.stability.eigenvalues,
                                      past_negative=True) if eigenpairs or self.stability.eigenvalues else Spectrum(
                eigenvalues=np.empty(0), modes=np.empty((self.problem.reductions.free_count, 0)),
                negative=parallel.negative_count(self.problem, matrix=matrix))
        elif eigenpairs or self.stability.eigenvalues:
            found = spectrum(self.problem, count=self.stability.eigenvalues,
                             K=free_matrix(matrix, self.problem.free_mask), M=self._mass, past_negative=True,
                             factorisation=ldlt)
        else:  # the count alone: with an inertia, no free-dof copy of the matrix (0.2 s at 50k unknowns)
            negative = (ldlt.negative if ldlt is not None
                        else negative_count(free_matrix(matrix, self.problem.free_mask)))
            found = Spectrum(eigenvalues=np.empty(0), modes=np.empty((int(self.problem.free_mask.sum()), 0)),
                             negative=negative)
        work.total = clock() - started
        self._work.append(work)
        return found

    def with_eigenpairs(self, point: _Converged) -> None:
        """Give ``point`` (a count-only check) its eigenpairs; the problem's state is kept."""
        if point.spectrum is None or len(point.spectrum.eigenvalues):
            return
        here = (self.parameter.Get(), self.problem.save_state())
        self._goto(point)
        point.spectrum = self.spectrum(eigenpairs=True)
        self.parameter.Set(here[0])
        self.problem.restore_state(here[1])

    def add_work(self, records) -> None:
        """Work of the step under way (Newton records of a solve)."""
        self._work.extend(records)

    def close_step(self, parameter: float, step: int | None = None) -> PathStep:
        """The step under way (``step``, default ``steps``) has ended: its work becomes a ``PathStep``."""
        step = PathStep(step=self.steps if step is None else step, parameter=parameter, records=self._work)
        self.step_work.append(step)
        self._work = []
        return step

    def converged(self, iterations: int = 0, *, eigenpairs: bool = False) -> _Converged:
        return _Converged(self.parameter.Get(), self.problem.save_state(), self.spectrum(eigenpairs=eigenpairs),
                          iterations)

    def _goto(self, point: _Converged) -> None:
        self.problem.restore_state(point.state)
        self.parameter.Set(point.parameter)

    # ------------------------------------------------------------------ records
    def record(self, point: _Converged, *, events: tuple[str, ...] = (), dissipated: float | None = None) -> PathPoint:
        """Record the problem's current state (which is ``point``)."""
        spec = point.spectrum
        events, self._pending = self._pending + events, ()
        pp = PathPoint(step=self.steps, parameter=point.parameter, energy=self.problem.energy(),
                       iterations=point.iterations, qoi={k: float(f()) for k, f in self.qoi.items()},
                       eigenvalues=tuple(float(v) for v in spec.eigenvalues) if spec else (),
                       negative=spec.negative if spec else None, events=events,
                       dissipated_fraction=dissipated, state=point.state if self.keep_states else None)
        self.points.append(pp)
        if self.history is not None:
            self.history.append(self.row(pp))
        if self.vtk is not None and (events or pp.step % self.vtk_every == 0):
            self.vtk.write(float(len(self.vtk.times)))
        report_progress(self.progress, f"step {pp.step}: parameter {pp.parameter:.6g}, iterations {pp.iterations}"
                        + (f", negative {pp.negative}" if pp.negative is not None else "")
                        + (f", events {', '.join(events)}" if events else ""), fraction=self.fraction(pp.parameter))
        return pp

    def row(self, pp: PathPoint) -> dict:
        """The history's row of a recorded point (a function of the point: a resumed run writes
        the rows of the path so far from its checkpoint)."""
        row = {"step": pp.step, "parameter": pp.parameter, **pp.qoi, "energy": pp.energy,
               "iterations": pp.iterations, "negative": pp.negative}
        if self.stability is not None:
            row.update({f"eig{i}": (pp.eigenvalues[i] if i < len(pp.eigenvalues) else None)
                        for i in range(self.stability.eigenvalues)})
        row.update({"events": ";".join(pp.events), "dissipated_fraction": pp.dissipated_fraction})
        return row

    def fraction(self, value: float) -> float | None:
        """Share of the way from the start to the target reached so far; the largest share: an
        arclength path may turn back past a limit point (None without a target)."""
        if self.target is None or self.target == self.start:
            return None
        share = (value - self.start) / (self.target - self.start)
        self._reached = max(self._reached, min(share, 1.0))
        return self._reached

    def take_up(self, checkpoint: Checkpoint) -> None:
        """Go on with the path of ``checkpoint`` (the problem holds its state): its points,
        events and step count; the rows of its points written to the history."""
        self.points, self.steps = list(checkpoint.points), checkpoint.steps
        self.events = _with_modes(self.problem, checkpoint.events)
        self.start = self.points[0].parameter  # progress: the share of the whole path
        if self.history is not None:
            for pp in self.points:
                self.history.append(self.row(pp))
        report_progress(self.progress, f"resumed at step {self.steps}: parameter {checkpoint.parameter:.6g}"
                        + (f" ({checkpoint.stop_reason}: the path had ended)" if checkpoint.stop_reason else ""),
                        fraction=self.fraction(checkpoint.parameter))

    def should_stop(self, pp: PathPoint) -> bool:
        if self.stop is not None and self.stop(pp):
            self.stop_reason = "criterion"
        elif self.steps >= self.max_steps:
            self.stop_reason = "max_steps"
        return bool(self.stop_reason)

    # ------------------------------------------------------------------ events
    def check(self, a: _Converged, b: _Converged, segment: Callable[[float], None],
              switch: Callable[[_Converged, _Converged], _Converged]) -> tuple[list[tuple[_Converged, str]], bool]:
        """Events between ``a`` and the problem's current state ``b``. Returns the located points
        to record before the next one (with their event names) and whether the path left ``b``
        for a new branch (the problem then holds the new branch's first point)."""
        if a.spectrum is None or b.spectrum is None or a.spectrum.negative == b.spectrum.negative:
            return [], False
        before, after = a.spectrum.negative, b.spectrum.negative

        def unlocated(details: dict) -> tuple[list, bool]:
            self._goto(b)
            self.events.append(Event(kind="stability change", step=self.steps, parameter=b.parameter,
                                     negative_before=before, negative_after=after,
                                     energy=self.problem.energy(), details=details))
            self._pending = ("stability change",)
            return [], False

        if not self.locate_events:
            return unlocated({})
        try:
            for end in (b, a):  # b first: the problem holds it, and is left at it
                self.with_eigenpairs(end)
            critical, error = self._locate(a, b, segment)
        except (NewtonError, LocationError) as err:  # reported at the end of the step, which did converge
            return unlocated({"locate_failed": str(err)})
        index = min(before, after)
        eigenvalue, phi = critical.spectrum.crossing(index)
        rate = parallel.load_rate(self.problem, self.parameter)
        projection = load_projection(phi, rate)
        kind = "bifurcation" if projection < self.stability.bifurcation_threshold else "limit point"
        event = Event(kind=kind, step=self.steps, parameter=critical.parameter, negative_before=before,
                      negative_after=after, energy=self.problem.energy(), eigenvalue=eigenvalue,
                      load_projection=projection, parameter_error=error,
                      mode=parallel.mode_function(self.problem, phi, name=f"critical_mode_{len(self.events)}"),
                      state=critical.state)
        self.events.append(event)
        located = [(critical, kind)]
        if kind == "bifurcation" and self.stability.switch:
            try:
                located.append((switch(a, critical), "branch switch"))
                return located, True
            except NewtonError as err:
                # neither the corrector nor the solve past the critical load found the new
                # branch: the path stays on its now unstable one
                event.details["switch_failed"] = str(err)
                self._pending = ("switch failed",)
        self._goto(b)
        return located, False

    def _locate(self, a: _Converged, b: _Converged, segment: Callable[[float], None]) -> tuple[_Converged, float]:
        """Secant (Illinois) on the crossing eigenvalue along the step, bracketed by the exact
        negative count, until the load parameter over the bracket varies by less than ``tol``.

        The equilibrium is solved half a tolerance beside the secant estimate (on the side of the
        longer part of the bracket), not at it: at the critical point the tangent is singular and
        Newton crawls (a 50k-unknown shell stalled at residual 6e-13 for 30 iterations there),
        while two solves at +-tol/2 already close the bracket around a good estimate."""
        index = min(a.spectrum.negative, b.spectrum.negative)
        lo = (0.0, a.spectrum.crossing(index)[0], a.parameter)
        hi = (1.0, b.spectrum.crossing(index)[0], b.parameter)
        kept = None  # which end stayed twice in a row (Illinois halves its value)
        for _ in range(self.stability.max_locate_iterations):
            width = hi[0] - lo[0]
            estimate = lo[0] - lo[1] * width / (hi[1] - lo[1])
            offset = 0.5 * self.stability.tol * width / (abs(hi[2] - lo[2]) or math.inf)
            s = estimate + (offset if hi[0] - estimate > estimate - lo[0] else -offset)
            # keep the point off the ends of the bracket so that both ends keep moving
            s = min(max(s, lo[0] + 0.05 * width), hi[0] - 0.05 * width)
            segment(s)
            point = self.converged(eigenpairs=True)
            if point.spectrum.negative < index:  # fewer than at either end: the tracked one is not alone
                raise LocationError(f"{point.spectrum.negative} negative eigenvalues at parameter {point.parameter:g}, "
                                    f"fewer than the {a.spectrum.negative} and {b.spectrum.negative} at the ends of "
                                    f"the step: more than one eigenvalue changes sign in it")
            new = (s, point.spectrum.crossing(index)[0], point.parameter)
            spread = max(lo[2], hi[2], new[2]) - min(lo[2], hi[2], new[2])
            # the side of the bracket is the sign of the tracked eigenvalue (number ``index``)
            if (point.spectrum.negative > index) == (a.spectrum.negative > index):
                lo, hi = new, (hi if kept != "hi" else (hi[0], hi[1] / 2, hi[2]))
                kept = "hi"
            else:
                hi, lo = new, (lo if kept != "lo" else (lo[0], lo[1] / 2, lo[2]))
                kept = "lo"
            if spread <= self.stability.tol:
                return point, spread
        raise LocationError(f"critical point between parameters {a.parameter:g} and {b.parameter:g} not "
                            f"located to {self.stability.tol:g} in {self.stability.max_locate_iterations} iterations")

    def branch_switch(self, a: _Converged, critical: _Converged, converge: Callable[..., NewtonResult]) -> _Converged:
        """Leave ``critical`` along ``+-`` its mode; keep the candidate with fewer negative
        eigenvalues, then the lower energy relative to the original branch at its load (that
        branch re-converged from the stable side ``a``).

        Where the bordered corrector (the state at the mode amplitude ``amplitude * length``)
        fails (also once its residual grows ``SWITCH_MAX_GROWTH``-fold), the same guess is solved
        at a fixed load past the critical one (by the larger of ``10 tol`` and half the way from
        ``a`` to the critical point): a
        bifurcated branch whose amplitude grows like ``sqrt(load)`` with a small factor puts
        that amplitude far beyond the corrector's reach (the coarse graded disk: ``mu`` 0.28
        past the critical value), while just past it the branch is near. A candidate that fell
        back onto the original branch (mode amplitude below 1e-3 of the guess's) fails the switch."""
        opts = self.stability
        index = min(a.spectrum.negative, critical.spectrum.negative)
        phi = critical.spectrum.crossing(index)[1]
        free = self.problem.free_mask
        amplitude = opts.amplitude * opts.length
        offset = max(10 * opts.tol, 0.5 * abs(critical.parameter - a.parameter))
        past = critical.parameter + math.copysign(offset, critical.parameter - a.parameter)
        candidates, methods = [], []
        for sign in (1.0, -1.0):
            guess = critical.state.copy()
            guess[free] += sign * amplitude * phi
            try:
                newton_result = converge(guess, critical.parameter, phi / (phi @ phi), sign * amplitude,
                                         max_growth=SWITCH_MAX_GROWTH)
                methods.append("bordered")
            except NewtonError as err:
                self.problem.restore_state(guess)
                self.parameter.Set(past)
                # next to the critical state Newton converges slowly (a nearly singular tangent)
                newton_result = self.problem.solve(**{**self.newton_options, "maxit": 60})
                left = abs(phi @ (self.problem.save_state()[free] - critical.state[free])) / (phi @ phi)
                if left < 1e-3 * amplitude:
                    raise NewtonError(f"the corrector failed ({err}) and the solve past the critical load "
                                      f"returned to the original branch", newton_result) from err
                methods.append(f"natural at {past:.6g} (the corrector failed: {err})")
            point = self.converged(newton_result.iterations)
            energy = self.problem.energy()
            self._goto(a)
            self.parameter.Set(point.parameter)
            self.problem.solve(**self.newton_options)
            original = self.problem.energy()
            candidates.append((point.spectrum.negative if point.spectrum else 0, energy - original, sign, point, energy, original))
        negative, gain, sign, chosen, energy, original = min(candidates, key=lambda c: c[:2])
        self._goto(chosen)
        self.events.append(Event(kind="branch switch", step=self.steps, parameter=chosen.parameter,
                                 negative_before=critical.spectrum.negative, negative_after=negative,
                                 energy=energy, state=chosen.state,
                                 details={"sign": sign, "energy_original_branch": original,
                                          "energy_gain": gain, "methods": methods,
                                          "candidates": [(c[2], c[0], c[1]) for c in candidates]}))
        return chosen

    def checkpoint(self, method: str, current: _Converged, previous: _Converged | None, step: float,
                   scale: float | None) -> Checkpoint:
        return Checkpoint(method=method, parameter=current.parameter, state=current.state,
                          previous_parameter=None if previous is None else previous.parameter,
                          previous_state=None if previous is None else previous.state, step=step, scale=scale,
                          steps=self.steps, atol=self.newton_options["atol"], points=list(self.points),
                          events=list(self.events), stop_reason=self.stop_reason, message=self.message,
                          ranks=self.problem.mesh.comm.size if self._distributed else 1)

    def keep(self, method: str, current: _Converged, previous: _Converged | None, step: float,
             scale: float | None) -> Checkpoint:
        """Rewrite ``checkpoint_file`` (if any) for the path so far; the replace is atomic, so a run
        stopped while writing leaves the previous step's checkpoint."""
        checkpoint = self.checkpoint(method, current, previous, step, scale)
        if self.checkpoint_file is not None:
            partial = self.checkpoint_file.with_name(self.checkpoint_file.stem + ".partial.npz")
            checkpoint.save(partial, comm=self.problem.mesh.comm.mpi4py if self._distributed else None)
            if writing_process():  # on a distributed mesh rank 0 wrote every rank's part
                os.replace(partial, self.checkpoint_file)
        return checkpoint

    def finish(self, method: str, current: _Converged, previous: _Converged | None, step: float,
               scale: float | None) -> PathResult:
        """The ended path (``stop_reason`` set), its checkpoint kept: resuming it returns it."""
        if self._work:  # the failed step that ended the path
            self.close_step(self.parameter.Get(), self.steps + 1)
        return PathResult(self.points, self.events, self.stop_reason,
                          self.keep(method, current, previous, step, scale), self.step_work)


def _with_modes(problem, events: list[Event]) -> list[Event]:
    """The events of a loaded checkpoint with their critical modes as GridFunctions again."""
    rebuilt = []
    for index, event in enumerate(events):
        if isinstance(event.mode, np.ndarray):
            mode = ngs.GridFunction(problem.space, name=f"critical_mode_{index}")  # the driver's name
            mode.vec.FV().NumPy()[:] = event.mode
            event = replace(event, mode=mode)
        rebuilt.append(event)
    return rebuilt


def follow_path(problem, parameter: ngs.Parameter, *, method: Method = "arclength", step: float,
                target: float | None = None, min_step: float | None = None, max_step: float | None = None,
                max_steps: int = 200, direction: int = 1, stop: Callable[[PathPoint], bool] | None = None,
                qoi: Mapping[str, Callable[[], float]] | None = None,
                stability: StabilityOptions | None = None, stabilization: Stabilization | None = None,
                history=None, vtk=None, vtk_every: int = 1, progress: Callable[[str], None] | None = None,
                restart: Checkpoint | None = None, keep_states: bool = False, grow: float = 1.5,
                easy_iterations: int = 4, hard_iterations: int = 8, max_correction: float | None = None,
                predictor: str = "secant", newton_options: dict | None = None, checkpoint_file: str | Path | None = None,
                resume: Checkpoint | None = None) -> PathResult:
    """Follow the equilibrium path of ``problem`` in ``parameter`` from its current state
    (equilibrated first) or from ``restart``, or go on with the path of ``resume``.

    ``step`` is the first increment of the load parameter (natural) or of arc length (in the
    same units); ``min_step``/``max_step`` bound it (defaults ``step * 1e-6`` and ``step * 10``).
    Stops at ``target`` (a natural run ends exactly there; an arclength run stops where the path
    first reaches it, re-converged at exactly that load), when ``stop(point)`` is true, or after
    ``max_steps`` steps. ``direction`` (+-1) is the initial sign of the load increment of an
    arclength run. ``qoi``: named callables evaluated at every point. ``history``: an
    ``ngsgel.output.History`` (or anything with ``append(row)``), ``vtk``: a ``VTKSeries`` written
    every ``vtk_every`` steps and at events; ``progress``: called with one line per step
    (``progress(message)``; a ``ngsgel.output.Progress`` also gets the fraction of the way from
    the start to ``target`` reached, for its percent done and time left).
    ``stabilization`` (natural runs only) damps the rate of displacement; events are then recorded
    without location. ``keep_states`` stores every state in its ``PathPoint``.
    ``max_correction`` (natural runs): refuse a step that converged farther from its predictor
    than this many predicted increments (``ngsgel.stepping.ramp``): a jump onto another branch
    that neither end's stability shows; 2 separates them on the snapping arch.
    ``predictor`` (natural runs): ``ramp``'s guess of each step after the first, ``"secant"`` or
    ``"quadratic"`` (the parabola with the path's tangent at the last state, from the stability
    check's factorisation: with a backend that gives the inertia, PARDISO).
    ``newton_options`` go to every Newton solve (a natural run's location of a change of the
    negative count without ``stall_trend``); unless it sets ``atol``, solves get the floor
    ``1e-10 * step * |dR/dlambda|`` (a solve that starts next to its solution cannot reduce a
    residual at round-off level by a relative factor).
    ``checkpoint_file`` (``.npz``): the ``Checkpoint`` of the path so far, written at its first
    point and rewritten after every step and at its end (replaced atomically).
    ``restart`` (a ``Checkpoint``): a new path from its state, with its step control.
    ``resume`` (a ``Checkpoint`` of this path, same options): the path goes on as if it had not
    stopped - its points, events and step numbers, its Newton floor; nothing is recorded twice, the
    rows of its points are written to ``history`` first (a history opened afresh then holds the path
    so far, and no row of a step past the checkpoint). An arclength path then takes the steps the
    uninterrupted one took; a natural one takes the same step sizes from a tangent predictor
    (``ramp`` starts without the secant of the two last states). A path that had ended is returned
    (or its ``ContinuationError`` raised) with the problem at its end state.
    Raises ``ContinuationError`` (with the path so far) when the step falls below ``min_step``.
    """
    if method not in ("natural", "arclength"):
        raise ValueError(f"method must be 'natural' or 'arclength', got {method!r}")
    if predictor not in PREDICTORS:
        raise ValueError(f"predictor must be one of {PREDICTORS}, got {predictor!r}")
    if not step > 0:
        raise ValueError(f"step must be positive, got {step!r}")
    if method == "natural" and target is None:
        raise ValueError("a natural-parameter run needs a target")
    if stabilization is not None and method != "natural":
        raise ValueError("stabilisation is for natural-parameter runs; arclength needs none")
    if direction not in (1, -1):
        raise ValueError(f"direction must be +1 or -1, got {direction!r}")
    if max_correction is not None and (method != "natural" or not max_correction > 0):
        raise ValueError(f"max_correction must be a number > 0 and is for natural-parameter runs, got "
                         f"{max_correction!r} with method {method!r}")
    if restart is not None and resume is not None:
        raise ValueError("restart starts a new path from a checkpoint, resume goes on with its path: not both")
    start = restart if restart is not None else resume
    if start is not None and start.method != method:
        raise ValueError(f"the checkpoint is from a {start.method!r} run, not {method!r}")
    if resume is not None and resume.atol is None:
        raise ValueError("the checkpoint holds no path (written before runs could be resumed): restart from it")
    if resume is not None and stabilization is not None:
        raise ValueError("a stabilised path cannot be resumed: the checkpoint does not hold its damping")
    if checkpoint_file is not None and Path(checkpoint_file).suffix != ".npz":
        raise ValueError(f"checkpoint_file must end in .npz, got {str(checkpoint_file)!r}")
    if parallel.runs_distributed(problem) and (method != "natural" or stabilization is not None
                                               or (stability is not None and stability.switch)):
        raise NotImplementedError(
            "on a distributed mesh follow_path runs method='natural' without stabilization or branch switching: "
            "the arclength corrector, the damping and the switch solve with a serial LinearSolver on this "
            f"rank's dofs (got method={method!r}, stabilization={stabilization!r}, "
            f"switch={stability is not None and stability.switch})")
    processes = problem.mesh.comm.size if parallel.runs_distributed(problem) else 1
    if start is not None and start.ranks != processes:
        raise ValueError(f"the checkpoint was written by {start.ranks} MPI process(es), this problem runs on "
                         f"{processes}: a checkpoint restarts on the number of processes that wrote it")
    min_step = step * 1e-6 if min_step is None else min_step
    max_step = step * 10 if max_step is None else max_step
    if start is not None:
        problem.restore_state(start.state)
        parameter.Set(start.parameter)
        step = start.step
    newton_options = dict(newton_options or {})
    if resume is not None:  # the run's own floor: its solves stop where the uninterrupted run's did
        newton_options.setdefault("atol", resume.atol)
    else:
        # the floor also for the first solve: a start that is already an equilibrium has a residual
        # at round-off, which no relative tolerance can reduce further
        newton_options.setdefault("atol", 1e-10 * step * float(np.linalg.norm(
            parallel.load_rate(problem, parameter).residual)))
    first = problem.solve(**newton_options) if resume is None else None
    driver = _Driver(problem, parameter, stability=stability, qoi=qoi or {}, history=history, vtk=vtk,
                     vtk_every=vtk_every, progress=progress, target=target, keep_states=keep_states, stop=stop,
                     max_steps=max_steps, locate=stabilization is None, newton_options=newton_options,
                     checkpoint_file=checkpoint_file)
    previous = None
    if start is not None and start.previous_state is not None:
        previous = _Converged(start.previous_parameter, start.previous_state, None)
    if resume is None:
        driver.add_work(first.records)
        current = driver.converged(first.iterations)
        driver.record(current, dissipated=0.0 if stabilization else None)
        driver.close_step(current.parameter)
        driver.keep(method, current, previous, step, restart.scale if restart else None)
    else:
        driver.take_up(resume)
        if resume.stop_reason:
            result = PathResult(driver.points, driver.events, resume.stop_reason, replace(resume, events=driver.events),
                                driver.step_work)
            if resume.stop_reason == "min_step":
                raise ContinuationError(resume.message, result)
            return result
        current = driver.converged(resume.points[-1].iterations)  # its spectrum again: the next step's check
        driver.close_step(current.parameter)
    if method == "natural":
        return _natural(driver, current, step=step, target=target, min_step=min_step, max_step=max_step,
                        stabilization=stabilization, grow=grow, easy=easy_iterations, max_correction=max_correction,
                        predictor=predictor, newton_options=newton_options)
    return _arclength(driver, current, previous, step=step, target=target, min_step=min_step, max_step=max_step,
                      direction=direction, scale=start.scale if start else None, grow=grow,
                      easy=easy_iterations, hard=hard_iterations, newton_options=newton_options)


def _corrector_work(result: NewtonResult, started: float, kind: str) -> Work:
    """A bordered-corrector solve as one record: its wall time, and per iteration one assembly,
    one factorisation and two solves (its residual evaluations are not counted)."""
    n = result.iterations
    return Work(kind, total=time.perf_counter() - started, assemblies=n, factorisations=n, solves=2 * n,
                residual_norm=result.residuals[-1] if result.residuals else math.nan)


# A branch-switch guess lies next to the new branch (its residual is that of the mode's amplitude);
# a corrector whose residual grows far beyond it has left for elsewhere and, unstopped, wanders
# through its iterations (the microlens half cap at d/H 0.733: from 2.2e-9 to 4e-7 at the first
# iteration, 1e-6 after 20, 46 s) before the switch tries the solve past the critical load.
SWITCH_MAX_GROWTH = 100.0


def _corrector(problem, parameter: ngs.Parameter, newton_options: dict) -> BorderedCorrector:
    """The bordered corrector with the run's Newton tolerances (its absolute floor above all: a
    branch-switch guess next to the critical state starts with a residual near round-off)."""
    return BorderedCorrector(problem, parameter, **{k: v for k, v in newton_options.items()
                                                    if k in ("rtol", "atol", "xtol", "maxit")})


def _natural(driver: _Driver, current: _Converged, *, step, target, min_step, max_step, stabilization, grow, easy,
             max_correction, predictor, newton_options) -> PathResult:
    problem, parameter = driver.problem, driver.parameter
    system = _Damped(problem, parameter, stabilization) if stabilization is not None else problem
    state = {"current": current}
    # between two converged states an equilibrium exists, and next to the critical one Newton
    # converges linearly: a location's solve is not given up on a slow trend
    location_options = {k: v for k, v in newton_options.items() if k != "stall_trend"}

    def segment_from(a: _Converged, b: _Converged) -> Callable[[float], None]:
        def solve_at(s: float) -> None:
            driver._goto(a)
            problem.restore_state(a.state + s * (b.state - a.state))
            parameter.Set(a.parameter + s * (b.parameter - a.parameter))
            driver.add_work(problem.solve(**location_options).records)
        return solve_at

    def switch(a: _Converged, critical: _Converged) -> _Converged:
        corrector = _corrector(problem, parameter, newton_options)
        free = problem.free_mask
        return driver.branch_switch(a, critical, lambda guess, lam, cx, s, **options: corrector.solve(
            (guess, lam), (critical.state[free], critical.parameter), (cx, 0.0), s, **options))

    def on_step(lam: float, newton_result: NewtonResult) -> bool:
        driver.steps += 1
        try:
            return step_taken(newton_result)
        finally:
            driver.close_step(lam)

    def step_taken(newton_result: NewtonResult) -> bool:
        a = state["current"]
        b = driver.converged(newton_result.iterations)
        located, switched = driver.check(a, b, segment_from(a, b), switch)
        for point, kind in located:
            driver._goto(point)
            driver.record(point, events=(kind,))
        if switched:
            state["current"] = located[-1][0]
            driver.keep("natural", state["current"], None, abs(b.parameter - a.parameter), None)
            return True
        driver._goto(b)
        pp = driver.record(b, dissipated=system.fraction if stabilization is not None else None)
        state["current"] = b
        if driver.should_stop(pp):  # the ended path's checkpoint is kept at the end
            return True
        # the step ramp takes next (it grows after an easy step): a resumed run steps alike
        taken = abs(b.parameter - a.parameter)
        driver.keep("natural", b, None, min(taken * grow, max_step) if newton_result.iterations <= easy else taken,
                    None)
        return False

    # the stability check's factorisation at the converged state starts the next solve, unless the
    # problem or the caller says chord steps there do not pay (``chord_start_after_check``)
    chord_start = driver.solver is not None and system is problem and getattr(problem, "chord_start_after_check", True)
    step_options = {"chord_start": True, **newton_options} if chord_start else newton_options

    def with_ramp_work(taken: int, ramp_result) -> None:
        """Put each ramp step's own records (predictor, failed tries, Newton) first in its path step."""
        for path_step, ramp_step in zip(driver.step_work[taken:], ramp_result.records):
            path_step.records[:0] = ramp_step.records
        if ramp_result.failed_work:  # the tries of a step that did not converge
            driver.add_work(ramp_result.failed_work)

    h = step
    while True:
        taken = len(driver.step_work)
        try:
            result = ramp(system, parameter, target, step=h, min_step=min_step, max_step=max_step, grow=grow,
                          easy_iterations=easy, on_step=on_step, newton_options=step_options,
                          tangent_start=stabilization is None,  # damping's tangent needs a step
                          max_correction=max_correction, predictor=predictor)
        except RampError as err:
            with_ramp_work(taken, err.result)
            driver.stop_reason, driver.message = "min_step", str(err)
            raise ContinuationError(str(err), driver.finish("natural", state["current"], None, h, None)) from err
        with_ramp_work(taken, result)
        if len(result.values) >= 2:
            h = abs(result.values[-1] - result.values[-2])
        if not result.stopped:
            driver.stop_reason = "target"
        if driver.stop_reason:
            break
    return driver.finish("natural", state["current"], None, h, None)


def _arclength(driver: _Driver, current: _Converged, previous: _Converged | None, *, step, target, min_step,
               max_step, direction, scale, grow, easy, hard, newton_options) -> PathResult:
    problem, parameter = driver.problem, driver.parameter
    free = problem.free_mask
    corrector = _corrector(problem, parameter, newton_options)

    def path_tangent() -> np.ndarray:
        """``dx_free/dlambda`` at the current state."""
        return state_rate(problem, parameter)[free]

    if scale is None:
        # |dx/dlambda| at the start: load and displacement share the arc length equally there
        scale = float(np.linalg.norm(path_tangent())) or 1.0

    def metric_direction(dx: np.ndarray, dlam: float) -> tuple[np.ndarray, float]:
        norm = math.sqrt(dx @ dx / scale**2 + dlam**2)
        return dx / norm, dlam / norm

    def advance(a: _Converged, d: tuple[np.ndarray, float], ds: float) -> NewtonResult:
        guess = a.state.copy()
        guess[free] += ds * d[0]
        started = time.perf_counter()
        try:
            result = corrector.solve((guess, a.parameter + ds * d[1]), (a.state[free], a.parameter),
                                     (d[0] / scale**2, d[1]), ds)
        except NewtonError as err:
            driver.add_work([_corrector_work(err.result, started, "failed corrector")])
            raise
        driver.add_work([_corrector_work(result, started, "corrector")])
        return result

    def switch(a: _Converged, critical: _Converged) -> _Converged:
        return driver.branch_switch(a, critical, lambda guess, lam, cx, s, **options: corrector.solve(
            (guess, lam), (critical.state[free], critical.parameter), (cx, 0.0), s, **options))

    ds = step
    while True:
        if previous is None:
            d = metric_direction(path_tangent() * direction, float(direction))
        else:
            d = metric_direction(current.state[free] - previous.state[free], current.parameter - previous.parameter)
        try:
            newton_result = advance(current, d, ds)
        except NewtonError as err:
            ds /= 2
            if ds < min_step:
                driver.stop_reason = "min_step"
                driver.message = (f"arc length step fell below min_step={min_step:g} at parameter "
                                  f"{current.parameter:g}: {err}")
                raise ContinuationError(driver.message, driver.finish("arclength", current, previous, ds, scale)) \
                    from err
            continue
        driver.steps += 1
        landed = target is not None and (parameter.Get() - target) * (current.parameter - target) <= 0 \
            and parameter.Get() != current.parameter
        if landed:
            # re-converge at exactly the target from the interpolated state
            t = (target - current.parameter) / (parameter.Get() - current.parameter)
            problem.restore_state(current.state + t * (problem.save_state() - current.state))
            parameter.Set(target)
            newton_result = problem.solve(**newton_options)
            driver.add_work(newton_result.records)
        b = driver.converged(newton_result.iterations)
        step_ds = ds if not landed else ds * t

        def segment(s: float, a=current, d=d, span=step_ds) -> None:
            driver._goto(a)
            advance(a, d, s * span)

        located, switched = driver.check(current, b, segment, switch)
        for point, kind in located:
            driver._goto(point)
            driver.record(point, events=(kind,))
        if switched:
            previous, current = located[-2][0], located[-1][0]
            driver.close_step(current.parameter)
            driver.keep("arclength", current, previous, ds, scale)
            continue
        driver._goto(b)
        pp = driver.record(b)
        driver.close_step(b.parameter)
        previous, current = current, b
        if landed:
            driver.stop_reason = "target"
            break
        if driver.should_stop(pp):
            break
        if newton_result.iterations <= easy:
            ds = min(ds * grow, max_step)
        elif newton_result.iterations > hard:
            ds = max(ds / 2, min_step)
        driver.keep("arclength", current, previous, ds, scale)  # with the next step: a resumed run steps alike
    return driver.finish("arclength", current, previous, ds, scale)
