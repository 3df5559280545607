"""Free-swelling disk with graded cross-links (thesis ch. 5, MODEL.md scene C): the axisymmetric
path (flat, or a bowl after an axisymmetric bifurcation), its stress profiles and the onset of
non-axisymmetric buckling by angular wave number.

The disk ``R = 1``, thickness ``t``, ``Nv(r) = n0 + (nR - n0) (r/R)^p``, ``chi = 0.5``, is
equilibrated at ``mu0`` (a graded gel has no stress-free uniform reference) and ``mu`` is raised
towards 0. The load parameter is the free-swelling stretch ``s`` of the softest gel of the
grading, ``mu = mu_free_soft(s)`` (a coefficient function of ``s``): nearly all the swelling
happens close to ``mu = 0``, where equal steps in ``mu`` would be huge steps in strain.

The r-z section is meshed symmetrically about the mid-plane (quads), so the flat plate is a
perfect pitchfork for bending: when a softer centre swells more than its rim it buckles into a
bowl, and the continuation driver locates that axisymmetric bifurcation (exact negative count of
the section's tangent), switches onto the bowl branch along the critical mode and follows it (no
imperfection). ``--imperfection`` adds a self-equilibrated radial shear ``E0 t r/R`` on the top
face instead, for comparison. At every converged state the second variation is scanned over wave
numbers ``k = 1 .. kmax`` (``ngsgel.harmonic``: exact for the 3D body, one 2D eigenproblem per k);
the first negative eigenvalue is bisected to the critical ``mu_c`` and its ``k_c``.

Reported per run: the axisymmetric events (bifurcation into a bowl, ``mu`` there), the deformed
mid-plane profile at the end and its shape exponent ``q`` (rise ~ r^q: 1 a cone, 2 a lens
(spherical cap), larger a bowl with a flat bottom), ``mu_c``, ``k_c``, the critical swelling
strain (the free-swelling mismatch ``lam_free(mu_c; soft) / lam_free(mu_c; stiff) - 1`` between
the softest and the stiffest gel), the hoop-stress profile at onset and where it turns
compressive, and the lowest eigenvalue by k along the path. ``--sweep P [P ...]`` runs several
exponents and draws their end profiles together. ``--onset-curve`` instead follows the flat path
to ``mu = 0`` and bisects the onset ``mu_c(k)`` of every wave number k = 1 .. kmax separately
(with the penetration depths of each critical mode, the local minima of ``mu_c(k)`` and ``k*``,
the k of the lowest eigenvalue at ``mu = 0``), for every p (``--p``/``--sweep``) and t/R
(``--t``/``--t-sweep``), with power-law fits of k against t/R; ``--end-only`` computes ``k*``
alone. ``--linear-buckling MU [MU ...]`` instead runs the eigenvalue buckling step of commercial
codes (Abaqus ``*BUCKLE``) on the flat disk equilibrated at each ``MU``: the order in which such a
code would list the wave numbers, whose modes are the usual imperfection seeds. What this script does not do: follow the non-axisymmetric post-buckled path
(``ngsgel/scenes/graded_plate_shell.py``).

    ngsgel run graded-plate --out results/graded_plate [--p 10 --n0 1e-2 --nR 1e-3 --t 0.01] [--quick]
    ngsgel run graded-plate --out results/softer_centre --n0 1e-3 --nR 1e-2 --sweep 0.25 0.75 2 10
    ngsgel run graded-plate --out results/onset_curves --onset-curve --sweep 0.25 0.75 2 10 --kmax 50
    ngsgel run graded-plate --out results/k_star --onset-curve --end-only --t-sweep 0.01 0.02 0.05 0.1 --kmax 100
    ngsgel run graded-plate --out results/buckle --linear-buckling -1 -0.5 -0.3 --sweep 0.25 0.75 2 10 --kmax 40
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from pathlib import Path
from dataclasses import dataclass

import numpy as np
import ngsolve as ngs

from geometries import plate_section
from geometries.fields import radial_grading
from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, follow_path, ramp
from ngsgel.continuation import PathResult, StabilityOptions
from ngsgel.harmonic import HarmonicStability, InstabilityOnset, first_harmonic_instability, stress_rate
from ngsgel.output import History, Progress, RunDirectory, VTKSeries, quick_run, scene_parser, silence_progress
from ngsgel.patterns import penetration_depth, power_law_fit
from ngsgel.supports import vertex_dof

CHI = 0.5


def _positive(name: str, value: float) -> float:
    if not (np.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def soft_stretch_load(n0: float, nR: float, mu0: float) -> tuple[ngs.Parameter, ngs.CoefficientFunction]:
    """The parameter ``s`` (at its value for ``mu0``) and ``mu`` as its function."""
    soft = FloryRehnerGel(Nv=min(n0, nR), chi=CHI)
    s = ngs.Parameter(soft.lam_free(mu0))
    J = s**3
    mu = soft.Nv * (s * s - 1) / J + ngs.log(1 - 1 / J) + 1 / J + CHI / (J * J)
    return s, mu


def build(*, n0: float, nR: float, p: float, t: float, maxh: float, layers: int = 2, order: int = 3,
          mu0: float = -1.0, imperfection: float = 0.0) -> tuple[EquilibriumProblem, ngs.Parameter]:
    """The axisymmetric section of the graded disk, equilibrated at ``mu0``, and its load
    parameter (the soft gel's free-swelling stretch, see the module notes). The axial rigid
    translation is removed by one statically determinate constraint (``u_z = 0`` at the centre
    of the mid-plane): its reaction must vanish, so no state is changed."""
    for name, value in (("n0", n0), ("nR", nR), ("p", p), ("t", t), ("maxh", maxh)):
        _positive(name, value)
    if not t < 0.5:
        raise ValueError(f"t (thickness / radius) must be < 0.5 for a plate, got {t}")
    if layers % 2:
        raise ValueError(f"layers must be even (a mid-plane vertex on the axis), got {layers}")
    stiff = FloryRehnerGel(Nv=max(n0, nR), chi=CHI)
    lam0 = stiff.lam_free(mu0)  # also checks mu0
    mesh = plate_section(R=1.0, t=t, maxh=maxh, layers=layers, quad=True).mesh  # mirror-symmetric in z
    gel = FloryRehnerGel(Nv=radial_grading(n0, nR, p, 1.0, model="axisymmetric"), chi=CHI)
    stretch, mu = soft_stretch_load(n0, nR, mu0)
    prob = EquilibriumProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=lam0, mu=mu, order=order)
    prob.fix("axis", "r")
    if imperfection:
        soft = FloryRehnerGel(Nv=min(n0, nR), chi=CHI)
        prob.add_traction("top", (imperfection * soft.youngs_modulus(lam0) * t * ngs.x, 0.0))
    prob.fix_dof(vertex_dof(prob, point=(0.0, 0.0), component=1))
    prob.solve()
    return prob, stretch


def mismatch_strain(stretch: float, n0: float, nR: float) -> tuple[float, float]:
    """``mu`` and ``lam_free(mu; soft) / lam_free(mu; stiff) - 1`` at the soft stretch ``stretch``."""
    soft, stiff = (FloryRehnerGel(Nv=n, chi=CHI) for n in (min(n0, nR), max(n0, nR)))
    mu = soft.mu_free(stretch)
    return mu, stretch / stiff.lam_free(mu) - 1.0


def stress_profile(prob: EquilibriumProblem, radii: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Radial and hoop Cauchy stress on the mid-plane (reference radii)."""
    sigma = prob.stress()
    mesh = prob.mesh
    pts = [mesh(float(r), 0.0) for r in radii]
    return np.array([sigma[0, 0](q) for q in pts]), np.array([sigma[2, 2](q) for q in pts])


def midplane_profile(prob: EquilibriumProblem, radii: np.ndarray) -> np.ndarray:
    """Deformed mid-plane: reference radius, current radius, height above the centre."""
    u = prob.displacement
    z_centre = u(prob.mesh(0.0, 0.0))[1]
    rows = []
    for R in radii:
        ur, uz = u(prob.mesh(float(R), 0.0))
        rows.append((R, R + ur, uz - z_centre))
    return np.array(rows)


def shape_exponent(profile: np.ndarray) -> float:
    """``q`` of the best fit ``z = z_rim (r / r_rim)^q`` of a deformed mid-plane (1: cone,
    2: spherical cap / lens, larger: a bowl, flat at the bottom); NaN for a flat plate."""
    from scipy.optimize import minimize_scalar

    r, z = profile[:, 1] / profile[-1, 1], profile[:, 2]
    if abs(z[-1]) < 1e-6 * profile[-1, 1]:
        return math.nan
    w = z / z[-1]
    return float(minimize_scalar(lambda q: np.sum((w - r**q) ** 2), bounds=(0.2, 20), method="bounded").x)


def compressive_from(radii: np.ndarray, hoop: np.ndarray) -> float | None:
    """Smallest radius beyond which the hoop stress stays compressive (None if never)."""
    negative = hoop < 0
    if not negative[-1]:
        return None
    last_positive = np.flatnonzero(~negative)
    return float(radii[last_positive[-1] + 1]) if len(last_positive) else float(radii[0])


@dataclass
class ScannedPath:
    path: PathResult
    stability: HarmonicStability
    onset: InstabilityOnset | None  # the state is left at the onset when there is one
    end_parameter: float  # where the path stopped (the first unstable state, or the target)
    end_profile: np.ndarray | None  # the caller's end_profile() there
    lowest_nonaxisymmetric: float  # the lowest k >= 1 eigenvalue seen along the path


def scan_path(prob: EquilibriumProblem, stretch: ngs.Parameter, *, nv: tuple[float, float], target: float,
              step: float, ks: list[int], length: float, history: History, progress,
              observe: Callable[[], dict], end_profile: Callable[[], np.ndarray] | None = None,
              method: str = "arclength", vtk: VTKSeries | None = None) -> ScannedPath:
    """Follow the axisymmetric path of a graded gel in its soft stretch to ``target`` (arclength by
    default: past a pitchfork the bowl's rise grows like the square root of the load, which a
    natural-parameter run crosses only in tiny steps): the driver locates axisymmetric bifurcations (a bowl leaving the flat state) and switches onto the new
    branch along the critical mode, ``0.1 length`` deep; every state is scanned over the wave
    numbers ``ks`` (non-axisymmetric, rigid motions excluded) and recorded in ``history`` with the
    quantities ``observe()`` returns. At the first negative eigenvalue the run stops and the
    onset is bisected from the last stable state. ``vtk`` gets every state of the path."""
    hs = HarmonicStability(prob)
    last_stable: dict = {"s": stretch.Get(), "state": prob.save_state()}
    lowest_seen = [math.inf]

    def unstable(point) -> bool:
        scan = hs.scan(ks, exclude_rigid=True)
        lowest = scan.lowest
        lowest_seen[0] = min(lowest_seen[0], *lowest.values())
        mu = mismatch_strain(point.parameter, *nv)[0]
        observed = observe()
        history.append({"soft_stretch": point.parameter, "mu": mu, **observed, "critical_k": scan.critical_k,
                        **{f"lowest_k{k}": v for k, v in lowest.items()}})
        progress(f"s = {point.parameter:.4f} mu = {mu:+.5f}  " + "  ".join(f"{k} {v:+.4f}" for k, v in observed.items())
                 + f"  lowest k = {scan.critical_k} ({min(lowest.values()):+.3e})")
        if scan.unstable:
            return True
        last_stable.update(s=point.parameter, state=prob.save_state())
        return False

    axisymmetric = StabilityOptions(eigenvalues=2, switch=True, amplitude=0.1, length=length, tol=1e-6)
    path = follow_path(prob, stretch, method=method, step=step, max_step=step, target=target,
                       stop=unstable, stability=axisymmetric, max_steps=1000, vtk=vtk)
    end_parameter = stretch.Get()
    profile = end_profile() if end_profile is not None else None
    onset = None
    if path.stop_reason == "criterion":
        s_unstable = path.points[-1].parameter
        prob.restore_state(last_stable["state"])
        stretch.Set(last_stable["s"])
        onset = first_harmonic_instability(prob, stretch, s_unstable, ks=ks, step=s_unstable - last_stable["s"],
                                           tolerance=1e-6, stability=hs)
        if not onset.found:
            raise RuntimeError(f"the instability seen at s = {s_unstable} was not found again on bisection")
    return ScannedPath(path=path, stability=hs, onset=onset, end_parameter=end_parameter, end_profile=profile,
                       lowest_nonaxisymmetric=lowest_seen[0])


def run(out: str, *, n0: float = 1e-2, nR: float = 1e-3, p: float = 10.0, t: float = 0.01,
        maxh: float = 0.02, layers: int = 2, order: int = 3, mu0: float = -1.0, kmax: int = 15,
        imperfection: float = 0.0, quick: bool = False) -> dict:
    if quick:
        maxh, order, kmax = max(maxh, 0.05), 2, min(kmax, 8)
    if not (isinstance(kmax, int) and kmax >= 2):
        raise ValueError(f"kmax must be an integer >= 2, got {kmax!r}")
    params = dict(n0=n0, nR=nR, p=p, t=t, maxh=maxh, layers=layers, order=order, mu0=mu0, kmax=kmax,
                  imperfection=imperfection, chi=CHI, quick=quick)
    run_dir = RunDirectory(out, params=params)
    progress = Progress("graded_plate")
    start = time.perf_counter()
    prob, stretch = build(n0=n0, nR=nR, p=p, t=t, maxh=maxh, layers=layers, order=order, mu0=mu0,
                          imperfection=imperfection)
    stretch_end = FloryRehnerGel(Nv=min(n0, nR), chi=CHI).lam_free(0.0)
    step = (stretch_end - stretch.Get()) / (25 if quick else 60)
    ks = list(range(1, kmax + 1))  # k = 0 is the section's own tangent: the driver checks it
    radii = np.linspace(0.0, 1.0, 101)[1:]
    centre = prob.mesh(0.0, 0.0)
    rim = prob.mesh(1.0, 0.0)

    with History(run_dir.file("path.csv")) as history:
        scanned = scan_path(prob, stretch, nv=(n0, nR), target=stretch_end, step=step, ks=ks, length=t,
                            history=history, progress=progress,
                            observe=lambda: {"rim_rise": prob.displacement(rim)[1] - prob.displacement(centre)[1]},
                            end_profile=lambda: midplane_profile(prob, radii),
                            vtk=VTKSeries(prob.mesh, prob.fields(), run_dir.file("section")))
    path, onset, hs = scanned.path, scanned.onset, scanned.stability
    profile = scanned.end_profile
    np.savetxt(run_dir.file("profile_end.csv"), profile, delimiter=",", header="R,r,z", comments="")
    summary: dict = {"found": False, "rim_rise_end": float(profile[-1, 2]),
                     "mu_end": mismatch_strain(scanned.end_parameter, n0, nR)[0],
                     "profile_exponent_end": shape_exponent(profile),
                     "axisymmetric_events": [{"kind": e.kind, "soft_stretch": e.parameter,
                                              "mu": mismatch_strain(e.parameter, n0, nR)[0]} for e in path.events],
                     "lowest_nonaxisymmetric_eigenvalue": scanned.lowest_nonaxisymmetric}
    if onset is not None:
        mu_c, strain_c = mismatch_strain(onset.parameter, n0, nR)
        radial, hoop = stress_profile(prob, radii)
        np.savetxt(run_dir.file("onset_profile.csv"), np.column_stack([radii, radial, hoop]), delimiter=",",
                   header="r,sigma_rr,sigma_hoop", comments="")
        a, b, c = hs.mode(onset.k, onset.spectrum.modes[:, 0])
        mode_r = np.array([[a(prob.mesh(float(r), 0.0)), b(prob.mesh(float(r), 0.0))] for r in radii])
        amplitude = np.abs(mode_r[:, 1]) / np.max(np.abs(mode_r[:, 1]))
        summary.update(found=True, mu_critical=mu_c, soft_stretch_critical=onset.parameter, k_critical=onset.k,
                       critical_swelling_strain=strain_c,
                       hoop_compressive_from_r=compressive_from(radii, hoop),
                       mode_half_width_r=float(radii[np.argmax(amplitude >= 0.5)]))
        plot(run_dir, radii, radial, hoop, amplitude, history_path=run_dir.file("path.csv"), summary=summary)
    summary["wall_s"] = time.perf_counter() - start
    summary["ndof_section"] = prob.space.ndof
    run_dir.write_json("summary.json", summary)
    plot_profiles({p: profile}, run_dir.file("profile_end.png"), title=f"n0 = {n0:g}, nR = {nR:g}, t/R = {t:g}, "
                  f"mu = {summary['mu_end']:.2g}")
    return summary


def plate_row(summary: dict) -> dict:
    """One line of a sweep table."""
    keys = ("found", "k_critical", "mu_critical", "mu_end", "rim_rise_end", "profile_exponent_end",
            "lowest_nonaxisymmetric_eigenvalue", "wall_s")
    bifurcations = [e["mu"] for e in summary["axisymmetric_events"] if e["kind"] == "bifurcation"]
    return {**{k: summary.get(k, math.nan) for k in keys},
            "mu_axisymmetric_bifurcation": bifurcations[0] if bifurcations else math.nan}


def sweep(out: str, ps, *, run_one: Callable[..., dict] | None = None, row: Callable[[dict], dict] = plate_row,
          draw: Callable | None = None, **options) -> list[dict]:
    """``run_one`` (default: this script's ``run``) for every grading exponent in ``ps``, one
    folder each; the table of ``row(summary)`` and the end profiles (of the runs that write
    ``profile_end.csv``) drawn by ``draw`` in ``out``."""
    run_one = run if run_one is None else run_one
    run_dir = RunDirectory(out, params={"ps": list(ps), **options})
    rows, profiles = [], {}
    with History(run_dir.file("sweep.csv")) as table:
        for p in ps:
            folder = run_dir.file(f"p{p:g}")
            rows.append({"p": p, **row(run_one(str(folder), p=p, **options))})
            table.append(rows[-1])
            if (folder / "profile_end.csv").exists():  # runs of a path have one; onset curves do not
                profiles[p] = np.loadtxt(folder / "profile_end.csv", delimiter=",", skiprows=1)
    if profiles and draw is None:
        plot_profiles(profiles, run_dir.file("profiles.png"),
                      title=", ".join(f"{k} = {options[k]:g}" for k in ("n0", "nR", "t") if k in options))
    elif profiles:
        draw(profiles, run_dir.file("profiles.png"))
    for line in rows:
        print("  ".join(f"{k} {v:.4g}" if isinstance(v, float) else f"{k} {v}" for k, v in line.items()))
    return rows


def plot_profiles(profiles: dict, path, *, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 4.2))
    for p, profile in profiles.items():
        for sign in (1, -1):  # the section and its mirror image through the axis
            ax.plot(sign * profile[:, 1], profile[:, 2], color=f"C{list(profiles).index(p)}",
                    label=f"p = {p:g}, q = {shape_exponent(profile):.2f}" if sign == 1 else None)
    ax.set_aspect("equal")
    ax.set_xlabel("r (current)")
    ax.set_ylabel("z - z(centre)")
    ax.set_title(title, fontsize=8)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def plot(run_dir, radii, radial, hoop, amplitude, *, history_path, summary) -> None:
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = list(csv.DictReader(open(history_path)))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2))
    ax1.plot(radii, radial, label="sigma_rr")
    ax1.plot(radii, hoop, label="sigma_hoop")
    ax1.plot(radii, amplitude * np.max(np.abs(hoop)), "k:", label="|w| of the critical mode (scaled)")
    ax1.axhline(0, color="grey", lw=0.5)
    ax1.set_xlabel("r / R")
    ax1.set_ylabel("mid-plane Cauchy stress [kT/v]")
    ax1.set_title(f"at onset mu = {summary['mu_critical']:.4f}, k = {summary['k_critical']}")
    ax1.legend(fontsize=8)
    stretches = np.array([float(r["soft_stretch"]) for r in rows])
    for key in rows[0]:
        if key.startswith("lowest_k"):
            ax2.plot(stretches, [float(r[key]) for r in rows], label=key[7:])
    ax2.axhline(0, color="grey", lw=0.5)
    ax2.set_yscale("symlog", linthresh=1e-7)
    ax2.set_xlabel("free-swelling stretch of the soft gel")
    ax2.set_ylabel("lowest eigenvalue of wave number k")
    ax2.legend(fontsize=7, ncol=3)
    fig.tight_layout()
    fig.savefig(run_dir.file("onset.png"), dpi=130)
    plt.close(fig)


