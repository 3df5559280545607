"""Which wave number a viscously stabilised swelling run of the softer-edge graded disk shows first
(thesis ch. 5, MODEL.md 5 C; issue 7).

On the flat path the first wave number to lose stability is k = 2 for every p (converged,
docs/graded.md), while the thesis reports k = 2, 4, 5, 8 "right after buckling" for p = 0.25,
0.75, 2, 10 (t/R = 0.01), computed with Abaqus shells, an infinitesimal imperfection and the
energy-dissipating stabiliser (``*Static, stabilize``: viscous forces ``c M* v``, ``M*`` a
unit-density mass matrix). With ``mu`` ramped through a fixed step time, such a run does not
show the first mode to go unstable but the first to grow visibly: after its onset mode k grows
like ``exp(G_k / (c mu'))`` with

    G_k(mu) = int max(0, -omega_k(mu')) dmu',     K phi = omega M phi on the flat state,

(``ngsgel.stability.growth_exponents``; ``omega_k`` the lowest eigenvalue of wave number k, unit
density, from ``ngsgel.harmonic`` on the r-z section: exact for the 3D body), and the pattern seen
is the k whose ``G_k`` first reaches ``T = c mu' ln(A / a0)`` (``fastest_growing``). ``T -> 0``
is the exact onset (k = 2 here); higher wave numbers go unstable later but grow faster, so a
larger ``T`` (more damping, a faster ramp, a smaller imperfection) selects a larger k. ``T`` is
one unknown number of the thesis's runs (its damping factor, step time, imperfection and even
the ramped variable are not given): this script tabulates the selected k against ``T`` for every
p and t/R, with ``mu`` and, as the other plausible protocol, the soft stretch ramped at a constant
rate, and reports the ``T`` (if any) at which all four of the thesis's p give its k at once, the k
of every p at the ``T`` that gives one p its thesis k, and the k that the ``T`` giving p = 10 its
k = 8 selects against t/R (thesis fig. 5-4: 8 at t/R = 0.01, 3 at 0.1, ``k ~ (t/R)^(-1/2)``), with
a power-law fit (the same ``T`` for every t/R: Abaqus sets ``c`` from the energy of the first
increment, which scales with t as the stiffness and the mass do). The growth is linear (a visible
amplitude is small against t), every mode is seeded equally, and the damping is constant, as
Abaqus's is within a step.

Writes per case ``eigenvalues_p{p}_t{t}.csv`` (soft stretch, ``mu`` and ``omega_k`` at every
state, flushed per state), ``selection_mu.csv`` and ``selection_stretch.csv`` (per threshold the
selected k and the load where it grows for every case), ``summary.json`` and ``selection.png``;
``--tables DIR`` analyses the tables of an earlier run again.

    ngsgel run graded-plate-growth --out results/graded_growth --sweep 0.25 0.75 2 10 --t-sweep 0.02 0.05 0.1
"""

from __future__ import annotations

import csv
import math
import time
from pathlib import Path

import numpy as np

from ngsgel.scenes.graded_plate import CHI, build, lowest_eigenvalue, mismatch_strain
from ngsgel import FloryRehnerGel, ramp
from ngsgel.harmonic import HarmonicStability
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser, silence_progress
from ngsgel.patterns import power_law_fit
from ngsgel.stability import fastest_growing

THESIS_K = {0.25: 2, 0.75: 4, 2.0: 5, 10.0: 8}  # fig. 5-3 B, softer edge, t/R = 0.01
THESIS_K_OF_T = {0.01: 8, 0.1: 3}  # fig. 5-4, p = 10
MU_START = -1.0  # the disk is equilibrated here (graded_plate's default) and ramped to the states
WAVE_NUMBERS = list(range(2, 41)) + [45, 50, 60, 70, 80, 90, 100]


