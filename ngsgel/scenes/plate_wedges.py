"""k-fold patterns of the softer-edge graded disk at ``mu = 0`` on mirror-symmetric wedges (issue 39, item 2b).

The disk of ``graded_plate_shell`` (``GelShell``, graded ``Nv``, t/R = 0.01) is computed on the
wedge ``0 <= theta <= pi/k`` with mirror planes on both straight edges (normal displacement and
rotation about the edge zero; the edge at ``pi/k`` has no coordinate normal, so its normal
displacement is held by a stiff penalty, ``MirrorShell``). The wedge carries only the wave numbers
0, k, 2k, ... of the deflection: for k >= 3 it excludes the k = 2 saddle the full disk buckles
into, and for k = 2 (the quarter disk) it is the saddle's own symmetry. From the flat state at
``mu_start`` the wedge follows ``mu`` in natural steps with the exact negative count; where the
branch loses stability (the flat state at its first onset, later branches at theirs) the state
is pushed along the critical mode and relaxed (``ngsgel.relaxation.settle_after``) and the next
branch is followed, up to ``mu = 0``. No seed load.

Every wedge is made of copies of one meshed base sector of angle ``pi / base_sectors``
(``geometries.plates.plate_sector_midsurface``), so the end state maps node by node onto the
full disk of ``2 base_sectors`` copies - one mesh for every k dividing ``base_sectors`` (20: k =
2, 4, 5). There the state is re-equilibrated (Newton, no symmetry imposed) and its energy, exact
negative count and lowest modes (with their wave numbers) are those of the full disk.

Writes per k ``path_k<k>.csv``, ``wedge_k<k>.json`` (legs, snaps, end state) and
``state_k<k>.npz``, and ``summary.json`` (the table: energies, differences to k = 2, negative
counts, lowest modes, rim harmonics, penetration depth).

    ngsgel run plate-wedges --out results/plate_wedges --p 0.75 --k 2 4 5
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import ngsolve as ngs
from scipy.spatial import cKDTree

from geometries.plates import SYM, SYM_END, plate_sector_midsurface, sector_copy_map
from ngsgel import FloryRehnerGel, follow_path, ramp
from ngsgel.continuation import ContinuationError, StabilityOptions
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser, silence_progress
from ngsgel.patterns import penetration_depth, periodic_peaks, wave_number
from ngsgel.relaxation import SettleError, _push_and_settle, settle_after
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


class MirrorShell(GelShell):
    """``GelShell`` with mirror planes through the z axis in any direction (``mirror``): on the
    edge the rotation about it is fixed and the displacement normal to the plane vanishes,
    exactly for a coordinate normal (``GelShell.symmetry``), otherwise through the penalty
    energy ``stiffness / 2 (u . m)^2`` per unit length (``m`` the plane's normal), added to the
    shell's forms when they are built (``GelShell`` constrains Cartesian components only)."""

    def __init__(self, *args, mirror_stiffness: float, **kwargs):
        super().__init__(*args, **kwargs)
        if not mirror_stiffness > 0:
            raise ValueError(f"mirror_stiffness must be > 0, got {mirror_stiffness!r}")
        self.mirror_stiffness = mirror_stiffness
        self._mirror_penalties: list[tuple[str, tuple[float, float, float]]] = []

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
                nR: float = GRADED_NR, base_sectors: int = BASE_SECTORS, realcompile: bool = False
                ) -> tuple[MirrorShell, ngs.Mesh]:
    """The graded disk's wedge ``0 <= theta <= pi/k`` (``base_sectors / k`` copies of the base
    sector) with mirror planes on both edges and the deflection pinned at the centre (the
    mirrors hold every other rigid motion)."""
    check_wave(k, base_sectors)
    bundle = plate_sector_midsurface(angle=math.pi / base_sectors, copies=base_sectors // k, maxh=maxh,
                                     curve_order=order)
    gel, lam0 = graded_gel(p, n0=n0, nR=nR)
    stiffness = MIRROR_PENALTY * FloryRehnerGel(Nv=max(n0, nR), chi=gel.chi).shear_modulus(lam0) * t / maxh
    shell = _graded(MirrorShell, bundle.mesh, p, t=t, order=order, n0=n0, nR=nR, realcompile=realcompile,
                    mirror_stiffness=stiffness)
    shell.mirror(SYM, angle=0.0)
    shell.mirror(SYM_END, angle=math.pi / k)
    shell.prescribe_point((0.0, 0.0, 0.0), "z", 0.0)
    return shell, bundle.mesh


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


