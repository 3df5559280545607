"""Work against precision of the thin-wall models (issue 10 item 5): error of an onset against the
reference, against wall time, one row per model and resolution.

(a) Inward-indented microlens cap (H = 0.3 R, t = 0.005 r, Nv = 1e-3, mu = 0, apex patch 0.05 R
    moved down rigidly): depth ``d/H`` of the first non-axisymmetric bifurcation and its wave
    number. Models: the axisymmetric solid with the harmonic (Fourier mode k) second variation
    (``ngsgel/scenes/microlens_onset.py``; the Fourier reduction of the 3D solid, so it is the 3D
    reference for the onset from an axisymmetric pre-buckling state), and ``GelShell`` on the
    full cap (``shell_cases.cap_shell_onset``: continuation driver, exact negative count), and the
    3D thin cap (``cap_solid``: prism layers through t, ``shell_cases.cap_solid_onset``: the same
    path, count and location, the count alone at every state).
(b) Softer-edge graded disk (t/R = 0.01, Nv 1e-2 -> 1e-3, exponent p): critical ``mu`` and wave
    number. Models: the axisymmetric section with the harmonic scan (``graded_plate.build``,
    ``first_harmonic_instability``), ``GelShell`` on the full disk
    (``shell_cases.graded_plate_shell_onset``) and the 3D thin solid (``plate_solid``: prism
    layers under a triangle mesh, ``shell_cases.graded_plate_solid_onset``: the same path,
    negative count and location as the shell), p = 2 only.

Reference for (a): the axisymmetric solid at h = 0.01, order 3 (d/H = 0.49090, k = 3; 0.49105 at
h = 0.02); for (b): the section at 100 x 4 cells (``shell_cases.GRADED_REFERENCE``). Errors are
relative; a row whose onset has the wrong wave number, or none, gets no error (inf). Wall times
exclude meshing and include the whole path, its stability checks and the location of the onset;
they depend on the machine's load (recorded in ``params.json``).

    python scripts/work_precision.py --out results/work_precision [--quick]
"""

from __future__ import annotations

import math
import os
import time

from ngsgel.scenes import graded_plate
from ngsgel.scenes import microlens_onset
from ngsgel.scenes.shell_cases import (APEX, GRADED_MU0, GRADED_N0, GRADED_NR, GRADED_REFERENCE, GRADED_T, H,
                                      cap_section_stiffness, cap_shell_onset, cap_solid_onset,
                                      graded_plate_shell_onset, graded_plate_solid_onset)
from ngsgel import FloryRehnerGel
from ngsgel.harmonic import first_harmonic_instability
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser

# 3D thin-solid rows of (b), p = 2, one prism layer (two curved layers lock, docs/benchmarks.md),
# cheapest first: ~10, 17, 30, 38, 80, 140 s on one loaded core
SOLID_ROWS = [dict(maxh=0.2, layers=1, order=2), dict(maxh=0.4, layers=1, order=3),
              dict(maxh=0.15, layers=1, order=2), dict(maxh=0.3, layers=1, order=3),
              dict(maxh=0.2, layers=1, order=3), dict(maxh=0.1, layers=1, order=2)]
