"""Post-buckled path of the softer-edge graded disk (thesis ch. 5, MODEL.md 5 C) as a shell.

The disk ``GelShell`` of ``shell_cases.graded_plate_shell`` (graded ``Nv`` as a field; the half
disk with mirror symmetry about y = 0 and three pins, or with ``--full-disk`` the full disk with six
statically determinate pins) is swollen towards ``mu = 0`` with the exact negative count of the
shell's tangent at every state. At the first bifurcation (the flat disk losing stability to the
k = 2 saddle, docs/graded.md) the driver switches onto the branch along the critical mode
(amplitude ``0.1 t``); with ``--switch-all`` it follows every branch by arclength and switches the
same way at every later change of the negative count.
Along the path the deflection ``w`` (z displacement; rigid tilt is removed by the pins) is
sampled on the circle ``r = 0.97 R`` and its Fourier content recorded: the dominant wave number,
its amplitude, the runner-up, the purity, the amplitudes of ``k = 1 .. 12`` and the
number of crests. Each event's
critical mode gets its wave number (``shell_cases.plate_mode_wave``).

By default (the half disk: the k = 2 onset of the full disk is a double eigenvalue, along which a
one-mode switch does not converge; ``--full-disk``, ``--switch-all``, ``--no-snaps`` for the other
protocols) the run ramps the flat disk to ``mu = -0.3``, switches once onto the saddle, follows the
buckled branch until it loses stability, lets the disk snap there (``ngsgel.relaxation.settle_after``: the
overdamped flow at ``mu`` just beyond the critical value, from the critical state pushed along
its mode, to a stable equilibrium) and follows the branch it lands on, as often as needed to
reach ``mu = 0``: the pattern the plate ends with. Resolution: the default ``--maxh 0.2`` (5-8 min)
shows the sequence (p = 10: 2 -> 4 -> 6), but the rim's end pattern needs finer elements:
``--maxh 0.1`` (about 35 min) ends at p = 10 with the thesis's k = 8 (as does 0.15; docs/graded.md).

Writes ``path.csv`` (driver history + rim wave content), ``events.json``, ``summary.json``
(with the penetration depth of the final dominant wave, ``pattern_depth``, and - half disk - the
end state's stability against the modes odd in y that the half disk excludes, ``odd_modes``), ``snaps.json``,
``state_end.npz``, ``shell.pvd`` (VTK of every state), ``shape_end.png`` (deflection map and rim profile at the
end), ``checkpoint.npz`` (the path so far, for ``--resume``; an ended leg moves to ``checkpoint_leg<n>.npz``).

    ngsgel run graded-plate-shell --out results/graded_plate_shell [--p 10 --maxh 0.2] [--quick]
    ngsgel run graded-plate-shell --out results/full_disk --full-disk --switch-all --mu-start -1
    ngsgel run graded-plate-shell --resume results/graded_plate_shell   # a stopped run, on from its last checkpoint
"""

from __future__ import annotations

import hashlib
import json
import time

import numpy as np
import ngsolve as ngs

from ngsgel.scenes.shell_cases import GRADED_N0, GRADED_NR, disk_circle_values, graded_plate_shell, odd_free_mask, plate_mode_wave
from ngsgel import FloryRehnerGel, NewtonError, follow_path, ramp
from ngsgel.continuation import ContinuationError, Resumption, StabilityOptions
from ngsgel.relaxation import settle, settle_after
from ngsgel.stepping import RampError
from ngsgel.stability import free_matrix, negative_count, spectrum
from ngsgel.output import (History, Progress, RunDirectory, VTKSeries, command_options, quick_run, resume_arguments,
                           scene_parser, silence_progress)
from ngsgel.patterns import penetration_depth, periodic_peaks, wave_number