def follow_wedge(shell: MirrorShell, mesh: ngs.Mesh, k: int, *, run_dir: RunDirectory, mu_start: float = MU_START,
                 step: float = 0.05, snap_overshoot: float = 1e-3, max_steps: int = 200, jump: bool = True,
                 first_overshoot: float = 0.02,
                 progress=None) -> dict:
    """The wedge's path from the flat state at ``mu_start`` to ``mu = 0`` (natural steps; at every
    loss of stability or stall the snap of ``graded_plate_shell``: ``settle_after``). ``jump``: the
    first snap relaxes at ``mu = 0`` itself (from the critical state pushed along its mode, the
    overdamped flow at ``mu = 0`` within the wedge's symmetry); otherwise it relaxes at
    ``first_overshoot`` past the onset and the branch is followed in ``mu``."""
    t = shell.thickness
    ramp(shell, shell.mu, mu_start, step=0.25)
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
    qoi = {"leg": lambda: leg, **{name: (lambda name=name: rim().get(name, 0.0))
                                  for name in ("rim_k", "rim_amplitude", "rim_purity", "rim_k_second", "rim_crests",
                                               "rim_max_abs_w")}}
    legs, snaps = [], []
    with History(run_dir.file(f"path_k{k}.csv")) as history:
        while True:
            stability = StabilityOptions(eigenvalues=4, switch=False, tol=1e-4)
            try:
                path = follow_path(shell, shell.mu, method="natural", step=step / 5, max_step=step,
                                   min_step=step / MIN_STEP_DIVISOR, target=0.0, stability=stability, qoi=qoi,
                                   history=history, max_steps=max_steps, stop=lambda pt: bool(pt.negative),
                                   progress=progress, easy_iterations=EASY_ITERATIONS,
                                   newton_options={"stall_window": STALL_WINDOW})
            except ContinuationError as exc:  # a stall: the fold lies within the last failed step
                path = exc.result
            legs.append({"leg": leg, "stop_reason": path.stop_reason, "from_mu": path.points[0].parameter,
                         "to_mu": path.points[-1].parameter, "steps": len(path.points),
                         "events": [{"kind": e.kind, "mu": e.parameter, "negative_after": e.negative_after,
                                     "eigenvalue": e.eigenvalue} for e in path.events],
                         "rim_end": dict(rim())})
            run_dir.write_json(f"wedge_k{k}.json", {"legs": legs, "snaps": snaps})
            if path.stop_reason == "target" and not path.points[-1].negative:
                break
            if path.stop_reason not in ("criterion", "min_step", "target") or len(legs) > 12:
                raise RuntimeError(f"the wedge path (k = {k}) ended with {path.stop_reason!r} at mu = "
                                   f"{path.points[-1].parameter}: {legs[-1]}")
            # the first snap leaves the flat state: 1e-3 past its onset the natural legs on the buckled
            # wedge stalled at their first step (p = 2, k = 5, h = 0.3); ``jump`` goes to mu = 0 at once
            overshoot = snap_overshoot if snaps else 1.0 if jump else first_overshoot
            try:
                settled = settle_after(shell, shell.mu, path, overshoot=overshoot, amplitude=0.1 * t, target=0.0,
                                       progress=progress)
            except SettleError:  # the flow stopped on a saddle (seen at mu = 0, k = 2): leave it downhill
                lowest = spectrum(shell, count=1, past_negative=True)
                mode = np.zeros(shell.space.ndof)
                mode[shell.free_mask] = lowest.modes[:, 0]
                settled = _push_and_settle(shell, shell.mu, shell.save_state(), mode, shell.mu.Get(),
                                           amplitude=0.1 * t, progress=progress)
            np.savez(run_dir.file(f"wedge_state_k{k}_leg{leg}.npz"), state=shell.save_state(), mu=shell.mu.Get())
            snaps.append({"leg": leg, "from_mu": path.points[-1].parameter, "mu": shell.mu.Get(),
                          "energy_drop": settled.energy_drop, "pseudo_time_steps": settled.steps,
                          "lowest_eigenvalue": settled.lowest_eigenvalue, "rim_after": dict(rim())})
            run_dir.write_json(f"wedge_k{k}.json", {"legs": legs, "snaps": snaps})
            leg += 1
            if shell.mu.Get() >= 0.0:  # settled at the target itself
                break
    return {"legs": legs, "snaps": snaps, "energy_wedge": shell.energy(), "rim_end": dict(rim())}


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
    points = np.array([v.point for v in mesh.vertices])
    pins = {}
    for axis, components in ((None, "xyz"), (0, "yz"), (1, "z")):
        if axis is None:
            point = (0.0, 0.0, 0.0)
        else:
            on_axis = np.flatnonzero((np.abs(points[:, 1 - axis]) < 1e-12) & (points[:, axis] > 0))
            point = tuple(points[on_axis[np.argmin(np.abs(points[on_axis, axis] - PIN_RADIUS))]])
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
        self.fixed.solve()  # (starts from the last state's rotations and stretches)
        return self.fixed.save_state()


