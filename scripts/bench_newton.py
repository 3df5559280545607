"""Newton step and load-step cost of ngsgel against a plain-NGSolve baseline, measured in one run.

Problem: a 3D gel block bonded at its base (order 2), swelling in a 10-step ramp of mu, at two
sizes, plus a thin plate. The baseline is what an NGSolve user writes: the same energy form,
``NewtonSolver`` from the previous solution at every step, sparse Cholesky, under TaskManager.
ngsgel runs its ``ramp`` twice: as it is, and with ``reuse_factorisation`` (chord steps).
Printed per case: unknowns, one iteration split into assembly, factorisation, solve, residual
and admissibility check, iterations per step, and the ratios ngsgel / baseline as medians of
``--repeat`` interleaved runs: the ramp time (if the baseline fails, NaN, on the steps it
survived, and ngsgel's whole ramp over the baseline's time to its failure as a bound), and the
most expensive ngsgel Newton iteration over the median baseline iteration. docs/benchmarks.md
has the numbers.

    python scripts/bench_newton.py --out results/bench_newton [--quick] [--repeat 3] [--cases block-30k]

``--threads-study``: the default and the chord-reuse ramp of the chosen cases on 1 and 2 NGSolve
threads, with the BLAS/LAPACK pools at their defaults and limited to one thread
(``ngsgel.using_threads``), interleaved; ratios to 1 thread and to the default BLAS pools.
``--before DIR``: the default ramp with the ngsgel package in DIR (e.g. ``git archive`` of an
older commit, unpacked) against this checkout's, in alternating fresh processes.

``--backends`` (issue 35): the bonded block of issue 35 (1 x 1 x 0.2, tetrahedra of order 2,
``Nv = 0.01``, ``chi = 0.5``, free at stretch 1.3, then 20 equal ``mu`` steps to the free state at
1.6; ``--sizes`` picks the meshes, e.g. ``28k,53k``): per backend (NGSolve sparsecholesky on 1
and 2 threads, umfpack, MKL PARDISO on 1 and 2 threads where installed) the time of the first
factorisation (analysis), a numeric refactorisation and a solve of its tangent; CG with BDDC on
the condensed tangent (setup once, two solves); the 20-step
ramp with the defaults (``inverse="auto"``, ``reuse_factorisation`` "auto": chord steps here),
with full Newton iterations only, and with sparsecholesky, per ramp and per Newton
iteration; and a path with stability tracking against the same path without
(``follow_path``, natural, 5 steps): the mean step time untracked, with the default count-only
check and with eigenpairs at every point, / untracked, from the ``PathResult.steps`` work records
(``--sizes ''`` for the path alone).
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import time
from dataclasses import dataclass

import numpy as np
import ngsolve as ngs
from ngsolve.nonlinearsolvers import NewtonSolver

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, RampError, Solid3D, Work, ramp
from ngsgel.newton import total_work
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


@dataclass
class Run:
    """One ramp: wall time, end time of each converged step (from the start), Newton iteration
    times (full iterations; chord steps apart), the mu where it failed (None: completed)."""

    wall: float
    step_ends: list[float]
    iteration_times: list[float]
    iterations_per_step: list[int]
    state: np.ndarray
    failed_at: float | None = None
    chord_steps: int = 0

    @property
    def iterations(self) -> int:
        return sum(self.iterations_per_step)


def mu_values() -> np.ndarray:
    return np.linspace(MU0, MU1, STEPS + 1)[1:]


def run_baseline(case: dict) -> Run:
    """NGSolve's NewtonSolver with its energy line search, from the previous solution at each step."""
    prob = make_problem(case)
    a, gfu = prob.form, prob.displacement  # the same energy form, solved by NGSolve's Newton
    stamps: list[float] = []
    run = Run(0.0, [], [], [], prob.save_state())
    start = time.perf_counter()
    solver = NewtonSolver(a, gfu, freedofs=prob.space.FreeDofs(), inverse="sparsecholesky")
    with ngs.TaskManager():
        for mu in mu_values():
            prob.mu.Set(mu)
            stamps.clear()
            stamps.append(time.perf_counter())
            # without its energy line search NGSolve's Newton steps into J <= 1 (NaN) in this ramp
            converged, its = solver.Solve(maxit=50, maxerr=1e-11, linesearch=True,
                                          callback=lambda it, err: stamps.append(time.perf_counter()))
            if converged < 0 or not np.all(np.isfinite(gfu.vec.FV().NumPy())):
                run.failed_at = float(mu)
                break
            run.iteration_times += list(np.diff(stamps))  # iterations of converged steps only
            run.iterations_per_step.append(its)
            run.step_ends.append(time.perf_counter() - start)
    run.wall = time.perf_counter() - start
    run.state = prob.save_state()
    return run