RIM_RADIUS = 0.97  # sampling circle just inside the curved rim
MU_START = -0.3  # below the k = 2 onsets of every p at h = 0.2 (the lowest: -0.291, p = 2)
RIM_SAMPLES = 128
RIM_MODES = 12
# A natural step past a fold has no equilibrium to converge to and Newton wanders at a constant
# residual; converging steps on the soft buckled branches can sit on a plateau for up to 9
# iterations (measured, p = 10) before they converge: give up after 10 without halving
STALL_WINDOW = 10
# The residual target is strict (the soft branches need it): even small converging natural steps
# take 5-7 iterations there, so the driver's default (grow after <= 4) never lets them grow again
EASY_ITERATIONS = 7
# The natural legs halve a failed step down to step / MIN_STEP_DIVISOR: where they stall, the
# fold lies within the last failed step (< 2 step / MIN_STEP_DIVISOR) past the last converged
# state, so a snap must overshoot more than that, or it relaxes before the fold, where the
# nearly singular branch still exists (measured: overshoot 2.5e-4 at step 0.05, the flow then
# cycled at residual 4e-12 ... 6e-9 for 300 pseudo-time steps and raised SettleError)
MIN_STEP_DIVISOR = 160


class RimWaves:
    """Fourier content of the shell's deflection on the circle ``radius`` at the current state
    (computed once per state), and its crests (peaks of at least a tenth of the deflection's range
    along the circle: the waves one counts on a picture, which a modulated or tilted edge wave
    shows more plainly than the purity of its dominant harmonic)."""

    def __init__(self, shell, mesh: ngs.Mesh, *, radius: float = RIM_RADIUS, n: int = RIM_SAMPLES,
                 max_mode: int = RIM_MODES, half: bool = False):
        self.shell, self.mesh, self.half = shell, mesh, half
        self.radius, self.n, self.max_mode = radius, n, max_mode
        self._key: bytes | None = None
        self._values: dict[str, float] = {}

    def values(self) -> dict[str, float]:
        key = hashlib.sha1(self.shell.save_state().tobytes()).digest()
        if key != self._key:
            w = disk_circle_values(self.shell.displacement[2], self.mesh, radius=self.radius, n=self.n,
                                   half=self.half)
            values = {"rim_mean_w": float(np.mean(w)), "rim_max_abs_w": float(np.max(np.abs(w)))}
            if np.ptp(w) > 0:
                analysis = wave_number(w, max_mode=self.max_mode)
                values.update(rim_k=analysis.k, rim_amplitude=analysis.amplitude, rim_purity=analysis.purity,
                              rim_k_second=analysis.second, rim_crests=periodic_peaks(w).count,
                              **{f"rim_a{m}": float(analysis.spectrum[m]) for m in range(1, self.max_mode + 1)})
            else:  # the flat state: no wave
                values.update(rim_k=0, rim_amplitude=0.0, rim_purity=0.0, rim_k_second=0, rim_crests=0,
                              **{f"rim_a{m}": 0.0 for m in range(1, self.max_mode + 1)})
            self._key, self._values = key, values
        return self._values

    def qoi(self) -> dict:
        names = list(self._names())
        return {name: (lambda name=name: self.values()[name]) for name in names}

    def _names(self):
        yield from ("rim_k", "rim_amplitude", "rim_purity", "rim_k_second", "rim_crests", "rim_mean_w", "rim_max_abs_w")
        yield from (f"rim_a{m}" for m in range(1, self.max_mode + 1))


def pattern_depth(shell, mesh: ngs.Mesh, k: int, *, half: bool, radii: np.ndarray | None = None) -> dict:
    """Penetration depth of the wave ``k`` of the current deflection: its Fourier amplitude on
    circles ``r = 0.05 .. RIM_RADIUS`` and the distance from the rim circle inward to where it
    falls to 5 % (the thesis's ``l_p``, ``ngsgel.patterns.penetration_depth``) and to half."""
    radii = np.linspace(0.05, RIM_RADIUS, 24) if radii is None else radii
    amplitude = np.array([wave_number(disk_circle_values(shell.displacement[2], mesh, radius=float(r), n=RIM_SAMPLES,
                                                         half=half), max_mode=max(k, RIM_MODES)).spectrum[k]
                          for r in radii])
    return {"k": k, "l_5%": penetration_depth(amplitude, radii), "l_half": penetration_depth(amplitude, radii, fraction=0.5),
            "radii": radii.tolist(), "amplitude": amplitude.tolist()}


