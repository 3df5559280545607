"""Shell against 3D thin solid against axisymmetric solid: speed against error on one cap case,
and the thin-plate (t/R = 1e-3) refinement study of the shell.

Cap (MODEL.md scene A geometry): base radius R = 1, apex height H = 0.3, mid-surface radius
r = 1.817, thickness ``t`` (default 0.08, t/r = 0.044), Nv = 1e-3, chi = 0.5, base clamped,
swelling step mu = -0.05 -> -0.049 from the free-swollen reference at -0.05. Quantity: the apex
rise. Reference: the axisymmetric section at h = t/16 with 8 layers (its own error is estimated
from the h = t/8, 4 layers value and printed). Each model at 2-3 resolutions reports unknowns,
wall time (mesh excluded, ramp included) and the relative error.

Point load: apex stiffness of the microlens cap (t/r = 0.005) against Reissner's shallow-shell
value. Large rotation: a strip rolled into a quarter circle by an end moment. Thin plate: clamped disk R = 1, t = 1e-3, uniform pressure giving w = 0.01 t; centre
deflection against Kirchhoff's p R^4 / (64 D) with the drained D, under h-refinement.

Newton iteration (``--newton``, issue 34): the cost of each part of one Newton iteration with a
stability check (tangent assembly, residual, factorisation, solve, negative count; medians of 3,
one thread) on the microlens half cap (h = 0.05, 0.01 on the apex patch, order 3, unloaded, the
apex push of 0.01 H pending) and the graded half disk (p = 2, h = 0.2, order 3, at its
equilibrium at mu0), for each shell variant (``SHELL_VARIANTS``: the python forms, the reference
model, against the compiled kernels), with ratios to the first variant from the same run; ``--quick``: the half cap at h = 0.1.

    python scripts/bench_shell.py --out results/bench_shell [--quick] [--thickness 0.08]
    python scripts/bench_shell.py --newton --out results/bench_shell_newton [--quick]
"""
from __future__ import annotations

import argparse
import math
import os
import time

import ngsolve as ngs

from ngsgel.output import History, Progress, RunDirectory
from ngsgel.scenes.shell_cases import (GEL, H, MU0, MU1, NEWTON_PARTS, apex_stiffness_over_reissner, cap_section_rise,
                                       cap_shell_rise, cap_solid_rise, graded_plate_shell, indented_half_cap_shell,
                                       newton_iteration_costs, rolled_strip_tip_error, thin_plate_deflection)

# shell variants compared per Newton iteration: name -> GelShell options (the first is the baseline:
# the energy as NGSolve coefficient functions with UMFPACK, the shell as issue 34 found it)
SHELL_VARIANTS = {"python forms, UMFPACK (reference)": {"kernels": "python", "inverse": "umfpack"},
                  "python forms, realcompile residual": {"kernels": "python", "realcompile": True, "inverse": "umfpack"},
                  "compiled kernels, UMFPACK": {"kernels": "compiled", "inverse": "umfpack"},
                  "compiled kernels, sparsecholesky": {"kernels": "compiled", "inverse": "sparsecholesky"},
                  "compiled kernels, default inverse (PARDISO where installed)": {"kernels": "compiled"}}


def record(history: History, rows: list[dict], row: dict) -> None:
    history.append(row)
    rows.append(row)


def timed(f, *args, **kwargs):
    start = time.perf_counter()
    value = f(*args, **kwargs)
    return value, time.perf_counter() - start