def run_ngsgel(case: dict, **newton_options) -> Run:
    prob = make_problem(case)
    run = Run(0.0, [], [], [], prob.save_state())
    start = time.perf_counter()

    def on_step(value, result):
        run.step_ends.append(time.perf_counter() - start)
        rejected = 0.0  # a rejected chord attempt is charged to the full iteration after it
        for record in result.records:
            if record.kind == "rejected chord":
                rejected += record.total
            elif record.kind == "newton":
                run.iteration_times.append(record.total + rejected)
                rejected = 0.0
        run.iterations_per_step.append(result.iterations)
        run.chord_steps += result.chord_steps

    step = (MU1 - MU0) / STEPS
    ramp(prob, prob.mu, MU1, step=step, max_step=step, grow=1.0, on_step=on_step, newton_options=newton_options)
    run.wall = time.perf_counter() - start
    run.state = prob.save_state()
    return run


def compare(base: Run, ours: Run) -> dict[str, float]:
    """Ratios ngsgel / baseline of one repetition.

    ``ramp_ratio``: whole ramp (NaN if the baseline failed). ``survived_ratio``: time to the last
    step the baseline converged, same steps (equals ``ramp_ratio`` if it completed).
    ``ramp_bound``: ngsgel's whole ramp over the baseline's time up to its failure, an upper
    bound of the ratio a completed baseline could give. ``iteration_ratio``: the most expensive
    ngsgel Newton iteration over the median baseline iteration (the baseline's first, which
    includes the symbolic factorisation, left out; ngsgel's is in its tangent predictor and
    counted in the ramp); ``iteration_ratio_median``: median over median."""
    k = len(base.step_ends)
    t_base = statistics.median(base.iteration_times[1:]) if len(base.iteration_times) > 1 else float("nan")
    return {"ramp_ratio": ours.wall / base.wall if base.failed_at is None else float("nan"),
            "survived_ratio": ours.step_ends[k - 1] / base.step_ends[k - 1] if k else float("nan"),
            "ramp_bound": ours.wall / base.wall,
            "iteration_ratio": max(ours.iteration_times) / t_base,
            "iteration_ratio_median": statistics.median(ours.iteration_times) / t_base}


VARIANTS = {"ngsgel": {}, "ngsgel-reuse": {"reuse_factorisation": True}}


def timed_ramp(case: dict, options: dict) -> tuple[float, int, int]:
    """Wall time, full iterations and factorisations (predictor's included) of ngsgel's ramp
    (10 equal steps as ``ramp(..., step=h, max_step=h, grow=1)``, the call an older ngsgel has too)."""
    prob = make_problem(case)
    prob.form
    step = (MU1 - MU0) / STEPS
    start = time.perf_counter()
    result = ramp(prob, prob.mu, MU1, step=step, max_step=step, grow=1.0, newton_options=options)
    wall = time.perf_counter() - start
    return wall, sum(n.iterations for n in result.newton), getattr(result, "factorisations", -1)


