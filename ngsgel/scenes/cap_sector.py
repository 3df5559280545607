"""The pure three-fold branch of the inward-indented microlens cap on a 60-degree mirror sector, and
where it loses stability on the whole cap (issue 39, item 3).

The cap of ``microlens.py --model shell`` (H = 0.3 R, t/r = 0.005, clamped base, sliding rigid apex
patch of radius 0.02 R, ``mu = 0``) is computed on the sector ``0 <= theta <= pi/3`` with mirror
planes on both meridians (``plate_wedges.MirrorShell``: the edge at 60 degrees by a stiff penalty).
The sector carries only deflections with the symmetry of an equilateral triangle (wave numbers 0,
3, 6, ...): its path in the depth ``d`` (natural steps, exact negative count of the sector's
tangent, the first bifurcation - axisymmetric to three-fold - located and switched onto) is the pure
three-fold branch. Modes of the other wave numbers are invisible to the sector, so every state is
also mapped onto the whole cap, a mesh made of six mirror images of the sector's
(``geometries.caps.cap_sector_midsurface``: node by node, ``plate_wedges.Reflection``), and the
exact negative count of the whole cap's tangent is taken there at every state from ``check_from``
on, then bisected in ``d`` between the last stable and the first unstable state to ``tol`` H.
Reported: that depth, the lowest eigenvalues of the whole cap there and their modes' wave numbers.

A patterned state of the cap turned about its axis is again an equilibrium (cap and loads are
axisymmetric), so on the three-fold branch the whole cap has a neutral mode, the pattern's
rotation. The mesh of six mirror images keeps only the rotations by 120 degrees, and leaves that
mode an eigenvalue of round-off size (|eig| ~ 1e-9 against ~1e-5 for the next) and either sign.
A negative eigenvalue whose mode is that rotation (``ROTATION_OVERLAP``) is therefore not counted as
a loss of stability: the criterion is the count of the other negative eigenvalues.

Writes ``path.csv`` (sector path with the whole cap's negative count where checked) and
``summary.json``.

    ngsgel run cap-sector --out results/cap_sector --maxh 0.06
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import ngsolve as ngs

from geometries.caps import cap_sector_midsurface
from geometries.plates import SYM, SYM_END
from ngsgel import follow_path
from ngsgel.continuation import ContinuationError, StabilityOptions
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser, silence_progress
from ngsgel.scenes.microlens import GEL, THICKNESS_RATIO
from ngsgel.scenes.plate_wedges import MIRROR_PENALTY, MirrorShell, Reflection
from ngsgel.shell import GelShell
from ngsgel.stability import conjugate_force, free_matrix, mass_matrix, negative_count, spectrum

SECTOR = math.pi / 3
ROTATION_OVERLAP = 0.9  # a mode this parallel (L2 cosine of the displacements) to the rotation is it


class SectorCap:
    """The cap on the 60-degree mirror sector and on the whole cap (six images of its mesh), both
    clamped at the base with the apex patch's z displacement prescribed to ``-depth``."""

    def __init__(self, *, H: float, maxh: float, apex_maxh: float, apex: float, order: int, realcompile: bool):
        self.H, self.r = H, (1 + H**2) / (2 * H)
        self.t = THICKNESS_RATIO * self.r
        self.zc = H - self.r
        self.lam0 = GEL.lam_free(0.0)
        self.force_scale = GEL.youngs_modulus(self.lam0) * self.t**2
        options = dict(H=H, angle=SECTOR, maxh=maxh, apex_radius=apex, apex_maxh=apex_maxh, curve_order=order)
        self.mesh = cap_sector_midsurface(copies=1, **options).mesh
        self.full_mesh = cap_sector_midsurface(copies=6, **options).mesh
        shell = dict(material=GEL, lam0=self.lam0, thickness=self.t, mu=0.0, order=order)
        stiffness = MIRROR_PENALTY * GEL.shear_modulus(self.lam0) * self.t / maxh
        self.sector = MirrorShell(self.mesh, mirror_stiffness=stiffness, realcompile=realcompile, **shell)
        self.sector.clamp("base")
        self.sector.mirror(SYM, angle=0.0)
        self.sector.mirror(SYM_END, angle=SECTOR)
        self.depth = ngs.Parameter(0.0)
        self.sector.prescribe_region("apex", "z", -self.depth)
        self.full = GelShell(self.full_mesh, **shell)
        self.full.clamp("base")
        self.full_depth = ngs.Parameter(0.0)
        self.full.prescribe_region("apex", "z", -self.full_depth)
        fixed = GelShell(self.full_mesh, **shell)
        fixed.fix_rotation("base")
        self.reflection = Reflection(self.mesh, fixed, 3)

    def force(self) -> float:
        """``F/(E0 t^2)`` of the whole cap (six sectors)."""
        return 6 * conjugate_force(self.sector, self.depth) / self.force_scale

    def whole_cap(self, *, eigenvalues: int = 0) -> dict:
        """The sector's current state on the whole cap: the exact negative count of its tangent
        (``negative``) and ``unstable``, that count without a negative eigenvalue whose mode is the
        pattern's neutral rotation (``rotation_overlap``); the lowest eigenvalues (at least
        ``eigenvalues``, all negative ones and the next when there are any) with their modes' wave
        numbers and overlaps with the rotation."""
        self.full_depth.Set(self.depth.Get())
        self.full.restore_state(self.reflection.state(self.sector))
        with ngs.TaskManager():
            K = free_matrix(self.full.tangent(self.full.state), self.full.free_mask)
        negative = negative_count(K)
        result = {"negative": negative, "unstable": negative}
        count = max(eigenvalues, negative + 1 if negative else 0)
        if count:
            with ngs.TaskManager():
                M = free_matrix(mass_matrix(self.full), self.full.free_mask)
            lowest = spectrum(self.full, count=count, K=K, M=M)
            rotation = self.rotation_generator()
            mode = ngs.GridFunction(self.full.space)
            result["modes"] = []
            for value, vector in zip(lowest.eigenvalues, lowest.modes.T):
                values = np.zeros(self.full.space.ndof)
                values[self.full.free_mask] = vector
                mode.vec.FV().NumPy()[:] = values
                overlap = self.rotation_overlap(mode.components[0], rotation)
                result["modes"].append({"eigenvalue": float(value), "rotation_overlap": overlap,
                                        **self.waves(mode.components[0])})
            rotating = [m for m in result["modes"] if m["eigenvalue"] < 0 and m["rotation_overlap"] > ROTATION_OVERLAP]
            result["unstable"] = negative - min(len(rotating), 1)
        return result

    def rotation_generator(self) -> ngs.CoefficientFunction:
        """Displacement rate of the whole cap's state turned about the z axis, per radian: with
        ``phi = X + u``, ``d/da [Q_a phi(Q_-a X)] = e_z x u - grad(u) (e_z x X)`` (zero for an
        axisymmetric state)."""
        u = self.full.displacement
        return ngs.Cross(ngs.CF((0.0, 0.0, 1.0)), u) - ngs.Grad(u) * ngs.CF((-ngs.y, ngs.x, 0.0))

    def rotation_overlap(self, mode_u: ngs.GridFunction, rotation: ngs.CoefficientFunction) -> float:
        """``|(phi, g)| / (|phi| |g|)`` in L2 of the mid-surface for a mode's displacement ``phi`` and
        the rotation's ``g`` (0 when ``g`` vanishes: an axisymmetric state has no rotation mode)."""
        mesh = self.full_mesh
        u = self.full.displacement
        gg, pp = (ngs.Integrate(f * f, mesh, ngs.BND) for f in (rotation, mode_u))
        if not gg > 1e-20 * ngs.Integrate(u * u, mesh, ngs.BND):
            return 0.0
        return float(abs(ngs.Integrate(mode_u * rotation, mesh, ngs.BND)) / math.sqrt(gg * pp))

    def waves(self, u: ngs.GridFunction | None = None) -> dict:
        """Wave content of the normal deflection of ``u`` (default: the whole cap's state) from its
        values at the mesh vertices (an ``H1`` field's vertex coefficients are its values there; the
        deformed mesh's point search misses points on the sphere): on rings of horizontal radius
        0.1 ... 0.9 (width 0.1) the amplitudes of ``cos, sin k theta``, k <= 8, by least squares; the
        ring where the non-axisymmetric part is largest, its dominant k (>= 1), the runner-up, and
        the amplitudes of k = 1 ... 6 over t."""
        u = self.full.displacement if u is None else u
        points = np.array([v.point for v in self.full_mesh.vertices])
        dofs = [u.space.components[0].GetDofNrs(v)[0] for v in self.full_mesh.vertices]
        values = np.stack([u.components[i].vec.FV().NumPy()[dofs] for i in range(3)], axis=1)
        normal = (points - [0.0, 0.0, self.zc]) / self.r
        w = np.sum(values * normal, axis=1)
        rho, theta = np.hypot(points[:, 0], points[:, 1]), np.arctan2(points[:, 1], points[:, 0])
        modes = np.arange(9)
        best = None
        for ring in np.arange(0.1, 0.95, 0.1):
            inside = np.abs(rho - ring) < 0.05
            if np.count_nonzero(inside) < 2 * len(modes):
                continue
            basis = np.concatenate([np.cos(np.outer(theta[inside], modes)), np.sin(np.outer(theta[inside], modes[1:]))],
                                   axis=1)
            coefficients = np.linalg.lstsq(basis, w[inside], rcond=None)[0]
            amplitude = np.hypot(coefficients[1:len(modes)], coefficients[len(modes):])
            if best is None or amplitude.max() > best[1].max():
                best = (float(ring), amplitude)
        ring, amplitude = best
        order = np.argsort(amplitude)[::-1] + 1
        return {"k": int(order[0]), "k_second": int(order[1]), "purity": float(amplitude[order[0] - 1] / amplitude.sum()),
                "ring": ring, **{f"a{m}_over_t": float(amplitude[m - 1] / self.t) for m in range(1, 7)}}


