"""k-fold patterns of the softer-edge graded disk at ``mu = 0`` on mirror-symmetric wedges (issue 39, item 2b).

The disk of ``graded_plate_shell`` (``GelShell``, graded ``Nv``, t/R = 0.01) is computed on the
wedge ``0 <= theta <= pi/k`` with mirror planes on both straight edges (normal displacement and
rotation about the edge zero; the edge at ``pi/k`` has no coordinate normal, so its normal
displacement is held by a stiff penalty, ``MirrorShell``). The wedge carries only the wave numbers
0, k, 2k, ... of the deflection: for k >= 3 it excludes the k = 2 saddle the full disk buckles
into, for k = 2 (the quarter disk) it is the saddle's own symmetry, and k = 1 is the half disk
of ``graded_plate_shell`` (wave numbers 0, 1, 2, ...; two extra pins). From the flat state at
``mu_start`` the wedge follows the load in natural steps with the exact negative count - by
default the softer gel's free-swelling stretch (``mu`` its function, as in ``graded_plate``;
steps of at most 0.5 % free-swelling mismatch, ``--load mu`` for steps in ``mu``); where the
branch loses stability (the flat state at its first onset, later branches at theirs) the state
is pushed along the critical mode and relaxed (``ngsgel.relaxation.settle_after``) and the next
branch is followed, up to ``mu = 0``. No seed load.

Every wedge is made of copies of one meshed base sector of angle ``pi / base_sectors``
(``geometries.plates.plate_sector_midsurface``), so the end state maps node by node onto the
full disk of ``2 base_sectors`` copies - one mesh for every k dividing ``base_sectors`` (20: k =
2, 4, 5). There the state is re-equilibrated (Newton, no symmetry imposed) and its energy, exact
negative count and lowest modes (with their wave numbers) are those of the full disk.

Writes per k ``path_k<k>.csv`` (``relax_k<k>.csv`` with ``--protocol relax``), ``wedge_k<k>.json``
(legs, snaps, end state, the full disk's rim deflection ``rim_w``) and ``state_k<k>.npz``; the
ParaView series ``wedge_k<k>.pvd`` of the wedge's states, one per row of the path's CSV as it is
written (displacement, thickness stretch, membrane and moment traces, graded ``Nv``), and
``full_k<k>.vtu``, the end state on the full disk (the same fields and its lowest mode's
displacement); ``summary.json`` (the table: energies, differences to k = 2, negative counts,
lowest modes, rim harmonics, penetration depth) and next to it ``plate_wedges.png``: the rim
deflection w(theta) of each k's full-disk end state and each wedge's rim wave amplitude along
its path.

    ngsgel run plate-wedges --out results/plate_wedges --p 0.75 --k 2 4 5
    ngsgel run plate-wedges --out results/half_disk --p 2 --k 1    # the shell path in the stretch
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path

import numpy as np
import ngsolve as ngs
from scipy.spatial import cKDTree

from geometries.plates import SYM, SYM_END, plate_sector_midsurface, sector_copy_map
from ngsgel import FloryRehnerGel, follow_path, ramp
from ngsgel.continuation import ContinuationError, StabilityOptions
from ngsgel.output import History, Progress, RunDirectory, VTKSeries, quick_run, scene_parser, silence_progress
from ngsgel.patterns import penetration_depth, periodic_peaks, wave_number
from ngsgel.newton import NewtonError
from ngsgel.relaxation import SettleError, _push_and_settle, settle, settle_after
from ngsgel.scenes.graded_plate import CHI as STRETCH_CHI, soft_stretch_load
from ngsgel.scenes.shell_cases import GRADED_MU0, GRADED_N0, GRADED_NR, graded_gel
from ngsgel.shell import GelShell
from ngsgel.stability import free_matrix, mass_matrix, negative_count, spectrum

BASE_SECTORS = 20  # base sector pi/20: the wedges of k = 2, 4, 5 and the full disk share its mesh
MU_START = -0.3  # below the k = 2 onsets of every p at h = 0.2 (graded_plate_shell.MU_START)
RIM_RADIUS = 0.97
RIM_SAMPLES = 160
RIM_MODES = 20
# Stiffness of the mirror penalty per unit edge length, in units of the membrane stiffness G t / h
# of the stiffer gel: the normal displacement it leaves is ~ strain h / MIRROR_PENALTY (~1e-8 R)
MIRROR_PENALTY = 1e6
STALL_WINDOW, EASY_ITERATIONS, MIN_STEP_DIVISOR = 10, 7, 160  # as graded_plate_shell's snapping legs
PIN_RADIUS = 0.25
# Absolute residual floor of the full-disk solves: a reflected equilibrium starts at a residual
# ~3e-11, so the relative target alone (1e-11 of it) lies below round-off (the p = 0.75, k = 4
# stretch run stopped at 9.8e-19 against a target of 3e-22)
FULL_DISK_ATOL = 1e-16
# The path's load parameter: ``mu``, or the free-swelling stretch of the softer gel (``mu`` its
# function, as in graded_plate.py): the free-swelling mismatch is 2.8 % at mu = -0.01, 14 % at
# -0.001 and 28.5 % at 0, so steps in mu that are safe early are huge near mu = 0, while near the
# end a step ds in the stretch changes the mismatch by ~ ds / 1.67 (the stiff gel's stretch)
LOADS = ("mu", "stretch")
PROTOCOLS = ("path", "relax")  # follow_wedge, relax_wedge
# each protocol's history of wedge k and its column of the load
HISTORIES = {"path": ("path_k{k}.csv", "parameter"), "relax": ("relax_k{k}.csv", "load")}
# Largest natural step: in mu (kT), or, for the stretch, in the mismatch: the path is cut into legs
# of STATION_SPAN in the stretch, each with the largest stretch step that changes the mismatch by
# at most this much at the leg's end (the mismatch grows ever faster in the stretch: 0.5 % is a
# stretch step of 0.03 at mu = -0.01, 0.009 near mu = 0), and never more than MAX_STRETCH_STEP
DEFAULT_STEP = {"mu": 0.05, "stretch": 0.005}
STATION_SPAN, MAX_STRETCH_STEP = 0.1, 0.05
# overshoots of the first snap (off the flat state) and of the later ones, in the load's units
# (stretch: ~ the same distance as mu's near the onsets, ds/dmu ~ 0.8 there; 1e-3 ~ 0.06 % mismatch)
FIRST_OVERSHOOT = {"mu": 0.02, "stretch": 0.016}
SNAP_OVERSHOOT = {"mu": 1e-3, "stretch": 1e-3}


class MirrorShell(GelShell):
    """``GelShell`` with mirror planes through the z axis in any direction (``mirror``): on the
    edge the rotation about it is fixed and the displacement normal to the plane vanishes,
    exactly for a coordinate normal (``GelShell.symmetry``), otherwise through the penalty
    energy ``stiffness / 2 (u . m)^2`` per unit length (``m`` the plane's normal), added to the
    shell's forms when they are built (``GelShell`` constrains Cartesian components only)."""

    def __init__(self, *args, mirror_stiffness: float, load: str = "mu", soft_nv: float | None = None,
                 stiff_nv: float | None = None, **kwargs):
        super().__init__(*args, **kwargs)
        if not mirror_stiffness > 0:
            raise ValueError(f"mirror_stiffness must be > 0, got {mirror_stiffness!r}")
        if load not in LOADS:
            raise ValueError(f"load must be one of {LOADS}, got {load!r}")
        self.mirror_stiffness = mirror_stiffness
        self._mirror_penalties: list[tuple[str, tuple[float, float, float]]] = []
        self._soft = None
        self.load = self.mu  # the path's parameter
        if load == "stretch":
            if soft_nv is None or stiff_nv is None:
                raise ValueError("load 'stretch' needs soft_nv and stiff_nv (Nv of the softer and the stiffer gel)")
            if self.material.chi != STRETCH_CHI:
                raise ValueError(f"load 'stretch' is for chi = {STRETCH_CHI} (graded_plate.soft_stretch_load), "
                                 f"got chi = {self.material.chi!r}")
            self._soft = FloryRehnerGel(Nv=soft_nv, chi=STRETCH_CHI)
            self._stiff = FloryRehnerGel(Nv=stiff_nv, chi=STRETCH_CHI)
            # the forms read ``self.mu`` when they are built: from now on a function of the stretch
            self.load, self.mu = soft_stretch_load(soft_nv, soft_nv, self.mu.Get())

    def mu_value(self) -> float:
        """The current chemical potential (kT)."""
        return self.load.Get() if self._soft is None else self._soft.mu_free(self.load.Get())

    def load_at(self, mu: float) -> float:
        """The load parameter's value at the chemical potential ``mu``."""
        return mu if self._soft is None else self._soft.lam_free(mu)

    def mismatch(self, stretch: float) -> float:
        """The free-swelling mismatch ``lam_free(soft) / lam_free(stiff) - 1`` at the soft stretch
        ``stretch`` (load 'stretch' only)."""
        return stretch / self._stiff.lam_free(self._soft.mu_free(stretch)) - 1.0

    def mirror(self, boundary: str, *, angle: float) -> None:
        """Mirror plane containing the z axis and the direction at polar ``angle`` (radians)."""
        self._check_open()
        self._check_edge(boundary)
        normal = (-math.sin(angle), math.cos(angle), 0.0)
        if abs(normal[0]) < 1e-12:
            self.symmetry(boundary, normal="y")
        elif abs(normal[1]) < 1e-12:
            self.symmetry(boundary, normal="x")
        else:
            self.fix_rotation(boundary)
            self._mirror_penalties.append((boundary, normal))

    def _build(self) -> None:
        super()._build()
        if not self._mirror_penalties:
            return
        u = self._space.TrialFunction()[0]
        penalty = sum(0.5 * self.mirror_stiffness * (u * ngs.CF(normal))**2
                      * ngs.ds(definedon=self.mesh.BBoundaries(boundary))
                      for boundary, normal in self._mirror_penalties)
        forms = [self._form] if self._residual_form is self._form else [self._form, self._residual_form]
        for form in forms:
            form += ngs.Variation(penalty)


def check_wave(k: int, base_sectors: int) -> None:
    if not (isinstance(k, int) and k >= 1 and base_sectors % k == 0):
        raise ValueError(f"k must be a positive integer dividing base_sectors = {base_sectors}, got {k!r}")


def _graded(shell_class, mesh, p: float, *, t: float, order: int, n0: float, nR: float, realcompile: bool,
            **extra) -> GelShell:
    gel, lam0 = graded_gel(p, n0=n0, nR=nR)
    return shell_class(mesh, material=gel, lam0=lam0, thickness=t, mu=GRADED_MU0, order=order,
                       realcompile=realcompile, **extra)


def wedge_plate(p: float, k: int, *, maxh: float, order: int = 3, t: float = 0.01, n0: float = GRADED_N0,
                nR: float = GRADED_NR, base_sectors: int = BASE_SECTORS, realcompile: bool = False,
                load: str = "mu") -> tuple[MirrorShell, ngs.Mesh]:
    """The graded disk's wedge ``0 <= theta <= pi/k`` (``base_sectors / k`` copies of the base
    sector) with mirror planes on both edges and the deflection pinned at the centre (for k >= 2
    the mirrors hold every other rigid motion; k = 1 is the half disk, mirrored about y = 0, whose
    x translation and tilt about y two more pins hold, statically determinate: the centre's x and
    the deflection of the vertex on the x axis nearest ``PIN_RADIUS``). ``load``: the path's load
    parameter ``shell.load`` (``LOADS``)."""
    check_wave(k, base_sectors)
    bundle = plate_sector_midsurface(angle=math.pi / base_sectors, copies=base_sectors // k, maxh=maxh,
                                     curve_order=order)
    gel, lam0 = graded_gel(p, n0=n0, nR=nR)
    stiffness = MIRROR_PENALTY * FloryRehnerGel(Nv=max(n0, nR), chi=gel.chi).shear_modulus(lam0) * t / maxh
    shell = _graded(MirrorShell, bundle.mesh, p, t=t, order=order, n0=n0, nR=nR, realcompile=realcompile,
                    mirror_stiffness=stiffness, load=load, soft_nv=min(n0, nR), stiff_nv=max(n0, nR))
    shell.mirror(SYM, angle=0.0)
    shell.mirror(SYM_END, angle=math.pi / k)
    shell.prescribe_point((0.0, 0.0, 0.0), "z", 0.0)
    if k == 1:
        shell.prescribe_point((0.0, 0.0, 0.0), "x", 0.0)
        shell.prescribe_point(_axis_vertex(bundle.mesh, 0), "z", 0.0)
    return shell, bundle.mesh


def _axis_vertex(mesh: ngs.Mesh, axis: int) -> tuple[float, float, float]:
    """The mesh vertex on the positive ``axis`` (0: x, 1: y) nearest ``PIN_RADIUS``."""
    points = np.array([v.point for v in mesh.vertices])
    on_axis = np.flatnonzero((np.abs(points[:, 1 - axis]) < 1e-12) & (points[:, axis] > 0))
    return tuple(points[on_axis[np.argmin(np.abs(points[on_axis, axis] - PIN_RADIUS))]])


def fold(points: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Each point (rows x, y, z) as the image ``Q_b x_w`` of a point ``x_w`` of the wedge
    ``0 <= theta <= pi/k`` under the map ``Q_b`` of its copy ``b`` of the wedge: returns the block
    numbers and the wedge points."""
    theta = np.mod(np.arctan2(points[:, 1], points[:, 0]), 2 * math.pi)
    blocks = np.minimum((theta / (math.pi / k)).astype(int), 2 * k - 1)
    folded = np.array([sector_copy_map(math.pi / k, int(b)).T @ x for b, x in zip(blocks, points)])
    return blocks, folded


def wedge_circle_values(w: ngs.CoefficientFunction, mesh: ngs.Mesh, k: int, *, radius: float,
                        n: int = RIM_SAMPLES) -> np.ndarray:
    """A field even under the wedge's mirrors (e.g. the deflection) on the full circle ``radius``,
    ``theta_i = 2 pi i / n``, from its values on the wedge."""
    theta = 2 * math.pi * np.arange(n) / n
    points = np.stack([radius * np.cos(theta), radius * np.sin(theta), np.zeros(n)], axis=1)
    _, folded = fold(points, k)
    return np.array([w(mesh(*x, ngs.BND)) for x in folded])


def rim_content(values: np.ndarray) -> dict:
    analysis = wave_number(values, max_mode=RIM_MODES)
    return {"rim_k": analysis.k, "rim_amplitude": analysis.amplitude, "rim_purity": analysis.purity,
            "rim_k_second": analysis.second, "rim_crests": periodic_peaks(values).count,
            "rim_max_abs_w": float(np.max(np.abs(values))),
            **{f"rim_a{m}": float(analysis.spectrum[m]) for m in range(1, RIM_MODES + 1)}}


def shell_fields(shell: GelShell) -> dict[str, ngs.CoefficientFunction]:
    """The fields of a wedge's or the full disk's state for VTK: the shell's own and the graded ``Nv``."""
    return {**shell.fields(), "Nv": ngs.CF(shell.material.Nv)}


def load_kind_and_step(shell: MirrorShell, step: float | None) -> tuple[str, float]:
    """Whether ``shell`` steps ``mu`` or the stretch, and the largest step (``DEFAULT_STEP`` of
    that kind unless given, in mu or in the mismatch)."""
    kind = "mu" if shell.load is shell.mu else "stretch"
    step = DEFAULT_STEP[kind] if step is None else step
    if not step > 0:
        raise ValueError(f"step must be > 0, got {step!r}")
    return kind, step


def follow_wedge(shell: MirrorShell, mesh: ngs.Mesh, k: int, *, run_dir: RunDirectory, mu_start: float = MU_START,
                 step: float | None = None, max_steps: int = 400, jump: bool = True, progress=None) -> dict:
    """The wedge's path from the flat state at ``mu_start`` to ``mu = 0`` (natural steps in
    ``shell.load``, at most ``step`` in mu or in the mismatch (``DEFAULT_STEP``); at every loss of
    stability or stall the snap of ``graded_plate_shell``: ``settle_after``, ``SNAP_OVERSHOOT``
    further). ``jump``: the first snap relaxes at ``mu = 0`` itself (from the critical state
    pushed along its mode, the overdamped flow at ``mu = 0`` within the wedge's symmetry);
    otherwise it relaxes ``FIRST_OVERSHOOT`` past the onset and the branch is followed. Writes
    ``path_k<k>.csv`` and the VTK series ``wedge_k<k>`` (``shell_fields``), one state per row, and
    a row (event "settled") for a snap that ends at ``mu = 0``."""
    t = shell.thickness
    kind, step = load_kind_and_step(shell, step)
    end = shell.load_at(0.0)
    start = shell.load_at(mu_start)

    def leg_plan(here: float) -> tuple[float, float]:
        """The next leg's target and largest step."""
        if kind == "mu":
            return end, step
        target = min(end, here + STATION_SPAN)
        slope = (shell.mismatch(target) - shell.mismatch(target - 1e-4)) / 1e-4
        return target, min(MAX_STRETCH_STEP, step / slope)

    ramp(shell, shell.load, start, step=(start - shell.load.Get()) / 3)
    with ngs.TaskManager():
        unstable = negative_count(free_matrix(shell.tangent(shell.state), shell.free_mask))
    if unstable:
        raise RuntimeError(f"the flat wedge (k = {k}) at mu_start = {mu_start} is already unstable "
                           f"({unstable} negative eigenvalues): lower mu_start")
    cache: dict = {}

    def rim() -> dict:
        key = hash(shell.save_state().tobytes())
        if cache.get("key") != key:
            values = wedge_circle_values(shell.displacement[2], mesh, k, radius=RIM_RADIUS)
            cache.update(key=key, values=rim_content(values) if np.ptp(values) > 0 else
                         {"rim_k": 0, "rim_amplitude": 0.0, "rim_max_abs_w": 0.0})
        return cache["values"]

    leg = 0
    qoi = {"leg": lambda: leg, "mu": shell.mu_value, **{name: (lambda name=name: rim().get(name, 0.0))
                                  for name in ("rim_k", "rim_amplitude", "rim_purity", "rim_k_second", "rim_crests",
                                               "rim_max_abs_w")}}
    legs, snaps = [], []
    at_station = False  # the last leg ended at its target, stable: go on at full step
    vtk = VTKSeries(mesh, shell_fields(shell), run_dir.series(f"wedge_k{k}"), derived_order=shell.order)
    with History(run_dir.file(HISTORIES["path"][0].format(k=k))) as history:
        while True:
            stability = StabilityOptions(eigenvalues=4, switch=False, tol=1e-4)
            target, max_step = leg_plan(shell.load.Get())
            try:
                path = follow_path(shell, shell.load, method="natural", step=max_step if at_station else max_step / 5,
                                   max_step=max_step, min_step=max_step / MIN_STEP_DIVISOR, target=target,
                                   stability=stability, qoi=qoi, history=history, vtk=vtk,
                                   max_steps=max_steps, stop=lambda pt: bool(pt.negative),
                                   progress=progress, easy_iterations=EASY_ITERATIONS,
                                   newton_options={"stall_window": STALL_WINDOW})
            except ContinuationError as exc:  # a stall: the fold lies within the last failed step
                path = exc.result
            legs.append({"leg": leg, "stop_reason": path.stop_reason, "from_load": path.points[0].parameter,
                         "to_load": path.points[-1].parameter, "to_mu": path.points[-1].qoi["mu"],
                         "max_step": max_step, "steps": len(path.points),
                         "events": [{"kind": e.kind, "load": e.parameter, "negative_after": e.negative_after,
                                     "eigenvalue": e.eigenvalue} for e in path.events],
                         "rim_end": dict(rim())})
            run_dir.write_json(f"wedge_k{k}.json", {"legs": legs, "snaps": snaps})
            leg += 1
            at_station = path.stop_reason == "target" and not path.points[-1].negative
            if at_station and target >= end:
                break
            if at_station:
                continue
            if path.stop_reason not in ("criterion", "min_step", "target") or len(snaps) > 12:
                raise RuntimeError(f"the wedge path (k = {k}) ended with {path.stop_reason!r} at {kind} = "
                                   f"{path.points[-1].parameter}: {legs[-1]}")
            # the first snap leaves the flat state: 1e-3 past its onset the natural legs on the buckled
            # wedge stalled at their first step (p = 2, k = 5, h = 0.3); ``jump`` goes to mu = 0 at once
            overshoot = SNAP_OVERSHOOT[kind] if snaps else end - start if jump else FIRST_OVERSHOOT[kind]
            try:
                settled = settle_after(shell, shell.load, path, overshoot=overshoot, amplitude=0.1 * t, target=end,
                                       progress=progress)
            except SettleError:  # the flow stopped on a saddle (seen at mu = 0, k = 2): leave it downhill
                lowest = spectrum(shell, count=1, past_negative=True)
                mode = np.zeros(shell.space.ndof)
                mode[shell.free_mask] = lowest.modes[:, 0]
                settled = _push_and_settle(shell, shell.load, shell.save_state(), mode, shell.load.Get(),
                                           amplitude=0.1 * t, progress=progress)
            np.savez(run_dir.file(f"wedge_state_k{k}_leg{leg - 1}.npz"), state=shell.save_state(),
                     mu=shell.mu_value(), load=shell.load.Get())
            snaps.append({"leg": leg - 1, "from_load": path.points[-1].parameter, "load": shell.load.Get(),
                          "mu": shell.mu_value(),
                          "energy_drop": settled.energy_drop, "pseudo_time_steps": settled.steps,
                          "lowest_eigenvalue": settled.lowest_eigenvalue, "rim_after": dict(rim())})
            run_dir.write_json(f"wedge_k{k}.json", {"legs": legs, "snaps": snaps})
            if shell.load.Get() >= end:  # settled at the target itself: no leg records the end state
                history.append({"step": 0, "parameter": shell.load.Get(), **{name: f() for name, f in qoi.items()},
                                "energy": shell.energy(), "events": "settled"})
                vtk.write(float(len(vtk.times)))
                break
    return {"legs": legs, "snaps": snaps, "energy_wedge": shell.energy(), "rim_end": dict(rim())}


def relax_wedge(shell: MirrorShell, mesh: ngs.Mesh, k: int, *, run_dir: RunDirectory, mu_start: float = MU_START,
                step: float | None = None, start: str | None = None, progress=None) -> dict:
    """The wedge's quasi-static path to ``mu = 0`` by relaxation (the slow-loading limit of a damped
    run, no located critical points): the load goes up in steps of at most ``step`` in mu or in the
    mismatch (``DEFAULT_STEP``; in the stretch never more than ``FIRST_OVERSHOOT``, the path's own
    overshoot off the flat state), and each state is the equilibrium Newton reaches from the last
    if the wedge's tangent there has no negative eigenvalue, else the stable equilibrium the
    overdamped flow (``settle``) reaches from the last state at the new load - pushed along its
    lowest mode first where the flow stops on an unstable (symmetric) equilibrium. Natural steps
    shrink to nothing where Newton needs many iterations next to a singular tangent (p = 2,
    quarter disk: 1e-4 in the stretch near ``mu = -3.4e-4``); these steps do not. ``start``: an
    ``.npz`` of a wedge state and its load (``follow_wedge``'s ``wedge_state_k*_leg*.npz``) to go on
    from, instead of the flat state at ``mu_start``. Writes ``relax_k<k>.csv`` and the VTK series
    ``wedge_k<k>`` (``shell_fields``), one state per row."""
    t = shell.thickness
    kind, step = load_kind_and_step(shell, step)
    end = shell.load_at(0.0)

    def next_load(here: float) -> float:
        if kind == "mu":
            return min(end, here + step)
        ahead = min(end, here + FIRST_OVERSHOOT[kind])  # the mismatch is convex in s: its slope ahead bounds it
        slope = (shell.mismatch(ahead) - shell.mismatch(ahead - 1e-4)) / 1e-4
        return min(end, here + min(FIRST_OVERSHOOT[kind], step / slope))

    if start is None:
        ramp(shell, shell.load, shell.load_at(mu_start), step=(shell.load_at(mu_start) - shell.load.Get()) / 3)
    else:
        saved = np.load(start)
        shell.load.Set(float(saved["load"]))
        shell.restore_state(saved["state"])
        shell.solve()
    with ngs.TaskManager():
        unstable = negative_count(free_matrix(shell.tangent(shell.state), shell.free_mask))
    if unstable:
        raise RuntimeError(f"the wedge's start (k = {k}, {kind} = {shell.load.Get()}) is unstable "
                           f"({unstable} negative eigenvalues)")
    snaps = []
    vtk = VTKSeries(mesh, shell_fields(shell), run_dir.series(f"wedge_k{k}"), derived_order=shell.order)
    with History(run_dir.file(HISTORIES["relax"][0].format(k=k))) as history:
        while True:
            rim = rim_content(wedge_circle_values(shell.displacement[2], mesh, k, radius=RIM_RADIUS))
            history.append({"load": shell.load.Get(), "mu": shell.mu_value(), "energy": shell.energy(),
                            "rim_k": rim["rim_k"], "rim_amplitude": rim["rim_amplitude"],
                            "rim_purity": rim["rim_purity"], "rim_k_second": rim["rim_k_second"],
                            "rim_a2": rim["rim_a2"], "rim_a4": rim["rim_a4"], "relaxed": bool(snaps) and
                            snaps[-1]["load"] == shell.load.Get()})
            vtk.write(float(len(vtk.times)))
            here = shell.load.Get()
            if here >= end:
                break
            before = shell.save_state()
            shell.load.Set(next_load(here))
            negative = None
            try:
                iterations = shell.solve().iterations
                with ngs.TaskManager():
                    negative = negative_count(free_matrix(shell.tangent(shell.state), shell.free_mask))
            except NewtonError as exc:
                failure = str(exc)
            if negative == 0:
                if progress is not None:
                    progress(f"{kind} {shell.load.Get():.6f} (mu {shell.mu_value():.4g}): Newton {iterations}, "
                             f"stable, rim k {rim['rim_k']}")
                continue
            reason = failure if negative is None else f"Newton's equilibrium has {negative} negative eigenvalues"
            shell.restore_state(before)
            energy_before = shell.energy()
            try:
                settled = settle(shell, parameter=shell.load, progress=progress)
            except SettleError:  # a symmetric start stops on the unstable equilibrium: leave it downhill
                lowest = spectrum(shell, count=1, past_negative=True)
                mode = np.zeros(shell.space.ndof)
                mode[shell.free_mask] = lowest.modes[:, 0]
                settled = _push_and_settle(shell, shell.load, shell.save_state(), mode, shell.load.Get(),
                                           amplitude=0.1 * t, progress=progress)
            rim_after = rim_content(wedge_circle_values(shell.displacement[2], mesh, k, radius=RIM_RADIUS))
            snaps.append({"load": shell.load.Get(), "mu": shell.mu_value(), "from_load": here, "reason": reason,
                          "energy_before_at_old_state": energy_before, "energy_after": shell.energy(),
                          "pseudo_time_steps": settled.steps, "lowest_eigenvalue": settled.lowest_eigenvalue,
                          "rim_k_before": rim["rim_k"], "rim_after": rim_after})
            np.savez(run_dir.file(f"relax_state_k{k}_snap{len(snaps) - 1}.npz"), state=shell.save_state(),
                     mu=shell.mu_value(), load=shell.load.Get())
            run_dir.write_json(f"relax_k{k}.json", {"snaps": snaps})
    return {"snaps": snaps, "energy_wedge": shell.energy(), "rim_end": rim}


def full_plate(p: float, *, maxh: float, order: int = 3, t: float = 0.01, n0: float = GRADED_N0,
               nR: float = GRADED_NR, base_sectors: int = BASE_SECTORS, realcompile: bool = False
               ) -> tuple[GelShell, ngs.Mesh, dict]:
    """The full disk of ``2 base_sectors`` copies of the base sector, rigid motions held by six
    pins whose values are ``ngs.Parameter`` s (set them to the state's own: a pattern's deflection
    at the off-centre pins is not zero)."""
    bundle = plate_sector_midsurface(angle=math.pi / base_sectors, copies=2 * base_sectors, maxh=maxh,
                                     curve_order=order)
    mesh = bundle.mesh
    shell = _graded(GelShell, mesh, p, t=t, order=order, n0=n0, nR=nR, realcompile=realcompile)
    pins = {}
    for axis, components in ((None, "xyz"), (0, "yz"), (1, "z")):
        point = (0.0, 0.0, 0.0) if axis is None else _axis_vertex(mesh, axis)
        for component in components:
            pins[point, component] = ngs.Parameter(0.0)
            shell.prescribe_point(point, component, pins[point, component])
    return shell, mesh, pins


def _h1_map(source_space: ngs.FESpace, source_mesh: ngs.Mesh, target_space: ngs.FESpace, target_mesh: ngs.Mesh,
            k: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For a scalar ``H1`` space of order <= 3 on the wedge (``source``) and on a disk made of
    images of it (``target``): for every target dof the source dof, its sign and the block of
    the wedge image it lies in (vertex values map as they are; an edge's odd-order functions
    change sign with its orientation, which follows the global vertex numbers; the cubic face
    bubble is symmetric)."""
    if target_space.globalorder > 3:
        raise ValueError("the map is for order <= 3 (higher face functions are not symmetric)")
    src_points = np.array([v.point for v in source_mesh.vertices])
    tree = cKDTree(src_points)
    tgt_points = np.array([v.point for v in target_mesh.vertices])
    blocks, folded = fold(tgt_points, k)
    distance, vertex_map = tree.query(folded)
    if distance.max() > 1e-8:
        raise ValueError(f"the target's vertices are not images of the source's (off by {distance.max():.3g})")
    source_edges = {frozenset(v.nr for v in e.vertices): e for e in source_mesh.edges}
    source_faces = {frozenset(v.nr for v in f.vertices): f for f in source_mesh.faces}
    n = target_space.ndof
    dof, sign, block = np.full(n, -1), np.ones(n), np.zeros(n, dtype=int)
    for v in target_mesh.vertices:
        for d_t, d_s in zip(target_space.GetDofNrs(v), source_space.GetDofNrs(source_mesh.vertices[int(vertex_map[v.nr])])):
            dof[d_t], block[d_t] = d_s, blocks[v.nr]
    for nodes, source_nodes in ((target_mesh.edges, source_edges), (target_mesh.faces, source_faces)):
        for node in nodes:
            vertices = [v.nr for v in node.vertices]
            centre = tgt_points[vertices].mean(axis=0)
            b, _ = fold(centre[None, :], k)
            Q = sector_copy_map(math.pi / k, int(b[0]))
            images = [int(tree.query(Q.T @ tgt_points[v])[1]) for v in vertices]
            source = source_nodes[frozenset(images)]
            flipped = False
            if len(vertices) == 2:  # orientation low -> high number on either mesh
                flipped = (images[0] < images[1]) != (vertices[0] < vertices[1])
            for i, (d_t, d_s) in enumerate(zip(target_space.GetDofNrs(node), source_space.GetDofNrs(source))):
                dof[d_t], block[d_t] = d_s, int(b[0])
                sign[d_t] = -1.0 if flipped and i % 2 else 1.0
    if np.any(dof < 0):
        raise ValueError("some target dofs have no source")
    return dof, sign, block


def reflect_displacement(source: ngs.GridFunction, source_mesh: ngs.Mesh, target: ngs.GridFunction,
                         target_mesh: ngs.Mesh, k: int) -> None:
    """``target`` (``VectorH1`` on a disk of wedge images) = the wedge's displacement ``source``
    reflected: ``u(Q_b x) = Q_b u(x)`` on every image ``b`` of the wedge ``0 <= theta <= pi/k``."""
    dof, sign, block = _h1_map(source.space.components[0], source_mesh, target.space.components[0], target_mesh, k)
    src = np.stack([source.components[i].vec.FV().NumPy() for i in range(3)])  # (3, n_source)
    values = src[:, dof] * sign
    maps = np.array([sector_copy_map(math.pi / k, b) for b in range(2 * k)])
    mapped = np.einsum("nij,jn->in", maps[block], values)
    for i in range(3):
        target.components[i].vec.FV().NumPy()[:] = mapped[i]


class Reflection:
    """States of a wedge shell (angle ``pi/k``) as states of a shell on a mesh made of its images
    (``geometries.plates.mirrored_sector_mesh``): the displacement reflected
    (``reflect_displacement``) and the rotations and thickness stretches solved for it on
    ``fixed``, a shell on the full mesh whose whole displacement is prescribed to ``u`` (give it the
    wedge's material, rotation conditions and load parameter values). The state it returns is an
    equilibrium of the full shell where the wedge's is one of the wedge."""

    def __init__(self, wedge_mesh: ngs.Mesh, fixed: GelShell, k: int):
        self.wedge_mesh, self.fixed, self.k = wedge_mesh, fixed, k
        self.u = ngs.GridFunction(ngs.VectorH1(fixed.mesh, order=fixed.order))
        for i, component in enumerate("xyz"):
            fixed.prescribe_region(".*", component, self.u[i])

    def state(self, wedge: GelShell) -> np.ndarray:
        reflect_displacement(wedge.displacement, self.wedge_mesh, self.u, self.fixed.mesh, self.k)
        self.fixed.space  # builds the forms and the state
        self.fixed.gf.components[0].vec.data = self.u.vec
        self.fixed.solve(atol=FULL_DISK_ATOL)  # (starts from the last state's rotations and stretches)
        return self.fixed.save_state()


def on_full_disk(wedge: MirrorShell, wedge_mesh: ngs.Mesh, k: int, *, p: float, maxh: float, order: int, t: float,
                 n0: float, nR: float, base_sectors: int, eigenvalues: int = 6, vtk: Path | None = None,
                 progress=None) -> dict:
    """The wedge's end state as a state of the full disk: the displacement reflected, rotations and
    thickness stretches solved for it (displacement prescribed), then the full disk's Newton from
    there (no symmetry imposed); its energy, exact negative count, lowest eigenvalues with their
    modes' wave numbers, the deflection ``rim_w`` on the rim circle, and how far Newton moved the
    reflected displacement. ``vtk``: where to write the state as a VTK file (``shell_fields`` and
    ``lowest_mode``, the displacement of the lowest eigenvalue's mode; default: not written)."""
    mu = wedge.mu_value()
    shell, mesh, pins = full_plate(p, maxh=maxh, order=order, t=t, n0=n0, nR=nR, base_sectors=base_sectors)
    reflection = Reflection(wedge_mesh, _graded(GelShell, mesh, p, t=t, order=order, n0=n0, nR=nR, realcompile=False),
                            k)
    reflection.fixed.mu.Set(mu)
    state = reflection.state(wedge)
    u = reflection.u
    reflected = u.vec.FV().NumPy().copy()
    for (point, component), parameter in pins.items():
        parameter.Set(u(mesh(*point, ngs.BND))["xyz".index(component)])
    shell.mu.Set(mu)
    shell.restore_state(state)
    residual_start = _free_residual(shell)
    newton = shell.solve(atol=FULL_DISK_ATOL)
    moved = float(np.max(np.abs(shell.displacement.vec.FV().NumPy() - reflected)))
    with ngs.TaskManager():
        K = free_matrix(shell.tangent(shell.state), shell.free_mask)
        M = free_matrix(mass_matrix(shell), shell.free_mask)
    lowest = spectrum(shell, count=eigenvalues, K=K, M=M)
    mode = ngs.GridFunction(shell.space)
    modes = []
    for value, vector in zip(lowest.eigenvalues, lowest.modes.T):
        full = np.zeros(shell.space.ndof)
        full[shell.free_mask] = vector
        mode.vec.FV().NumPy()[:] = full
        modes.append({"eigenvalue": float(value), **_mode_wave(mode.components[0], mesh)})
    values = np.array([shell.displacement[2](mesh(RIM_RADIUS * math.cos(a), RIM_RADIUS * math.sin(a), 0.0, ngs.BND))
                       for a in 2 * math.pi * np.arange(RIM_SAMPLES) / RIM_SAMPLES])
    content = rim_content(values)
    if vtk is not None:
        mode.vec.FV().NumPy()[:] = 0.0
        mode.vec.FV().NumPy()[shell.free_mask] = lowest.modes[:, 0]
        VTKSeries(mesh, {**shell_fields(shell), "lowest_mode": mode.components[0]}, vtk, derived_order=shell.order).write(mu)
    radii = np.linspace(0.05, RIM_RADIUS, 24)
    amplitude = [wave_number(np.array([shell.displacement[2](mesh(r * math.cos(a), r * math.sin(a), 0.0, ngs.BND))
                                       for a in 2 * math.pi * np.arange(RIM_SAMPLES) / RIM_SAMPLES]),
                             max_mode=RIM_MODES).spectrum[content["rim_k"]] for r in radii]
    return {"ndof": shell.space.ndof, "energy": shell.energy(), "residual_reflected": residual_start,
            "newton_iterations": newton.iterations, "max_displacement_change": moved,
            "negative": lowest.negative, "modes": modes, "rim": content, "rim_w": values.tolist(),
            "l_5%": penetration_depth(np.array(amplitude), radii), "state": shell.save_state()}


def _free_residual(shell: GelShell) -> float:
    r = shell.state.CreateVector()
    shell.residual(shell.state, r)
    return float(np.linalg.norm(r.FV().NumPy()[shell.free_mask]))


def _mode_wave(mode_u, mesh: ngs.Mesh) -> dict:
    """Wave number of a mode's deflection on the circle (r/R = 0.3 ... 0.95) where it is largest."""
    best = None
    for rho in np.linspace(0.3, 0.95, 14):
        values = np.array([mode_u[2](mesh(rho * math.cos(a), rho * math.sin(a), 0.0, ngs.BND))
                           for a in 2 * math.pi * np.arange(64) / 64])
        analysis = wave_number(values, max_mode=12)
        if best is None or analysis.amplitude > best[1].amplitude:
            best = (float(rho), analysis)
    return {"k": best[1].k, "purity": best[1].purity, "k_second": best[1].second, "mode_radius": best[0]}


def run(out: str, *, p: float, ks: tuple[int, ...] = (2, 4, 5), maxh: float = 0.2, order: int = 3, t: float = 0.01,
        n0: float = GRADED_N0, nR: float = GRADED_NR, base_sectors: int = BASE_SECTORS, mu_start: float = MU_START,
        step: float | None = None, jump: bool = False, load: str = "stretch", realcompile: bool = False,
        protocol: str = "path", start_state: str | None = None) -> dict:
    """For each wave number in ``ks``: the wedge's path to ``mu = 0`` (``protocol`` 'path':
    ``follow_wedge``, 'relax': ``relax_wedge``, which may go on from the saved wedge state
    ``start_state`` of the one k) and its end state on the full disk (``on_full_disk``);
    ``summary.json`` tabulates them with the energies relative to the lowest k (k = 2 when
    computed: the full disk's first pattern)."""
    for k in ks:
        check_wave(k, base_sectors)
    if protocol not in PROTOCOLS:
        raise ValueError(f"protocol must be one of {PROTOCOLS}, got {protocol!r}")
    if start_state is not None and (protocol != "relax" or len(ks) != 1):
        raise ValueError(f"start_state is for protocol 'relax' and one k, got protocol {protocol!r} and ks {ks!r}")
    run_dir = RunDirectory(out, params=dict(p=p, ks=list(ks), maxh=maxh, order=order, t=t, n0=n0, nR=nR,
                                            base_sectors=base_sectors, mu_start=mu_start, step=step, jump=jump,
                                            load=load, protocol=protocol, start_state=start_state))
    progress = Progress("plate_wedges")
    rows = {}
    for k in ks:
        clock = time.perf_counter()
        wedge, mesh = wedge_plate(p, k, maxh=maxh, order=order, t=t, n0=n0, nR=nR, base_sectors=base_sectors,
                                  realcompile=realcompile, load=load)
        if protocol == "relax":
            path = relax_wedge(wedge, mesh, k, run_dir=run_dir, mu_start=mu_start, step=step, start=start_state,
                               progress=progress)
        else:
            path = follow_wedge(wedge, mesh, k, run_dir=run_dir, mu_start=mu_start, step=step, jump=jump,
                                progress=progress)
        np.savez(run_dir.file(f"wedge_state_k{k}.npz"), state=wedge.save_state(), mu=wedge.mu_value())
        full = on_full_disk(wedge, mesh, k, p=p, maxh=maxh, order=order, t=t, n0=n0, nR=nR,
                            base_sectors=base_sectors, vtk=run_dir.series(f"full_k{k}"), progress=progress)
        np.savez(run_dir.file(f"state_k{k}.npz"), state=full.pop("state"), mu=wedge.mu_value())
        rows[k] = {"k_wedge": k, "energy_full": full["energy"], "energy_wedge_times_2k": 2 * k * path["energy_wedge"],
                   "wedge": path, "full": full, "wall_s": time.perf_counter() - clock}
        run_dir.write_json(f"wedge_k{k}.json", rows[k])
        progress(f"k = {k}: full-disk energy {full['energy']:.10g}, negative {full['negative']}, rim k "
                 f"{full['rim']['rim_k']} (purity {full['rim']['rim_purity']:.2f})")
    reference_k = 2 if 2 in rows else min(rows, key=lambda k: rows[k]["energy_full"])
    reference = rows[reference_k]["energy_full"]
    table = [{"k_wedge": k, "rim_k": r["full"]["rim"]["rim_k"], "rim_purity": r["full"]["rim"]["rim_purity"],
              "rim_crests": r["full"]["rim"]["rim_crests"], "energy": r["energy_full"],
              "energy_minus_reference": r["energy_full"] - reference,
              "negative_full": r["full"]["negative"], "lowest_modes": r["full"]["modes"][:4],
              "l_5%": r["full"]["l_5%"], "newton_iterations_full": r["full"]["newton_iterations"],
              "max_displacement_change": r["full"]["max_displacement_change"], "wall_s": r["wall_s"]}
             for k, r in rows.items()]
    summary = {"p": p, "maxh": maxh, "order": order, "ndof_full": next(iter(rows.values()))["full"]["ndof"],
               "table": table}
    run_dir.write_json("summary.json", summary)
    plot(run_dir, rows, reference_k=reference_k, protocol=protocol, load=load,
         title=f"p = {p:g}, h = {maxh:g} R, order {order}, protocol {protocol}")
    return summary


def plot(run_dir: RunDirectory, rows: dict[int, dict], *, reference_k: int, protocol: str, load: str,
         title: str) -> Path:
    """``plate_wedges.png`` next to ``summary.json``: left, the deflection w(theta) on the rim circle
    of each k's end state on the full disk (``rows``, as ``run`` makes them; in the legend its
    energy relative to that of ``reference_k`` and its negative count); right, each wedge's rim
    wave amplitude against the load (the rows of the ``protocol``'s history, ``HISTORIES``;
    ``load``: the load's kind, ``LOADS``)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    theta = 360 * np.arange(RIM_SAMPLES) / RIM_SAMPLES
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5))
    for k, row in rows.items():
        full = row["full"]
        ax.plot(theta, full["rim_w"], label=f"k = {k}: E - E(k = {reference_k}) = "
                f"{row['energy_full'] - rows[reference_k]['energy_full']:.2g}, {full['negative']} negative")
        name, load_column = HISTORIES[protocol]
        with open(run_dir.file(name.format(k=k)), newline="") as file:
            path = [(float(r[load_column]), float(r["rim_amplitude"])) for r in csv.DictReader(file)]
        bx.plot(*zip(*path), ".-", ms=3, label=f"k = {k}")
    ax.set_xlabel("theta [deg]")
    ax.set_ylabel(f"w at r = {RIM_RADIUS} R, full disk at mu = 0 [R]")
    ax.legend(fontsize=8)
    bx.set_xlabel({"mu": "mu [kT]", "stretch": "softer gel's free-swelling stretch"}[load])
    bx.set_ylabel("wedge's rim wave amplitude [R]")
    bx.legend(fontsize=8)
    fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    target = run_dir.file("plate_wedges.png")
    fig.savefig(target, dpi=130)
    plt.close(fig)
    return target


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/plate_wedges",
                          quick="p = 0.75, k = 4 only, h = 0.3 R")
    parser.add_argument("--p", type=float, default=0.75, help="grading exponent p of Nv(r) = n0 + (nR - n0) (r/R)^p")
    parser.add_argument("--k", type=int, nargs="+", default=[2, 4, 5],
                        help="wedge wave numbers: wedges of angle pi/k (each must divide --base-sectors)")
    parser.add_argument("--maxh", type=float, default=0.2, help="element size of the base sector's mesh / R")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the shell's displacement (2 or 3)")
    parser.add_argument("--t", type=float, default=0.01, help="thickness t / disk radius R")
    parser.add_argument("--base-sectors", type=int, default=BASE_SECTORS,
                        help="the base sector's angle is pi / this (dimensionless count)")
    parser.add_argument("--mu-start", type=float, default=MU_START, help="the flat wedge's start, below its onset (kT)")
    parser.add_argument("--load", choices=LOADS, default="stretch",
                        help="the path's load parameter: the softer gel's free-swelling stretch (mu its function; "
                             "steps near mu = 0 are steps in mismatch) or mu itself (kT; the runs before 2026-12-05 "
                             "evening)")
    parser.add_argument("--step", type=float, default=None,
                        help="largest natural step: in the free-swelling mismatch (load stretch; default 0.005) "
                             "or in mu (kT; default 0.05)")
    parser.add_argument("--jump", action="store_true",
                        help="relax at mu = 0 from the onset's critical state instead of following the buckled "
                             "wedge in mu from 0.02 past its onset (the jump ended on unstable states at p = 0.75)")
    parser.add_argument("--protocol", choices=PROTOCOLS, default="path",
                        help="path: natural continuation with located losses of stability and snaps "
                             "(follow_wedge); relax: load steps each relaxed to a stable equilibrium (relax_wedge)")
    parser.add_argument("--start-state", default=None, metavar="FILE",
                        help="protocol relax, one --k: go on from this saved wedge state (a relax_state_*.npz with "
                             "state and load; default: none, start flat at --mu-start)")
    parser.add_argument("--realcompile", action="store_true", help="compile the residual to C++ (~20 s per shell)")
    args = parser.parse_args(argv)
    p, ks, maxh = args.p, tuple(args.k), args.maxh
    if quick_run(args):
        p, ks, maxh = 0.75, (4,), 0.3
    with silence_progress(args.quiet):
        summary = run(args.out, p=p, ks=ks, maxh=maxh, order=args.order, t=args.t, base_sectors=args.base_sectors,
                      mu_start=args.mu_start, step=args.step, jump=args.jump, load=args.load,
                      realcompile=args.realcompile, protocol=args.protocol, start_state=args.start_state)
    print(json.dumps(summary, indent=1, default=str))
    return summary


if __name__ == "__main__":
    main()