def threads_study(case: dict, repeat: int, variants: list[str]) -> list[dict]:
    """The default and the chord-reuse ramp on 1 and 2 NGSolve threads, each with the BLAS pools at
    their defaults and limited to one thread (``ngsgel.using_threads``), interleaved."""
    import threadpoolctl
    from ngsgel import using_threads

    default_blas = max(i["num_threads"] for i in threadpoolctl.threadpool_info() if i["user_api"] == "blas")
    configs = [(n, limited) for limited in (False, True) for n in (1, 2)]
    times: dict[tuple, list[float]] = {}
    counts: dict[tuple, tuple[int, int]] = {}
    for _ in range(repeat):
        for variant in variants:
            options = VARIANTS[variant]
            for n, limited in configs:
                if limited:
                    with using_threads(n):
                        wall, its, facs = timed_ramp(case, options)
                else:
                    ngs.SetNumThreads(n)
                    with threadpoolctl.threadpool_limits(default_blas, user_api="blas"):
                        wall, its, facs = timed_ramp(case, options)
                times.setdefault((variant, n, limited), []).append(wall)
                counts[(variant, n, limited)] = (its, facs)
                print(f"    {variant}, {n} thread(s), BLAS {'1 thread' if limited else f'{default_blas} threads'}: "
                      f"{wall:.2f}s", flush=True)
    rows = []
    for variant in variants:
        for n, limited in configs:
            wall = statistics.median(times[(variant, n, limited)])
            key_one = (variant, 1, limited)
            key_default = (variant, n, False)
            rows.append({"variant": variant, "threads": n, "blas_threads": 1 if limited else default_blas,
                         "ramp_s": wall, "runs": ", ".join(f"{t:.1f}" for t in times[(variant, n, limited)]),
                         "iterations": counts[(variant, n, limited)][0],
                         "factorisations": counts[(variant, n, limited)][1],
                         "over_1_thread": wall / statistics.median(times[key_one]),
                         "over_blas_default": wall / statistics.median(times[key_default])})
            print(f"  {variant}, {n} thread(s), BLAS {rows[-1]['blas_threads']}: {wall:.2f}s "
                  f"(runs {rows[-1]['runs']}; {rows[-1]['iterations']} iterations, "
                  f"{rows[-1]['factorisations']} factorisations); / 1 thread {rows[-1]['over_1_thread']:.2f}, "
                  f"/ default BLAS {rows[-1]['over_blas_default']:.2f}", flush=True)
    return rows


def before_after(case_name: str, before: str, repeat: int) -> list[dict]:
    """ngsgel's ramp (default options) with the ngsgel package in ``before`` against this one,
    each run in a fresh process with the process defaults for threads, interleaved."""
    import json
    import subprocess
    import sys

    here = os.path.dirname(os.path.abspath(__file__))
    trees = {"before": before, "after": os.path.dirname(here)}
    times: dict[str, list[float]] = {k: [] for k in trees}
    iterations = {}
    for _ in range(repeat):
        for label, tree in trees.items():
            env = dict(os.environ, PYTHONPATH=os.pathsep.join([tree, here]))
            out = subprocess.run([sys.executable, os.path.abspath(__file__), "--child", case_name], env=env,
                                 check=True, capture_output=True, text=True).stdout
            child = json.loads(out.strip().splitlines()[-1])
            times[label].append(child["wall"])
            iterations[label] = child["iterations"]
            print(f"    {label}: {child['wall']:.2f}s ({child['iterations']} iterations, ngsgel from "
                  f"{child['package']})", flush=True)
    ratio = statistics.median(times["after"]) / statistics.median(times["before"])
    print(f"  default ramp: before {statistics.median(times['before']):.2f}s, after "
          f"{statistics.median(times['after']):.2f}s, after / before {ratio:.2f}", flush=True)
    return [{"label": k, "ramp_s": statistics.median(v), "runs": ", ".join(f"{t:.1f}" for t in v),
             "iterations": iterations[k], "after_over_before": ratio} for k, v in times.items()]