# --------------------------------------------------------------------------- onset curve mu_c(k)

@dataclass
class WaveOnset:
    """First loss of stability of one wave number ``k`` on the flat (axisymmetric) path."""

    k: int
    found: bool  # False: k stays stable up to the target
    soft_stretch: float  # bisected onset (NaN if not found)
    mu: float
    depth_half: float  # penetration depths of the critical mode's deflection (NaN if not found)
    depth_5pct: float
    lowest_end: float  # lowest eigenvalue of k at the end of the path (the target)


def mode_deflection(hs: HarmonicStability, k: int, vector: np.ndarray, radii: np.ndarray) -> np.ndarray:
    """|w| = |b| of a mode of wave number ``k`` on the mid-plane at ``radii``, over its maximum."""
    b = hs.mode(k, vector)[1]
    mesh = hs.problem.mesh
    w = np.abs([b(mesh(float(r), 0.0)) for r in radii])
    return w / np.max(w)


def lowest_eigenvalue(hs: HarmonicStability, k: int) -> float:
    """The lowest eigenvalue of wave number ``k`` (rigid motions excluded; with several negative
    ones the lowest, not the one nearest zero)."""
    return float(np.min(hs.spectrum(k, count=1, exclude_rigid=True, past_negative=True).eigenvalues))


