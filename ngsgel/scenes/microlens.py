"""Hydrogel microlens under an apex load (thesis ch. 3, MODEL.md scene A): the load-depth path of
the clamped cap with every event, the vertex count along it, the gel volume change and the fits
of the thesis.

The cap (base radius ``R = 1``, apex height ``H``, mid-surface radius ``r = (R^2 + H^2)/(2H)``,
thickness ``t = 0.005 r``, ``Nv = 1e-3``, ``chi = 0.5``, ``mu = 0``, base clamped, or with
``--edge hinged`` held on its mid-surface circle and free to rotate) is pushed at its apex under
displacement control (an apex patch of radius ``--apex`` carries the prescribed displacement, the
stand-in for the thesis's concentrated displacement). The path is followed by
pseudo-arclength, so limit points in depth (snap-through under displacement control) are passed
and the jump at fixed depth is measured on the path itself. Force ``F`` is the reaction
work-conjugate to the depth (``ngsgel.stability.conjugate_force``), reported as ``F/(E0 t^2)``
with the thesis's ``E0 = 3 Nv / lam0``; depth as ``d/H``.

Models (``--model``):

- ``axisymmetric``: the r-z section (vertical loads). At every state the second variation is
  scanned over wave numbers ``k = 1 .. kmax`` (``ngsgel.harmonic``, exact for the 3D cap); the
  first negative eigenvalue is bisected to the depth where the cap leaves the axisymmetric path
  and its ``k`` (the number of vertices of the first polygonal state). Past that depth the
  section follows the axisymmetric branch, now unstable: the ``k`` that are unstable there are
  recorded but are not the post-buckled vertex counts. ``--mu-at DEPTH --mu-to MU`` then
  changes ``mu`` at that depth with the indenter holding the depth or (``--hold force``) the
  force, and records which ``k`` are unstable at each ``mu`` (``mu_change.csv``): where the
  axisymmetric state is stable again, a polygonal state has no reason to stay.
- ``shell``: ``ngsgel.shell.GelShell`` on the cap's mid-surface (by default the half cap
  ``y >= 0`` with mirror symmetry, which carries every ``cos k theta`` pattern and the lateral
  load along x). The depth is stepped by natural-parameter continuation (displacement control,
  as an experiment: where the path ends at a limit point the run stops and says so) with the
  exact negative count of the shell's tangent at every state; each change is located and the run
  switches onto the bifurcated branch of fewer negative eigenvalues (``StabilityOptions``), so the
  path goes through the polygonal states. The vertex count along it is the dominant ``cos k
  theta`` of the normal deflection on circles of the mid-surface. ``--mu-at DEPTH --mu-to MU``
  then changes ``mu`` at that depth (the thesis's return of a 4-vertex state to axisymmetry).
  The shell needs the dimple's ridge resolved (width ``sqrt(t r)``): ``--maxh 0.05`` for
  ``H = 0.3`` (docs/microlens.md); a step costs minutes.

Fits (the symbols of the thesis's formulas are garbled in the seed; reconstructed here):

- inward, early: ``F/(E0 t^2) = C sqrt(d t)/r`` (the large-deflection point load of a thin
  shell, ``F ~ E t^(5/2) d^(1/2) / r``; the seed reads "F/Et^2 = 0.42 sqrt(td)/r"), least squares
  over ``d/H <= --fit-depth``; the thesis's ``C = 0.42``.
- outward: ``F/(E0 t^2) = C [(1 + d/H) - (1 + d/H)^-2]`` (uniaxial tension of an incompressible
  neo-Hookean solid, the form of the thesis's eq. 3-7); the coefficient is fitted.

    ngsgel run microlens --out results/microlens --H 0.1 --depth 1.0 [--quick]
    ngsgel run microlens --out results/microlens_out --H 0.2 --direction outward --depth 1.0
    ngsgel run microlens --out results/microlens_shell --model shell --maxh 0.05 --depth 1.6
    ngsgel run microlens --out results/microlens_mu --maxh 0.02 --mu-at 0.859 --mu-to=1.5e-4
    ngsgel run microlens --out results/microlens_rise --model shell --polygon 4 --polygon-at 0.859 --mu-to=1.6e-4 --mu-steps 16
    ngsgel run microlens --resume results/microlens_shell   # a stopped run, on from its last checkpoint
"""

from __future__ import annotations

import json
import math
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from scipy import optimize
import ngsolve as ngs

from geometries import cap_midsurface, cap_section
from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, NewtonError, follow_path, ramp
from ngsgel.continuation import Checkpoint, ContinuationError, Event, PathResult, Resumption, StabilityOptions
from ngsgel.harmonic import HarmonicStability, first_harmonic_instability
from ngsgel.output import (History, Progress, RunDirectory, VTKSeries, command_options, quick_run, resume_arguments,
                           scene_parser)
from ngsgel.patterns import WaveAnalysis, load_drops, periodic_peaks, wave_number
from ngsgel.relaxation import settle, settle_after
from ngsgel.shell import GelShell
from ngsgel.stepping import RampError
from ngsgel.stability import conjugate_force, growth_exponents
from ngsgel.supports import pin_vertex_component

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
THICKNESS_RATIO = 0.005  # t / r
DIRECTIONS = ("inward", "outward", "lateral")
EDGES = ("clamped", "hinged")
INDENTERS = ("sliding", "bonded")
AXISYMMETRIC_DIRECTIONS = ("inward", "outward")
MU_HOLDS = ("depth", "force")  # what the indenter keeps while mu changes (axisymmetric model)
BASE_MIDPOINT = (1.0, 0.0)  # (r, z) of the base's mid-surface circle in the section
JUMP_RATIO = 2.0  # a shell step converged farther from its predictor than this many increments jumped
# Next to a critical state of the shell path (H = 0.3R, d/H 1.36) Newton sits at a residual of
# ~3e-13 (1e-4 of its start, 1e3 above the driver's floor) for 30 iterations, 200 s, and the
# halved step lands nearer the critical state and fails the same way; the slowest converging step
# measured there plateaued for ~8 iterations: give up after 10 without halving
STALL_WINDOW = 10
# A try next to a fold that cannot converge cuts its residual by 0.2-0.7 % per iteration, each with
# six line-search cuts (20 s a try at d/H 1.79); the slow phases of steps that do converge drop
# 10 % or more per iteration: give up once three iterations, kept up, would not halve it in ten
STALL_TREND = 3


@dataclass(frozen=True)
class Indentation:
    """``H`` apex height over base radius, ``direction`` of the apex displacement, final
    ``depth`` in units of ``H``, ``mu`` of the bath, support of the base ``edge``: ``clamped``
    (the thesis's), or ``hinged`` (displacements of the base's mid-surface circle held, free to
    rotate: the support under which a shallow cap snaps through, docs/microlens.md), and the
    ``indenter`` on the apex patch: ``sliding`` (only the loaded component prescribed: a
    frictionless flat punch) or ``bonded`` (the other components held too: a sticking punch)."""

    H: float
    direction: str = "inward"
    depth: float = 1.0
    mu: float = 0.0
    edge: str = "clamped"
    indenter: str = "sliding"

    def __post_init__(self):
        if not (isinstance(self.H, (int, float)) and 0 < self.H <= 1):
            raise ValueError(f"H (apex height / base radius) must be in (0, 1], got {self.H!r}")
        if self.direction not in DIRECTIONS:
            raise ValueError(f"direction must be one of {DIRECTIONS}, got {self.direction!r}")
        if not (isinstance(self.depth, (int, float)) and 0 < self.depth <= 3):
            raise ValueError(f"depth (final depth / H) must be in (0, 3], got {self.depth!r}")
        if not (isinstance(self.mu, (int, float)) and -1 <= self.mu <= 0):
            raise ValueError(f"mu must be in [-1, 0], got {self.mu!r}")
        if self.edge not in EDGES:
            raise ValueError(f"edge must be one of {EDGES}, got {self.edge!r}")
        if self.indenter not in INDENTERS:
            raise ValueError(f"indenter must be one of {INDENTERS}, got {self.indenter!r}")

    @property
    def r(self) -> float:
        return (1 + self.H**2) / (2 * self.H)

    @property
    def t(self) -> float:
        return THICKNESS_RATIO * self.r

    @property
    def sign(self) -> float:
        """Sign of the prescribed apex displacement (vertical; lateral: along +x)."""
        return -1.0 if self.direction == "inward" else 1.0

    @property
    def component(self) -> str:
        """Component of the apex displacement that is prescribed."""
        return "x" if self.direction == "lateral" else "z"

    @property
    def depth_column(self) -> str:
        """The path column of the thesis's depth axis: ``d/R`` for a lateral load, ``d/H`` otherwise."""
        return "d_over_R" if self.direction == "lateral" else "d_over_H"


@dataclass(frozen=True)
class SectionResolution:
    """Cell length ``maxh`` along the section, ``layers`` across the wall, element ``order``,
    apex patch radius ``apex`` (cells of ``apex/4`` on it)."""

    maxh: float = 0.01
    layers: int = 2
    order: int = 3
    apex: float = 0.02

    def __post_init__(self):
        if not (0 < self.maxh <= 0.2):
            raise ValueError(f"maxh must be in (0, 0.2], got {self.maxh!r}")
        if not (isinstance(self.layers, int) and 1 <= self.layers <= 16):
            raise ValueError(f"layers must be an integer in [1, 16], got {self.layers!r}")
        if not (isinstance(self.order, int) and 1 <= self.order <= 6):
            raise ValueError(f"order must be an integer in [1, 6], got {self.order!r}")
        if not (0 < self.apex <= 0.2):
            raise ValueError(f"apex (patch radius / R) must be in (0, 0.2], got {self.apex!r}")


