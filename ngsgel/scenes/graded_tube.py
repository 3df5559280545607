"""Free swelling of a tube with axially graded cross-links (thesis ch. 5.5, MODEL.md scene D):
the axisymmetric (trumpet) path and the onset of non-axisymmetric buckling (petals) at its head.

The tube (inner radius ``Ri = 1``, wall ``t``, height ``L`` in the swollen reference at ``mu0``)
stands on a smooth rigid base (rollers: a base it were bonded to would hold the swelling gel's
foot at its dry-ish radius, and the foot, not the head, would buckle); ``Nv(z) = n0 + (nL - n0) (z/L)^p`` runs from the stiff
base (``n0 = 1e-2``) to the soft free head (``nL = 1e-3``), ``chi = 0.5``. The thesis gives no
dimensions; the defaults ``t = 0.02``, ``L = 2`` are our choice (at ``t = 0.05`` and 0.1 the
tube does not buckle up to ``mu = 0`` even at p = 10). As ``mu`` rises to 0 (load
parameter: the soft gel's free-swelling stretch, as in ``graded_plate.py``) the head swells more
than the base and flares into a trumpet; where its hoop compression is large enough the wall
buckles into ``k`` petals. Every state of the axisymmetric (r-z) path is scanned over wave
numbers ``k = 1 .. kmax`` (``ngsgel.harmonic``, exact for the 3D tube); the first negative
eigenvalue is bisected to ``mu_c``, ``k_c``. Reported: the flare of the head along the path,
the deformed mid-wall profile at the end (or at onset) with its curvature (concave, straight,
convex), ``mu_c``, ``k_c`` and the penetration depth of the critical mode from the head.
``--sweep P [P ...]`` runs several exponents; ``--linear-buckling MU [MU ...]`` the eigenvalue
buckling step (Abaqus ``*BUCKLE``) of the trumpet at those ``mu`` (``graded_plate.py``). Not done: the post-buckled petals (a 3D run).

    ngsgel run graded-tube --out results/graded_tube --sweep 1 3 5 7.5 10 [--quick]
    ngsgel run graded-tube --out results/tube_buckle --linear-buckling -1 -0.5 -0.1 --sweep 5 7.5 10
"""

from __future__ import annotations

import math
import time

import numpy as np

from geometries import tube_section
from geometries.fields import axial_grading
from ngsgel.scenes.graded_plate import (CHI, add_grading_options, check_bases, continuous_critical_wave_number, linear_buckling_bases,
                          local_minima, mismatch_strain, onset_curve, scan_path, soft_stretch_load, sweep,
                          write_onset_curve)
from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, ramp
from ngsgel.output import History, Progress, RunDirectory, VTKSeries, quick_run, scene_parser, silence_progress

RI = 1.0


def build(*, n0: float, nL: float, p: float, t: float, L: float, maxh: float, order: int,
          mu0: float) -> tuple[EquilibriumProblem, object]:
    """The r-z section of the graded tube on a smooth base, equilibrated at ``mu0``, and its load
    parameter (the soft gel's free-swelling stretch)."""
    for name, value in (("n0", n0), ("nL", nL), ("p", p), ("t", t), ("L", L), ("maxh", maxh)):
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    if not t < RI:
        raise ValueError(f"t (wall thickness / inner radius) must be < 1, got {t}")
    stiff = FloryRehnerGel(Nv=max(n0, nL), chi=CHI)
    lam0 = stiff.lam_free(mu0)  # also checks mu0
    mesh = tube_section(Ri=RI, Ro=RI + t, Hz=L, maxh=maxh, wall_layers=2, quad=True).mesh
    gel = FloryRehnerGel(Nv=axial_grading(n0, nL, p, L, model="axisymmetric"), chi=CHI)
    stretch, mu = soft_stretch_load(n0, nL, mu0)
    prob = EquilibriumProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=lam0, mu=mu, order=order)
    prob.fix("base", "z")
    prob.solve()
    return prob, stretch