def onset_curve(prob: EquilibriumProblem, stretch: ngs.Parameter, *, nv: tuple[float, float], target: float,
                step: float, ks: list[int], tolerance: float = 1e-6, radii: np.ndarray | None = None,
                profile: Callable | None = None, progress=None, onsets: bool = True) -> list[WaveOnset]:
    """The onset ``mu_c(k)`` of every wave number in ``ks`` on the flat path: the soft stretch is
    ramped to ``target`` in steps of at most ``step`` (no branch switching: the mid-plane symmetric
    flat state is followed also where it is unstable), every state is scanned over the ks still
    stable, and each k whose lowest eigenvalue first turns negative between two states is bisected alone from the
    earlier one (``first_harmonic_instability`` with ``ks = [k]``) to ``tolerance`` in the stretch.
    The critical mode's deflection gives the penetration depths: the distance from the rim over
    which ``|w|`` stays above half, and above 5 %, of its value at the rim (``radii``: mid-plane
    samples, default 1001 points on (0, 1]); ``profile(hs, k, vector) -> (positions, amplitude)``
    replaces that sampling for other bodies (the depth is measured from the largest position).
    The problem is left at the end of the path.
    ``onsets=False``: only the lowest eigenvalue of every k at the end (no scans on the way, no
    bisection; every ``found`` is False)."""
    radii = np.linspace(0.0, 1.0, 1001)[1:] if radii is None else radii
    if profile is None:
        def profile(hs, k, vector):
            return radii, mode_deflection(hs, k, vector, radii)
    hs = HarmonicStability(prob)
    scan = hs.scan(ks, exclude_rigid=True)
    if scan.unstable:
        raise ValueError(f"the start at s = {stretch.Get():g} is already unstable for k in {scan.unstable}")
    states = [(stretch.Get(), prob.save_state())]
    first_unstable: dict[int, int] = {}  # k -> index of the first state where it is unstable
    pending = list(ks) if onsets else []  # a k once unstable is not scanned again: only its first crossing counts

    def on_step(value, _newton) -> bool:
        states.append((value, prob.save_state()))
        if pending:
            for k in hs.scan(pending, exclude_rigid=True).unstable:
                first_unstable[k] = len(states) - 1
                pending.remove(k)
        if progress is not None:
            progress(f"s = {value:.4f} mu = {mismatch_strain(value, *nv)[0]:+.5f}  {len(pending)} k still stable")
        return False

    ramp(prob, stretch, target, step=step, max_step=step, on_step=on_step)
    end = (stretch.Get(), prob.save_state())
    lowest_end = {k: lowest_eigenvalue(hs, k) for k in ks}
    result = []
    for k in ks:
        first = first_unstable.get(k)
        if first is None:
            result.append(WaveOnset(k, False, math.nan, math.nan, math.nan, math.nan, lowest_end[k]))
            continue
        (s_lo, x_lo), (s_hi, _) = states[first - 1], states[first]
        prob.restore_state(x_lo)
        stretch.Set(s_lo)
        onset = first_harmonic_instability(prob, stretch, s_hi, ks=[k], step=s_hi - s_lo, tolerance=tolerance,
                                           stability=hs)
        if not onset.found:
            raise RuntimeError(f"k = {k}: the instability seen at s = {s_hi} was not found again on bisection")
        where, w = profile(hs, k, onset.spectrum.modes[:, 0])
        result.append(WaveOnset(k, True, onset.parameter, mismatch_strain(onset.parameter, *nv)[0],
                                penetration_depth(w, where, fraction=0.5), penetration_depth(w, where, fraction=0.05),
                                lowest_end[k]))
        if progress is not None:
            progress(f"k = {k}: mu_c = {result[-1].mu:+.6f}, depth (half) {result[-1].depth_half:.3f}")
    prob.restore_state(end[1])
    stretch.Set(end[0])
    return result