# 3D thin-cap rows of (a), one prism layer, cheapest first (h / patch h, unknowns, wall on one core
# under the bench lock, load 2.3-3.6, 2026-12-06): 0.2/0.025 order 2 (7902, 5 s) and 0.15/0.02,
# 0.1/0.0125 order 3 (30684, 63624; 168 s, 396 s) stay stable to 0.6 H (0.15/0.02: the lowest eigenvalue falls
# from 3.8e-4 unloaded to 1.6e-6 at d/H = 0.57 and rises again, steps cut to under 1/40 of 0.1 H
# there; 0.2/0.025 order 2: 1.5e-5 at 0.6, still falling), as the coarse shells do. The first
# mesh found to change the count is h = 0.05 / 0.0125, order 3 (192684 unknowns, ~7.5 s per
# Newton iteration, untimed dev runs): 0 -> 2 between d/H = 0.45 and 0.5 with k = 3 (lowest eigenvalue 8.95e-6 and
# -1.12e-6 there: interpolated 0.493-0.494, +0.4 to +0.7 %), but the driver's location failed (a
# solve next to the double critical point stalled ~200x above the Newton floor), so the row would
# have no located onset; 16 min to the step that holds it, ~27 min with the failed location and
# the lowest mode's eigen solve. Not in the list: it costs the full run half an hour for a bracket.
# The half cap (mirror plane y = 0) keeps one mode of each pair, so the onset is a simple
# eigenvalue and is located: h = 0.05 / 0.0125 order 3, 93504 unknowns, d/H 0.49110 (+0.04 %),
# k = 3, 137 s on 2 quiet threads (2026-12-06). Its location needs the Newton floor 1e-6: with
# 1e-7 a solve next to the critical state ended in a failed line search at residual 9.1e-12.
CAP_SOLID_ROWS = [dict(maxh=0.2, apex_maxh=0.025, layers=1, order=2),
                  dict(maxh=0.15, apex_maxh=0.02, layers=1, order=3),
                  dict(maxh=0.1, apex_maxh=0.0125, layers=1, order=3),
                  dict(maxh=0.05, apex_maxh=0.0125, layers=1, order=3, half=True, newton_floor=1e-6)]
# the shell's cap rows: the full cap at h = 0.1 (stable past 1.12 x the reference depth) and the
# half cap on the 3D half cap's mesh size (2026-12-06, 2 quiet threads: 52635 unknowns, count
# 0 -> 1 in (0.5, 0.6] H, k = 4 at 0.6, location failed, 213 s - slower than the 3D half cap,
# which is within 0.04 %)
CAP_SHELL_ROWS = [dict(maxh=0.1, apex_maxh=0.0125, order=3), dict(maxh=0.05, apex_maxh=0.01, order=3, half=True)]
# the 3D cap's search ends 22 % past the reference depth: a row stable to there is off by more than
# 20 % anyway, and past ~0.5 H the coarse paths crawl (near the dip)
CAP_SOLID_DEPTH_MAX = 0.6
CAP_REFERENCE = {"depth_over_H": 0.49090, "k": 3}  # axisymmetric solid, h = 0.01, order 3 (docs/benchmarks.md)
PLATE_REFERENCE_K = 2


def cap_section_row(*, maxh: float, order: int) -> dict:
    """The axisymmetric solid's onset (``microlens_onset.onset``) and its patch stiffness."""
    stiffness, _ = cap_section_stiffness(maxh=maxh, order=order)
    onset = microlens_onset.onset(H, maxh=maxh, order=order, apex=APEX)
    return {"case": "cap", "model": "axisymmetric", "resolution": f"h={maxh:g} order {order}",
            "ndof": onset["ndof_section"], "seconds": onset["wall_s"], "value": onset["depth_over_H"],
            "k": onset["k"], "stiffness": stiffness}


def cap_shell_row(*, maxh: float, apex_maxh: float, order: int, half: bool = False) -> dict:
    row = cap_shell_onset(maxh=maxh, apex_maxh=apex_maxh, order=order, half=half)
    return {"case": "cap", "model": f"shell order {order}",
            "resolution": f"{'half cap ' * half}h={maxh:g}/{apex_maxh:g} order {order}",
            "ndof": row["ndof"], "seconds": row["seconds"], "value": row.get("depth_over_H", math.nan),
            "k": row.get("k"), "stiffness": row["stiffness"]}