def eigenvalue_table(csv_path, *, n0: float, nR: float, p: float, t: float, maxh: float, order: int,
                     mu_low: float, points: int, ks: list[int], progress=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``mu``, the soft stretch and ``omega[i, j]`` (lowest eigenvalue of ``ks[j]``, rigid motions excluded) at
    ``points`` states of the flat disk, equally spaced in the soft stretch from ``mu_low`` to 0
    (the flat, mid-plane symmetric state is an equilibrium all the way, stable or not)."""
    soft = FloryRehnerGel(Nv=min(n0, nR), chi=CHI)
    prob, stretch = build(n0=n0, nR=nR, p=p, t=t, maxh=maxh, order=order, mu0=MU_START)
    hs = HarmonicStability(prob)
    grid = np.linspace(soft.lam_free(mu_low), soft.lam_free(0.0), points)
    mu, omega = [], []
    with History(csv_path) as table:
        for s in grid:
            ramp(prob, stretch, float(s), step=0.02, max_step=0.02)
            mu.append(mismatch_strain(float(s), n0, nR)[0])
            omega.append([lowest_eigenvalue(hs, k) for k in ks])
            if len(mu) == 1 and min(omega[0]) < 0:
                raise ValueError(f"mu_low = {mu_low} is past the onset of k = {ks[int(np.argmin(omega[0]))]} "
                                 f"(p = {p:g}, t = {t:g}): lower it")
            table.append({"soft_stretch": float(s), "mu": mu[-1], **{f"k{k}": w for k, w in zip(ks, omega[-1])}})
            if progress is not None:
                progress(f"p = {p:g} t = {t:g}: mu = {mu[-1]:+.5f}, lowest at k = {ks[int(np.argmin(omega[-1]))]}")
    return np.array(mu), grid, np.array(omega)


def read_table(csv_path) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[int]]:
    """An ``eigenvalue_table`` CSV: ``mu``, soft stretch, ``omega`` and the wave numbers."""
    with open(csv_path) as f:
        rows = list(csv.DictReader(f))
    ks = [int(name[1:]) for name in rows[0] if name.startswith("k")]
    return (np.array([float(r["mu"]) for r in rows]), np.array([float(r["soft_stretch"]) for r in rows]),
            np.array([[float(r[f"k{k}"]) for k in ks] for r in rows]), ks)


def selected(load: np.ndarray, omega: np.ndarray, ks: list[int], threshold: float) -> tuple[int | None, float]:
    """The wave number that first grows by ``threshold`` and the load where it does."""
    choice = fastest_growing(load, omega, threshold)
    return (None, math.nan) if choice is None else (ks[choice.index], choice.load)


def matching_thresholds(thresholds, table: dict, wanted: dict) -> list[float]:
    """The thresholds at which the selected k equals ``wanted[key]`` for every key of ``wanted``
    in ``table`` (``table[key]``: selected k per threshold)."""
    keys = [key for key in wanted if key in table]
    if not keys:
        return []
    return [T for i, T in enumerate(thresholds) if all(table[key][i] == wanted[key] for key in keys)]


def geometric_middle(values) -> float:
    return math.exp(0.5 * (math.log(values[0]) + math.log(values[-1])))


def analyse(curves: dict, ks: list[int], *, ramp_variable: str, p: float, csv_path) -> dict:
    """Selected k against the threshold for every case, with ``mu`` (index 0 of a curve) or the
    soft stretch (index 1) ramped at a constant rate; the thresholds (if any) that give the
    thesis's k for all its p at t/R = 0.01, and those that give its k = 8 for p = 10 alone, with
    the k that threshold selects against t/R at ``p`` and a power-law fit."""
    column = {"mu": 0, "stretch": 1}[ramp_variable]
    thresholds = np.geomspace(1e-9, 1e-1, 161)
    table = {case: [] for case in curves}
    with History(csv_path) as out_table:
        for T in thresholds:
            row = {"threshold": float(T)}
            for (q, s), curve in curves.items():
                k, at = selected(curve[column], curve[2], ks, T)
                table[(q, s)].append(k)
                row[f"k_p{q:g}_t{s:g}"], row[f"at_p{q:g}_t{s:g}"] = k, at
            out_table.append(row)
    thesis_cases = {q: (q, s) for q, s in curves if math.isclose(s, 0.01)}  # fig. 5-3 B is t/R = 0.01
    at_thesis_t = {q: table[case] for q, case in thesis_cases.items()}
    result: dict = {"ramp": ramp_variable, "matched_p": [q for q in THESIS_K if q in at_thesis_t],
                    "thresholds_matching_thesis": matching_thresholds(thresholds, at_thesis_t, THESIS_K)}
    for q in result["matched_p"]:
        alone = matching_thresholds(thresholds, at_thesis_t, {q: THESIS_K[q]})
        result[f"thresholds_p{q:g}"] = [alone[0], alone[-1]] if alone else []
        if alone:  # the other p at the threshold that gives this p its thesis k
            T = geometric_middle(alone)
            result[f"k_at_threshold_p{q:g}"] = {f"{r:g}": selected(curves[case][column], curves[case][2], ks, T)[0]
                                                for r, case in thesis_cases.items()}
    if THESIS_K.get(p) and result.get(f"thresholds_p{p:g}"):
        T = geometric_middle(result[f"thresholds_p{p:g}"])
        rows = sorted((s, *selected(curves[(q, s)][column], curves[(q, s)][2], ks, T)) for q, s in curves if q == p)
        result["selected_against_t"] = {"p": p, "threshold": T, "rows": [{"t": s, "k": k, "at": at} for s, k, at in rows]}
        usable = [(s, k) for s, k, _ in rows if k is not None]
        if len(usable) >= 3:
            result["k_of_t_fit"] = power_law_fit(*zip(*usable))
    result["table"] = table
    result["thresholds"] = thresholds
    return result


def run(out: str, *, ps, ts=(), p: float = 10.0, t: float = 0.01, n0: float = 1e-2, nR: float = 1e-3,
        maxh: float = 0.02, order: int = 3, mu_low: float = -0.35, points: int = 30, ks: list[int] | None = None,
        tables: str | None = None, quick: bool = False) -> dict:
    """``tables``: a folder with the ``eigenvalues_p*_t*.csv`` of an earlier run to analyse
    instead of computing them (the options that set the tables are then not used)."""
    if quick:
        maxh, order, points, ks = 0.05, 2, 10, list(range(2, 13))
    ks = list(WAVE_NUMBERS if ks is None else ks)
    if not (isinstance(points, int) and points >= 3):
        raise ValueError(f"points must be an integer >= 3, got {points!r}")
    if not MU_START < mu_low < 0:
        raise ValueError(f"mu_low must be in ({MU_START}, 0), got {mu_low!r}")
    if not ks or min(ks) < 2 or ks != sorted(set(ks)):
        raise ValueError(f"ks must be increasing wave numbers >= 2, got {ks!r}")
    cases = list(dict.fromkeys([(float(q), float(t)) for q in ps] + [(float(p), float(s)) for s in ts]))
    run_dir = RunDirectory(out, params=dict(ps=list(ps), ts=list(ts), p=p, t=t, n0=n0, nR=nR, maxh=maxh, order=order,
                                            mu_low=mu_low, points=points, ks=ks, tables=tables, quick=quick, chi=CHI))
    progress = Progress("graded_plate_growth")
    start = time.perf_counter()
    curves = {}
    for case in cases:
        name = f"eigenvalues_p{case[0]:g}_t{case[1]:g}.csv"
        if tables is not None:
            *curves[case], found = read_table(Path(tables) / name)
            if found != ks:
                raise ValueError(f"{name} in {tables} has wave numbers {found}, expected {ks}")
            continue
        clock = time.perf_counter()
        curves[case] = eigenvalue_table(run_dir.file(name), n0=n0, nR=nR, p=case[0], t=case[1], maxh=maxh,
                                        order=order, mu_low=mu_low, points=points, ks=ks, progress=progress)
        progress(f"p = {case[0]:g} t = {case[1]:g}: {time.perf_counter() - clock:.0f} s")
    analyses = {ramp_variable: analyse(curves, ks, ramp_variable=ramp_variable, p=p,
                                       csv_path=run_dir.file(f"selection_{ramp_variable}.csv"))
                for ramp_variable in ("mu", "stretch")}
    # the first to lose stability: selected at the smallest threshold (its zero crossing, interpolated)
    summary: dict = {"cases": [{"p": q, "t": s, "k_first_unstable": analyses["mu"]["table"][(q, s)][0],
                                "k_most_unstable_end": ks[int(np.argmin(curves[(q, s)][2][-1]))]} for q, s in cases],
                     "thesis_k": {f"{q:g}": k for q, k in THESIS_K.items()}}
    for ramp_variable, result in analyses.items():
        summary[f"ramp_{ramp_variable}"] = {k: v for k, v in result.items() if k not in ("table", "thresholds")}
    summary["wall_s"] = time.perf_counter() - start
    run_dir.write_json("summary.json", summary)
    plot_selection(analyses, run_dir.file("selection.png"))
    return summary


def plot_selection(analyses: dict, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(analyses), figsize=(6.5 * len(analyses), 4.5), squeeze=False)
    for ax, (ramp_variable, result) in zip(axes[0], analyses.items()):
        for i, ((p, t), ks) in enumerate(result["table"].items()):
            k = np.array([np.nan if v is None else v for v in ks], dtype=float)
            ax.step(result["thresholds"], k, where="post", color=f"C{i % 10}", label=f"p = {p:g}, t/R = {t:g}")
            if math.isclose(t, 0.01) and p in THESIS_K:
                ax.axhline(THESIS_K[p], color=f"C{i % 10}", ls=":", lw=0.8)
        match = result["thresholds_matching_thesis"]
        if match:
            ax.axvspan(match[0], match[-1], color="0.85", label="all thesis k (dotted)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel(f"growth threshold T ({ramp_variable} ramped at a constant rate)")
        ax.set_ylabel("first wave number to grow by T")
        ax.set_title(f"dotted: thesis k (t/R = 0.01); {'no' if not match else len(match)} common T")
        ax.legend(fontsize=7)
        ax.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> dict:
    parser = scene_parser(__doc__, out="results/graded_growth", quick="coarse section, k <= 12, 10 states")
    parser.add_argument("--p", type=float, default=10.0, help="grading exponent of the t/R sweep (dimensionless)")
    parser.add_argument("--t", type=float, default=0.01, help="thickness t / R of the p sweep")
    parser.add_argument("--sweep", type=float, nargs="+", default=[10.0],
                        help="grading exponents p (at --t), dimensionless")
    parser.add_argument("--t-sweep", type=float, nargs="+", default=[], help="thicknesses t / R (at --p)")
    parser.add_argument("--n0", type=float, default=1e-2, help="Nv at the centre (dimensionless)")
    parser.add_argument("--nR", type=float, default=1e-3, help="Nv at the edge (dimensionless)")
    parser.add_argument("--maxh", type=float, default=0.02, help="cell size along the section / R")
    parser.add_argument("--order", type=int, default=3, help="polynomial order of the displacement")
    parser.add_argument("--mu-low", type=float, default=-0.35,
                        help="chemical potential of the first state, below every onset (kT)")
    parser.add_argument("--points", type=int, default=30, help="states, equally spaced in the soft stretch")
    parser.add_argument("--tables", help="analyse the eigenvalue tables in this folder (of an earlier run) "
                                         "instead of computing them (default: compute)")
    args = parser.parse_args(argv)
    with silence_progress(args.quiet):
        summary = run(args.out, ps=args.sweep, ts=args.t_sweep, p=args.p, t=args.t, n0=args.n0, nR=args.nR,
                      maxh=args.maxh, order=args.order, mu_low=args.mu_low, points=args.points, tables=args.tables,
                      quick=quick_run(args))
    for case in summary["cases"]:
        print(f"p = {case['p']:g}, t/R = {case['t']:g}: first unstable k = {case['k_first_unstable']}, "
              f"most unstable at mu = 0: k = {case['k_most_unstable_end']}")
    for ramp_variable in ("mu", "stretch"):
        result = summary[f"ramp_{ramp_variable}"]
        match = result["thresholds_matching_thesis"]
        print(f"{ramp_variable} ramped: thresholds giving the thesis's k for all p in {result['matched_p']}: "
              + (f"{match[0]:.3g} ... {match[-1]:.3g}" if match else "none"))
        for q in result["matched_p"]:
            if result.get(f"k_at_threshold_p{q:g}"):
                print(f"  at the threshold giving p = {q:g} its k = {THESIS_K[q]}: k by p "
                      f"{result[f'k_at_threshold_p{q:g}']}")
        if "selected_against_t" in result:
            rows = result["selected_against_t"]["rows"]
            print(f"  against t/R at p = {args.p:g}: " + ", ".join(f"{r['t']:g} -> {r['k']}" for r in rows))
        if "k_of_t_fit" in result:
            fit = result["k_of_t_fit"]
            print(f"  k ~ (t/R)^b, b = {fit['exponent']:.2f} +- {fit['standard_error']:.2f} (thesis: -1/2)")
    return summary


if __name__ == "__main__":
    main()