def run(out: str, *, quick: bool = False, t: float = 0.08) -> dict:
    run_dir = RunDirectory(out, params={"H": H, "t": t, "Nv": GEL.Nv, "chi": GEL.chi, "mu0": MU0,
                                        "mu1": MU1, "quick": quick})
    progress = Progress("bench_shell")
    (reference, ref_ndof), ref_time = timed(cap_section_rise, t, maxh=t / 16, layers=8)
    (coarser_ref, _), _ = timed(cap_section_rise, t, maxh=t / 8, layers=4)
    progress(f"reference: section h=t/16, 8 layers: apex rise {reference:.7f} ({ref_ndof} dofs, "
             f"{ref_time:.1f}s); h=t/8, 4 layers differs by {abs(coarser_ref / reference - 1):.2%}")
    cases = [("shell", cap_shell_rise, dict(maxh=h)) for h in ((0.4, 0.2) if quick else (0.4, 0.2, 0.1))]
    cases += [("axisymmetric", cap_section_rise, dict(maxh=t / f, layers=4)) for f in (1, 2, 4)]
    cases += [("solid3d", cap_solid_rise, dict(maxh=h, layers=2)) for h in ((0.3, 0.15) if quick else (0.3, 0.15, 0.1))]
    rows = []
    with History(run_dir.file("cap.csv")) as history:
        for model, f, options in cases:
            (rise, ndof), wall = timed(f, t, **options)
            row = {"model": model, **{k: options.get(k, "") for k in ("maxh", "layers")}, "ndof": ndof,
                   "seconds": wall, "apex_rise": rise, "rel_error": abs(rise / reference - 1)}
            record(history, rows, row)
            progress(f"{model:12s} {options}: {ndof:6d} dofs {wall:7.1f}s  rise {rise:.7f}  "
                     f"error {row['rel_error']:.2%}")
    plate = []
    with History(run_dir.file("thin_plate.csv")) as history:
        for maxh in ((0.5, 0.25) if quick else (0.5, 0.25, 0.125)):
            (ratio, ndof), wall = timed(thin_plate_deflection, t=1e-3, maxh=maxh)
            error = abs(ratio - 1)
            rate = math.log(plate[-1]["rel_error"] / error, 2) if plate else float("nan")
            row = {"t": 1e-3, "maxh": maxh, "ndof": ndof, "seconds": wall, "w_over_kirchhoff": ratio,
                   "rel_error": error, "rate": rate}
            record(history, plate, row)
            progress(f"thin plate t=1e-3 h={maxh}: {ndof} dofs {wall:.1f}s  w/w_K = {ratio:.7f}  "
                     f"error {error:.2e}  rate {rate:.2f}")
    point = []
    with History(run_dir.file("point_load.csv")) as history:
        for apex_maxh in ((0.04,) if quick else (0.04, 0.02)):
            (ratio, ndof), wall = timed(apex_stiffness_over_reissner, maxh=0.2, apex_maxh=apex_maxh)
            row = {"apex_maxh": apex_maxh, "ndof": ndof, "seconds": wall, "k_over_reissner": ratio}
            record(history, point, row)
            progress(f"cap point load t/r=0.005, apex h={apex_maxh}: {ndof} dofs {wall:.1f}s  "
                     f"k/k_Reissner = {ratio:.5f}")
    (error, ndof, steps), wall = timed(rolled_strip_tip_error)
    run_dir.write_json("rolled_strip.json", {"tip_error_over_L": error, "ndof": ndof, "steps": steps,
                                            "seconds": wall})
    progress(f"strip rolled to a quarter circle: tip error {error:.1e} L ({ndof} dofs, {steps} steps, {wall:.1f}s)")
    return {"reference": reference, "cap": rows, "plate": plate, "point": point, "rolled_strip": error}


def solved(shell):
    """The shell at its equilibrium (the graded disk's reference is not one: the soft rim swells)."""
    shell.solve()
    return shell


def newton_costs(out: str, *, quick: bool = False) -> list[dict]:
    """Per-iteration cost of every ``SHELL_VARIANTS`` entry on the two cases, one thread, with the
    ratios ``old / new`` (time of the baseline over the variant's) per part and for the iteration,
    and each variant's tangent over its own residual."""
    run_dir = RunDirectory(out, params={"variants": list(SHELL_VARIANTS), "quick": quick})
    progress = Progress("bench_shell --newton")
    cap_maxh = 0.1 if quick else 0.05
    cases = {f"half cap h={cap_maxh}": lambda **o: indented_half_cap_shell(maxh=cap_maxh, apex_maxh=0.01, **o),
             "graded half disk h=0.2": lambda **o: solved(graded_plate_shell(2.0, maxh=0.2, order=3, half=True, **o)[0])}
    rows = []
    ngs.SetNumThreads(1)
    with History(run_dir.file("newton_iteration.csv")) as history:
        for case, build in cases.items():
            baseline = None
            for variant, options in SHELL_VARIANTS.items():
                shell = build(**options)
                shell.form
                costs = newton_iteration_costs(shell)
                baseline = baseline or costs
                row = {"case": case, "variant": variant, "elements": shell.mesh.GetNE(ngs.BND), **costs,
                       "tangent_over_residual": costs["tangent"] / costs["residual"],
                       **{f"speedup_{part}": baseline[part] / costs[part] for part in (*NEWTON_PARTS, "iteration")}}
                record(history, rows, row)
                progress(f"{case}, {variant}: " + ", ".join(f"{part} {costs[part]:.3f}s" for part in NEWTON_PARTS)
                         + f"; iteration {costs['iteration']:.3f}s, tangent/residual {row['tangent_over_residual']:.1f}, "
                         f"iteration speed-up {row['speedup_iteration']:.2f}x ({costs['free_dofs']} free dofs, "
                         f"{costs['negative']} negative)")
    return rows


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="results/bench_shell", help="output folder")
    parser.add_argument("--quick", action="store_true", help="two resolutions per model; --newton: the half cap at h = 0.1 (also set by env CI)")
    parser.add_argument("--thickness", type=float, default=0.08, help="cap wall thickness (default 0.08)")
    parser.add_argument("--newton", action="store_true",
                        help="only the cost per Newton iteration of the shell variants (one thread)")
    args = parser.parse_args(argv)
    if args.newton:
        rows = newton_costs(args.out, quick=args.quick or bool(os.environ.get("CI")))
        print(f"results in {args.out}")
        return {"newton": rows}
    if not 0 < args.thickness < 0.5:
        raise ValueError(f"--thickness must be in (0, 0.5), got {args.thickness}")
    result = run(args.out, quick=args.quick or bool(os.environ.get("CI")), t=args.thickness)
    print(f"results in {args.out}")
    return result


if __name__ == "__main__":
    main()
