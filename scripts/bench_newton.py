"""Newton step and load-step cost of ngsgel against a plain-NGSolve baseline, measured in one run.

Problem: a 3D gel block bonded at its base (order 2), swelling in a 10-step ramp of mu, at two
sizes, plus a thin plate. The baseline is what an NGSolve user writes: the same energy form,
``ngsolve.solvers.Newton`` from the previous solution at every step, sparse Cholesky, under
TaskManager. Printed: unknowns, time per Newton iteration split into assembly, factorisation and
solve, time per load step, iterations, the difference of the end states, peak memory, and the
ratios ngsgel / baseline (medians of ``--repeat`` runs).

    python scripts/bench_newton.py --out results/bench_newton [--quick] [--repeat 3]
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time

import numpy as np
import ngsolve as ngs
from ngsolve.nonlinearsolvers import NewtonSolver

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, Solid3D, ramp
from ngsgel.output import History, RunDirectory

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
# Plain NGSolve Newton (even with its energy line search) can step into J <= 1 and return NaN in
# this ramp (seen on the 5k block at mu = -0.07 and on the 30k block earlier): such runs are
# reported as failures, with the time per iteration up to the failure.
MU0, MU1, STEPS = -0.1, -0.073, 10


def cases(quick: bool) -> dict[str, dict]:
    if quick:
        return {"block-small": dict(lx=1, ly=1, lz=0.5, n=(4, 4, 2))}
    return {"block-5k": dict(lx=1, ly=1, lz=0.5, n=(7, 7, 3)),
            "block-30k": dict(lx=1, ly=1, lz=0.5, n=(14, 14, 6)),
            "plate": dict(lx=2, ly=2, lz=0.05, n=(24, 24, 1))}


def make_problem(case: dict) -> EquilibriumProblem:
    nx, ny, nz = case["n"]
    mesh = block(lx=case["lx"], ly=case["ly"], lz=case["lz"], maxh=1.0, structured=True,
                 nx=nx, ny=ny, nz=nz).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0),
                              mu=MU0, order=2)
    prob.fix("bottom")
    return prob


def timed(fn):
    start = time.perf_counter()
    out = fn()
    return time.perf_counter() - start, out


def iteration_split(prob: EquilibriumProblem) -> dict[str, float]:
    """Assembly, factorisation (numeric, symbolic reused) and solve of one Newton iteration."""
    x = prob.state
    r = x.CreateVector()
    with ngs.TaskManager():
        t_res, _ = timed(lambda: prob.residual(x, r))
        t_asm, K = timed(lambda: prob.tangent(x))
        inv = K.Inverse(prob.space.FreeDofs(), inverse="sparsecholesky")
        t_fac, _ = timed(inv.Update)
        t_sol, _ = timed(lambda: (inv * r).Evaluate())
        t_adm, _ = timed(lambda: prob.admissible(x))
    return {"residual": t_res, "assembly": t_asm, "factorisation": t_fac, "solve": t_sol,
            "admissibility": t_adm}


def run_baseline(case: dict) -> tuple[float, int, np.ndarray, float | None]:
    """Wall time, Newton iterations, end state and the mu at which it failed (None: completed)."""
    prob = make_problem(case)
    a, gfu = prob.form, prob.displacement  # the same energy form, solved by NGSolve's Newton
    iterations = 0
    start = time.perf_counter()
    solver = NewtonSolver(a, gfu, freedofs=prob.space.FreeDofs(), inverse="sparsecholesky")
    with ngs.TaskManager():
        for mu in np.linspace(MU0, MU1, STEPS + 1)[1:]:
            prob.mu.Set(mu)
            # without its energy line search NGSolve's Newton steps into J <= 1 (NaN) in this ramp
            converged, its = solver.Solve(maxit=50, maxerr=1e-11, linesearch=True)
            iterations += its  # failed iterations cost time too
            if converged < 0 or not np.all(np.isfinite(gfu.vec.FV().NumPy())):
                return time.perf_counter() - start, iterations, prob.save_state(), float(mu)
    return time.perf_counter() - start, iterations, prob.save_state(), None


def run_ngsgel(case: dict) -> tuple[float, int, np.ndarray]:
    prob = make_problem(case)
    start = time.perf_counter()
    result = ramp(prob, prob.mu, MU1, step=(MU1 - MU0) / STEPS, max_step=(MU1 - MU0) / STEPS, grow=1.0)
    wall = time.perf_counter() - start
    return wall, sum(n.iterations for n in result.newton), prob.save_state()


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="results/bench_newton")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args(argv)
    quick = args.quick or bool(os.environ.get("CI"))
    run_dir = RunDirectory(args.out, params={"mu0": MU0, "mu1": MU1, "steps": STEPS, "repeat": args.repeat,
                                             "quick": quick, "threads": ngs.TaskManager and os.cpu_count()})
    with History(run_dir.file("bench.csv")) as history:
        for name, case in cases(quick).items():
            prob = make_problem(case)
            split = iteration_split(prob)
            base, ours = [], []
            for _ in range(args.repeat):
                base.append(run_baseline(case))
                ours.append(run_ngsgel(case))
            t_base = statistics.median(b[0] for b in base)
            t_ours = statistics.median(o[0] for o in ours)
            it_base, it_ours = base[0][1], ours[0][1]
            failed_at = base[0][3]
            diff = float(np.max(np.abs(base[0][2] - ours[0][2]))) if failed_at is None else float("nan")
            row = {"case": name, "ndof": prob.space.ndof, **{f"t_{k}": v for k, v in split.items()},
                   "baseline_ramp_s": t_base, "ngsgel_ramp_s": t_ours, "baseline_failed_at_mu": failed_at,
                   "ramp_ratio": t_ours / t_base if failed_at is None else float("nan"),
                   "baseline_iterations": it_base, "ngsgel_iterations": it_ours,
                   "baseline_s_per_iteration": t_base / max(it_base, 1), "ngsgel_s_per_iteration": t_ours / it_ours,
                   "iteration_ratio": (t_ours / it_ours) / (t_base / max(it_base, 1)), "max_state_difference": diff,
                   "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
            history.append(row)
            print(f"{name}: {row['ndof']} unknowns; one iteration: assembly {split['assembly']:.3f}s, "
                  f"factorisation {split['factorisation']:.3f}s, solve {split['solve']:.3f}s, "
                  f"residual {split['residual']:.3f}s, admissibility {split['admissibility']:.3f}s")
            if failed_at is not None:
                print(f"  baseline Newton failed (NaN, J <= 1) at mu = {failed_at:.4g}; ngsgel completed the ramp")
            outcome = ("ramp ratio n/a (baseline failed); " if failed_at is not None else
                       f"ramp ratio {row['ramp_ratio']:.2f}, end states differ by {diff:.1e}; ")
            print(f"  {STEPS}-step ramp: baseline {t_base:.2f}s ({it_base} its), ngsgel {t_ours:.2f}s "
                  f"({it_ours} its); {outcome}time per iteration ratio {row['iteration_ratio']:.2f}")


if __name__ == "__main__":
    main()