class AxisymmetricCap:
    """The cap's r-z section under a prescribed vertical apex displacement ``sign * depth``."""

    def __init__(self, case: Indentation, res: SectionResolution):
        if case.direction not in AXISYMMETRIC_DIRECTIONS:
            raise ValueError(f"direction must be one of {AXISYMMETRIC_DIRECTIONS} for the axisymmetric model "
                             f"(a lateral load needs --model shell), got {case.direction!r}")
        if case.edge == "hinged" and res.layers % 2:
            raise ValueError(f"a hinged edge needs an even number of layers (a vertex on the mid-surface), "
                             f"got layers = {res.layers}")
        self.case = case
        self.lam0 = GEL.lam_free(case.mu)
        self.force_scale = GEL.youngs_modulus(self.lam0) * case.t**2
        bundle = cap_section(H=case.H, t=case.t, maxh=res.maxh, layers=res.layers, apex_radius=res.apex,
                             apex_maxh=min(res.maxh, res.apex / 4))
        self.mesh = bundle.mesh
        self.volume0 = bundle.exact_volume
        self.depth = ngs.Parameter(0.0)
        self.problem = EquilibriumProblem(self.mesh, kinematics=Axisymmetric(), materials=GEL, lam0=self.lam0,
                                          mu=case.mu, order=res.order)
        self.problem.fix("axis", "r")
        self.problem.prescribe("apex", "z", case.sign * self.depth)
        if case.indenter == "bonded":
            self.problem.fix("apex", "r")
        if case.edge == "clamped":
            self.problem.fix("base")
            pins = []
        else:
            pins = [BASE_MIDPOINT]
            for component in (0, 1):
                pin_vertex_component(self.problem, point=BASE_MIDPOINT, component=component)
        self.harmonic = HarmonicStability(self.problem, pins=pins)

    def force(self) -> float:
        """``F/(E0 t^2)``: ``dE/d(depth)``, positive when the cap resists the prescribed motion."""
        return conjugate_force(self.problem, self.depth) / self.force_scale

    def volume_change(self) -> float:
        """Gel volume over its value in the free-swollen, unloaded cap, minus one."""
        p = self.problem
        return p.integrate(ngs.Det(p.deformation_gradient(p.displacement))) / self.volume0 - 1.0


@dataclass(frozen=True)
class ShellResolution:
    """Mid-surface element size ``maxh``, ``apex_maxh`` on the apex patch of radius ``apex``,
    displacement ``order``; ``half``: the half cap ``y >= 0`` with mirror symmetry; ``realcompile``:
    the shell's Python forms with the residual compiled to C++ (``GelShell``'s compiled kernels,
    used otherwise where a compiler exists, are faster)."""

    maxh: float = 0.05
    apex_maxh: float = 0.01
    order: int = 3
    apex: float = 0.02
    half: bool = True
    realcompile: bool = False

    def __post_init__(self):
        if not (0 < self.maxh <= 0.5):
            raise ValueError(f"maxh must be in (0, 0.5], got {self.maxh!r}")
        if not (0 < self.apex <= 0.2):
            raise ValueError(f"apex (patch radius / R) must be in (0, 0.2], got {self.apex!r}")
        if not (0 < self.apex_maxh <= self.maxh):
            raise ValueError(f"apex_maxh must be in (0, maxh = {self.maxh}], got {self.apex_maxh!r}")
        if not (isinstance(self.order, int) and 2 <= self.order <= 5):
            raise ValueError(f"order must be an integer in [2, 5] for the shell, got {self.order!r}")


@dataclass(frozen=True)
class CapWaves:
    """Waves of a cap's normal deflection ``w`` on the circle (about the point ``centre`` of the
    x axis) where its non-axisymmetric part is largest (horizontal radius ``radius``): the Fourier
    analysis (``None`` where every circle is exactly constant), and the number of bulges (outward
    peaks of ``w``) and dents (peaks of ``-w``) there, each of at least 0.1 of ``w``'s range
    (``ngsgel.patterns.periodic_peaks``). A pure ``cos k theta`` has ``k`` of each; a broken
    polygon (three dents of a four-fold arrangement) shows up here, not in the dominant ``k``."""

    radius: float
    analysis: WaveAnalysis | None
    bulges: int
    dents: int
    centre: float = 0.0


def _normal_deflection(u: ngs.CoefficientFunction, mesh: ngs.Mesh, *, r: float, zc: float, half: bool):
    """``w(x, y)``: the normal displacement ``u . (X - zc e_z)/r`` of a cap's mid-surface (sphere of
    radius ``r`` centred at height ``zc``; ``w > 0`` away from the centre) above the point
    ``(x, y)`` of the base plane; ``half``: the mesh is the half ``y >= 0`` of a mirror-symmetric
    cap (``u(x, y) = u(x, -y)``)."""
    w = ngs.InnerProduct(u, ngs.CF((ngs.x, ngs.y, ngs.z - zc)) / r)

    def at(x: float, y: float) -> float:
        return w(mesh(float(x), float(abs(y) if half else y), zc + math.sqrt(r * r - x * x - y * y), ngs.BND))
    return at


def cap_waves(u: ngs.CoefficientFunction, mesh: ngs.Mesh, *, r: float, zc: float, half: bool,
              radii=np.linspace(0.1, 0.9, 9), n: int = 64, centre: float = 0.0) -> CapWaves:
    """``CapWaves`` of the normal displacement ``w`` (``_normal_deflection``) sampled at ``n``
    angles on the circles of horizontal radii ``radii`` about the point ``(centre, 0)`` of the base
    plane (the axis by default; circles that would reach past 0.95 of the base radius are left
    out)."""
    w = _normal_deflection(u, mesh, r=r, zc=zc, half=half)
    theta = 2.0 * np.pi * np.arange(n) / n
    best = None
    for rho in radii:
        if abs(centre) + rho > 0.95:
            continue
        values = np.array([w(centre + rho * c, rho * s) for c, s in zip(np.cos(theta), np.sin(theta))])
        if np.ptp(values) == 0.0:  # exactly axisymmetric here (e.g. the unloaded cap): no wave
            continue
        analysis = wave_number(values, max_mode=12)
        if best is None or analysis.amplitude > best[1].amplitude:
            best = (float(rho), analysis, values)
    if best is None:
        return CapWaves(radius=float(radii[0]), analysis=None, bulges=0, dents=0, centre=centre)
    rho, analysis, values = best
    return CapWaves(radius=rho, analysis=analysis, bulges=periodic_peaks(values).count,
                    dents=periodic_peaks(-values).count, centre=centre)


def dimple_centre(u: ngs.CoefficientFunction, mesh: ngs.Mesh, *, r: float, zc: float, half: bool,
                  n: int = 181) -> float:
    """x of the deepest inward deflection on the cap's x axis: the centre of the dimple a lateral
    apex load pushes into the rear side (thesis fig. 3-5B), about which its vertices are counted;
    0 (the axis) where no inward deflection reaches a tenth of the largest one along the axis."""
    w = _normal_deflection(u, mesh, r=r, zc=zc, half=half)
    xs = np.linspace(-0.9, 0.9, n)
    values = np.array([w(x, 0.0) for x in xs])
    return float(xs[np.argmin(values)]) if -values.min() > 0.1 * np.abs(values).max() else 0.0


class ShellCap:
    """The cap as a ``GelShell`` under a prescribed apex displacement ``sign * depth`` along
    ``case.component`` (the apex patch moves rigidly), base clamped or hinged (``case.edge``)."""

    def __init__(self, case: Indentation, res: ShellResolution):
        self.case, self.res = case, res
        self.lam0 = GEL.lam_free(case.mu)
        self.force_scale = GEL.youngs_modulus(self.lam0) * case.t**2
        bundle = cap_midsurface(H=case.H, maxh=res.maxh, apex_radius=res.apex, apex_maxh=res.apex_maxh,
                                curve_order=res.order, half=res.half)
        self.mesh = bundle.mesh
        self.shell = GelShell(self.mesh, material=GEL, lam0=self.lam0, thickness=case.t, mu=case.mu,
                              order=res.order, realcompile=res.realcompile)
        if case.edge == "clamped":
            self.shell.clamp("base")
        else:
            self.shell.simply_support("base")
        if res.half:
            self.shell.symmetry("sym", normal="y")
        self.depth = ngs.Parameter(0.0)
        self.shell.prescribe_region("apex", case.component, case.sign * self.depth)
        if case.indenter == "bonded":
            for component in sorted({"x", "y", "z"} - {case.component}):
                self.shell.prescribe_region("apex", component, 0.0)
        self._waves = CapWaves(radius=0.0, analysis=None, bulges=0, dents=0)

    def force(self) -> float:
        """``F/(E0 t^2)`` of the whole cap (twice the half cap's)."""
        copies = 2.0 if self.res.half else 1.0
        return copies * conjugate_force(self.shell, self.depth) / self.force_scale

    def volume_change(self) -> float:
        return self.shell.volume_ratio() - 1.0

    def update_waves(self) -> float:
        """Vertex count of the current state, on circles about the apex (a lateral load: about the
        dimple it pushes into the rear side, ``dimple_centre``): 0 while the dominant wave's normal
        deflection is below 0.05 t (the discretisation's own asymmetry and the growth of the
        critical mode just before a bifurcation stay below: 0.005 t at 0.99 of the onset depth,
        h = 0.05)."""
        geometry = {"r": self.case.r, "zc": self.case.H - self.case.r, "half": self.res.half}
        centre = dimple_centre(self.shell.displacement, self.mesh, **geometry) if self.case.direction == "lateral" else 0.0
        self._waves = cap_waves(self.shell.displacement, self.mesh, centre=centre, **geometry)
        return self.vertices()

    @property
    def waves(self) -> CapWaves:
        """The wave analysis of the last ``update_waves``."""
        return self._waves

    def vertices(self) -> float:
        """The vertex count of the last ``update_waves``."""
        return float(self._waves.analysis.k) if self._patterned() else 0.0

    def _patterned(self) -> bool:
        return self.wave_amplitude() > 0.05

    def state_label(self) -> str:
        """The current state in two lines (of the last ``update_waves``), for figure titles."""
        case = self.case
        depth = self.depth.Get()
        return (f"H/R = {case.H:g}, {case.direction}, d/H = {depth / case.H:.4f} (d/R = {depth:.4f}), mu = "
                f"{self.shell.mu.Get():.3g}\nvertices k = {self.vertices():.0f}, dents = {self.dents():.0f}")

    def wave_centre(self) -> float:
        """x of the centre of the last ``update_waves``' circles (0: the apex)."""
        return self._waves.centre

    def wave_amplitude(self) -> float:
        """Amplitude of the dominant wave over ``t`` (of the last ``update_waves``)."""
        analysis = self._waves.analysis
        return 0.0 if analysis is None else analysis.amplitude / self.case.t

    def second_wave(self) -> float:
        """The runner-up wave number on the same circle (a broken symmetry of the polygon shows
        here first: e.g. 4 or 5 next to a dominant 3)."""
        analysis = self._waves.analysis
        return 0.0 if analysis is None else float(analysis.second)

    def second_amplitude(self) -> float:
        analysis = self._waves.analysis
        return 0.0 if analysis is None else analysis.spectrum[analysis.second] / self.case.t

    def dents(self) -> float:
        """Inward peaks of the deflection on the wave's circle (0 while the last ``update_waves`` found
        no pattern)."""
        return float(self._waves.dents) if self._patterned() else 0.0

    def bulges(self) -> float:
        """Outward peaks of the deflection on the wave's circle (0 while the last ``update_waves``
        found no pattern)."""
        return float(self._waves.bulges) if self._patterned() else 0.0