def local_minima(onsets: list[WaveOnset]) -> list[WaveOnset]:
    """The wave numbers whose onset ``mu_c`` is lower than (or equal to) both neighbours' (a k that
    never goes unstable counts as +infinity; the ends of the scanned range count if lower than
    their one neighbour), lowest ``mu_c`` first."""
    mu = np.array([o.mu if o.found else math.inf for o in onsets])
    padded = np.concatenate([[math.inf], mu, [math.inf]])
    found = [o for i, o in enumerate(onsets) if o.found and mu[i] <= padded[i] and mu[i] <= padded[i + 2]]
    return sorted(found, key=lambda o: o.mu)


def write_onset_curve(path, onsets: list[WaveOnset]) -> None:
    """``onset_curve.csv``: one row per wave number."""
    with History(path) as table:
        for o in onsets:
            table.append({"k": o.k, "found": o.found, "soft_stretch_c": o.soft_stretch, "mu_c": o.mu,
                          "depth_half": o.depth_half, "depth_5pct": o.depth_5pct, "lowest_end": o.lowest_end})


def continuous_critical_wave_number(onsets: list[WaveOnset]) -> float | None:
    """The minimiser of the parabola through ``mu_c`` at the first-unstable k and its two
    neighbours: the critical wave number as a real number (how the selection drifts between
    integers as a parameter changes). None if a neighbour is missing or never goes unstable."""
    found = {o.k: o.mu for o in onsets if o.found}
    if not found:
        return None
    k = min(found, key=found.get)
    if k - 1 not in found or k + 1 not in found:
        return None
    left, mid, right = found[k - 1], found[k], found[k + 1]
    curvature = left - 2 * mid + right
    return float(k + 0.5 * (left - right) / curvature) if curvature > 0 else None


