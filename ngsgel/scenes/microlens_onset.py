"""Hydrogel microlens under an inward apex load (thesis ch. 3, MODEL.md scene A): the first
non-axisymmetric instability of the clamped cap against Fitch's thresholds.

The cap (base radius ``R = 1``, apex height ``H``, thickness ``t = 0.005 r``, ``Nv = 1e-3``,
``mu = 0``) is pushed down at its apex under displacement control along the axisymmetric path
(r-z section; the load acts on an apex patch of radius ``apex``, the stand-in for the thesis's
concentrated displacement). At every converged state the second variation is scanned over
angular wave numbers ``k = 0 .. kmax`` (``ngsgel.harmonic``, exact for the 3D cap); the first
negative eigenvalue is bisected to the critical depth ``d/H`` and its wave number ``k``, which is
the number of vertices of the first polygonal state. Fitch's parameter
``lambda = 2 [3 (1 - nu^2)]^(1/4) sqrt(H/t)`` and his ranges (3 waves for lambda > 13.5, 4 for
9.9-13.5, 5 for 9.2-9.9, axisymmetric below 9.2) are tabulated next to ours twice: with the
thesis's nu = 0.5 and with the gel's drained Poisson ratio. The drained one is the right one here:
at fixed ``mu`` the solvent moves freely in and out, so the gel's incremental response about its
free-swollen state is the drained one (shear modulus ``Nv/lam0``, drained bulk modulus ``K`` of
``FloryRehnerGel.bulk_modulus``; nu = 0.31 for Nv = 1e-3, chi = 0.5, mu = 0), and that is what a
linear elastic shell of Fitch's theory must have to share the gel shell's bending and stretching
stiffnesses. nu = 0.5 is the instantaneous (undrained) response of a transient run, which the
equilibrium indentation never sees.

    ngsgel run microlens-onset --out results/microlens_onset [--H 0.1 0.2 0.3 0.4] [--quick]
"""

from __future__ import annotations

import math
import time

from ngsgel.scenes.microlens import GEL, THICKNESS_RATIO, AxisymmetricCap, Indentation, SectionResolution
from ngsgel.harmonic import first_harmonic_instability
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser


def fitch_lambda(H: float, t: float, nu: float = 0.5) -> float:
    return 2.0 * (3.0 * (1.0 - nu**2)) ** 0.25 * math.sqrt(H / t)


def drained_poisson_ratio(mu: float) -> float:
    """Poisson ratio of the cap's gel at fixed ``mu`` about its free-swollen state."""
    return GEL.drained_poisson_ratio(GEL.lam_free(mu))


def fitch_waves(lam: float) -> str:
    """Fitch's range for the first non-axisymmetric mode of a point-loaded clamped cap."""
    if lam > 13.5:
        return "3"
    if lam > 9.9:
        return "4"
    if lam > 9.2:
        return "5"
    return "axisymmetric"


def onset(H: float, *, maxh: float, layers: int = 2, order: int = 3, apex: float = 0.02, kmax: int = 8,
          max_depth: float = 2.0) -> dict:
    """First non-axisymmetric instability of the inward-loaded cap of apex height ``H``."""
    start = time.perf_counter()
    case = Indentation(H=H, direction="inward", depth=max_depth)
    cap = AxisymmetricCap(case, SectionResolution(maxh=maxh, layers=layers, order=order, apex=apex))
    t = case.t
    found = first_harmonic_instability(cap.problem, cap.depth, max_depth * H, ks=list(range(kmax + 1)),
                                       step=0.02 * H, max_step=0.05 * H, tolerance=1e-4 * H,
                                       stability=cap.harmonic)
    lam = fitch_lambda(H, t)
    nu = drained_poisson_ratio(case.mu)
    lam_drained = fitch_lambda(H, t, nu)
    return {"H": H, "t": t, "fitch_lambda": lam, "fitch_waves": fitch_waves(lam), "nu_drained": nu,
            "fitch_lambda_drained": lam_drained, "fitch_waves_drained": fitch_waves(lam_drained), "found": found.found,
            "depth_over_H": found.parameter / H if found.found else None, "k": found.k,
            "ndof_section": cap.problem.space.ndof, "maxh": maxh, "order": order, "apex_radius": apex,
            "wall_s": time.perf_counter() - start}


def main(argv=None) -> list[dict]:
    parser = scene_parser(__doc__, out="results/microlens_onset", quick="coarse, H = 0.3 only")
    parser.add_argument("--H", type=float, nargs="+", default=[0.1, 0.15, 0.2, 0.25, 0.3, 0.35, 0.4],
                        help="apex heights H / R")
    parser.add_argument("--maxh", type=float, default=0.01, help="cell length along the section / R")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the displacement")
    parser.add_argument("--apex", type=float, default=0.02, help="radius of the loaded apex patch / R")
    parser.add_argument("--kmax", type=int, default=8, help="largest angular wave number scanned")
    args = parser.parse_args(argv)
    quick = quick_run(args)
    heights = [0.3] if quick else args.H
    maxh, order = (0.04, 2) if quick else (args.maxh, args.order)
    run_dir = RunDirectory(args.out, params=dict(H=heights, maxh=maxh, order=order, apex=args.apex,
                                                 kmax=args.kmax, t_over_r=THICKNESS_RATIO, quick=quick))
    progress = Progress("microlens_onset", quiet=args.quiet)
    rows = []
    with History(run_dir.file("onset.csv")) as history:
        for H in heights:
            row = onset(H, maxh=maxh, order=order, apex=args.apex, kmax=args.kmax)
            history.append(row)
            rows.append(row)
            progress(f"H/R = {H}: lambda = {row['fitch_lambda']:.2f} (Fitch: {row['fitch_waves']}), drained "
                     f"{row['fitch_lambda_drained']:.2f} (Fitch: {row['fitch_waves_drained']}), "
                     + (f"k = {row['k']} at d/H = {row['depth_over_H']:.4f}" if row["found"]
                        else "no instability") + f", {row['wall_s']:.1f} s")
    return rows


if __name__ == "__main__":
    main()
