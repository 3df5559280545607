"""Bonded gel block under a step of mu: one compute rank against two, measured in one run.

    python scripts/mpi_block.py --n 12 --inverse bddc masterinverse
    python scripts/mpi_block.py --n 16 --inverse masterinverse --no-serial   # 56k dofs, 2.5 min
    python scripts/mpi_block.py --n 20 --inverse masterinverse --no-serial --compute-ranks 2  # > 12 min

runs the block (``n x n x n/2`` hexahedra, order 2, bonded at its bottom, ``mu`` from -0.1 to
-0.099, full Newton iterations) under ``mpiexec -n P+1`` for each number ``P`` of compute ranks
(rank 0 holds no elements) and each parallel linear solver, and prints per run: the dofs, the
Newton and Krylov iterations, the time per Newton iteration and its parts (assembly, linear
solve), the time the compute ranks wait on rank 0's serial solver (BDDC's coarse wirebasket
solve and its factorisation, or the whole "masterinverse" solve), the CPU seconds and peak
resident memory of each rank, and the speed-up of two compute ranks over one with the ceiling
Amdahl's law puts on it: ``T1 / (S1 + (T1 - S1) / 2)``, ``S1`` the serial-solver wait of the
one-compute-rank run. The serial reference (no MPI, NGSolve's sparsecholesky) checks the
energies to 1e-8; ``--no-serial`` skips it for large blocks and checks the MPI runs against the
first one instead. The load average is printed around every run: on a shared machine a ratio is
only as good as the cores the ranks got.

Environment the script sets for its ``mpiexec`` runs (a user's run needs the same):

- ``MPIR_CVAR_ENABLE_HEAVY_YIELD=1``: MPICH's waiting ranks sleep briefly (nanosleep) between
  polls instead of spinning. Rank 0 waiting in a barrier while two ranks compute used 1.5-1.8
  CPU s in 2.7-4.2 s by default and 0.2-0.4 s with it (MPICH 5.0.2 ch4, 3 ranks on 2 cores);
  ``MPIR_CVAR_CH4_PROGRESS_THROTTLE`` and ``MPIR_CVAR_POLLS_BEFORE_YIELD`` did not lower it.
- ``OMP_NUM_THREADS=1``, ``MKL_NUM_THREADS=1``: one thread per rank (with
  ``ngs.SetNumThreads(1)``), so ranks do not compete with their own BLAS/PARDISO threads.
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
MPI_ENVIRONMENT = {"MPIR_CVAR_ENABLE_HEAVY_YIELD": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
# NGSolve timers on a compute rank that measure its wait on rank 0's serial BDDC coarse solver
COARSE_TIMERS = ("Apply BDDC preconditioner - wb solve", "BDDC Finalize")


def solve_block(n: int, inverse: str, mesh) -> dict:
    import ngsolve as ngs

    from ngsgel import EquilibriumProblem, FloryRehnerGel, Solid3D

    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=gel, lam0=gel.lam_free(MU0), mu=MU0, order=2,
                              inverse=inverse)
    prob.fix("bottom")
    prob.form
    started, cpu_started = time.perf_counter(), time.process_time()
    prob.mu.Set(MU1)
    with ngs.TaskManager():  # full Newton iterations only: their cost is what is compared
        result = prob.solve(reuse_factorisation=False)
    total, cpu = time.perf_counter() - started, time.process_time() - cpu_started
    work = result.work
    krylov = getattr(prob._solver, "krylov_iterations", [])
    linear = work.factorisation + work.solve
    if inverse == "bddc":
        timers = {t["name"]: t["time"] for t in ngs.Timers()}
        serial_wait = sum(timers.get(name, 0.0) for name in COARSE_TIMERS)
    else:  # the compute ranks wait for the whole gathered direct solve
        serial_wait = linear
    return {"ndof": int(getattr(prob.space, "ndofglobal", prob.space.ndof)), "iterations": result.iterations,
            "total": total, "cpu": cpu, "assembly": work.assembly, "linear": linear, "serial_wait": serial_wait,
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
    if comm.rank == 0:  # the slowest compute rank's times; every rank takes the same Krylov iterations
        compute = rows[1:]
        row = {**row, **{key: max(r[key] for r in compute) for key in ("total", "assembly", "linear", "serial_wait")},
               "memory": [r["memory"] for r in rows], "cpu": [r["cpu"] for r in rows]}
        print(MARKER + json.dumps(row), flush=True)


def load_average() -> str:
    return ", ".join(f"{x:.2f}" for x in os.getloadavg())


def run_mpi(ranks: int, n: int, inverse: str) -> dict:
    mpiexec = shutil.which("mpiexec", path=os.path.dirname(sys.executable)) or shutil.which("mpiexec")
    if mpiexec is None:
        sys.exit("mpiexec not found: pip install ngsgel[mpi]")
    run = subprocess.run([mpiexec, "-n", str(ranks), sys.executable, __file__, "--child", "--n", str(n),
                          "--inverse", inverse], capture_output=True, text=True, env={**os.environ, **MPI_ENVIRONMENT})
    if run.returncode != 0:
        sys.exit(f"mpiexec -n {ranks} failed:\n{run.stdout[-2000:]}\n{run.stderr[-2000:]}")
    (line,) = [line for line in run.stdout.splitlines() if line.startswith(MARKER)]
    return json.loads(line[len(MARKER):])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--n", type=int, default=8, help="elements along x and y (n/2 along z)")
    parser.add_argument("--inverse", nargs="+", default=["bddc", "masterinverse"], choices=["bddc", "masterinverse"],
                        help="parallel linear solvers to compare")
    parser.add_argument("--compute-ranks", type=int, nargs="+", default=[1, 2],
                        help="numbers of compute ranks to run (mpiexec -n P+1 each)")
    parser.add_argument("--no-serial", action="store_true",
                        help="skip the serial reference (large blocks); MPI runs are checked against the first one")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.n < 1:
        parser.error(f"--n must be an integer >= 1, got {args.n}")
    if min(args.compute_ranks) < 1:
        parser.error(f"--compute-ranks must be integers >= 1, got {args.compute_ranks}")
    if args.child:
        child(args.n, args.inverse[0])
        return
    import ngsolve as ngs

    ngs.SetNumThreads(1)
    print(f"load average (1, 5, 15 min) at the start: {load_average()}")
    reference = None
    if not args.no_serial:
        serial = solve_block(args.n, "sparsecholesky", block_mesh(args.n))
        reference = serial["energy"]
        print(f"bonded block n={args.n}: {serial['ndof']} dofs; serial sparsecholesky {serial['iterations']} Newton "
              f"iterations, {serial['total'] / serial['iterations']:.3f} s per iteration")
    print(f"{'solver':14s} {'ranks':>5s} {'dofs':>8s} {'Newton':>6s} {'s/iter':>7s} {'assembly':>8s} {'linear':>7s} "
          f"{'rank-0 wait':>11s} {'Krylov its/solve':>22s} {'CPU s per rank':>20s} {'MiB per rank':>20s} "
          f"{'energy dev.':>11s} {'load avg (1 min)':>16s}")
    for inverse in args.inverse:
        rows = {}
        for compute_ranks in args.compute_ranks:
            load_before = os.getloadavg()[0]
            row = run_mpi(compute_ranks + 1, args.n, inverse)
            rows[compute_ranks] = row
            its = row["iterations"]
            reference = row["energy"] if reference is None else reference
            deviation = (row["energy"] - reference) / abs(reference)
            krylov = "/".join(str(k) for k in row["krylov"]) or "-"
            cpu = ", ".join(f"{c:.1f}" for c in row["cpu"])
            memory = ", ".join(f"{m:.0f}" for m in row["memory"])
            print(f"{inverse:14s} {compute_ranks:5d} {row['ndof']:8d} {its:6d} {row['total'] / its:7.3f} "
                  f"{row['assembly'] / its:8.3f} {row['linear'] / its:7.3f} {row['serial_wait'] / its:11.3f} "
                  f"{krylov:>22s} {cpu:>20s} {memory:>20s} {deviation:11.1e} "
                  f"{load_before:7.2f}->{os.getloadavg()[0]:.2f}", flush=True)
            if abs(deviation) > 1e-8:
                sys.exit(f"{inverse} on {compute_ranks} compute ranks: energy off the reference by {deviation:.1e}")
        if 1 in rows and 2 in rows:
            one = rows[1]
            per_iteration = {p: rows[p]["total"] / rows[p]["iterations"] for p in (1, 2)}
            ceiling = one["total"] / (one["serial_wait"] + (one["total"] - one["serial_wait"]) / 2)
            print(f"{inverse}: 2 compute ranks {per_iteration[1] / per_iteration[2]:.2f}x the speed of 1 per Newton "
                  f"iteration; Amdahl ceiling {ceiling:.2f}x (rank 0's serial solver: "
                  f"{one['serial_wait'] / one['total']:.0%} of the 1-rank time)")
    print(f"load average (1, 5, 15 min) at the end: {load_average()}")


if __name__ == "__main__":
    main()