def midwall_profile(prob: EquilibriumProblem, t: float, heights: np.ndarray) -> np.ndarray:
    """Deformed mid-wall line: reference height, current radius, current height."""
    r_mid = RI + t / 2
    rows = []
    for Z in heights:
        ur, uz = prob.displacement(prob.mesh(r_mid, float(Z)))
        rows.append((Z, r_mid + ur, Z + uz))
    return np.array(rows)


def profile_curvature(profile: np.ndarray) -> float:
    """Mean second derivative ``d^2 r / dz^2`` of the deformed mid-wall (quadratic fit, in units of
    its length): > 0 convex (flaring more and more towards the head), < 0 concave."""
    r, z = profile[:, 1], profile[:, 2]
    s = (z - z[0]) / (z[-1] - z[0])
    return float(2 * np.polyfit(s, r, 2)[0])


def run(out: str, *, n0: float = 1e-2, nL: float = 1e-3, p: float = 10.0, t: float = 0.02, L: float = 2.0,
        maxh: float = 0.05, order: int = 3, mu0: float = -1.0, kmax: int = 20, quick: bool = False) -> dict:
    if quick:
        maxh, order, kmax = max(maxh, 0.1), 2, min(kmax, 12)
    if not (isinstance(kmax, int) and kmax >= 2):
        raise ValueError(f"kmax must be an integer >= 2, got {kmax!r}")
    run_dir = RunDirectory(out, params=dict(n0=n0, nL=nL, p=p, t=t, L=L, Ri=RI, maxh=maxh, order=order, mu0=mu0,
                                            kmax=kmax, chi=CHI, quick=quick))
    progress = Progress(f"graded_tube p={p:g}")
    start = time.perf_counter()
    prob, stretch = build(n0=n0, nL=nL, p=p, t=t, L=L, maxh=maxh, order=order, mu0=mu0)
    stretch_end = FloryRehnerGel(Nv=min(n0, nL), chi=CHI).lam_free(0.0)
    step = (stretch_end - stretch.Get()) / (25 if quick else 50)
    ks = list(range(1, kmax + 1))
    heights = np.linspace(0.0, L, 81)
    head, foot = prob.mesh(RI + t, L), prob.mesh(RI + t, 0.0)

    def flare() -> dict:
        """Outer radius of the head over that of the base (both deformed)."""
        return {"head_flare": (RI + t + prob.displacement(head)[0]) / (RI + t + prob.displacement(foot)[0])}

    with History(run_dir.file("path.csv")) as history:
        scanned = scan_path(prob, stretch, nv=(n0, nL), target=stretch_end, step=step, ks=ks, length=t,
                            history=history, progress=progress, observe=flare,
                            end_profile=lambda: midwall_profile(prob, t, heights),
                            vtk=VTKSeries(prob.mesh, prob.fields(), run_dir.file("section")))
    profile = scanned.end_profile
    np.savetxt(run_dir.file("profile_end.csv"), profile, delimiter=",", header="Z,r,z", comments="")
    summary: dict = {"found": False, "mu_end": mismatch_strain(scanned.end_parameter, n0, nL)[0],
                     "head_flare_end": float(profile[-1, 1] / profile[0, 1]), "profile_curvature_end": profile_curvature(profile),
                     "axisymmetric_events": [e.kind for e in scanned.path.events],
                     "lowest_nonaxisymmetric_eigenvalue": scanned.lowest_nonaxisymmetric}
    onset = scanned.onset
    if onset is not None:
        a, b, c = scanned.stability.mode(onset.k, onset.spectrum.modes[:, 0])
        points = [prob.mesh(RI + t / 2, float(Z)) for Z in heights]
        amplitude = np.array([math.hypot(a(q), c(q)) for q in points])
        amplitude /= amplitude.max()
        np.savetxt(run_dir.file("onset_mode.csv"), np.column_stack([heights, amplitude]), delimiter=",",
                   header="Z,amplitude", comments="")
        summary.update(found=True, k_critical=onset.k, k_at_scan_limit=onset.k == kmax, mu_critical=mismatch_strain(onset.parameter, n0, nL)[0],
                       soft_stretch_critical=onset.parameter,
                       critical_swelling_strain=mismatch_strain(onset.parameter, n0, nL)[1],
                       penetration_depth=float(L - heights[np.argmax(amplitude >= 0.5)]))
    summary["wall_s"] = time.perf_counter() - start
    summary["ndof_section"] = prob.space.ndof
    run_dir.write_json("summary.json", summary)
    plot({p: profile}, run_dir.file("profile_end.png"))
    progress(f"done: {summary}")
    return summary