def plate_section_row(p: float, *, maxh: float, order: int, kmax: int = 8) -> dict:
    """Onset on the axisymmetric section of ``graded_plate`` (no axisymmetric bifurcation on the
    softer-edge path, so a plain ramp in the soft stretch with the harmonic scan suffices)."""
    start = time.perf_counter()
    prob, stretch = graded_plate.build(n0=GRADED_N0, nR=GRADED_NR, p=p, t=GRADED_T, maxh=maxh, order=order,
                                       mu0=GRADED_MU0)
    end = FloryRehnerGel(Nv=min(GRADED_N0, GRADED_NR), chi=graded_plate.CHI).lam_free(0.0)
    onset = first_harmonic_instability(prob, stretch, end, ks=list(range(1, kmax + 1)),
                                       step=(end - stretch.Get()) / 60, tolerance=1e-7)
    if not onset.found:
        raise RuntimeError(f"the section of p = {p} did not buckle up to mu = 0")
    mu_c = graded_plate.mismatch_strain(onset.parameter, GRADED_N0, GRADED_NR)[0]
    return {"case": f"plate p={p:g}", "model": "axisymmetric", "resolution": f"h={maxh:g} order {order}",
            "ndof": prob.space.ndof, "seconds": time.perf_counter() - start, "value": mu_c, "k": onset.k,
            "stiffness": math.nan}


def plate_shell_row(p: float, *, maxh: float, order: int) -> dict:
    row = graded_plate_shell_onset(p, maxh=maxh, order=order)
    return {"case": f"plate p={p:g}", "model": f"shell order {order}", "resolution": f"h={maxh:g} order {order}",
            "ndof": row["ndof"], "seconds": row["seconds"], "value": row.get("mu_critical", math.nan),
            "k": row.get("k"), "stiffness": math.nan}


def thin_solid_row(case: str, onset: dict, value: str) -> dict:
    """The work-precision row of a 3D thin-solid onset row (``shell_cases.graded_plate_solid_onset``,
    ``cap_solid_onset``); ``value``: the key of its critical parameter."""
    through = f"{onset['layers']} layer{'s' * (onset['layers'] > 1)} order {onset['order']}"
    mesh = ("half cap " if onset.get("half") else "") + f"h={onset['maxh']:g}" + (
        f"/{onset['apex_maxh']:g}" if "apex_maxh" in onset else "")
    return {"case": case, "model": f"3D thin solid {through}", "resolution": f"{mesh} {through}",
            "ndof": onset["ndof"], "seconds": onset["seconds"], "value": onset.get(value, math.nan),
            "k": onset.get("k"), "stiffness": onset.get("stiffness", math.nan)}


def graded_plate_solid_row(p: float, *, maxh: float, layers: int, order: int) -> dict:
    return thin_solid_row(f"plate p={p:g}", graded_plate_solid_onset(p, maxh=maxh, layers=layers, order=order),
                          "mu_critical")


def cap_solid_row(*, maxh: float, apex_maxh: float, layers: int, order: int, half: bool = False,
                  newton_floor: float = 1e-7, depth_max: float = CAP_SOLID_DEPTH_MAX) -> dict:
    return thin_solid_row("cap", cap_solid_onset(maxh=maxh, apex_maxh=apex_maxh, layers=layers, order=order,
                                                 half=half, newton_floor=newton_floor, depth_max=depth_max),
                          "depth_over_H")


def with_errors(rows: list[dict]) -> list[dict]:
    for row in rows:
        if row["case"] == "cap":
            reference, k_ref = CAP_REFERENCE["depth_over_H"], CAP_REFERENCE["k"]
        else:
            reference, k_ref = GRADED_REFERENCE[float(row["case"].split("=")[1])], PLATE_REFERENCE_K
        right = row["k"] == k_ref and math.isfinite(row["value"])
        row["error"] = abs(row["value"] / reference - 1) if right else math.inf
    return rows


def time_to(rows: list[dict], case: str, model_prefix: str, level: float = 0.01) -> float:
    """Least wall time of a row of ``case`` whose model starts with ``model_prefix`` and whose
    error is at most ``level`` (inf if none)."""
    times = [r["seconds"] for r in rows if r["case"] == case and r["model"].startswith(model_prefix)
             and r["error"] <= level]
    return min(times, default=math.inf)