def shell_qoi(cap: ShellCap) -> dict:
    """The quantities a shell path records at every state."""
    H = cap.case.H
    return {"d_over_H": lambda: cap.depth.Get() / H, "d_over_R": cap.depth.Get, "mu": lambda: cap.shell.mu.Get(),
            "force": cap.force,
            "volume_change": cap.volume_change, "k": cap.update_waves, "wave_amplitude_over_t": cap.wave_amplitude,
            "k_second": cap.second_wave, "second_amplitude_over_t": cap.second_amplitude, "dents": cap.dents,
            "bulges": cap.bulges, "wave_centre": cap.wave_centre}


def indent_axisymmetric_shell(cap: ShellCap, target: float, *, step: float, history=None, vtk=None,
                              progress=None, checkpoint_file=None, resume: Checkpoint | None = None) -> PathResult:
    """The shell pushed to the depth ``target`` along its axisymmetric branch: natural steps
    without stability analysis, so the path stays on that branch past its bifurcations (nothing
    but round-off seeds a non-axisymmetric mode, and Newton converges to the nearest equilibrium,
    stable or not). A step Newton cannot make raises (``ContinuationError``).
    ``checkpoint_file``/``resume``: see ``follow_path``."""
    return follow_path(cap.shell, cap.depth, method="natural", step=step, max_step=step, target=target,
                       min_step=step / 16, qoi=shell_qoi(cap), history=history, vtk=vtk, progress=progress,
                       newton_options={"reuse_factorisation": True}, checkpoint_file=checkpoint_file, resume=resume)


def check_polygon(k: int, amplitude: float, *, at: float | None = None, depth: float | None = None) -> None:
    """Bad input of a polygonal push (``at``, ``depth``: its depth / H and the run's final one)."""
    if at is not None and not 0 < at <= depth:
        raise ValueError(f"polygon_at (depth / H) must be in (0, depth = {depth}], got {at!r}")
    if not (isinstance(k, int) and k >= 2):
        raise ValueError(f"polygon must be an integer wave number >= 2, got {k!r}")
    if not (math.isfinite(amplitude) and amplitude > 0):
        raise ValueError(f"polygon amplitude must be a finite number > 0 (thicknesses), got {amplitude!r}")


def push_into_polygon(cap: ShellCap, k: int, *, amplitude: float, progress=None) -> dict:
    """Push the current (axisymmetric) state by a ``k``-fold normal deflection of ``amplitude``
    thicknesses, ``cos(k theta) sin^2(pi s)`` (``s`` from 0 at the apex patch's rim to 1 at the base,
    so the patch and the clamped base keep their values and slopes), and relax it at the current
    load by the overdamped flow (``ngsgel.relaxation.settle``) to a stable state: the polygonal
    state the cap holds at this depth, if that lies in the basin the push reaches. Returns the
    record of the relaxation and of the state it ends in."""
    check_polygon(k, amplitude)
    case = cap.case
    rho = ngs.sqrt(ngs.x * ngs.x + ngs.y * ngs.y)
    a = cap.res.apex
    s = (rho - a) / (1.0 - a)
    normal = ngs.CF((ngs.x, ngs.y, ngs.z - (case.H - case.r))) / case.r
    shape = ngs.IfPos(rho - a, ngs.sin(math.pi * s) ** 2, 0.0) * ngs.cos(k * ngs.atan2(ngs.y, ngs.x))
    push = ngs.GridFunction(cap.shell.gf.components[0].space)
    push.Set(amplitude * case.t * shape * normal, definedon=cap.mesh.Boundaries(".*"))
    cap.shell.gf.components[0].vec.data += push.vec
    k_pushed, amplitude_pushed = cap.update_waves(), cap.wave_amplitude()
    clock = time.perf_counter()
    settled = settle(cap.shell, parameter=cap.depth, progress=progress)
    return {"k": k, "push_over_t": amplitude, "k_pushed": k_pushed, "amplitude_pushed_over_t": amplitude_pushed,
            "d_over_H": cap.depth.Get() / case.H, "mu": cap.shell.mu.Get(), "force": cap.force(),
            "k_after": cap.update_waves(), "amplitude_after_over_t": cap.wave_amplitude(),
            "second_after": cap.second_wave(), "second_amplitude_after_over_t": cap.second_amplitude(),
            "dents_after": cap.dents(), "energy_drop": settled.energy_drop, "distance": settled.distance,
            "pseudo_time_steps": settled.steps, "rejected": settled.rejected,
            "lowest_eigenvalue": settled.lowest_eigenvalue, "wall_s": time.perf_counter() - clock}


def follow_shell(cap: ShellCap, parameter: ngs.Parameter, target: float, *, step: float, max_step: float,
                 history=None, vtk=None, progress=None, stage: str = "indentation", checkpoint_file=None,
                 restart: Checkpoint | None = None, resume: Checkpoint | None = None) -> PathResult:
    """Natural-parameter path of ``parameter`` (the depth or ``mu``) to ``target`` with exact
    stability (the negative count at every state, eigenpairs only where it changes), location of
    every change to ``2e-3 H`` (depth) or ``step / 50`` (mu) and a switch onto the bifurcated
    branch; each step guessed by the parabola through the last two states (``ramp``'s quadratic
    predictor); steps that converge far from their predictor (``JUMP_RATIO``) or whose Newton solve
    does not halve its residual in ``STALL_WINDOW`` iterations (or, at the rate of its last
    ``STALL_TREND``, would not) are cut as failed. A path that cannot go on (a limit point under
    displacement control) ends with ``stop_reason`` "stalled: ..." instead of raising; one left on
    an unstable branch (the location or the branch switch failed) stops there ("criterion").
    ``checkpoint_file``/``restart``/``resume``: see ``follow_path``."""
    case = cap.case
    tol = 2e-3 * case.H if parameter is cap.depth else step / 50
    try:
        # a step cut to 1/16 of the first has met a state Newton cannot reach: stop there (stalled)
        return follow_path(cap.shell, parameter, method="natural", step=step, max_step=max_step, target=target,
                           min_step=step / 16,
                           stability=StabilityOptions(tol=tol, switch=True, length=case.t, amplitude=0.1),
                           qoi=shell_qoi(cap), history=history, vtk=vtk, progress=progress,
                           checkpoint_file=checkpoint_file, restart=restart, resume=resume,
                           # on an unstable branch: a change whose location or branch switch failed
                           stop=lambda pt: pt.negative > 0,
                           # two stable states coexist on some paths (lateral 0.6R, bonded patch): a
                           # large step can converge onto the other one, which no eigenvalue shows
                           max_correction=JUMP_RATIO,
                           # 3 Newton iterations from the parabola against 4-5 from the secant
                           predictor="quadratic",
                           # no chord steps: with the compiled kernels one costs a third of an
                           # iteration, and next to the folds an old factorisation puts the step
                           # off along the soft mode, which the residual norm barely sees (d/H 1.62:
                           # 2 chord steps then 4 iterations stuck at 2e-12, 6.7 s against 3.6 s)
                           # line search by interpolation: 6 residuals instead of 15 in a failed try
                           # next to a fold (d/H 1.94); the whole path 19:52 -> 18:39
                           newton_options={"reuse_factorisation": False, "stall_window": STALL_WINDOW,
                                           "stall_trend": STALL_TREND, "backtrack": "quadratic"})
    except ContinuationError as error:
        result = error.result
        result.stop_reason = f"stalled in the {stage}: {error}"
        return result


class HarmonicMonitor:
    """Lowest eigenvalue of each wave number ``1 .. kmax`` at the current state (rigid ``k = 1``
    modes excluded), computed once per state for the path's quantities of interest."""

    def __init__(self, cap: AxisymmetricCap, kmax: int):
        self.cap, self.ks = cap, list(range(1, kmax + 1))
        self.lowest: dict[int, float] = {}

    def update(self) -> float:
        self.lowest = self.cap.harmonic.scan(self.ks, exclude_rigid=True).lowest
        return min(self.lowest.values())

    def critical_k(self) -> float:
        return float(min(self.lowest, key=self.lowest.get))

    def unstable_count(self) -> float:
        return float(sum(v < 0 for v in self.lowest.values()))