def odd_modes(shell, mesh: ngs.Mesh, *, count: int = 3) -> dict:
    """The half disk's current state (even in y) as a state of the full disk, against the
    perturbations the half disk's symmetry excludes: the exact negative count and the ``count``
    lowest eigenvalues of the tangent among the modes odd in y (``shell_cases.odd_free_mask``),
    each with the wave number of its deflection (``sin k theta``). One value near zero whose k is
    the state's own is the neutral rotation of the pattern about the axis (a zero mode of the
    disk, which the mesh breaks slightly to either sign), not an instability."""
    mask = odd_free_mask(shell, mesh)
    with ngs.TaskManager():
        K = free_matrix(shell.tangent(shell.state), mask)
        M = free_matrix(shell.mass_matrix(), mask)
    odd = spectrum(shell, count=count, K=K, M=M)
    mode = ngs.GridFunction(shell.space)
    modes = []
    for value, vector in zip(odd.eigenvalues, odd.modes.T):
        full = np.zeros(shell.space.ndof)
        full[mask] = vector
        mode.vec.FV().NumPy()[:] = full
        modes.append({"eigenvalue": float(value), **plate_mode_wave(mode.components[0], mesh, half=True, odd=True)})
    return {"negative": odd.negative, "modes": modes}


def check_grading(n0: float, nR: float) -> None:
    """Bad ``Nv`` values raise before any work."""
    for name, value in (("n0", n0), ("nR", nR)):
        if not 0 < value < 0.5:
            raise ValueError(f"{name} (Nv) must be in (0, 0.5), got {value!r}")