def onset_curve_case(out: str, *, n0: float = 1e-2, nR: float = 1e-3, p: float = 10.0, t: float = 0.01,
                     maxh: float = 0.02, layers: int = 2, order: int = 3, mu0: float = -1.0, kmax: int = 40,
                     end_only: bool = False, quick: bool = False) -> dict:
    """``onset_curve`` for wave numbers 1 .. kmax of one graded disk, ``onset_curve.csv`` and a
    summary: the first-unstable ``k_c``, ``mu_c``, the edge-wave minimum (the lowest local
    minimum of ``mu_c(k)`` other than ``k_c``'s, if any) with its penetration depths, and the
    wave number ``k*`` of the lowest eigenvalue of the flat disk at the end (``mu = 0``; flagged
    when it is ``kmax``, i.e. possibly outside the scanned range). ``end_only``: ``k*`` alone."""
    if quick:
        maxh, order, kmax = max(maxh, 0.05), 2, min(kmax, 8)
    if not (isinstance(kmax, int) and kmax >= 2):
        raise ValueError(f"kmax must be an integer >= 2, got {kmax!r}")
    run_dir = RunDirectory(out, params=dict(n0=n0, nR=nR, p=p, t=t, maxh=maxh, layers=layers, order=order,
                                            mu0=mu0, kmax=kmax, chi=CHI, end_only=end_only, quick=quick,
                                            mode="onset curve"))
    start = time.perf_counter()
    prob, stretch = build(n0=n0, nR=nR, p=p, t=t, maxh=maxh, layers=layers, order=order, mu0=mu0)
    stretch_end = FloryRehnerGel(Nv=min(n0, nR), chi=CHI).lam_free(0.0)
    step = (stretch_end - stretch.Get()) / (25 if quick else 60)
    onsets = onset_curve(prob, stretch, nv=(n0, nR), target=stretch_end, step=step, ks=list(range(1, kmax + 1)),
                         progress=Progress(f"onset curve p = {p:g}, t = {t:g}"), onsets=not end_only)
    write_onset_curve(run_dir.file("onset_curve.csv"), onsets)
    minima = local_minima(onsets)
    summary: dict = {"p": p, "t": t, "maxh": maxh, "layers": layers, "order": order, "kmax": kmax,
                     "ndof_section": prob.space.ndof, "found": bool(minima),
                     "local_minima": [{"k": o.k, "mu_c": o.mu} for o in minima],
                     "k_most_unstable_end": min(onsets, key=lambda o: o.lowest_end).k,
                     "lowest_end": min(o.lowest_end for o in onsets)}
    summary["k_most_unstable_end_at_kmax"] = summary["k_most_unstable_end"] == kmax
    if minima:
        first, edge = minima[0], next((o for o in minima[1:] if o.k > minima[0].k), None)
        summary.update(k_critical=first.k, mu_critical=first.mu, depth_half_critical=first.depth_half,
                       depth_5pct_critical=first.depth_5pct)
        if edge is not None:
            summary.update(k_edge=edge.k, mu_edge=edge.mu, depth_half_edge=edge.depth_half,
                           depth_5pct_edge=edge.depth_5pct, mu_gap_edge=edge.mu - first.mu)
    summary["wall_s"] = time.perf_counter() - start
    run_dir.write_json("summary.json", summary)
    return summary