def follow_axisymmetric(cap: AxisymmetricCap, *, kmax: int, step: float, max_step: float,
                        target: float | None = None, history=None, vtk=None, progress=None, checkpoint_file=None,
                        resume: Checkpoint | None = None) -> PathResult:
    """The axisymmetric path to the depth ``target`` (default: the case's final depth) by
    arclength, with the exact axisymmetric stability (limit points, axisymmetric bifurcations)
    and the harmonic scan at every state. ``checkpoint_file``/``resume``: see ``follow_path``
    (the checkpoint keeps every state: ``first_nonaxisymmetric`` starts from one of them)."""
    monitor = HarmonicMonitor(cap, kmax)
    qoi = {"d_over_H": lambda: cap.depth.Get() / cap.case.H, "force": cap.force,
           "volume_change": cap.volume_change, "lowest_nonaxisymmetric": monitor.update,
           "k_lowest": monitor.critical_k, "unstable_k_count": monitor.unstable_count,
           **{f"lowest_k{k}": (lambda k=k: monitor.lowest[k]) for k in monitor.ks}}
    return follow_path(cap.problem, cap.depth, method="arclength", step=step, max_step=max_step,
                       min_step=step * 1e-4, target=cap.case.depth * cap.case.H if target is None else target,
                       max_steps=400, qoi=qoi,
                       stability=StabilityOptions(eigenvalues=1, locate=True, tol=1e-5 * cap.case.H),
                       keep_states=True, history=history, vtk=vtk, progress=progress, checkpoint_file=checkpoint_file,
                       resume=resume)


def first_nonaxisymmetric(cap: AxisymmetricCap, path: PathResult, *, kmax: int) -> dict | None:
    """Bisect the first step where a wave number ``k >= 1`` turns unstable (from the state before
    it, on the same branch) to ``1e-4 H``."""
    points = path.points
    first = next((i for i, pt in enumerate(points) if pt.qoi["lowest_nonaxisymmetric"] < 0), None)
    if first is None:
        return None
    if first == 0:
        raise RuntimeError("the unloaded cap is already unstable")
    before = points[first - 1]
    if points[first].parameter <= before.parameter:
        raise RuntimeError(f"the first non-axisymmetric instability lies on a part of the path where the "
                           f"depth decreases (steps {first - 1}, {first}); bisection in depth is not possible")
    cap.problem.restore_state(before.state)
    cap.depth.Set(before.parameter)
    found = first_harmonic_instability(cap.problem, cap.depth, points[first].parameter, ks=list(range(kmax + 1)),
                                       step=(points[first].parameter - before.parameter) / 2,
                                       tolerance=1e-4 * cap.case.H, stability=cap.harmonic)
    if not found.found:
        raise RuntimeError(f"the harmonic scan found k = {points[first].qoi['k_lowest']:.0f} unstable at step "
                           f"{first} but not when re-solving from step {first - 1}")
    cap.depth.Set(found.parameter)
    cap.problem.solve()
    return {"d_over_H": found.parameter / cap.case.H, "k": found.k, "force": cap.force(),
            "volume_change": cap.volume_change(), "path_step": first}


def growth_along_path(case: Indentation, path: PathResult) -> dict:
    """Growth exponents of the wave numbers on the axisymmetric path, read as a run with viscous
    stabilisation and no imperfection (the thesis's Abaqus runs, sec. 3.2) would see it: with the
    depth ramped at a constant rate under the overdamped flow ``c M dx/dtau = -K x``, wave number
    k grows by ``exp(G_k / (c d'))`` after it loses stability, ``G_k = int max(0, -omega_k) dd``
    (``ngsgel.stability.growth_exponents``; ``omega_k`` the lowest eigenvalue of k with the
    harmonic scan's mass ``int |u|^2 dV``, depth ``d`` in units of R). A pattern becomes visible
    where the largest ``G_k`` reaches ``T = c d' ln(A / a0)``, one number of the run: departing at
    depth ``d`` means ``T = max_k G_k(d)`` and the pattern seen first is its argmax. Rows: per
    path state on the path's first stretch of strictly increasing depth (the exponents need a
    monotonic load), ``G_k``, the leading k and its ``G``; ``depths`` (d/H) and ``G`` as arrays."""
    d = path.column("d_over_H") * case.H
    end = next((i for i in range(1, d.size) if d[i] <= d[i - 1]), d.size)
    ks = sorted(int(name[len("lowest_k"):]) for name in path.points[0].qoi if name.startswith("lowest_k"))
    depths = d[:end] / case.H
    if end < 2 or not ks:
        return {"rows": [], "ks": ks, "depths": depths, "G": np.zeros((end, len(ks))),
                "until_d_over_H": float(d[end - 1] / case.H)}
    omega = np.array([[pt.qoi[f"lowest_k{k}"] for k in ks] for pt in path.points[:end]])
    G = growth_exponents(d[:end], omega)
    rows = []
    for i in range(end):
        lead = int(np.argmax(G[i]))
        rows.append({"d_over_H": float(depths[i]), "leading_k": ks[lead] if G[i, lead] > 0 else 0,
                     "threshold": float(G[i, lead]), **{f"G_k{k}": float(G[i, j]) for j, k in enumerate(ks)}})
    return {"rows": rows, "ks": ks, "depths": depths, "G": G, "until_d_over_H": float(d[end - 1] / case.H)}