def run(out: str, *, p: float = 10.0, n0: float = GRADED_N0, nR: float = GRADED_NR, t: float = 0.01,
        maxh: float = 0.2, order: int = 3, step: float = 0.05,
        max_steps: int = 200, eigenvalues: int = 4, realcompile: bool = False, mu_start: float | None = MU_START,
        maxit: int | None = None, half: bool = True, switch_all: bool = False, through_snaps: bool = True,
        snap_overshoot: float = 1e-3, jump_ratio: float | None = None, quick: bool = False,
        options: dict | None = None, resume: bool = False) -> dict:
    """The defaults are the protocol that reaches ``mu = 0`` (docs/graded.md): the half disk, one
    switch onto the saddle, then its branch and the ones it snaps to.
    ``mu_start``: ramp the flat disk there first (natural steps, no stability check: it must lie
    below the onset; the driver's first state then shows no negative eigenvalue, which is checked;
    None: start at ``mu0``).
    ``maxit``: Newton iterations per solve (the driver's default when None). A Newton failure of
    the driver (e.g. in the branch switch) writes its residual history to ``newton_failure.json``
    before it propagates. ``half``: the half disk with mirror symmetry about y = 0
    (``shell_cases.graded_plate_shell``): the k = 2 eigenvalue is simple there. ``switch_all``
    False: legs; the first switches onto the buckled branch and stops once the rim wave exceeds
    0.1 t, the next follows that branch to ``mu = 0`` locating (not switching at) every later
    change of the negative count, with its critical mode's wave number (column ``leg``).
    ``through_snaps`` (with ``switch_all`` False): the legs after the first follow ``mu`` in
    natural steps (``step / 5`` growing to ``step``, a leg after a snap from ``snap_overshoot``; a
    solve gives up after ``STALL_WINDOW`` iterations
    that do not halve its residual, a step grows after <= ``EASY_ITERATIONS``) and also end where the followed branch loses
    stability or the steps stall (below ``step / MIN_STEP_DIVISOR``: a fold); the disk then snaps at ``mu`` =
    critical (or last) + ``snap_overshoot`` (at most 0) (``ngsgel.relaxation.settle_after``: pushed 0.1 t
    along the critical mode, relaxed by the overdamped flow to a stable state, reported in
    ``events.json`` as "snap") and the next leg follows the branch it lands on. ``jump_ratio``:
    those natural legs also refuse a step that converged farther from its predictor than this
    many predicted increments (``follow_path``'s ``max_correction``: a jump onto another branch).
    ``n0``, ``nR``: ``Nv`` at the centre and the rim (MODEL.md 5 C; the thesis's text gives both
    divided by 3, its ch. 5.2).
    Every step rewrites ``checkpoint.npz`` (an ended leg moves to ``checkpoint_leg<n>.npz``:
    ``ngsgel.continuation.Resumption``); ``resume``: the run in ``out`` goes on from the last one
    (a snap whose next leg has not begun relaxes again, from the end of its leg). ``options``:
    the command line, kept in ``params.json`` (``ngsgel.output.resume_arguments``)."""
    check_grading(n0, nR)
    if through_snaps and switch_all:
        raise ValueError("through_snaps needs switch_all=False (legs that locate, not switch)")
    if not snap_overshoot > 0:
        raise ValueError(f"snap_overshoot must be positive (mu rises), got {snap_overshoot!r}")
    if jump_ratio is not None and not jump_ratio > 0:
        raise ValueError(f"jump_ratio must be a number > 0, got {jump_ratio!r}")
    if quick:  # the coarsest mesh whose onset is right (at h = 0.3 it comes at a mu 42 % lower)
        maxh, max_steps, realcompile, half = 0.2, min(max_steps, 8), False, True
        switch_all, through_snaps = False, False
    if through_snaps and not snap_overshoot > 2 * step / MIN_STEP_DIVISOR:  # only snapping legs use it
        raise ValueError(f"snap_overshoot must exceed 2 step / {MIN_STEP_DIVISOR} = {2 * step / MIN_STEP_DIVISOR:g} "
                         f"(the resolution of a stalled natural leg), got {snap_overshoot!r}")
    params = dict(p=p, n0=n0, nR=nR, t=t, maxh=maxh, order=order, step=step, max_steps=max_steps,
                  eigenvalues=eigenvalues,
                  realcompile=realcompile, mu_start=mu_start, maxit=maxit, half=half,
                  switch_all=switch_all, through_snaps=through_snaps, snap_overshoot=snap_overshoot,
                  jump_ratio=jump_ratio, quick=quick,
                  rim_radius=RIM_RADIUS, options=options)
    run_dir = RunDirectory(out, params=params, resume=resume)
    if not resume:  # an earlier run's checkpoints here would be taken for this run's by a resume
        for stale in run_dir.path.glob("checkpoint*.npz"):
            stale.unlink()
    resumption = Resumption(resume)
    latest = run_dir.file("checkpoint.npz")
    first = resumption.take(latest)
    progress = Progress("graded_plate_shell")
    start = time.perf_counter()
    shell, mesh, pins = graded_plate_shell(p, maxh=maxh, order=order, t=t, realcompile=realcompile, half=half,
                                           n0=n0, nR=nR)
    rim = RimWaves(shell, mesh, half=half)
    if mu_start is not None and first is None:  # (a resumed run starts from its checkpoint)
        ramp(shell, shell.mu, mu_start, step=0.25)
        with ngs.TaskManager():
            unstable = negative_count(free_matrix(shell.tangent(shell.state), shell.free_mask))
        if unstable:  # before any path work: a switch from an unstable start fails obscurely
            raise RuntimeError(f"the flat disk at mu_start = {mu_start} is already unstable ({unstable} negative "
                               f"eigenvalues at h = {maxh}): lower mu_start")
    error, points, all_events, snaps = None, [], [], []
    leg = 0
    qoi = {"leg": lambda: leg, **rim.qoi()}
    vtk = VTKSeries(mesh, shell.fields(), run_dir.series("shell"), derived_order=shell.order)
    with History(run_dir.file("path.csv")) as history:
        while True:
            switch = switch_all or leg == 0
            stability = StabilityOptions(eigenvalues=eigenvalues, switch=switch, amplitude=0.1, length=t, tol=1e-4)
            if switch_all:
                stop = None
            elif leg == 0:  # ends once the disk has left the flat state (rim wave > 0.1 t)
                stop = lambda pt: pt.qoi["rim_amplitude"] > 0.1 * t
            else:
                stop = (lambda pt: bool(pt.negative)) if through_snaps else None
            # past the first switch a snapping run steps mu itself: the arclength corrector failed to
            # locate the saddle's loss of stability at h = 0.15 (docs/graded.md)
            natural = through_snaps and leg > 0
            # A leg after a snap starts on a soft branch: started at step / 5 (the try to mu = 0
            # failed, the halved one converged in 25 Newton iterations) the last leg landed on
            # another equilibrium, which lost stability at mu = -0.00082 and snapped to a state of
            # purity 0.631; from the overshoot its steps follow the branch, as steps of 1e-4 do
            # (docs/benchmarks.md, "Which of the two end states is the branch's")
            first_step = snap_overshoot if leg > 1 else step / 5
            newton_options = {} if maxit is None else {"maxit": maxit}
            leg_options = {"newton_options": newton_options}
            if natural:
                leg_options = {"easy_iterations": EASY_ITERATIONS, "max_correction": jump_ratio,
                               "newton_options": {**newton_options, "stall_window": STALL_WINDOW}}
            try:
                path = follow_path(shell, shell.mu, method="natural" if natural else "arclength",
                                   step=first_step if natural else step, max_step=step,
                                   min_step=step / MIN_STEP_DIVISOR if natural else None, target=0.0, stability=stability,
                                   qoi=qoi, history=history, max_steps=max_steps - len(points), stop=stop,
                                   vtk=vtk, progress=progress, checkpoint_file=latest,
                                   resume=resumption.take(latest, leg) if leg else first, **leg_options)
            except ContinuationError as exc:  # the path so far is kept: reported, or (snapping) a stall
                path = exc.result
                if not natural:
                    error = str(exc)
            except NewtonError as exc:  # recorded for the report, then raised
                run_dir.write_json("newton_failure.json", {"message": str(exc), "residuals": exc.result.residuals,
                                                           "iterations": exc.result.iterations,
                                                           "line_search_cuts": exc.result.line_search_cuts,
                                                           "leg": leg, "wall_s": time.perf_counter() - start})
                raise
            points += path.points
            all_events += [(leg, e) for e in path.events]
            if (error is not None or path.stop_reason not in ("criterion", "min_step") or switch_all
                    or len(points) >= max_steps):
                break
            Resumption.end_leg(latest, leg)
            if natural and resumption.reached(latest, leg + 1):  # the stopped run had snapped: its record
                snaps.append(json.loads(run_dir.file("snaps.json").read_text())[len(snaps)])
            elif natural:  # the branch lost stability (located event) or the steps stalled (a fold)
                clock = time.perf_counter()
                settled = settle_after(shell, shell.mu, path, overshoot=snap_overshoot, amplitude=0.1 * t,
                                       target=0.0, progress=progress)
                snaps.append({"leg": leg, "kind": "snap", "stop_reason": path.stop_reason,
                              "from_mu": path.points[-1].parameter,
                              "mu": shell.mu.Get(), "energy_drop": settled.energy_drop,
                              "distance": settled.distance, "pseudo_time_steps": settled.steps,
                              "rejected": settled.rejected, "lowest_eigenvalue": settled.lowest_eigenvalue,
                              "rim_after": dict(rim.values()), "wall_s": time.perf_counter() - clock})
                run_dir.write_json("snaps.json", snaps)
            leg += 1
    if points[0].negative:
        raise RuntimeError(f"the start at mu = {points[0].parameter} is already unstable "
                           f"({points[0].negative} negative eigenvalues): lower mu_start")
    events = []
    for leg, e in all_events:
        row = {"leg": leg, "kind": e.kind, "step": e.step, "mu": e.parameter, "mu_error": e.parameter_error,
               "negative_before": e.negative_before, "negative_after": e.negative_after, "eigenvalue": e.eigenvalue}
        if e.mode is not None:
            row.update({f"mode_{k}": v for k, v in plate_mode_wave(e.mode.components[0], mesh, half=half).items()})
        events.append(row)
    events += snaps
    run_dir.write_json("events.json", events)
    negatives = [pt.negative for pt in points]
    np.savez(run_dir.file("state_end.npz"), state=shell.save_state(), mu=shell.mu.Get())
    rim_end = rim.values()
    summary = {"ndof": shell.space.ndof, "steps": len(points), "stop_reason": path.stop_reason,
               "error": error, "mu_end": points[-1].parameter, "negative_end": negatives[-1],
               "max_negative": max(n for n in negatives if n is not None), "events": events,
               "rim_end": rim_end,
               "penetration_depth": pattern_depth(shell, mesh, int(rim_end["rim_k"]), half=half) if rim_end["rim_k"] else None,
               "pin_reactions": [shell.reaction(pt, "z") for pt in pins],
               # the half disk's end state on the full disk: the modes odd in y
               "odd_modes_end": odd_modes(shell, mesh) if half else None,
               "wall_s": time.perf_counter() - start}
    plot_shape(shell, mesh, run_dir.file("shape_end.png"),
               title=f"p = {p:g}, t/R = {t:g}, mu = {summary['mu_end']:.4g}", half=half)
    run_dir.write_json("summary.json", summary)  # last: a folder with it holds a finished run
    return summary


