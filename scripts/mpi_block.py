"""Bonded gel block under a step of mu: one compute rank against two, measured in one run.

    python scripts/mpi_block.py --n 8 --inverse bddc masterinverse

runs the block (``n x n x n/2`` hexahedra, order 2, bonded at its bottom, ``mu`` from -0.1 to
-0.099) under ``mpiexec -n 2`` (1 compute rank: rank 0 holds no elements) and ``mpiexec -n 3``
(2 compute ranks) for each parallel linear solver, one thread per rank, and prints the Newton
iterations, the time per Newton iteration and its parts (assembly, linear solve), the Krylov
iterations, the peak resident memory of each rank and the speed-up of two compute ranks over
one. A serial run (no MPI, NGSolve's sparsecholesky) is the reference for the solution: the
energies must agree to 1e-8. The load average before and after is printed: on a shared machine
the ratio is only as good as the cores the ranks got.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import shutil
import subprocess
import sys
import time

MARKER = "BLOCK "
MU0, MU1 = -0.1, -0.099


def solve_block(n: int, inverse: str, mesh) -> dict:
    import ngsolve as ngs

    from ngsgel import EquilibriumProblem, FloryRehnerGel, Solid3D

    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=gel, lam0=gel.lam_free(MU0), mu=MU0, order=2,
                              inverse=inverse)
    prob.fix("bottom")
    prob.form
    started = time.perf_counter()
    prob.mu.Set(MU1)
    with ngs.TaskManager():  # full Newton iterations only: their cost is what is compared
        result = prob.solve(reuse_factorisation=False)
    total = time.perf_counter() - started
    work = result.work
    krylov = getattr(prob._solver, "krylov_iterations", [])
    return {"ndof": int(getattr(prob.space, "ndofglobal", prob.space.ndof)), "iterations": result.iterations,
            "total": total, "assembly": work.assembly, "linear": work.factorisation + work.solve,
            "krylov": list(krylov), "energy": prob.energy()}


def block_mesh(n: int):
    from geometries import block

    return block(lx=1, ly=1, lz=0.5, maxh=1.0, structured=True, nx=n, ny=n, nz=max(1, n // 2)).mesh


def child(n: int, inverse: str) -> None:
    import ngsolve as ngs

    from ngsgel import parallel

    ngs.SetNumThreads(1)
    comm = parallel.world()
    row = solve_block(n, inverse, parallel.distribute_mesh(lambda: block_mesh(n)))
    row["memory"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024  # MiB (Linux: kB)
    rows = comm.gather(row, root=0)
    if comm.rank == 0:  # the slowest rank's times; every rank takes the same Krylov iterations
        row = {**row, **{key: max(r[key] for r in rows) for key in ("total", "assembly", "linear")},
               "memory": [r["memory"] for r in rows]}
        print(MARKER + json.dumps(row), flush=True)


def run_mpi(ranks: int, n: int, inverse: str) -> dict:
    mpiexec = shutil.which("mpiexec", path=os.path.dirname(sys.executable)) or shutil.which("mpiexec")
    if mpiexec is None:
        sys.exit("mpiexec not found: pip install ngsgel[mpi]")
    env = {**os.environ, "MPIR_CVAR_ENABLE_HEAVY_YIELD": "1"}  # waiting ranks yield their core
    run = subprocess.run([mpiexec, "-n", str(ranks), sys.executable, __file__, "--child", "--n", str(n),
                          "--inverse", inverse], capture_output=True, text=True, env=env)
    if run.returncode != 0:
        sys.exit(f"mpiexec -n {ranks} failed:\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}")
    (line,) = [line for line in run.stdout.splitlines() if line.startswith(MARKER)]
    return json.loads(line[len(MARKER):])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=8, help="elements along x and y (n/2 along z)")
    parser.add_argument("--inverse", nargs="+", default=["bddc", "masterinverse"], choices=["bddc", "masterinverse"],
                        help="parallel linear solvers to compare")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.n < 1:
        parser.error(f"--n must be an integer >= 1, got {args.n}")
    if args.child:
        child(args.n, args.inverse[0])
        return
    import ngsolve as ngs

    ngs.SetNumThreads(1)
    print("load average (1, 5, 15 min) at the start: " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))
    serial = solve_block(args.n, "sparsecholesky", block_mesh(args.n))
    print(f"bonded block n={args.n}: {serial['ndof']} dofs; serial sparsecholesky {serial['iterations']} Newton "
          f"iterations, {serial['total'] / serial['iterations']:.3f} s per iteration")
    print(f"{'solver':14s} {'ranks':>5s} {'Newton':>6s} {'s/iter':>7s} {'assembly':>8s} {'linear':>7s} "
          f"{'Krylov its/solve':>18s} {'MiB per rank (0, 1, ...)':>26s} {'energy - serial':>16s}")
    for inverse in args.inverse:
        per_iteration = {}
        for ranks in (2, 3):
            row = run_mpi(ranks, args.n, inverse)
            its = row["iterations"]
            per_iteration[ranks] = row["total"] / its
            deviation = (row["energy"] - serial["energy"]) / abs(serial["energy"])
            krylov = "/".join(str(k) for k in row["krylov"]) or "-"
            memory = ", ".join(f"{m:.0f}" for m in row["memory"])
            print(f"{inverse:14s} {ranks - 1:5d} {its:6d} {per_iteration[ranks]:7.3f} {row['assembly'] / its:8.3f} "
                  f"{row['linear'] / its:7.3f} {krylov:>18s} {memory:>26s} {deviation:16.1e}")
            if abs(deviation) > 1e-8:
                sys.exit(f"{inverse} on {ranks - 1} compute ranks: energy off the serial one by {deviation:.1e}")
        speed_up = per_iteration[2] / per_iteration[3]
        print(f"{inverse}: 2 compute ranks {speed_up:.2f}x the speed of 1 per Newton iteration")
    print("load average (1, 5, 15 min) at the end: " + ", ".join(f"{x:.2f}" for x in os.getloadavg()))


if __name__ == "__main__":
    main()