def plot(rows: list[dict], path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cases = sorted({r["case"] for r in rows})
    fig, axes = plt.subplots(1, len(cases), figsize=(5.5 * len(cases), 4.2), squeeze=False)
    for ax, case in zip(axes[0], cases):
        for i, model in enumerate(sorted({r["model"] for r in rows if r["case"] == case})):
            pts = sorted((r["seconds"], r["error"]) for r in rows if r["case"] == case and r["model"] == model
                         and math.isfinite(r["error"]) and r["error"] > 0)
            if pts:
                ax.loglog(*zip(*pts), "o-", color=f"C{i}", label=model)
        ax.axhline(0.01, color="grey", lw=0.6, ls="--")
        ax.set_xlabel("wall time [s]")
        ax.set_ylabel("relative error of the onset")
        ax.set_title(case)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


if __name__ == "__main__":
    parser = scene_parser(__doc__, out="results/work_precision", quick="plate p = 2 only, coarsest resolutions")
    parser.add_argument("--plate-p", type=float, nargs="+", default=[2.0, 10.0], help="grading exponents of (b)")
    args = parser.parse_args()
    quick = quick_run(args)
    run_dir = RunDirectory(args.out, params={"quick": quick, "plate_p": args.plate_p, "load": os.getloadavg()})
    progress = Progress("work_precision")
    # --quick: the graded plate (p = 2) at the coarsest resolution of each model (2-4 min); the
    # full run adds the cap (shell rows ~5 min, 3D thin cap rows ~12 min on 2 cores), p = 10 and
    # the finer 3D thin solids (~5 min)
    plate_ps = [2.0] if quick else args.plate_p
    jobs = []
    if not quick:
        jobs += [(cap_section_row, dict(maxh=0.04, order=2)), (cap_section_row, dict(maxh=0.02, order=3)),
                 *[(cap_shell_row, options) for options in CAP_SHELL_ROWS]]
        jobs += [(cap_solid_row, options) for options in CAP_SOLID_ROWS]
    for p in plate_ps:
        jobs += [(plate_section_row, dict(p=p, maxh=0.04, order=2)), (plate_shell_row, dict(p=p, maxh=0.3, order=3))]
        if not quick:
            jobs += [(plate_section_row, dict(p=p, maxh=0.02, order=3)), (plate_shell_row, dict(p=p, maxh=0.2, order=3)),
                     (plate_shell_row, dict(p=p, maxh=0.4, order=3))]  # the cheapest shell within 1 % at p = 2
    # the 3D thin solid (p = 2 only), cheapest first; --quick: its coarsest row (~10 s, 4.5 % error)
    jobs += [(graded_plate_solid_row, dict(p=2.0, **options)) for options in SOLID_ROWS[:1 if quick else None]]
    rows = []
    with History(run_dir.file("work_precision.csv")) as history:
        for job, options in jobs:
            row = job(**options)
            rows.append(row)
            with_errors([row])
            history.append(row)
            progress(f"{row['case']:10s} {row['model']:14s} {row['resolution']:24s} {row['ndof']:7d} dofs "
                     f"{row['seconds']:7.1f} s  value {row['value']:.5f}  k {row['k']}  error {row['error']:.2e}")
    summary = {"rows": rows}
    for case in sorted({r["case"] for r in rows}):
        shell = time_to(rows, case, "shell")
        for model in ("axisymmetric", "3D thin solid"):
            if not any(r["case"] == case and r["model"].startswith(model) for r in rows):
                continue
            other = time_to(rows, case, model)
            ratio = shell / other if math.isfinite(other) and math.isfinite(shell) else math.nan
            summary[f"{case}: time to 1% shell / {model}"] = ratio
            progress(f"{case}: time to 1 % error: shell {shell:.1f} s, {model} {other:.1f} s, ratio {ratio:.2f}")
    run_dir.write_json("work_precision.json", summary)
    plot(rows, run_dir.file("work_precision.png"))