def seeded_pattern(out: str, *, p: float, k: int, load: float = 1e-3, n0: float = GRADED_N0, nR: float = GRADED_NR,
                   t: float = 0.01, maxh: float = 0.2,
                   order: int = 3, mu_start: float = MU_START, step: float = 0.01,
                   realcompile: bool = False) -> dict:
    """Whether the wave number ``k`` is a stable pattern of the disk at ``mu = 0`` when a run is
    seeded with it (the thesis's runs seeded "an infinitesimal initial geometry imperfection" of
    unstated shape): the half disk carries a transverse dead load ``load * D / R^4 * cos(k theta)
    (r/R)^k`` (``D = G t^3 / 6`` of the stiff gel, ``R = 1``), is swollen from ``mu_start`` to 0 by
    natural steps (the k-fold path; the exact negative count and the rim waves at every state),
    then the seed load is removed at ``mu = 0``, or where the steps stall (a fold of the seeded
    path: ``stall`` in the summary, ``mu_end`` there), and the disk relaxed to a stable state
    (``ngsgel.relaxation.settle``: Newton-like where the state is stable). Reported: the rim
    deflection the seed makes at ``mu_start`` (over t), the path's negative counts, and the end
    state's wave number, purity, amplitude, energy and lowest eigenvalue - k "survives" if the end
    state's dominant wave is still k."""
    if not (isinstance(k, int) and k >= 2):
        raise ValueError(f"k must be an integer >= 2, got {k!r}")
    if not load > 0:
        raise ValueError(f"load must be > 0, got {load!r}")
    if not mu_start < 0:
        raise ValueError(f"mu_start must be < 0, got {mu_start!r}")
    check_grading(n0, nR)
    run_dir = RunDirectory(out, params=dict(p=p, k=k, load=load, n0=n0, nR=nR, t=t, maxh=maxh, order=order,
                                            mu_start=mu_start,
                                            step=step, realcompile=realcompile, mode="seeded pattern"))
    progress = Progress(f"seeded k = {k}, p = {p:g}")
    start = time.perf_counter()
    shell, mesh, _ = graded_plate_shell(p, maxh=maxh, order=order, t=t, realcompile=realcompile, half=True,
                                        n0=n0, nR=nR)
    stiff = FloryRehnerGel(Nv=max(n0, nR), chi=shell.material.chi)
    scale = ngs.Parameter(1.0)
    r = ngs.sqrt(ngs.x * ngs.x + ngs.y * ngs.y)
    q = load * stiff.shear_modulus(shell.lam0) * t**3 / 6 * ngs.cos(k * ngs.atan2(ngs.y, ngs.x)) * r**k
    shell.add_surface_load(".*", (0.0, 0.0, scale * q))
    rim = RimWaves(shell, mesh, half=True)
    ramp(shell, shell.mu, mu_start, step=0.25)
    seeded = rim.values()
    rows = []

    def record(value, _newton=None) -> None:
        with ngs.TaskManager():
            negative = negative_count(free_matrix(shell.tangent(shell.state), shell.free_mask))
        rows.append({"mu": value, "negative": negative, **rim.values()})
        history.append(rows[-1])
        progress(f"mu = {value:+.5f}: negative {negative}, rim k = {rows[-1]['rim_k']} "
                 f"(amplitude {rows[-1]['rim_amplitude']:.3g}, purity {rows[-1]['rim_purity']:.2f})")

    stall = None
    with History(run_dir.file("path.csv")) as history:
        record(mu_start)
        try:
            ramp(shell, shell.mu, 0.0, step=step, max_step=5 * step, min_step=step / 1000, on_step=record)
        except RampError as exc:  # the seeded branch folds before mu = 0: kept in the report
            stall = {"mu": shell.mu.Get(), "message": str(exc)}
            progress(f"stalled at mu = {shell.mu.Get():+.5f}: {exc}")
    with_load = rim.values()
    scale.Set(0.0)
    relaxed = settle(shell, parameter=shell.mu, progress=progress)
    end = rim.values()
    summary = {"p": p, "k_seeded": k, "seed_rim_amplitude_over_t": seeded["rim_a%d" % k] / t if k <= RIM_MODES else None,
               "stall": stall, "mu_end": shell.mu.Get(), "max_negative_on_path": max(r["negative"] for r in rows),
               "rim_with_seed": with_load, "rim_end": end, "k_end": end["rim_k"], "survives": end["rim_k"] == k,
               "energy_end": shell.energy(), "lowest_eigenvalue_end": relaxed.lowest_eigenvalue,
               "settle_steps": relaxed.steps, "settle_distance": relaxed.distance,
               "penetration_depth": pattern_depth(shell, mesh, int(end["rim_k"]), half=True) if end["rim_k"] else None,
               "wall_s": time.perf_counter() - start}
    run_dir.write_json("summary.json", summary)
    np.savez(run_dir.file("state_end.npz"), state=shell.save_state(), mu=shell.mu.Get())
    plot_shape(shell, mesh, run_dir.file("shape_end.png"), title=f"p = {p:g}, seeded k = {k}, mu = {shell.mu.Get():.3g}",
               half=True)
    return summary