def on_full_disk(wedge: MirrorShell, wedge_mesh: ngs.Mesh, k: int, *, p: float, maxh: float, order: int, t: float,
                 n0: float, nR: float, base_sectors: int, eigenvalues: int = 6, progress=None) -> dict:
    """The wedge's end state as a state of the full disk: the displacement reflected, rotations and
    thickness stretches solved for it (displacement prescribed), then the full disk's Newton from
    there (no symmetry imposed); its energy, exact negative count, lowest eigenvalues with their
    modes' wave numbers, and how far Newton moved the reflected displacement."""
    mu = wedge.mu.Get()
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
    newton = shell.solve()
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
    radii = np.linspace(0.05, RIM_RADIUS, 24)
    amplitude = [wave_number(np.array([shell.displacement[2](mesh(r * math.cos(a), r * math.sin(a), 0.0, ngs.BND))
                                       for a in 2 * math.pi * np.arange(RIM_SAMPLES) / RIM_SAMPLES]),
                             max_mode=RIM_MODES).spectrum[content["rim_k"]] for r in radii]
    return {"ndof": shell.space.ndof, "energy": shell.energy(), "residual_reflected": residual_start,
            "newton_iterations": newton.iterations, "max_displacement_change": moved,
            "negative": lowest.negative, "modes": modes, "rim": content,
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
        step: float = 0.05, jump: bool = False, realcompile: bool = False) -> dict:
    """For each wave number in ``ks``: the wedge's path to ``mu = 0`` (``follow_wedge``) and its
    end state on the full disk (``on_full_disk``); ``summary.json`` tabulates them with the
    energies relative to the lowest k (k = 2 when computed: the full disk's first pattern)."""
    for k in ks:
        check_wave(k, base_sectors)
    run_dir = RunDirectory(out, params=dict(p=p, ks=list(ks), maxh=maxh, order=order, t=t, n0=n0, nR=nR,
                                            base_sectors=base_sectors, mu_start=mu_start, step=step, jump=jump))
    progress = Progress("plate_wedges")
    rows = {}
    for k in ks:
        clock = time.perf_counter()
        wedge, mesh = wedge_plate(p, k, maxh=maxh, order=order, t=t, n0=n0, nR=nR, base_sectors=base_sectors,
                                  realcompile=realcompile)
        path = follow_wedge(wedge, mesh, k, run_dir=run_dir, mu_start=mu_start, step=step, jump=jump,
                            progress=progress)
        np.savez(run_dir.file(f"wedge_state_k{k}.npz"), state=wedge.save_state(), mu=wedge.mu.Get())
        full = on_full_disk(wedge, mesh, k, p=p, maxh=maxh, order=order, t=t, n0=n0, nR=nR,
                            base_sectors=base_sectors, progress=progress)
        np.savez(run_dir.file(f"state_k{k}.npz"), state=full.pop("state"), mu=wedge.mu.Get())
        rows[k] = {"k_wedge": k, "energy_full": full["energy"], "energy_wedge_times_2k": 2 * k * path["energy_wedge"],
                   "wedge": path, "full": full, "wall_s": time.perf_counter() - clock}
        run_dir.write_json(f"wedge_k{k}.json", rows[k])
        progress(f"k = {k}: full-disk energy {full['energy']:.10g}, negative {full['negative']}, rim k "
                 f"{full['rim']['rim_k']} (purity {full['rim']['rim_purity']:.2f})")
    reference = rows[2]["energy_full"] if 2 in rows else min(r["energy_full"] for r in rows.values())
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
    return summary


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
    parser.add_argument("--step", type=float, default=0.05, help="largest natural step in mu (kT)")
    parser.add_argument("--jump", action="store_true",
                        help="relax at mu = 0 from the onset's critical state instead of following the buckled "
                             "wedge in mu from 0.02 past its onset (the jump ended on unstable states at p = 0.75)")
    parser.add_argument("--realcompile", action="store_true", help="compile the residual to C++ (~20 s per shell)")
    args = parser.parse_args(argv)
    p, ks, maxh = args.p, tuple(args.k), args.maxh
    if quick_run(args):
        p, ks, maxh = 0.75, (4,), 0.3
    with silence_progress(args.quiet):
        summary = run(args.out, p=p, ks=ks, maxh=maxh, order=args.order, t=args.t, base_sectors=args.base_sectors,
                      mu_start=args.mu_start, step=args.step, jump=args.jump, realcompile=args.realcompile)
    print(json.dumps(summary, indent=1, default=str))
    return summary


if __name__ == "__main__":
    main()