def onset_curve_case(out: str, *, n0: float = 1e-2, nL: float = 1e-3, p: float = 10.0, t: float = 0.02, L: float = 2.0,
                     maxh: float = 0.05, order: int = 3, mu0: float = -1.0, kmax: int = 20, quick: bool = False) -> dict:
    """Onset ``mu_c(k)`` of every wave number k = 1 .. kmax on the axisymmetric (trumpet) path
    (``graded_plate.onset_curve``; each k bisected alone) with the penetration depth of each
    critical mode from the head, the first-unstable ``k_c`` and the continuous critical wave
    number (``continuous_critical_wave_number``: how ``k_c`` drifts between integers with p)."""
    if quick:
        maxh, order, kmax = max(maxh, 0.1), 2, min(kmax, 12)
    run_dir = RunDirectory(out, params=dict(n0=n0, nL=nL, p=p, t=t, L=L, Ri=RI, maxh=maxh, order=order, mu0=mu0,
                                            kmax=kmax, chi=CHI, quick=quick, mode="onset curve"))
    start = time.perf_counter()
    prob, stretch = build(n0=n0, nL=nL, p=p, t=t, L=L, maxh=maxh, order=order, mu0=mu0)
    stretch_end = FloryRehnerGel(Nv=min(n0, nL), chi=CHI).lam_free(0.0)
    heights = np.linspace(0.0, L, 201)
    points = [prob.mesh(RI + t / 2, float(Z)) for Z in heights]

    def profile(hs, k, vector):  # |u_r, u_theta| of the mode along the mid-wall; depth from the head
        a, _, c = hs.mode(k, vector)
        return heights, np.array([math.hypot(a(q), c(q)) for q in points])

    onsets = onset_curve(prob, stretch, nv=(n0, nL), target=stretch_end, step=(stretch_end - stretch.Get()) / 50,
                         ks=list(range(1, kmax + 1)), profile=profile, progress=Progress(f"tube onset curve p = {p:g}"))
    write_onset_curve(run_dir.file("onset_curve.csv"), onsets)
    minima = local_minima(onsets)
    summary = {"p": p, "t": t, "L": L, "maxh": maxh, "kmax": kmax, "found": bool(minima),
               "local_minima": [{"k": o.k, "mu_c": o.mu} for o in minima],
               "k_continuous": continuous_critical_wave_number(onsets)}
    if minima:
        summary.update(k_critical=minima[0].k, mu_critical=minima[0].mu, depth_half_critical=minima[0].depth_half,
                       k_at_scan_limit=minima[0].k == kmax)
    summary["wall_s"] = time.perf_counter() - start
    run_dir.write_json("summary.json", summary)
    return summary


def linear_buckling_case(out: str, *, n0: float = 1e-2, nL: float = 1e-3, p: float = 10.0, t: float = 0.02,
                         L: float = 2.0, maxh: float = 0.05, order: int = 3, bases=(-1.0, -0.5, -0.1),
                         kmax: int = 20, quick: bool = False) -> dict:
    """The eigenvalue buckling step (``graded_plate.linear_buckling_bases``) of the trumpet at each
    base ``mu``, k = 2 .. kmax (k = 0, 1 carry rigid motions on the smooth base)."""
    if quick:
        maxh, order, kmax = max(maxh, 0.1), 2, min(kmax, 12)
    bases = check_bases(bases)
    run_dir = RunDirectory(out, params=dict(n0=n0, nL=nL, p=p, t=t, L=L, Ri=RI, maxh=maxh, order=order, bases=bases,
                                            kmax=kmax, chi=CHI, quick=quick, mode="linear buckling"))
    start = time.perf_counter()
    soft = FloryRehnerGel(Nv=min(n0, nL), chi=CHI)

    def build_at(base: float):
        # one Newton solve from the reference does not reach a state close to mu = 0 (graded
        # mismatch): equilibrate at -0.1 at most, then ramp
        prob, stretch = build(n0=n0, nL=nL, p=p, t=t, L=L, maxh=maxh, order=order, mu0=min(base, -0.1))
        if base > -0.1:
            ramp(prob, stretch, soft.lam_free(base), step=(soft.lam_free(base) - stretch.Get()) / 10)
        return prob, stretch

    with History(run_dir.file("linear_buckling.csv")) as table:
        rows = linear_buckling_bases(build_at, soft, bases, range(2, kmax + 1), table=table,
                                     progress=Progress(f"tube linear buckling p = {p:g}"))
    summary = {"p": p, "t": t, "L": L, "bases": rows, "wall_s": time.perf_counter() - start}
    run_dir.write_json("summary.json", summary)
    return summary