def draw_growth(case: Indentation, growth: dict, departures: list[dict], filename) -> None:
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    depths = growth["depths"]
    for k, G in zip(growth["ks"], growth["G"].T):
        if np.any(G > 0):
            ax.semilogy(depths, np.where(G > 0, G, np.nan), "-", lw=1, label=f"k = {k}")
    for dep in departures:
        if dep.get("threshold"):
            ax.plot(dep["d_over_H"], dep["threshold"], "ko", ms=4)
            ax.annotate(f" k = {dep['k']}", (dep["d_over_H"], dep["threshold"]), fontsize=8)
    ax.set_xlabel("d/H")
    ax.set_ylabel("growth exponent G_k (depth in R)")
    ax.set_title(f"H/R = {case.H:g}: growth of the unstable wave numbers on the axisymmetric path", fontsize=9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(filename, dpi=130)
    plt.close(fig)


def departure(growth: dict, d_over_H: float) -> dict | None:
    """The threshold ``T`` at which a stabilised run leaves the axisymmetric path at ``d_over_H``
    and the wave number it shows (``growth_along_path``; ``G_k`` linear between the states).
    None beyond the analysed path."""
    depths = growth["depths"]
    if not growth["rows"] or not depths[0] <= d_over_H <= depths[-1]:
        return None
    G = np.array([np.interp(d_over_H, depths, column) for column in growth["G"].T])
    order = np.argsort(G)[::-1]
    return {"d_over_H": d_over_H, "threshold": float(G[order[0]]), "k": growth["ks"][order[0]] if G[order[0]] > 0 else 0,
            "runner_up_k": growth["ks"][order[1]], "runner_up_ratio": float(G[order[1]] / G[order[0]]) if G[order[0]] > 0 else 0.0}


def snap_drops(path: PathResult) -> list[dict]:
    """Jumps at fixed depth past each limit point in depth: the structure under displacement
    control leaves the path at a depth maximum and lands where the path next returns to that depth
    with its depth increasing again. ``drop`` is ``1 - F_after / F_before``."""
    d = path.column("parameter")
    f = path.column("force")
    drops = []
    for i in range(1, len(d) - 1):
        if d[i] >= d[i - 1] and d[i] > d[i + 1]:  # a depth maximum: snap
            lim_d, lim_f = d[i], f[i]
            for j in range(i + 1, len(d) - 1):
                if d[j] < lim_d <= d[j + 1]:
                    s = (lim_d - d[j]) / (d[j + 1] - d[j])
                    after = f[j] + s * (f[j + 1] - f[j])
                    drops.append({"depth": float(lim_d), "force_before": float(lim_f), "force_after": float(after),
                                  "drop": float(1 - after / lim_f), "limit_step": i, "landing_step": j + 1})
                    break
            else:
                drops.append({"depth": float(lim_d), "force_before": float(lim_f), "force_after": None,
                              "drop": None, "limit_step": i, "landing_step": None})
    return drops


def force_maxima(path: PathResult) -> list[dict]:
    """Local maxima of the force along the path and the following minimum: a segment of negative
    stiffness, where a force-controlled cap would snap (``drop = 1 - F_min / F_max``)."""
    f = path.column("force")
    found = []
    for i in range(1, len(f) - 1):
        if f[i] > f[i - 1] and f[i] >= f[i + 1]:
            j = i + 1
            while j + 1 < len(f) and f[j + 1] <= f[j]:
                j += 1
            found.append({"d_over_H": float(path.points[i].qoi["d_over_H"]), "force_max": float(f[i]),
                          "d_over_H_min": float(path.points[j].qoi["d_over_H"]), "force_min": float(f[j]),
                          "drop": float(1 - f[j] / f[i])})
    return found


def fit_coefficient(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Least-squares ``C`` of ``y = C x`` and the relative rms misfit."""
    c = float(np.dot(x, y) / np.dot(x, x))
    return c, float(np.sqrt(np.mean((y - c * x) ** 2)) / np.sqrt(np.mean(y**2)))


def fits(case: Indentation, path: PathResult, fit_depth: float) -> dict:
    d_over_h = path.column("d_over_H")
    force = path.column("force")
    early = (d_over_h > 0) & (d_over_h <= fit_depth) & np.concatenate([[True], np.diff(d_over_h) > 0])
    if early.sum() < 3:
        raise RuntimeError(f"fewer than 3 path points with 0 < d/H <= {fit_depth}: refine the first steps")
    d = d_over_h[early] * case.H
    if case.direction == "inward":
        c, misfit = fit_coefficient(np.sqrt(d * case.t) / case.r, force[early])
        return {"form": "F/(E0 t^2) = C sqrt(d t)/r", "C": c, "thesis_C": 0.42, "misfit": misfit,
                "fit_range_d_over_H": fit_depth}
    stretch = 1 + d / case.H
    c, misfit = fit_coefficient(stretch - stretch**-2, force[early])
    return {"form": "F/(E0 t^2) = C [(1 + d/H) - (1 + d/H)^-2]", "C": c, "misfit": misfit,
            "fit_range_d_over_H": fit_depth}


def finish_force_figure(fig, ax, bx, path: PathResult, title: str, filename, *, column: str = "d_over_H") -> None:
    """Labels of the force panel ``ax`` (depth axis ``column``), the volume change along the path
    in ``bx``, saved."""
    label = column.replace("_over_", "/")
    ax.set_xlabel(label)
    ax.set_ylabel("F/(E0 t^2)")
    ax.set_title(title)
    ax.legend(fontsize=7)
    bx.plot(path.column(column), 100 * path.column("volume_change"), color="k")
    bx.set_xlabel(label)
    bx.set_ylabel("gel volume change (%)")
    fig.tight_layout()
    fig.savefig(filename, dpi=130)
    plt.close(fig)


def draw(case: Indentation, path: PathResult, summary: dict, filename) -> None:
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    d, f = path.column("d_over_H"), path.column("force")
    ax.plot(d, f, "-", color="k", lw=1.2, label="axisymmetric path")
    unstable = path.column("lowest_nonaxisymmetric") < 0
    ax.plot(d[unstable], f[unstable], ".", color="tab:red", ms=3, label="unstable to k >= 1")
    first = summary["first_nonaxisymmetric"]
    if first is not None:
        ax.plot(first["d_over_H"], first["force"], "o", color="tab:red",
                label=f"leaves axisymmetry: k = {first['k']}, d/H = {first['d_over_H']:.3f}")
    for ev in summary["events"]:
        ax.axvline(ev["d_over_H"], color="tab:blue", lw=0.6, ls=":")
    for drop in summary["snaps"]:
        if drop["drop"] is not None:
            ax.annotate(f"snap: drop {100 * drop['drop']:.0f} %", (drop["depth"] / case.H, drop["force_before"]),
                        fontsize=8)
    fit = summary["fit"]
    xs = np.linspace(0, min(d.max(), 3 * fit["fit_range_d_over_H"]), 100)
    if case.direction == "inward":
        ax.plot(xs, fit["C"] * np.sqrt(xs * case.H * case.t) / case.r, "--", color="tab:green",
                label=f"C sqrt(d t)/r, C = {fit['C']:.3f} (thesis 0.42)")
    else:
        s = 1 + xs
        ax.plot(xs, fit["C"] * (s - s**-2), "--", color="tab:green", label=f"C[(1+d/H)-(1+d/H)^-2], C = {fit['C']:.3g}")
    finish_force_figure(fig, ax, bx, path, f"H/R = {case.H:g}, {case.direction}", filename)


def draw_mu_change(case: Indentation, change: dict, filename) -> None:
    """Lowest eigenvalue of each wave number and the force against ``mu`` at the held depth or force."""
    rows = change["rows"]
    mu = np.array([row["mu"] for row in rows])
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    ks = sorted(int(name[len("lowest_k"):]) for name in rows[0] if name.startswith("lowest_k"))
    for k in ks:
        ax.plot(mu, [row[f"lowest_k{k}"] for row in rows], "-", lw=1, label=f"k = {k}")
    ax.axhline(0.0, color="k", lw=0.6)
    ax.set_xlabel("mu")
    ax.set_ylabel("lowest eigenvalue")
    ax.set_yscale("symlog", linthresh=1e-6)
    ax.legend(fontsize=7, ncol=2)
    bx.plot(mu, [row["force"] for row in rows], "-", color="k")
    bx.set_ylabel("F/(E0 t^2)")
    bx.ticklabel_format(axis="y", useOffset=False)
    dx = bx.twinx()
    dx.plot(mu, [row["d_over_H"] for row in rows], "--", color="tab:blue")
    dx.set_ylabel("d/H (dashed)", color="tab:blue")
    for axis in (ax, bx):
        axis.set_xlabel("mu")
        axis.ticklabel_format(axis="x", style="sci", scilimits=(-3, 3))
    fig.suptitle(f"H/R = {case.H:g}, mu changed at d/H = {change['d_over_H']:g}, {change['hold']} held")
    fig.tight_layout()
    fig.savefig(filename, dpi=130)
    plt.close(fig)


def run(case: Indentation, res: SectionResolution, out: str, *, kmax: int = 8, step: float = 0.01,
        max_step: float = 0.04, fit_depth: float = 0.1, mu_at: float | None = None, mu_to: float | None = None,
        mu_steps: int = 10, hold: str = "depth", mu_kmax: int = 40, departures: tuple[float, ...] = (),
        progress=None, options: dict | None = None, resume: bool = False) -> dict:
    """One indentation on the axisymmetric model; ``step``/``max_step`` in units of ``H``. With
    ``mu_at`` (depth / H) the indentation stops there and ``mu`` goes to ``mu_to`` in
    ``mu_steps`` steps with the apex ``hold`` (``change_mu_axisymmetric``; ``mu_change.csv``),
    scanning ``k <= mu_kmax`` (a rise wrinkles the clamped rim at k ~ 20-30, docs/microlens.md).
    ``departures`` (depths / H): the growth threshold of a stabilised run that leaves the
    axisymmetric path there and the wave number it shows (``departure``; all states in
    ``growth.csv``). The path rewrites ``checkpoint.npz`` every step; ``resume``: the run in
    ``out`` goes on from it (the mu change, which has none, runs again). ``options``: the
    command line, kept in ``params.json`` (``ngsgel.output.resume_arguments``)."""
    check_mu_change(case, mu_at=mu_at, mu_to=mu_to, mu_steps=mu_steps, hold=hold)
    bad = [d for d in departures if not (math.isfinite(d) and 0 < d <= case.depth)]
    if bad:
        raise ValueError(f"departure depths must lie in (0, depth = {case.depth}] (d/H), got {bad}")
    start = time.perf_counter()
    run_dir = RunDirectory(out, params={"case": asdict(case), "resolution": asdict(res), "kmax": kmax, "mu_kmax": mu_kmax,
                                        "model": "axisymmetric", "t_over_r": THICKNESS_RATIO, "mu_at": mu_at,
                                        "mu_to": mu_to, "mu_steps": mu_steps, "hold": hold, "options": options},
                           resume=resume)
    if not resume:
        remove_checkpoints(run_dir, ("checkpoint*.npz",))
    checkpoint = Resumption(resume).take(run_dir.file("checkpoint.npz"))
    cap = AxisymmetricCap(case, res)
    target = case.depth if mu_at is None else mu_at
    with History(run_dir.file("path.csv")) as history:
        path = follow_axisymmetric(cap, kmax=kmax, step=step * case.H, max_step=max_step * case.H,
                                   target=target * case.H, history=history,
                                   vtk=VTKSeries(cap.mesh, cap.problem.fields(), run_dir.series("cap")),
                                   progress=progress, checkpoint_file=run_dir.file("checkpoint.npz"), resume=checkpoint)
    summary = {
        "ndof": cap.problem.space.ndof, "t": case.t, "r": case.r,
        "stop_reason": path.stop_reason, "steps": len(path.points) - 1,
        "events": [{"kind": ev.kind, "d_over_H": ev.parameter / case.H} for ev in path.events],
        "snaps": snap_drops(path),
        "force_maxima": force_maxima(path),
        "max_volume_change": float(np.max(np.abs(path.column("volume_change")))),
        "fit": fits(case, path, fit_depth),
    }
    summary["first_nonaxisymmetric"] = first_nonaxisymmetric(cap, path, kmax=kmax)
    summary["negative_nonaxisymmetric_anywhere"] = bool(np.any(path.column("lowest_nonaxisymmetric") < 0))
    growth = growth_along_path(case, path)
    with History(run_dir.file("growth.csv")) as table:
        for row in growth["rows"]:
            table.append(row)
    summary["growth"] = {"until_d_over_H": growth["until_d_over_H"],
                         "departures": [departure(growth, d) or {"d_over_H": d, "threshold": None,
                                                                 "reason": "beyond the analysed path"}
                                        for d in departures]}
    if any(row["leading_k"] for row in growth["rows"]):  # something grew: a figure to draw
        draw_growth(case, growth, summary["growth"]["departures"], run_dir.file("growth.png"))
    if mu_to is not None and path.stop_reason != "target":
        summary["mu_change"] = {"hold": hold, "d_over_H": mu_at, "rows": [], "axisymmetric_stable": [],
                                "stop_reason": f"not done: the path stopped before d/H = {mu_at} ({path.stop_reason})"}
    elif mu_to is not None:
        end = path.points[-1]  # the bisection above moved the state: back to the path's end
        cap.problem.restore_state(end.state)
        cap.depth.Set(end.parameter)
        cap.problem.solve()
        with History(run_dir.file("mu_change.csv")) as history:
            rows, stop = change_mu_axisymmetric(cap, mu_to, steps=mu_steps, kmax=mu_kmax, hold=hold, history=history,
                                                vtk=VTKSeries(cap.mesh, cap.problem.fields(), run_dir.series("cap_mu")),
                                                progress=progress)
        summary["mu_change"] = {"hold": hold, "d_over_H": mu_at, "rows": rows, "stop_reason": stop,
                                "axisymmetric_stable": [row["mu"] for row in rows if not row["unstable_k"]]}
        draw_mu_change(case, summary["mu_change"], run_dir.file("mu_change.png"))
    summary["wall_s"] = time.perf_counter() - start
    draw(case, path, summary, run_dir.file("force_depth.png"))
    run_dir.write_json("summary.json", summary)  # last: a folder with it holds a finished run
    return summary


def vertex_sequence(path: PathResult) -> list[dict]:
    """The states along the path where the vertex count ``k`` or the number of dents changes:
    both from then on."""
    changes, last = [], None
    for point in path.points:
        pattern = (int(point.qoi["k"]), int(point.qoi["dents"]))
        if pattern != last:
            changes.append({"d_over_H": float(point.qoi["d_over_H"]), "d_over_R": float(point.qoi["d_over_R"]),
                            "mu": float(point.qoi["mu"]), "k": pattern[0], "dents": pattern[1],
                            "force": float(point.qoi["force"])})
            last = pattern
    return changes


def follow_through_snaps(cap: ShellCap, parameter: ngs.Parameter, end: float, *, step: float, max_step: float,
                         snaps: int, tau: float | None, history, vtk, progress, run_dir: RunDirectory,
                         checkpoint_name: str = "checkpoint.npz", stage: str = "indentation",
                         restart: Checkpoint | None = None, resumption: Resumption | None = None) -> PathResult:
    """``follow_shell`` of ``parameter`` (the depth or ``mu``) to ``end``; where it stalls (no
    equilibrium found next to the last one: a snap under displacement control, or a step Newton
    cannot make next to a critical state) or loses stability at a point it could not locate, the
    parameter moves one ``step`` further and the cap relaxes there by the overdamped flow
    (``ngsgel.relaxation.settle_after``) to a stable state, recorded as a "snap" event (force and
    vertex count before and after, energy drop, cost), and the path goes on from it; at most
    ``snaps`` times. The legs are joined into one path; ``snaps_<stage>.json`` in the run folder.
    The legs keep their checkpoint in ``checkpoint_name`` (a leg that a snap ends moved to
    ``<stem>_leg<n>.npz``: ``Resumption``); a ``resumption`` takes them up, and a snap whose next
    leg has begun is not relaxed again (its record is read back)."""
    resumption = resumption or Resumption(False)
    latest = run_dir.file(checkpoint_name)
    snaps_file = run_dir.file(f"snaps_{stage.replace(' ', '_')}.json")  # snaps_indentation.json, ...
    legs, records = [], []
    while True:
        resume = resumption.take(latest, len(legs))
        path = follow_shell(cap, parameter, end, step=step, max_step=max_step, history=history, vtk=vtk,
                            progress=progress, stage=stage, checkpoint_file=latest,
                            restart=restart if not legs and resume is None else None, resume=resume)
        legs.append(path)
        lost = path.stop_reason == "criterion"  # left on an unstable branch (follow_shell's stop)
        if not (path.stop_reason.startswith("stalled") or lost) or len(records) >= snaps:
            break
        Resumption.end_leg(latest, len(legs) - 1)
        if resumption.reached(latest, len(legs)):  # the stopped run had relaxed: its record
            records.append(json.loads(snaps_file.read_text())[len(records)])
            continue
        last = path.points[-1]
        clock = time.perf_counter()
        settled = settle_after(cap.shell, parameter, path, overshoot=step, target=end,
                               amplitude=0.1 * cap.case.t, tau=tau, progress=progress)
        record = {"stage": stage, "after_step": last.step, "negative_before": last.negative,
                  "energy": settled.energy_end, "from": path.checkpoint.parameter, "to": parameter.Get(),
                  "d_over_H": cap.depth.Get() / cap.case.H, "mu": cap.shell.mu.Get(),
                  "force_before": last.qoi["force"], "k_before": last.qoi["k"], "force_after": cap.force(),
                  "k_after": cap.update_waves(), "dents_before": last.qoi["dents"], "dents_after": cap.dents(),
                  "energy_drop": settled.energy_drop, "distance": settled.distance,
                  "pseudo_time_steps": settled.steps, "rejected": settled.rejected,
                  "lowest_eigenvalue": settled.lowest_eigenvalue,
                  "wall_s": time.perf_counter() - clock, "stalled": path.stop_reason}
        records.append(record)
        draw_deflection(cap, run_dir.file(f"shape_{stage.replace(' ', '_')}_snap{len(records)}.png"),
                        title=f"after snap {len(records)}: {cap.state_label()}")
        run_dir.write_json(snaps_file.name, records)
        if progress is not None:
            progress(f"snap to d/H {record['d_over_H']:.4f}, mu {record['mu']:.4g}: force "
                     f"{record['force_before']:.5g} -> {record['force_after']:.5g}, "
                     f"k {record['k_before']:.0f} -> {record['k_after']:.0f}, "
                     f"dents {record['dents_before']:.0f} -> {record['dents_after']:.0f}")
    points = [pt for leg in legs for pt in leg.points]
    events = [ev for leg in legs for ev in leg.events]
    events += [Event(kind="snap", step=r["after_step"], parameter=r["to"], negative_before=r["negative_before"],
                     negative_after=0, energy=r["energy"], details=r) for r in records]
    return PathResult(points, events, legs[-1].stop_reason, legs[-1].checkpoint)


def shell_summary(case: Indentation, cap: ShellCap, stages: list[tuple[str, PathResult]]) -> dict:
    summary = {"ndof": cap.shell.space.ndof, "elements": cap.mesh.GetNE(ngs.BND), "t": case.t, "r": case.r}
    for name, path in stages:
        d, f = path.column("d_over_H"), path.column("force")
        summary[name] = {
            "stop_reason": path.stop_reason, "steps": len(path.points) - 1,
            "events": [{"kind": ev.kind, "d_over_H": cap.depth.Get() / case.H if name == "mu change" else ev.parameter / case.H,
                        "parameter": ev.parameter, "parameter_error": ev.parameter_error,
                        "negative_before": ev.negative_before, "negative_after": ev.negative_after} for ev in path.events],
            "vertex_sequence": vertex_sequence(path),
            # a restart that changes mu at the checkpoint's depth has a one-point indentation
            "load_drops": [asdict(drop) for drop in load_drops(d, f)] if name == "indentation" and len(d) > 1 else [],
            "max_volume_change": float(np.max(np.abs(path.column("volume_change")))),
        }
    return summary


def draw_deflection(cap: ShellCap, filename, *, title: str) -> None:
    """Top view of the normal deflection ``w/t`` of the whole cap (the half cap mirrored) on a polar
    grid of the base plane, with the circle of the last vertex count (``ShellCap.update_waves``)."""
    w = _normal_deflection(cap.shell.displacement, cap.mesh, r=cap.case.r, zc=cap.case.H - cap.case.r,
                           half=cap.res.half)
    radii = np.linspace(0.0, 0.98, 50)
    theta = np.linspace(0.0, 2.0 * np.pi, 181)
    R, T = np.meshgrid(radii, theta, indexing="ij")
    values = np.array([[w(x, y) for x, y in zip(xs, ys)] for xs, ys in zip(R * np.cos(T), R * np.sin(T))])
    fig, ax = plt.subplots(figsize=(5.6, 4.6))
    image = ax.contourf(R * np.cos(T), R * np.sin(T), values / cap.case.t, 30, cmap="RdBu_r")
    fig.colorbar(image, ax=ax, label="normal deflection w / t (inward < 0)")
    waves = cap.waves
    if waves.analysis is not None:
        ax.add_patch(plt.Circle((waves.centre, 0.0), waves.radius, fill=False, ls="--", lw=0.8, color="k"))
    ax.set_aspect("equal")
    ax.set_title(title, fontsize=9)
    fig.tight_layout()
    fig.savefig(filename, dpi=110)
    plt.close(fig)


def draw_shell(case: Indentation, path: PathResult, event_depths: list[float], filename) -> None:
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.2))
    column = case.depth_column
    scale = 1.0 if column == "d_over_H" else case.H  # events are stored in d/H
    d, f, k = path.column(column), path.column("force"), path.column("k")
    ax.plot(d, f, "-", color="k", lw=1.0)
    for kk in sorted(set(k.astype(int))):
        sel = k == kk
        ax.plot(d[sel], f[sel], "o", ms=3, label="axisymmetric" if kk == 0 else f"k = {kk} (dominant wave)")
    for d_over_H in event_depths:
        ax.axvline(d_over_H * scale, color="tab:blue", lw=0.6, ls=":")
    finish_force_figure(fig, ax, bx, path, f"shell, H/R = {case.H:g}, {case.direction}", filename, column=column)


def check_mu_change(case: Indentation, *, mu_at: float | None, mu_to: float | None, mu_steps: int,
                    restart: str | None = None, hold: str = "depth") -> None:
    """Bad input of the ``mu`` change at a depth (``--mu-at``/``--mu-to``), before any meshing."""
    if mu_at is not None and mu_to is None:
        raise ValueError("mu_at needs mu_to (the depth / H where mu changes, and its new value)")
    if mu_to is not None and mu_at is None and restart is None:
        raise ValueError("mu_to needs mu_at, or a restart whose depth is where mu changes")
    if mu_at is not None and not 0 < mu_at <= case.depth:
        raise ValueError(f"mu_at (depth / H) must be in (0, depth = {case.depth}], got {mu_at!r}")
    if mu_to is not None:
        if not -1 <= mu_to or mu_to == case.mu:
            raise ValueError(f"mu_to must be >= -1 and differ from mu = {case.mu}, got {mu_to!r}")
        try:
            GEL.lam_free(mu_to)
        except ValueError as error:
            raise ValueError(f"mu_to = {mu_to!r}: {error}") from error
    if not (isinstance(mu_steps, int) and mu_steps >= 1):
        raise ValueError(f"mu_steps must be an integer >= 1, got {mu_steps!r}")
    if hold not in MU_HOLDS:
        raise ValueError(f"hold must be one of {MU_HOLDS}, got {hold!r}")


def change_mu_axisymmetric(cap: AxisymmetricCap, mu_to: float, *, steps: int, kmax: int, hold: str,
                           history=None, vtk=None, progress=None) -> tuple[list[dict], str]:
    """``mu`` stepped from its value to ``mu_to`` in ``steps`` equal steps with the apex ``hold``:
    ``depth`` (the indenter stays where it is, as a displacement boundary condition carried into
    the next step does) or ``force`` (the depth re-found at every ``mu``: ``_hold_force``). At
    every state the exact negative count and the lowest eigenvalue of each
    wave number ``k = 0 .. kmax`` (rigid modes excluded; ``k = 0`` at fixed depth), so the rows
    show where the axisymmetric state gains or loses stability against the polygonal modes.
    Returns the rows and why the stage stopped: ``target``, or the failed solve (past a limit
    point of the held quantity, e.g. a force the shrinking cap can no longer carry)."""
    p, depth = cap.problem, cap.depth
    force0 = cap.force()
    ks = list(range(kmax + 1))
    mu0 = p.mu.Get()
    rows = []
    for i in range(steps + 1):
        if i:
            p.mu.Set(mu0 + (mu_to - mu0) * i / steps)
            try:
                if hold == "depth":
                    p.solve()
                else:
                    _hold_force(cap, force0)
            except (NewtonError, RampError, HoldError) as error:
                return rows, f"no equilibrium holding the {hold} at mu = {p.mu.Get():g}: {error}"
        scan = cap.harmonic.scan(ks, exclude_rigid=True)
        row = {"mu": p.mu.Get(), "d_over_H": depth.Get() / cap.case.H, "force": cap.force(),
               "volume_change": cap.volume_change(), "unstable_k": scan.unstable,
               **{f"lowest_k{k}": value for k, value in scan.lowest.items()}}
        rows.append(row)
        if history is not None:
            history.append(row)
        if vtk is not None:
            vtk.write(p.mu.Get())
        if progress is not None:
            progress(f"mu {row['mu']:.6g}: d/H {row['d_over_H']:.5f}, F/(E0 t^2) {row['force']:.6g}, "
                     f"unstable k {row['unstable_k']}")
    return rows, "target"


class HoldError(RuntimeError):
    """No depth near the current one carries the held force (past a limit point in force)."""


def _hold_force(cap: AxisymmetricCap, force: float, *, step: float = 0.005, max_steps: int = 40) -> None:
    """Move the indenter to the depth where the cap carries ``force`` (``F/(E0 t^2)``): walk the
    path in depth steps of ``step H`` until the force is bracketed, then Brent's method inside
    the bracket; every move of the indenter is a ramp from the last state (cut back where Newton
    struggles)."""

    def excess(depth: float) -> float:
        ramp(cap.problem, cap.depth, depth)
        return cap.force() - force

    a = cap.depth.Get()
    fa = excess(a)
    direction = 1.0 if fa < 0 else -1.0  # deeper where the force is short (positive stiffness)
    for _ in range(max_steps):
        b = a + direction * step * cap.case.H
        fb = excess(b)
        if fa * fb <= 0:
            excess(optimize.brentq(excess, min(a, b), max(a, b), xtol=1e-9 * cap.case.H, rtol=1e-12))
            return
        if abs(fb) > abs(fa):
            raise HoldError(f"F/(E0 t^2) = {force:.6g} is out of reach: moving the indenter from d/H "
                            f"{a / cap.case.H:.5f} to {b / cap.case.H:.5f} takes the force further from it "
                            f"({fa + force:.6g} -> {fb + force:.6g}; a limit point in force)")
        a, fa = b, fb
    raise HoldError(f"F/(E0 t^2) = {force:.6g} not bracketed within {max_steps} depth steps of {step} H")


def run_shell(case: Indentation, res: ShellResolution, out: str, *, step: float = 0.025, max_step: float = 0.05,
              mu_at: float | None = None, mu_to: float | None = None, mu_steps: int = 10, restart: str | None = None,
              snaps: int = 3, snap_tau: float | None = None, polygon: int | None = None, polygon_at: float | None = None,
              polygon_amplitude: float = 0.5, progress=None, options: dict | None = None, resume: bool = False) -> dict:
    """One apex load on the shell (steps in units of ``H``); with ``mu_at`` (depth / H) the
    indentation stops there and ``mu`` goes to ``mu_to`` in ``mu_steps`` steps at that depth
    (``mu_at`` omitted with ``restart``: at the checkpoint's depth). ``mu_to`` may lie above the
    bath's 0 up to the gel's ``mu_max`` (a slight swelling, as in the thesis's fig. 3-3B).
    Where the path stalls, the cap snaps at the next depth (at most ``snaps`` times, first
    pseudo-time step ``snap_tau``; see ``follow_through_snaps``).
    Every step rewrites ``checkpoint.npz`` (``mu_change.npz`` in the mu stage,
    ``axisymmetric_push.npz`` before a polygonal push; the path up to the n-th snap moves to
    ``..._leg<n-1>.npz``) in the run folder; ``restart`` (such a file of an indentation) starts
    from it. ``resume``: the run in ``out``
    goes on from its last checkpoint (a polygonal push or a snap whose next path has no checkpoint
    yet is relaxed again). ``options``: the command line, kept in ``params.json``
    (``ngsgel.output.resume_arguments``).
    ``polygon = k``: instead of following the path through its bifurcations, the cap is pushed to
    ``polygon_at`` (depth / H) on its axisymmetric branch and relaxed there from a ``k``-fold push
    of ``polygon_amplitude`` thicknesses (``push_into_polygon``; ``path_axisymmetric.csv``,
    ``polygon.json``); from the state it lands in ``mu`` changes (with ``mu_to``, at that depth)
    or the indentation goes on to ``case.depth`` (``path.csv``)."""
    if polygon is not None:
        if polygon_at is None or mu_at is not None or restart is not None:
            raise ValueError("polygon needs polygon_at (the depth / H where the polygonal state is made; a mu "
                             "change with mu_to happens there), and neither mu_at nor restart")
        check_polygon(polygon, polygon_amplitude, at=polygon_at, depth=case.depth)
        if mu_to is not None:
            mu_at = polygon_at
    elif polygon_at is not None:
        raise ValueError("polygon_at needs polygon (the wave number of the push)")
    check_mu_change(case, mu_at=mu_at, mu_to=mu_to, mu_steps=mu_steps, restart=restart)
    checkpoint = None if restart is None else Checkpoint.load(restart)
    start = time.perf_counter()
    run_dir = RunDirectory(out, params={"case": asdict(case), "resolution": asdict(res), "model": "shell",
                                        "t_over_r": THICKNESS_RATIO, "step": step, "max_step": max_step,
                                        "mu_at": mu_at, "mu_to": mu_to, "mu_steps": mu_steps, "restart": restart,
                                        "snaps": snaps, "snap_tau": snap_tau, "polygon": polygon,
                                        "polygon_at": polygon_at, "polygon_amplitude": polygon_amplitude,
                                        "options": options}, resume=resume)
    if not resume:
        remove_checkpoints(run_dir, ("checkpoint*.npz", "mu_change*.npz", "axisymmetric_push.npz"))
    resumption = Resumption(resume)
    cap = ShellCap(case, res)
    vtk = VTKSeries(cap.mesh, cap.shell.fields(), run_dir.series("cap"), derived_order=res.order)
    if polygon is not None:
        depth_end = polygon_at * case.H
    elif mu_to is None:
        depth_end = case.depth * case.H
    else:  # the checkpoint's own depth exactly: the indentation stage is then its one re-converged state
        depth_end = checkpoint.parameter if mu_at is None else mu_at * case.H
    snap_options = {"snaps": snaps, "tau": snap_tau, "vtk": vtk, "progress": progress, "run_dir": run_dir,
                    "resumption": resumption}
    made = None
    with History(run_dir.file("path.csv")) as history:
        if polygon is None:
            stages = [("indentation", follow_through_snaps(cap, cap.depth, depth_end, step=step * case.H,
                                                           max_step=max_step * case.H, history=history,
                                                           restart=checkpoint, **snap_options))]
        else:
            push_file = run_dir.file("axisymmetric_push.npz")
            with History(run_dir.file("path_axisymmetric.csv")) as axisymmetric_history:  # no eigenvalue columns
                stages = [("axisymmetric push", indent_axisymmetric_shell(cap, depth_end, step=step * case.H,
                                                                    history=axisymmetric_history, vtk=vtk,
                                                                    progress=progress, checkpoint_file=push_file,
                                                                    resume=resumption.take(push_file)))]
            following = "mu_change.npz" if mu_to is not None else "checkpoint.npz"  # the next stage's checkpoint
            if resumption.reached(run_dir.file(following), 0):  # the stopped run had made the polygon: its record
                made = json.loads(run_dir.file("polygon.json").read_text())
            else:
                made = push_into_polygon(cap, polygon, amplitude=polygon_amplitude, progress=progress)
                run_dir.write_json("polygon.json", made)
                draw_deflection(cap, run_dir.file("shape_polygon.png"), title=f"relaxed from a {polygon}-fold push: "
                                                                              f"{cap.state_label()}")
            if progress is not None:
                progress(f"pushed {polygon}-fold ({polygon_amplitude} t) at d/H {made['d_over_H']:.4f}: relaxed to k = "
                         f"{made['k_after']:.0f} ({made['amplitude_after_over_t']:.3f} t), force {made['force']:.5g}, "
                         f"lowest eigenvalue {made['lowest_eigenvalue']:.3g}, {made['wall_s']:.0f} s")
            if mu_to is None and polygon_at < case.depth:  # on along the polygonal branch
                stages.append(("indentation", follow_through_snaps(cap, cap.depth, case.depth * case.H,
                                                                   step=step * case.H, max_step=max_step * case.H,
                                                                   history=history, **snap_options)))
        if mu_to is not None and stages[0][1].stop_reason == "target":
            mu_step = abs(mu_to - case.mu) / mu_steps
            stages.append(("mu change", follow_through_snaps(cap, cap.shell.mu, mu_to, step=mu_step, max_step=mu_step,
                                                             history=history, checkpoint_name="mu_change.npz",
                                                             stage="mu change", **snap_options)))
    summary = shell_summary(case, cap, stages)
    if made is not None:
        summary["polygon"] = made
    summary["wall_s"] = time.perf_counter() - start
    depth_stages = [(name, path) for name, path in stages if name != "mu change"]
    joined = PathResult([pt for _, path in depth_stages for pt in path.points],
                        [ev for _, path in depth_stages for ev in path.events],
                        depth_stages[-1][1].stop_reason, depth_stages[-1][1].checkpoint)
    draw_shell(case, joined, [ev["d_over_H"] for name, _ in depth_stages for ev in summary[name]["events"]],
               run_dir.file("force_depth.png"))
    cap.update_waves()
    draw_deflection(cap, run_dir.file("shape_end.png"), title=f"end: {cap.state_label()}")
    run_dir.write_json("summary.json", summary)  # last: a folder with it holds a finished run
    return summary


def remove_checkpoints(run_dir: RunDirectory, patterns: tuple[str, ...]) -> None:
    """Remove the checkpoints an earlier run left in the folder of a fresh one: resuming it would
    take them for its own."""
    for pattern in patterns:
        for stale in run_dir.path.glob(pattern):
            stale.unlink()


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/microlens",
                          quick="axisymmetric: coarse section (maxh 0.04 R, order 2), H = 0.3 R, to d/H = 0.6; shell: "
                                "coarse half cap (h = 0.2 R, order 2, no C++ compile) to d/H = 0.3, steps 0.1 H")
    parser.add_argument("--H", type=float, default=0.3, help="apex height H / base radius R")
    parser.add_argument("--direction", default="inward", choices=DIRECTIONS,
                        help="of the apex displacement (lateral: along x, shell only)")
    parser.add_argument("--depth", type=float, default=1.0, help="final apex displacement d / H")
    parser.add_argument("--mu", type=float, default=0.0, help="chemical potential of the bath (kT), in [-1, 0]")
    parser.add_argument("--edge", default="clamped", choices=EDGES,
                        help="support of the base: clamped (the thesis's) or hinged at its mid-surface")
    parser.add_argument("--indenter", default="sliding", choices=INDENTERS,
                        help="apex patch: sliding (only the loaded component prescribed) or bonded (all held)")
    parser.add_argument("--model", default="axisymmetric", choices=("axisymmetric", "shell"),
                        help="the r-z section with the harmonic scan, or the shell on the mid-surface")
    parser.add_argument("--maxh", type=float, default=None,
                        help="cell length along the section / R (axisymmetric, default 0.01) or element size of the "
                             "mid-surface / R (shell, default 0.05)")
    parser.add_argument("--apex-maxh", type=float, default=0.01, help="shell: element size on the apex patch / R")
    parser.add_argument("--full", action="store_true", help="shell: the whole cap instead of the mirror half")
    parser.add_argument("--step", type=float, default=0.025,
                        help="shell: depth step / H (natural parameter; it grows to twice this)")
    parser.add_argument("--mu-at", type=float, default=None,
                        help="change mu at this depth d / H (default: no change; shell with --restart: at the "
                             "checkpoint's depth) ...")
    parser.add_argument("--mu-to", type=float, default=None,
                        help="... to this chemical potential (kT; up to the gel's mu_max > 0; default: none) ...")
    parser.add_argument("--mu-steps", type=int, default=10, help="... in this many steps")
    parser.add_argument("--hold", default="depth", choices=MU_HOLDS,
                        help="axisymmetric: what the indenter keeps while mu changes (shell: the depth)")
    parser.add_argument("--restart", default=None, metavar="CHECKPOINT",
                        help="shell: a new run (in --out) from this checkpoint (.npz) of another run with the same case "
                             "and mesh, e.g. on to another --depth or with --mu-to (default: none)")
    parser.add_argument("--resume", default=None, metavar="DIR",
                        help="go on with the stopped run in DIR from its last checkpoint to the end it would have "
                             "reached, with its own options (its params.json; an option given as well must agree); "
                             "summary.json's wall_s is then the resumed part's (default: none, a new run)")
    parser.add_argument("--snaps", type=int, default=3,
                        help="shell: where the path stalls, relax to a stable state one step deeper, at most this often")
    parser.add_argument("--snap-tau", type=float, default=None,
                        help="shell: first pseudo-time step of that relaxation (of M dx/dtau = -R, in units of 1 / "
                             "eigenvalue of the tangent against M; default 1 / lowest eigenvalue, 0.5 / |lowest| if "
                             "negative)")
    parser.add_argument("--polygon", type=int, default=None, metavar="K",
                        help="shell, with --polygon-at: push the cap to that depth on its axisymmetric branch and relax "
                             "it there from a K-fold push (instead of following the bifurcations), then change mu "
                             "(with --mu-to) or go on to --depth (default: none, follow the bifurcations)")
    parser.add_argument("--polygon-at", type=float, default=None,
                        help="... the depth d / H of that push (default: none)")
    parser.add_argument("--polygon-amplitude", type=float, default=0.5, help="... of this many thicknesses t")
    parser.add_argument("--layers", type=int, default=2, help="axisymmetric: cells across the wall")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the displacement")
    parser.add_argument("--apex", type=float, default=0.02, help="radius of the loaded apex patch / R")
    parser.add_argument("--kmax", type=int, default=8,
                        help="axisymmetric: wave numbers k = 1 .. KMAX scanned along the path")
    parser.add_argument("--mu-kmax", type=int, default=40,
                        help="... and k = 0 .. MU_KMAX at every mu of a mu change (a rise wrinkles the clamped rim at "
                             "k ~ 20-30)")
    parser.add_argument("--fit-depth", type=float, default=0.1, help="fit the early force F/(E0 t^2) up to this d/H")
    parser.add_argument("--departure", type=float, nargs="*", default=[],
                        help="axisymmetric: depths d / H where a stabilised run is taken to leave the axisymmetric "
                             "path (the growth threshold and wave number it implies; default: none)")
    args = resume_arguments(parser, argv)
    if args.resume is None and args.restart is not None:  # a resumed run finds it from any working folder
        args.restart = str(Path(args.restart).resolve())
    quick = quick_run(args)
    if args.model == "shell":
        return main_shell(args, quick)
    if args.polygon is not None or args.polygon_at is not None:
        raise ValueError("polygon and polygon_at need the shell model (--model shell)")
    case = Indentation(H=0.3 if quick else args.H, direction=args.direction, depth=0.6 if quick else args.depth,
                       mu=args.mu, edge=args.edge, indenter=args.indenter)
    res = (SectionResolution(maxh=0.04, layers=2, order=2, apex=args.apex) if quick else
           SectionResolution(maxh=args.maxh or 0.01, layers=args.layers, order=args.order, apex=args.apex))
    for name in ("kmax", "mu_kmax"):
        value = getattr(args, name)
        if not (isinstance(value, int) and 2 <= value <= 60):
            raise ValueError(f"{name} must be an integer in [2, 60], got {value!r}")
    if not 0 < args.fit_depth <= 1:
        raise ValueError(f"fit-depth must be in (0, 1], got {args.fit_depth!r}")
    summary = run(case, res, args.out, kmax=args.kmax, mu_kmax=args.mu_kmax, fit_depth=args.fit_depth, mu_at=args.mu_at,
                  mu_to=args.mu_to, mu_steps=args.mu_steps, hold=args.hold, departures=tuple(args.departure),
                  progress=Progress("microlens", quiet=args.quiet), options=command_options(args),
                  resume=args.resume is not None)
    first = summary["first_nonaxisymmetric"]
    print(f"H/R = {case.H}, {case.direction}: {summary['steps']} steps, events "
          f"{[(e['kind'], round(e['d_over_H'], 4)) for e in summary['events']]}, snaps "
          f"{[(round(s['depth'] / case.H, 4), s['drop']) for s in summary['snaps']]}, force maxima "
          f"{[(round(m['d_over_H'], 4), round(m['drop'], 4)) for m in summary['force_maxima']]}, first non-axisymmetric "
          f"{None if first is None else (first['k'], round(first['d_over_H'], 4))}, fit C = {summary['fit']['C']:.4g} "
          f"(misfit {summary['fit']['misfit']:.2g}), max |volume change| {summary['max_volume_change']:.2e}, "
          f"{summary['wall_s']:.1f} s")
    for dep in summary["growth"]["departures"]:
        print(f"leaving the axisymmetric path at d/H = {dep['d_over_H']}: "
              + (f"threshold {dep['threshold']:.3e}, k = {dep['k']} (runner-up {dep['runner_up_k']}, "
                 f"G ratio {dep['runner_up_ratio']:.3f})" if dep["threshold"] is not None else dep["reason"]))
    if "mu_change" in summary:
        change = summary["mu_change"]
        print(f"mu changed at d/H = {change['d_over_H']} holding the {change['hold']} ({change['stop_reason']}): "
              f"unstable k per mu {[(round(row['mu'], 8), row['unstable_k']) for row in change['rows']]}")
    return summary


def main_shell(args, quick: bool) -> dict:
    """``--model shell``; ``--quick``: a coarse half cap (h = 0.2, order 2) to d/H = 0.3, which
    exercises the run but does not resolve the ridge where the first polygon forms."""
    case = Indentation(H=args.H, direction=args.direction, depth=0.3 if quick else args.depth, mu=args.mu,
                       edge=args.edge, indenter=args.indenter)
    res = ShellResolution(maxh=0.2 if quick else (args.maxh or 0.05), apex_maxh=0.05 if quick else args.apex_maxh,
                          order=2 if quick else args.order, apex=args.apex, half=not args.full)
    summary = run_shell(case, res, args.out, step=0.1 if quick else args.step, max_step=0.1 if quick else 2 * args.step,
                        mu_at=args.mu_at, mu_to=args.mu_to, mu_steps=args.mu_steps, restart=args.restart, snaps=args.snaps,
                        snap_tau=args.snap_tau, polygon=args.polygon, polygon_at=args.polygon_at,
                        polygon_amplitude=args.polygon_amplitude, progress=Progress("microlens shell", quiet=args.quiet),
                        options=command_options(args), resume=args.resume is not None)
    for name in ("axisymmetric push", "indentation", "mu change"):
        if name in summary:
            stage = summary[name]
            print(f"{name}: {stage['steps']} steps ({stage['stop_reason']}), events "
                  f"{[(e['kind'], round(e['d_over_H'], 4)) for e in stage['events']]}, vertices "
                  f"{[(v['k'], round(v['d_over_H'], 3)) for v in stage['vertex_sequence']]}, load drops "
                  f"{[(round(x['displacement'], 3), round(x['relative_drop'], 4)) for x in stage['load_drops']]}, "
                  f"max |volume change| {stage['max_volume_change']:.2e}")
    print(f"shell: {summary['ndof']} unknowns, {summary['wall_s']:.1f} s")
    return summary


if __name__ == "__main__":
    main()