ISSUE35_SIZES = {"8k": 0.08, "28k": 0.053, "53k": 0.039, "108k": 0.038}  # netgen maxh: 7,923 / 28,584 / 52,962 / 108,426 unknowns
ISSUE35_GEL = FloryRehnerGel(Nv=1e-2, chi=0.5)


def issue35_problem(maxh: float, inverse: str) -> EquilibriumProblem:
    mesh = block(lx=1, ly=1, lz=0.2, maxh=maxh).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=ISSUE35_GEL, lam0=1.3,
                              mu=ISSUE35_GEL.mu_free(1.3), order=2, inverse=inverse)
    prob.fix("bottom")
    prob.form
    return prob


def issue35_mu_values(steps: int = 20) -> list[float]:
    return list(np.linspace(ISSUE35_GEL.mu_free(1.3), ISSUE35_GEL.mu_free(1.6), steps + 1)[1:])


def backend_times(maxh: float, inverse: str, threads: int) -> dict[str, float]:
    """First factorisation, numeric refactorisation and solve of the tangent at the start."""
    import threadpoolctl
    from ngsgel.newton import LinearSolver

    prob = issue35_problem(maxh, inverse)
    ngs.SetNumThreads(threads)
    with ngs.TaskManager(), threadpoolctl.threadpool_limits(threads, user_api="blas"):
        K = prob.tangent(prob.state)
        r = prob.state.CreateVector()
        prob.residual(prob.state, r)
        solver = LinearSolver(prob.space.FreeDofs(), inverse=inverse)
        first, _ = timed(lambda: solver.factor(K))
        refactor, inv = timed(lambda: solver.factor(K))
        out = r.CreateVector()

        def apply():
            out.data = inv * r

        solve, _ = timed(apply)
    ngs.SetNumThreads(1)
    return {"ndof": prob.space.ndof, "first_s": first, "refactor_s": refactor, "solve_s": solve}


def bddc_times(maxh: float) -> dict[str, float]:
    """CG with NGSolve's BDDC on the statically condensed tangent at the start, the preconditioner
    set up once and used for two solves, against the direct solution (relative difference)."""
    from ngsolve.krylovspace import CGSolver

    prob = issue35_problem(maxh, "auto")
    u = prob.space.TrialFunction()
    Fp = prob.deformation_gradient(u)
    energy = prob.region_sum(lambda mat, name: mat.reference_energy(Fp, prob.mu, prob.lam0_of(name)))
    times = {"ndof": prob.space.ndof}
    with ngs.TaskManager():
        form = ngs.BilinearForm(prob.space, symmetric=True, condense=True)
        form += ngs.Variation(energy)
        bddc = ngs.Preconditioner(form, "bddc")
        times["setup_s"], _ = timed(lambda: form.AssembleLinearization(prob.state))  # assembly + BDDC
        rhs = prob.state.CreateVector()
        prob.residual(prob.state, rhs)
        rhs.FV().NumPy()[~prob.free_mask] = 0.0
        x = rhs.CreateVector()

        def solve():
            cg = CGSolver(form.mat, bddc.mat, tol=1e-10, maxiter=2000)
            condensed = rhs.CreateVector()
            condensed.data = rhs + form.harmonic_extension_trans * rhs
            x.data = cg * condensed
            x.data += form.inner_solve * condensed
            x.data += form.harmonic_extension * x
            return cg.iterations

        times["first_solve_s"], times["cg_iterations"] = timed(solve)
        times["reused_solve_s"], _ = timed(solve)
        direct = (prob.tangent(prob.state).Inverse(prob.space.FreeDofs(), inverse="umfpack") * rhs).Evaluate()
    times["difference"] = float(np.linalg.norm(x.FV().NumPy() - direct.FV().NumPy())
                                / np.linalg.norm(direct.FV().NumPy()))
    return times