def onset_curves(out: str, ps, ts, **options) -> list[dict]:
    """``onset_curve_case`` for every (p, t) pair of ``ps`` x ``ts``, one folder each, the table
    ``onset_curves.csv`` and the figure ``onset_curves.png`` (``mu_c`` against k) in ``out``."""
    run_dir = RunDirectory(out, params={"ps": list(ps), "ts": list(ts), **options})
    keys = ("k_critical", "mu_critical", "depth_half_critical", "k_edge", "mu_edge", "mu_gap_edge",
            "depth_half_edge", "depth_5pct_edge", "k_most_unstable_end", "k_most_unstable_end_at_kmax",
            "lowest_end", "ndof_section", "wall_s")
    rows, curves = [], {}
    with History(run_dir.file("onset_curves.csv")) as table:
        for p in ps:
            for t in ts:
                folder = run_dir.file(f"p{p:g}_t{t:g}")
                summary = onset_curve_case(str(folder), p=p, t=t, **options)
                rows.append({"p": p, "t": t, **{k: summary.get(k, math.nan) for k in keys}})
                table.append(rows[-1])
                curves[(p, t)] = np.genfromtxt(folder / "onset_curve.csv", delimiter=",", names=True)
    fits = {}
    for p in ps:  # k(t/R) at fixed p, for the edge-wave minimum and for k* (unstable, inside the scanned range)
        for key in ("k_edge", "k_most_unstable_end"):
            usable = [r for r in rows if r["p"] == p and np.isfinite(r[key]) and not r["k_most_unstable_end_at_kmax"]
                      and r["lowest_end"] < 0]
            if len({r["t"] for r in usable}) >= 3:
                fits[f"p{p:g}_{key}"] = fit = power_law_fit([r["t"] for r in usable], [r[key] for r in usable])
                print(f"p = {p:g}: {key} ~ (t/R)^b, b = {fit['exponent']:.3f} +- {fit['standard_error']:.3f} "
                      f"({fit['points']} points)")
    if fits:
        run_dir.write_json("k_fits.json", fits)
    plot_onset_curves(curves, run_dir.file("onset_curves.png"))
    for line in rows:
        print("  ".join(f"{k} {v:.5g}" if isinstance(v, float) else f"{k} {v}" for k, v in line.items()))
    return rows