def run(out: str, *, H: float = 0.3, maxh: float = 0.06, apex_maxh: float = 0.01, apex: float = 0.02, order: int = 3,
        depth: float = 1.6, step: float = 0.05, check_from: float = 0.5, tol: float = 0.005,
        realcompile: bool = False) -> dict:
    """The sector's path to ``depth`` H (natural steps of ``step`` H, halved when Newton fails, the
    sector's first bifurcation switched onto with amplitude 0.1 t), the whole cap checked at every
    state from ``check_from`` H on; between the last stable and the first unstable one the run
    bisects to ``tol`` H ("unstable": ``SectorCap.whole_cap``'s count, the rotation excluded)."""
    for name, value in (("maxh", maxh), ("step", step), ("depth", depth), ("tol", tol)):
        if not value > 0:
            raise ValueError(f"{name} must be > 0, got {value!r}")
    if not 0 <= check_from <= depth:
        raise ValueError(f"check_from must be in [0, depth = {depth!r}], got {check_from!r}")
    run_dir = RunDirectory(out, params=dict(H=H, maxh=maxh, apex_maxh=apex_maxh, apex=apex, order=order, depth=depth,
                                            step=step, check_from=check_from, tol=tol))
    progress = Progress("cap_sector")
    start = time.perf_counter()
    cap = SectorCap(H=H, maxh=maxh, apex_maxh=apex_maxh, apex=apex, order=order, realcompile=realcompile)
    checks: list[dict] = []

    def check(**extra) -> dict:
        result = {"d_over_H": cap.depth.Get() / H, **extra, **cap.whole_cap()}
        checks.append(result)
        run_dir.write_json("checks.json", checks)
        return result

    def whole_unstable() -> float:
        if cap.depth.Get() < check_from * H - 1e-12:
            return -1
        return check()["unstable"]

    qoi = {"d_over_H": lambda: cap.depth.Get() / H, "force": cap.force, "whole_unstable": whole_unstable}
    stability = StabilityOptions(eigenvalues=3, switch=True, amplitude=0.1, length=cap.t, tol=tol * H)
    with History(run_dir.file("path.csv")) as history:
        try:
            path = follow_path(cap.sector, cap.depth, method="natural", step=step * H, max_step=step * H,
                               min_step=step * H / 64, target=depth * H, stability=stability, qoi=qoi,
                               history=history, keep_states=True, progress=progress,
                               stop=lambda pt: pt.qoi["whole_unstable"] > 0)
        except ContinuationError as exc:
            path = exc.result
    points = path.points
    summary = {"ndof_sector": cap.sector.space.ndof, "ndof_whole": cap.full.space.ndof,
               "sector_events": [{"kind": e.kind, "d_over_H": e.parameter / H, "negative_after": e.negative_after}
                                 for e in path.events],
               "stop_reason": path.stop_reason, "end_d_over_H": points[-1].parameter / H}
    checked = [pt for pt in points if pt.qoi["whole_unstable"] >= 0]
    first = next((i for i, pt in enumerate(checked) if pt.qoi["whole_unstable"] > 0), None)
    if first == 0:
        summary["unstable_from_first_check"] = checked[0].parameter / H
    elif first is not None and "branch switch" in checked[first].events:
        # the bracket spans the sector's switch to another branch: no path in d joins its ends
        summary["bracket_across_branch_switch"] = [checked[first - 1].parameter / H, checked[first].parameter / H]
    elif first is not None:
        stable, unstable = checked[first - 1], checked[first]
        low, high = stable.parameter, unstable.parameter
        cap.sector.restore_state(stable.state)
        while high - low > tol * H:
            middle = 0.5 * (low + high)
            cap.depth.Set(middle)
            cap.sector.solve()
            result = check(bisection=True)
            progress(f"bisection: d/H = {middle / H:.4f}, whole cap negative {result['negative']}, "
                     f"unstable {result['unstable']}")
            if result["unstable"]:
                high = middle
            else:
                low = middle
        cap.depth.Set(high)
        cap.sector.solve()
        summary.update(loss_d_over_H=0.5 * (low + high) / H, bracket=[low / H, high / H], force=cap.force(),
                       whole_cap=cap.whole_cap(eigenvalues=4), waves=cap.waves(),
                       sector_negative=int(negative_count(free_matrix(cap.sector.tangent(cap.sector.state),
                                                                      cap.sector.free_mask))))
    summary["wall_s"] = time.perf_counter() - start
    run_dir.write_json("summary.json", summary)
    return summary


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/cap_sector", quick="h = 0.1 R, order 2, to d/H = 0.6")
    parser.add_argument("--H", type=float, default=0.3, help="apex height / base radius")
    parser.add_argument("--maxh", type=float, default=0.06, help="element size of the sector's mesh / R")
    parser.add_argument("--apex-maxh", type=float, default=0.01, help="element size on the apex patch / R")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the shell's displacement")
    parser.add_argument("--depth", type=float, default=1.6, help="final depth / H")
    parser.add_argument("--step", type=float, default=0.05, help="depth step / H")
    parser.add_argument("--check-from", type=float, default=0.5, help="depth / H from which the whole cap is checked")
    parser.add_argument("--tol", type=float, default=0.005, help="bisection tolerance of the depth / H")
    args = parser.parse_args(argv)
    maxh, order, depth = args.maxh, args.order, args.depth
    if quick_run(args):
        maxh, order, depth = 0.1, 2, 0.6
    with silence_progress(args.quiet):
        summary = run(args.out, H=args.H, maxh=maxh, apex_maxh=args.apex_maxh, order=order, depth=depth,
                      step=args.step, check_from=args.check_from, tol=args.tol)
    print(json.dumps(summary, indent=1, default=str))
    return summary


if __name__ == "__main__":
    main()