def issue35_ramp(maxh: float, inverse: str, reuse: bool | None = None) -> dict[str, float]:
    """The 20-step ramp (strict: no cut-back); a failed step ends it, and the times are those of
    the steps before it (``steps`` says how many converged). ``reuse``: Newton's
    ``reuse_factorisation`` (None: the problem's default)."""
    prob = issue35_problem(maxh, inverse)
    try:
        result = ramp(prob, prob.mu, values=issue35_mu_values(), strict=True,
                      newton_options={} if reuse is None else {"reuse_factorisation": reuse})
    except RampError as err:
        result = err.result
        print(f"  FAILED: {err}", flush=True)
    work = total_work(w for step in result.records for w in step.records)  # converged steps only
    iterations = sum(n.iterations for n in result.newton)
    return {"ndof": prob.space.ndof, "steps": result.steps, "ramp_s": work.total, "iterations": iterations,
            "factorisations": work.factorisations, "s_per_iteration": work.total / iterations,
            **{f"{part}_s": getattr(work, part) for part in Work.TIMES if part != "total"}}


def issue35_path(maxh: float, stability, steps: int = 5) -> list:
    from ngsgel.continuation import follow_path

    prob = issue35_problem(maxh, "auto")
    mu = issue35_mu_values(steps)
    result = follow_path(prob, prob.mu, method="natural", step=mu[0] - ISSUE35_GEL.mu_free(1.3),
                         max_step=mu[0] - ISSUE35_GEL.mu_free(1.3), grow=1.0, target=mu[-1], stability=stability)
    return result.steps[1:]  # the steps, not the start


def tracking_costs(maxh: float, path_size: str, history: History) -> None:
    """Mean step time of the same path untracked, with the count-only stability check (the
    default) and with two eigenpairs recorded at every point, in one run."""
    from ngsgel.continuation import StabilityOptions

    variants = {"untracked": None, "count-only": StabilityOptions(), "eigenpairs": StabilityOptions(eigenvalues=2)}
    steps = {name: issue35_path(maxh, options) for name, options in variants.items()}
    mean = {name: statistics.mean(s.work.total for s in v) for name, v in steps.items()}
    row = {"size": path_size}
    for name, v in steps.items():
        check = statistics.mean(s.part("stability").total for s in v)
        facs = statistics.mean(s.work.factorisations for s in v)
        print(f"{path_size}: follow_path step, 1 thread, {name}: {mean[name]:.2f}s ({facs:.1f} factorisations"
              + (f", stability check {check:.2f}s" if variants[name] else "")
              + f"), / untracked {mean[name] / mean['untracked']:.2f}", flush=True)
        row.update({f"{name}_s": mean[name], f"{name}_check_s": check, f"{name}_factorisations": facs,
                    f"{name}_ratio": mean[name] / mean["untracked"]})
    history.append(row)


def issue35(sizes: list[str], run_dir, path_size: str) -> None:
    from ngsgel.linalg import pardiso_available

    backends = [("sparsecholesky", 1), ("sparsecholesky", 2), ("umfpack", 1)]
    backends += [("pardiso", 1), ("pardiso", 2)] if pardiso_available() else []
    ngs.SetNumThreads(1)
    histories = {name: History(run_dir.file(f"{name}.csv")) for name in ("backends", "bddc", "ramps", "path_steps")}
    for size in sizes:
        maxh = ISSUE35_SIZES[size]
        for inverse, threads in backends:
            if inverse == "umfpack" and size != sizes[0]:
                continue  # 5-6x sparsecholesky's time already at the first size
            t = backend_times(maxh, inverse, threads)
            print(f"{size} ({t['ndof']} unknowns) {inverse}, {threads} thread(s): first factorisation "
                  f"{t['first_s']:.2f}s, refactorisation {t['refactor_s']:.2f}s, solve {t['solve_s']:.3f}s", flush=True)
            histories["backends"].append({"size": size, "inverse": inverse, "threads": threads, **t})
        t = bddc_times(maxh)
        print(f"{size} ({t['ndof']} unknowns) CG + BDDC (condensed), 1 thread: assembly + BDDC setup {t['setup_s']:.2f}s, "
              f"solve {t['first_solve_s']:.2f}s ({t['cg_iterations']} CG iterations to 1e-10), again with the same "
              f"preconditioner {t['reused_solve_s']:.2f}s; relative difference to the direct solution "
              f"{t['difference']:.1e}", flush=True)
        histories["bddc"].append({"size": size, **t})
        for inverse, reuse in (("auto", None), ("auto", False), ("sparsecholesky", False)):
            if inverse == "sparsecholesky" and size != sizes[0]:
                continue
            t = issue35_ramp(maxh, inverse, reuse)
            label = "defaults" if reuse is None else f"inverse={inverse!r}, reuse_factorisation={reuse}"
            print(f"{size}: 20-step ramp, {label}, 1 thread: "
                  f"{t['steps']} steps converged in {t['ramp_s']:.1f}s, {t['iterations']} iterations, "
                  f"{t['factorisations']} factorisations, {t['s_per_iteration']:.2f}s per iteration; in all: "
                  + ", ".join(f"{part} {t[part + '_s']:.1f}s" for part in Work.TIMES if part != "total"), flush=True)
            histories["ramps"].append({"size": size, "inverse": inverse, "reuse": "auto" if reuse is None else reuse, "threads": 1, **t})
    tracking_costs(ISSUE35_SIZES[path_size], path_size, histories["path_steps"])
    for history in histories.values():
        history.close()