def linear_buckling_bases(build_at: Callable[[float], tuple], soft: FloryRehnerGel, bases, ks, *, table,
                          progress) -> list[dict]:
    """The eigenvalue buckling step of commercial codes (Abaqus ``*BUCKLE``), whose modes are the
    usual seeds of "an infinitesimal initial geometry imperfection": at the axisymmetric state
    ``build_at(mu)`` (a problem and its soft-stretch load) for each ``mu`` in ``bases``,
    ``(K_k + lambda G_k) phi = 0`` for every k in ``ks`` with ``G_k`` the initial-stress matrix of
    the stress per unit load increment (``ngsgel.harmonic``: ``stress_rate``, ``linear_buckling``).
    Multipliers per unit ``mu`` (the load's rate at the base): a commercial code lists the modes
    in that order, lowest first. One ``table`` row per base and k; per base the first k (None if
    the increment compresses nothing that can buckle: no positive multiplier) and the next three."""
    rows = []
    for base in bases:
        prob, stretch = build_at(base)
        s0 = stretch.Get()
        h = 1e-6 * s0
        mu_per_stretch = (soft.mu_free(s0 + h) - soft.mu_free(s0 - h)) / (2 * h)
        hs = HarmonicStability(prob)
        rate = stress_rate(prob, stretch)
        multipliers = {}
        for k in ks:
            multipliers[k] = float(hs.linear_buckling(k, rate)[0]) * mu_per_stretch
            table.append({"mu_base": base, "k": k, "multiplier_mu": multipliers[k], "mu_linear": base + multipliers[k]})
        listed = [k for k in sorted(multipliers, key=multipliers.get) if math.isfinite(multipliers[k])]
        first = listed[0] if listed else None
        rows.append({"mu_base": base, "k_first": first, "multiplier_mu": multipliers[first] if first else math.inf,
                     "mu_linear": base + multipliers[first] if first else math.inf, "next_k": listed[1:4],
                     "next_multipliers": [multipliers[k] for k in listed[1:4]], "first_at_kmax": first == max(ks)})
        progress(f"base mu {base:g}: " + (f"first k {first} at mu {base + multipliers[first]:+.4f}, then "
                                            + ", ".join(f"{k} ({base + multipliers[k]:+.4f})" for k in listed[1:4])
                                            if first else "no positive multiplier for any k"))
    return rows


def check_bases(bases) -> list[float]:
    bases = [float(b) for b in bases]
    if not bases or any(not b < 0 for b in bases):
        raise ValueError(f"bases must be chemical potentials < 0 (states below mu = 0), got {bases!r}")
    return bases


def linear_buckling_case(out: str, *, n0: float = 1e-2, nR: float = 1e-3, p: float = 10.0, t: float = 0.01,
                         maxh: float = 0.02, layers: int = 2, order: int = 3, bases=(-1.0, -0.5, -0.3),
                         kmax: int = 40, quick: bool = False) -> dict:
    """``linear_buckling_bases`` for the flat disk, k = 2 .. kmax (k = 0, 1 carry rigid motions):
    ``linear_buckling.csv`` and a summary with the first k per base."""
    if quick:
        maxh, order, kmax = max(maxh, 0.05), 2, min(kmax, 8)
    if not (isinstance(kmax, int) and kmax >= 2):
        raise ValueError(f"kmax must be an integer >= 2, got {kmax!r}")
    bases = check_bases(bases)
    run_dir = RunDirectory(out, params=dict(n0=n0, nR=nR, p=p, t=t, maxh=maxh, layers=layers, order=order,
                                            bases=bases, kmax=kmax, chi=CHI, quick=quick, mode="linear buckling"))
    start = time.perf_counter()
    with History(run_dir.file("linear_buckling.csv")) as table:
        rows = linear_buckling_bases(
            lambda base: build(n0=n0, nR=nR, p=p, t=t, maxh=maxh, layers=layers, order=order, mu0=base),
            FloryRehnerGel(Nv=min(n0, nR), chi=CHI), bases, range(2, kmax + 1), table=table,
            progress=Progress(f"linear buckling p = {p:g}, t = {t:g}"))
    summary = {"p": p, "t": t, "bases": rows, "wall_s": time.perf_counter() - start}
    run_dir.write_json("summary.json", summary)
    return summary