def linear_buckling_row(summary: dict) -> dict:
    return {f"k_first_base{b['mu_base']:g}": b["k_first"] for b in summary["bases"]}


def onset_row(summary: dict) -> dict:
    keys = ("found", "k_critical", "k_continuous", "mu_critical", "depth_half_critical", "k_at_scan_limit", "wall_s")
    return {k: summary.get(k, math.nan) for k in keys}


def tube_row(summary: dict) -> dict:
    """One line of a sweep table."""
    keys = ("found", "k_critical", "k_at_scan_limit", "mu_critical", "penetration_depth", "mu_end",
            "head_flare_end", "profile_curvature_end", "lowest_nonaxisymmetric_eigenvalue", "wall_s")
    return {k: summary.get(k, math.nan) for k in keys}


def plot(profiles: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 5))
    for i, (p, profile) in enumerate(profiles.items()):
        for sign in (1, -1):
            ax.plot(sign * profile[:, 1], profile[:, 2], color=f"C{i}", label=f"p = {p:g}" if sign == 1 else None)
    ax.set_aspect("equal")
    ax.set_xlabel("r (current)")
    ax.set_ylabel("z (current)")
    ax.set_title("mid-wall at the end of the axisymmetric path (or at onset)", fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/graded_tube", quick="coarse section, k <= 12")
    add_grading_options(parser, t=0.02, t_help="wall thickness t / Ri", length="Ri", maxh=0.05, kmax=20)
    parser.add_argument("--L", type=float, default=2.0, help="height L / Ri")
    parser.add_argument("--n0", type=float, default=1e-2, help="Nv at the base (dimensionless)")
    parser.add_argument("--nL", type=float, default=1e-3, help="Nv at the head (dimensionless)")
    parser.add_argument("--onset-curve", action="store_true",
                        help="onset mu_c(k) of every k = 1 .. kmax on the trumpet path and the continuous critical k")
    parser.add_argument("--linear-buckling", type=float, nargs="+", metavar="MU",
                        help="instead: the eigenvalue buckling step (Abaqus *BUCKLE) of the trumpet at each of these "
                             "mu (kT) (default: none, the path)")
    args = parser.parse_args(argv)
    with silence_progress(args.quiet):
        return _main(args)


def _main(args) -> dict:
    """The run the parsed options ask for."""
    options = dict(n0=args.n0, nL=args.nL, t=args.t, L=args.L, maxh=args.maxh, order=args.order, mu0=args.mu0, kmax=args.kmax,
                   quick=quick_run(args))
    if args.linear_buckling:
        options.pop("mu0")
        return {"sweep": sweep(args.out, args.sweep or [args.p], run_one=linear_buckling_case, row=linear_buckling_row,
                               bases=args.linear_buckling, **options)}
    if args.onset_curve:
        return {"sweep": sweep(args.out, args.sweep or [args.p], run_one=onset_curve_case, row=onset_row, **options)}
    if args.sweep:
        return {"sweep": sweep(args.out, args.sweep, run_one=run, row=tube_row, draw=plot, **options)}
    summary = run(args.out, p=args.p, **options)
    print(summary)
    return summary


if __name__ == "__main__":
    main()