def main(argv=None) -> None:
    global STEPS
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default="results/bench_newton")
    parser.add_argument("--quick", action="store_true")
    parser.add_argument("--repeat", type=int, default=3)
    parser.add_argument("--cases", default=None, help="comma-separated subset of the cases")
    parser.add_argument("--steps", type=int, default=None, help=f"load steps of the ramp (default {STEPS})")
    parser.add_argument("--threads-study", action="store_true",
                        help="instead: default and chord-reuse ramps on 1 and 2 threads, BLAS limited or not")
    parser.add_argument("--before", default=None, metavar="DIR",
                        help="instead: the default ramp with the ngsgel package in DIR (e.g. an older commit's) "
                             "against this one, in fresh processes")
    parser.add_argument("--variants", default=None, help=f"--threads-study: a subset of {','.join(VARIANTS)}")
    parser.add_argument("--backends", action="store_true",
                        help="instead: issue 35's block, per backend factorisation/solve times, default ramp, "
                             "tracked / untracked path step")
    parser.add_argument("--sizes", default="28k,53k",
                        help=f"--backends: meshes among {','.join(ISSUE35_SIZES)} ('' for the path only)")
    parser.add_argument("--path-size", default="28k", help="--backends: the mesh of the tracked / untracked path")
    parser.add_argument("--child", default=None, help=argparse.SUPPRESS)  # one --before run: prints its time
    args = parser.parse_args(argv)
    STEPS = args.steps or STEPS
    quick = args.quick or bool(os.environ.get("CI"))
    chosen = cases(quick) | cases(not quick)
    if args.child:
        import json
        import ngsgel
        wall, its, _ = timed_ramp(chosen[args.child], {})
        print(json.dumps({"wall": wall, "iterations": its, "package": os.path.dirname(ngsgel.__file__)}))
        return
    chosen = {k: chosen[k] for k in args.cases.split(",")} if args.cases else cases(quick)
    if args.backends:
        import logging
        logging.basicConfig(level=logging.INFO, format="%(name)s: %(message)s")  # the backend choice
        run_dir = RunDirectory(args.out, params={"sizes": args.sizes, "cores": os.cpu_count()})
        issue35([size for size in args.sizes.split(",") if size], run_dir, args.path_size)
        return
    if args.threads_study or args.before:
        run_dir = RunDirectory(args.out, params={"mu0": MU0, "mu1": MU1, "steps": STEPS, "repeat": args.repeat,
                                                 "cases": list(chosen), "before": args.before,
                                                 "cores": os.cpu_count()})
        with History(run_dir.file("threads.csv" if args.threads_study else "before_after.csv")) as history:
            for name, case in chosen.items():
                print(f"{name}: {make_problem(case).space.ndof} unknowns", flush=True)
                variants = args.variants.split(",") if args.variants else list(VARIANTS)
                rows = (threads_study(case, args.repeat, variants) if args.threads_study
                        else before_after(name, args.before, args.repeat))
                for row in rows:
                    history.append({"case": name, **row})
        return
    run_dir = RunDirectory(args.out, params={"mu0": MU0, "mu1": MU1, "steps": STEPS, "repeat": args.repeat,
                                             "quick": quick, "threads": os.cpu_count()})
    med = statistics.median
    with History(run_dir.file("bench.csv")) as history:
        for name, case in chosen.items():
            prob = make_problem(case)
            split = iteration_split(prob)
            print(f"{name}: {prob.space.ndof} unknowns; one iteration: assembly {split['assembly']:.3f}s, "
                  f"factorisation {split['factorisation']:.3f}s, solve {split['solve']:.3f}s, "
                  f"residual {split['residual']:.3f}s, admissibility {split['admissibility']:.3f}s", flush=True)
            runs = {"baseline": []} | {v: [] for v in VARIANTS}
            for _ in range(args.repeat):  # interleaved, so that a change of machine load hits all alike
                runs["baseline"].append(run_baseline(case))
                for variant, options in VARIANTS.items():
                    runs[variant].append(run_ngsgel(case, **options))
            base = runs["baseline"]
            failed = [b.failed_at for b in base if b.failed_at is not None]
            print(f"  baseline: {med(b.wall for b in base):.2f}s, iterations per step "
                  f"{base[0].iterations_per_step}, median iteration {med(base[0].iteration_times[1:]):.3f}s"
                  + (f"; FAILED (NaN, J <= 1) at mu = {failed[0]:.4g} in {len(failed)}/{len(base)} runs, "
                     f"after {len(base[0].step_ends)} of {STEPS} steps" if failed else ""))
            for variant in VARIANTS:
                ours = runs[variant]
                ratios = [compare(b, o) for b, o in zip(base, ours)]
                r = {key: med(x[key] for x in ratios) for key in ratios[0]}
                diff = float(np.max(np.abs(base[0].state - ours[0].state))) if base[0].failed_at is None else float("nan")
                row = {"case": name, "variant": variant, "ndof": prob.space.ndof, **{f"t_{k}": v for k, v in split.items()},
                       "baseline_ramp_s": med(b.wall for b in base), "ngsgel_ramp_s": med(o.wall for o in ours),
                       "baseline_failed_at_mu": failed[0] if failed else None, "baseline_steps": len(base[0].step_ends),
                       "baseline_iterations": base[0].iterations, "ngsgel_iterations": ours[0].iterations,
                       "ngsgel_chord_steps": ours[0].chord_steps,
                       "baseline_s_per_iteration": med(base[0].iteration_times[1:]),
                       "ngsgel_s_per_iteration": med(ours[0].iteration_times),
                       **r, "max_state_difference": diff,
                       "peak_rss_MB": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024}
                history.append(row)
                k = len(base[0].step_ends)
                ramp_text = (f"ramp ratio {r['ramp_ratio']:.2f}, end states differ by {diff:.1e}" if not failed else
                             f"ramp ratio n/a (baseline failed); on the {k} steps it survived {r['survived_ratio']:.2f}; "
                             f"whole ramp / baseline up to its failure {r['ramp_bound']:.2f}")
                print(f"  {variant}: {row['ngsgel_ramp_s']:.2f}s, iterations per step {ours[0].iterations_per_step}"
                      + (f" (+{ours[0].chord_steps} chord steps)" if ours[0].chord_steps else "")
                      + f", median iteration {row['ngsgel_s_per_iteration']:.3f}s; {ramp_text}; per-iteration cost "
                      f"ratio max {r['iteration_ratio']:.2f} (median {r['iteration_ratio_median']:.2f})", flush=True)


if __name__ == "__main__":
    main()