def plot_onset_curves(curves: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for i, ((p, t), data) in enumerate(curves.items()):
        label = f"p = {p:g}, t/R = {t:g}"
        ax.plot(data["k"], data["mu_c"], "o-", ms=3, color=f"C{i % 10}", label=label)
        ax2.plot(data["k"], data["lowest_end"], "o-", ms=3, color=f"C{i % 10}", label=label)
    ax.set_xlabel("wave number k")
    ax.set_ylabel("onset mu_c(k) on the flat path")
    ax.set_yscale("symlog", linthresh=1e-3)
    ax2.set_xlabel("wave number k")
    ax2.set_ylabel("lowest eigenvalue of k, flat disk at mu = 0")
    ax2.set_yscale("symlog", linthresh=1e-6)
    for a in (ax, ax2):
        a.legend(fontsize=7)
        a.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def add_grading_options(parser, *, t: float, t_help: str, length: str, maxh: float, kmax: int) -> None:
    """The options every graded-gel scene shares: exponent(s), thickness, mesh, start, scan.
    ``length`` names the scene's unit of length (``R``, ``Ri``)."""
    parser.add_argument("--p", type=float, default=10.0, help="grading exponent (dimensionless)")
    parser.add_argument("--sweep", type=float, nargs="+",
                        help="run these grading exponents p instead of --p (default: --p only)")
    parser.add_argument("--t", type=float, default=t, help=t_help)
    parser.add_argument("--maxh", type=float, default=maxh, help=f"cell size along the section / {length}")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the displacement")
    parser.add_argument("--mu0", type=float, default=-1.0, help="starting chemical potential (kT)")
    parser.add_argument("--kmax", type=int, default=kmax, help="largest angular wave number scanned")


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/graded_plate", quick="coarse section, k <= 8")
    add_grading_options(parser, t=0.01, t_help="thickness t / R", length="R", maxh=0.02, kmax=15)
    parser.add_argument("--n0", type=float, default=1e-2, help="Nv at the centre (dimensionless)")
    parser.add_argument("--nR", type=float, default=1e-3, help="Nv at the edge (dimensionless)")
    parser.add_argument("--layers", type=int, default=2, help="cells through the thickness (even)")
    parser.add_argument("--imperfection", type=float, default=0.0,
                        help="top shear dead load / (E0 t), dimensionless (0: branch switching, no imperfection)")
    parser.add_argument("--onset-curve", action="store_true",
                        help="onset mu_c(k) of every k = 1 .. kmax on the flat path, for every p (--p or --sweep) "
                             "and t (--t or --t-sweep)")
    parser.add_argument("--t-sweep", type=float, nargs="+",
                        help="with --onset-curve: these thicknesses t / R instead of --t (default: --t only)")
    parser.add_argument("--end-only", action="store_true",
                        help="with --onset-curve: only the lowest eigenvalue of every k at mu = 0 (no onsets)")
    parser.add_argument("--linear-buckling", type=float, nargs="+", metavar="MU",
                        help="instead: the eigenvalue buckling step (Abaqus *BUCKLE) of the flat disk at each of "
                             "these mu (kT), k = 2 .. kmax, for every p (--p or --sweep) (default: none, the path)")
    args = parser.parse_args(argv)
    with silence_progress(args.quiet):
        return _main(args)


def _main(args) -> dict:
    """The run the parsed options ask for."""
    options = dict(n0=args.n0, nR=args.nR, t=args.t, maxh=args.maxh, layers=args.layers, order=args.order,
                   mu0=args.mu0, kmax=args.kmax, imperfection=args.imperfection,
                   quick=quick_run(args))
    if args.linear_buckling:
        for key in ("mu0", "imperfection"):
            options.pop(key)
        results = [linear_buckling_case(str(Path(args.out) / f"p{p:g}"), p=p, bases=args.linear_buckling, **options)
                   for p in (args.sweep or [args.p])]
        for r in results:
            print(f"p = {r['p']:g}: " + "; ".join(f"base {b['mu_base']:g}: k {b['k_first']} (then {b['next_k']})"
                                                  for b in r["bases"]))
        return {"linear_buckling": results}
    if args.onset_curve:
        options.pop("imperfection")
        ts = args.t_sweep or [options.pop("t")]
        options.pop("t", None)
        return {"onset_curves": onset_curves(args.out, args.sweep or [args.p], ts, end_only=args.end_only, **options)}
    if args.sweep:
        return {"sweep": sweep(args.out, args.sweep, **options)}
    summary = run(args.out, p=args.p, **options)
    if summary["found"]:
        print(f"onset: mu_c = {summary['mu_critical']:.5f}, k_c = {summary['k_critical']}, mismatch strain "
              f"{summary['critical_swelling_strain']:.4f}, hoop compressive from r = {summary['hoop_compressive_from_r']}; "
              f"{summary['wall_s']:.1f} s; results in {args.out}")
    else:
        print(f"no non-axisymmetric instability up to mu = 0 (rim rise {summary['rim_rise_end']:+.4f}, profile "
              f"exponent {summary['profile_exponent_end']:.2f}, events {summary['axisymmetric_events']}); "
              f"{summary['wall_s']:.1f} s; results in {args.out}")
    return summary


if __name__ == "__main__":
    main()