def plot_shape(shell, mesh: ngs.Mesh, path, *, title: str, half: bool = False) -> None:
    """Deflection map on a polar grid (reference positions) and the deflection on the rim circle
    (``half``: mirrored from the half disk)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    radii = np.linspace(0.0, RIM_RADIUS, 40)
    theta = 2 * np.pi * np.arange(181) / 180
    w = np.array([disk_circle_values(shell.displacement[2], mesh, radius=max(float(r), 1e-9), n=180, half=half)
                  for r in radii])
    w = np.concatenate([w, w[:, :1]], axis=1)  # closed in theta
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.5))
    R, T = np.meshgrid(radii, theta, indexing="ij")
    image = ax1.contourf(R * np.cos(T), R * np.sin(T), w, 30, cmap="RdBu_r")
    fig.colorbar(image, ax=ax1, label="w (z displacement)")
    ax1.set_aspect("equal")
    ax1.set_title(title, fontsize=9)
    ax2.plot(np.degrees(theta), w[-1])
    ax2.set_xlabel("theta [deg]")
    ax2.set_ylabel(f"w at r = {RIM_RADIUS} R (reference)")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/graded_plate_shell",
                          quick=f"half disk, h = 0.2 R, from mu = {MU_START} through the first switch onto the "
                                "saddle, 8 steps, no C++ compile (about 2 min)")
    parser.add_argument("--p", type=float, default=10.0, help="grading exponent p of Nv(r) = n0 + (nR - n0) (r/R)^p")
    parser.add_argument("--n0", type=float, default=GRADED_N0, help="Nv at the centre (dimensionless)")
    parser.add_argument("--nR", type=float, default=GRADED_NR, help="Nv at the rim (dimensionless)")
    parser.add_argument("--t", type=float, default=0.01, help="thickness t / disk radius R")
    parser.add_argument("--maxh", type=float, default=0.2, help="element size of the shell mesh / R")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the shell's displacement")
    parser.add_argument("--step", type=float, default=0.05,
                        help="step in mu (kT): arc length (in mu) of the first leg and of arclength legs, their "
                             "maximum; snapping legs step mu from step / 5 up to step")
    parser.add_argument("--max-steps", type=int, default=200, help="path points of all legs together, at most")
    parser.add_argument("--realcompile", action="store_true",
                        help="the shell's Python forms with a C++-compiled residual instead of its compiled kernels")
    parser.add_argument("--mu-start", type=float, default=MU_START,
                        help="ramp the flat disk to this mu (kT) first, below the onset")
    parser.add_argument("--maxit", type=int, help="Newton iterations per solve (default: the driver's)")
    parser.add_argument("--full-disk", dest="half", action="store_false",
                        help="the full disk instead of the half with mirror symmetry about y = 0 (the one-mode switch "
                             "at the double k = 2 eigenvalue of the full disk does not converge)")
    parser.add_argument("--switch-all", action="store_true",
                        help="switch onto the new branch at every bifurcation (arclength) instead of snapping")
    parser.add_argument("--no-snaps", action="store_true",
                        help="after the first switch follow the branch by arclength, locating (not snapping at) later "
                             "bifurcations")
    parser.add_argument("--snap-overshoot", type=float, default=1e-3,
                        help="mu (kT) beyond the critical value to snap at")
    parser.add_argument("--seed-wave", type=int, help="instead: seed this wave number (half disk, transverse "
                        "dead load), swell to mu = 0, remove the seed and relax (seeded_pattern; default: none, "
                        "the path)")
    parser.add_argument("--seed-load", type=float, default=1e-3,
                        help="seed load in units of D / R^4 (D = G t^3 / 6 of the stiffer gel)")
    parser.add_argument("--jump-ratio", type=float, default=None,
                        help="snapping legs: refuse steps that converge this many predicted increments from "
                             "their predictor (a jump onto another branch); default: no such check")
    parser.add_argument("--resume", default=None, metavar="DIR",
                        help="go on with the stopped path run in DIR from its last checkpoint to the end it would "
                             "have reached, with its own options (its params.json; an option given as well must "
                             "agree); summary.json's wall_s is then the resumed part's (default: none, a new run)")
    args = resume_arguments(parser, argv)
    with silence_progress(args.quiet):
        if args.seed_wave is not None:
            summary = seeded_pattern(args.out, p=args.p, k=args.seed_wave, load=args.seed_load, n0=args.n0,
                                     nR=args.nR, t=args.t, maxh=args.maxh, order=args.order,
                                     realcompile=args.realcompile, mu_start=args.mu_start)
            print(json.dumps({k: v for k, v in summary.items() if k not in ("rim_with_seed", "penetration_depth")},
                             default=str, indent=1))
            return summary
        summary = run(args.out, p=args.p, n0=args.n0, nR=args.nR, t=args.t, maxh=args.maxh, order=args.order,
                      step=args.step, max_steps=args.max_steps, realcompile=args.realcompile,
                      mu_start=args.mu_start, maxit=args.maxit, half=args.half, switch_all=args.switch_all,
                      through_snaps=not (args.switch_all or args.no_snaps), snap_overshoot=args.snap_overshoot,
                      jump_ratio=args.jump_ratio, quick=quick_run(args), options=command_options(args),
                      resume=args.resume is not None)
    print(json.dumps({k: v for k, v in summary.items() if k != "events"}, default=str, indent=1))
    for e in summary["events"]:
        print(e)
    return summary


if __name__ == "__main__":
    main()
