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
exact negative count of the whole cap's tangent is taken there (every ``check_every`` steps, then
bisected in ``d`` between the last stable and the first unstable state to ``tol`` H). Reported:
that depth, the lowest eigenvalues of the whole cap there and their modes' wave numbers.

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
        """The sector's current state on the whole cap: exact negative count of its tangent and,
        with ``eigenvalues``, the lowest ones with the wave numbers of their modes."""
        self.full_depth.Set(self.depth.Get())
        self.full.restore_state(self.reflection.state(self.sector))
        with ngs.TaskManager():
            K = free_matrix(self.full.tangent(self.full.state), self.full.free_mask)
        result = {"negative": negative_count(K)}
        if eigenvalues:
            with ngs.TaskManager():
                M = free_matrix(mass_matrix(self.full), self.full.free_mask)
            lowest = spectrum(self.full, count=eigenvalues, K=K, M=M)
            mode = ngs.GridFunction(self.full.space)
            result["modes"] = []
            for value, vector in zip(lowest.eigenvalues, lowest.modes.T):
                values = np.zeros(self.full.space.ndof)
                values[self.full.free_mask] = vector
                mode.vec.FV().NumPy()[:] = values
                result["modes"].append({"eigenvalue": float(value), **self.waves(mode.components[0])})
        return result

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
    state from ``check_from`` H on; at the first unstable one the run bisects back to ``tol`` H."""
    for name, value in (("maxh", maxh), ("step", step), ("depth", depth), ("tol", tol)):
        if not value > 0:
            raise ValueError(f"{name} must be > 0, got {value!r}")
    run_dir = RunDirectory(out, params=dict(H=H, maxh=maxh, apex_maxh=apex_maxh, apex=apex, order=order, depth=depth,
                                            step=step, check_from=check_from, tol=tol))
    progress = Progress("cap_sector")
    start = time.perf_counter()
    cap = SectorCap(H=H, maxh=maxh, apex_maxh=apex_maxh, apex=apex, order=order, realcompile=realcompile)
    checks: list[dict] = []

    def whole_negative() -> float:
        if cap.depth.Get() < check_from * H - 1e-12:
            return -1
        check = {"d_over_H": cap.depth.Get() / H, **cap.whole_cap()}
        checks.append(check)
        run_dir.write_json("checks.json", checks)
        return check["negative"]

    qoi = {"d_over_H": lambda: cap.depth.Get() / H, "force": cap.force, "whole_negative": whole_negative}
    stability = StabilityOptions(eigenvalues=3, switch=True, amplitude=0.1, length=cap.t, tol=tol * H)
    with History(run_dir.file("path.csv")) as history:
        try:
            path = follow_path(cap.sector, cap.depth, method="natural", step=step * H, max_step=step * H,
                               min_step=step * H / 64, target=depth * H, stability=stability, qoi=qoi,
                               history=history, keep_states=True, progress=progress,
                               stop=lambda pt: pt.qoi["whole_negative"] > 0)
        except ContinuationError as exc:
            path = exc.result
    points = path.points
    summary = {"ndof_sector": cap.sector.space.ndof, "ndof_whole": cap.full.space.ndof,
               "sector_events": [{"kind": e.kind, "d_over_H": e.parameter / H, "negative_after": e.negative_after}
                                 for e in path.events],
               "stop_reason": path.stop_reason, "end_d_over_H": points[-1].parameter / H}
    unstable = [pt for pt in points if pt.qoi["whole_negative"] > 0]
    if unstable:  # bisect between the last whole-stable state and the first unstable one
        first = points.index(unstable[0])
        stable = points[first - 1]
        low, high = stable.parameter, unstable[0].parameter
        cap.sector.restore_state(stable.state)
        cap.depth.Set(low)
        while high - low > tol * H:
            middle = 0.5 * (low + high)
            cap.depth.Set(middle)
            cap.sector.solve()
            negative = cap.whole_cap()["negative"]
            checks.append({"d_over_H": middle / H, "negative": negative, "bisection": True})
            run_dir.write_json("checks.json", checks)
            progress(f"bisection: d/H = {middle / H:.4f}, whole cap negative {negative}")
            if negative:
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
