"""3D gels on a mesh distributed over two MPI compute ranks give the serial results.

The test runs this file under ``mpiexec -n 3`` (rank 0 holds no elements: two compute ranks) and
compares with the same problems solved serially in the test process: the displacement at every
mesh vertex and the energy to 1e-8 of their size, and the exact number of negative eigenvalues
of the free tangent. Skipped where MPI is not installed (``pip install ngsgel[mpi]``).

Problems: a gel block bonded at its bottom swelling under two steps of ``mu`` (both parallel
linear solvers: BDDC with CG and the direct solve on rank 0), and a gel column clamped at both
ends, shortened on its straight branch to 0.6 and 1.6 times its clamped-clamped Euler strain
``pi^2 h^2 / (3 L^2)``: the square section buckles in x and y at once, so the tangent has 0 and
then 2 negative eigenvalues (the next pair comes at 2.05 times, Euler's second clamped mode).

Drivers and output: ``ramp`` of the block's ``mu`` (tangent predictor through the problem's
parallel solver, then secant steps) gives the serial steps, iterations and states; ``follow_path``
(natural, default stability checks) along the column from 0.6 to 1.6 times the Euler strain
locates the bifurcation where the count goes from 0 to 2 at the serial load, with the serial
counts; its history, progress lines and VTK pieces are written once (rank 0; one piece per
compute rank), and a run killed after its last row, before its checkpoint, resumed from the
3-rank checkpoint on 3 ranks ends as the uninterrupted one (a serial process refuses that file).

Transient: a gel block bonded at its bottom, its top wetted (``mu`` ramped from -0.1 to -0.05
over the march), displacement and chemical potential, ``march`` with BDF2 under error control:
the serial steps (times, iterations, orders), solvent content and state; the solvent balance of
every step over all ranks; a march killed in ``on_step`` after a BDF2 step, before its
checkpoint, resumed from the 3-rank checkpoint on 3 ranks, takes the uninterrupted steps to the
same state (and a serial process refuses that file).
"""

from __future__ import annotations

import csv
import dataclasses
import importlib.util
import io
import json
import math
import os
import shutil
import subprocess
import sys
import types
from pathlib import Path

import numpy as np
import ngsolve as ngs
import pytest

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, Solid3D, TransientProblem, parallel
from ngsgel.continuation import Checkpoint, StabilityOptions, follow_path
from ngsgel.output import History, Progress, RunDirectory, VTKSeries
from ngsgel.stability import free_matrix, negative_count
from ngsgel.stepping import ramp
from ngsgel.transient import MarchCheckpoint, StepRecord, TransientResult, march, time_ramp

from killed_runs import Killed, KilledHistory
from test_transient import assert_balanced

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
MU0 = -0.1
COLUMN_LENGTH = 8.0
EULER_STRAIN = math.pi**2 / (3 * COLUMN_LENGTH**2)  # clamped-clamped, unit square section
SHORTENINGS = (0.6, 1.6)  # times the Euler strain
MARKER = "MPI-RESULT "
RAMP = dict(target=-0.08, step=0.005)  # mu from -0.1: three steps, the step grows after easy ones
PACED = {"reuse_factorisation": True, "chord_pacing": True}
PATH = dict(method="natural", step=0.5 * EULER_STRAIN * COLUMN_LENGTH,
            target=SHORTENINGS[1] * EULER_STRAIN * COLUMN_LENGTH, stability=StabilityOptions())
KILL_AT = 4  # the path's rows: start, bifurcation, end of its step, target
WETTED_MU = -0.05  # the top's mu at the march's end
MARCH_END = 1e-3
MARCH = dict(dt_start=1e-4)  # BDF2 under error control (the default rtol 1e-3)
MARCH_KILL_AT = 8  # killed in on_step of this step (BDF2 from the fourth), before its checkpoint


def swelling_block():
    return block(lx=1, ly=1, lz=0.5, maxh=1.0, structured=True, nx=4, ny=4, nz=2).mesh


def column():
    return block(lx=1, ly=1, lz=COLUMN_LENGTH, maxh=1.0, structured=True, nx=2, ny=2, nz=8).mesh


def small_block():
    return block(lx=1, ly=1, lz=0.5, maxh=1.0, structured=True, nx=2, ny=2, nz=2).mesh


def vertex_values(prob) -> dict:
    """Coordinates and displacement of this process's mesh vertices."""
    points = [list(vertex.point) for vertex in prob.mesh.vertices]
    return {"points": points, "values": [list(prob.displacement(prob.mesh(*p))) for p in points]}


def swell(mesh, inverse: str) -> tuple[EquilibriumProblem, dict]:
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0), mu=MU0, order=2,
                              inverse=inverse)
    prob.fix("bottom")
    iterations = []
    for mu in (-0.095, -0.09):
        prob.mu.Set(mu)
        iterations.append(prob.solve().iterations)
    return prob, {"energy": prob.energy(), "iterations": iterations, **vertex_values(prob)}


def compress(mesh, inverse: str, count) -> tuple[EquilibriumProblem, dict]:
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0), mu=MU0, order=2,
                              inverse=inverse)
    shortening = ngs.Parameter(0.0)
    prob.fix("bottom")
    prob.fix("top", ["x", "y"])
    prob.prescribe("top", "z", -shortening)
    negative, energy = [], []
    for factor in SHORTENINGS:
        shortening.Set(factor * EULER_STRAIN * COLUMN_LENGTH)
        prob.solve()
        negative.append(count(prob))
        energy.append(prob.energy())
    return prob, {"negative": negative, "energy": energy, **vertex_values(prob)}


def serial_count(prob) -> int:
    return negative_count(free_matrix(prob.tangent(prob.state), prob.free_mask))


def ramp_block(mesh, inverse: str, newton_options: dict | None = None) -> tuple[EquilibriumProblem, dict]:
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0), mu=MU0, order=2,
                              inverse=inverse)
    prob.fix("bottom")
    result = ramp(prob, prob.mu, **RAMP, newton_options=newton_options or {})
    return prob, {"parameters": result.values, "iterations": [n.iterations for n in result.newton],
                  "kinds": [work.kind for step in result.records for work in step.records],
                  "energy": prob.energy(), **vertex_values(prob)}


def column_problem(mesh, inverse: str) -> tuple[EquilibriumProblem, ngs.Parameter]:
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0), mu=MU0, order=2,
                              inverse=inverse)
    shortening = ngs.Parameter(SHORTENINGS[0] * EULER_STRAIN * COLUMN_LENGTH)
    prob.fix("bottom")
    prob.fix("top", ["x", "y"])
    prob.prescribe("top", "z", -shortening)
    return prob, shortening


def transient_block(mesh, inverse: str = "auto") -> TransientProblem:
    prob = TransientProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(MU0), mu0=MU0,
                            inverse=inverse)
    prob.fix("bottom")
    prob.immerse("top", time_ramp(prob.t, start=MU0, end=WETTED_MU, duration=MARCH_END))
    return prob


def march_summary(prob, result) -> dict:
    """The records (as numbers, NaN where a step has no error estimate) and the state at every vertex."""
    points = [list(vertex.point) for vertex in prob.mesh.vertices]
    return {"records": [[float(value) for value in dataclasses.astuple(r)] for r in result.records],
            "initial content": prob.initial_content, **vertex_values(prob),
            "mu": [prob.chemical_potential(prob.mesh(*p)) for p in points]}


def same_records(first, second) -> bool:
    """Equal step records (a step without an error estimate has NaN there, in both)."""
    as_array = lambda records: np.array([dataclasses.astuple(r) for r in records], dtype=float)
    return len(first) == len(second) and np.array_equal(as_array(first), as_array(second), equal_nan=True)


def distributed_march(folder: Path) -> dict:
    """The block's march, then killed and resumed on as many ranks."""
    prob = transient_block(parallel.distribute_mesh(small_block))
    whole = march(prob, MARCH_END, **MARCH)
    results = {"march": march_summary(prob, whole)}
    whole_state = prob.save_state()
    seen = []

    def stop(problem, record) -> None:
        seen.append(record.time)
        if len(seen) == MARCH_KILL_AT:
            raise Killed

    prob = transient_block(parallel.distribute_mesh(small_block))
    with pytest.raises(Killed):
        march(prob, MARCH_END, on_step=stop, checkpoint_file=folder / "march.pkl",
              checkpoint_data=lambda: list(seen), **MARCH)
    checkpoint = MarchCheckpoint.load(folder / "march.pkl")
    prob = transient_block(parallel.distribute_mesh(small_block))  # as a new run would: nothing but the file
    try:
        march(prob, MARCH_END, resume=dataclasses.replace(checkpoint, ranks=1), **MARCH)
        refused = ""
    except ValueError as err:
        refused = str(err)
    resumed = march(prob, MARCH_END, resume=checkpoint, **MARCH)
    gap = np.max(np.abs(prob.save_state() - whole_state), initial=0.0)
    results["resumed march"] = {"checkpoint ranks": checkpoint.ranks, "checkpoint steps": len(checkpoint.records),
                                "checkpoint data": checkpoint.data, "serial checkpoint refused": refused,
                                "same records": bool(same_records(resumed.records, whole.records)),
                                "state gap": prob.mesh.comm.Max(float(gap))}
    return results


def path_summary(result) -> dict:
    return {"parameters": [p.parameter for p in result.points], "negative": [p.negative for p in result.points],
            "steps": [p.step for p in result.points], "stop": result.stop_reason,
            "events": [[e.kind, e.parameter, e.negative_before, e.negative_after] for e in result.events]}


def distributed_paths(folder: Path) -> dict:
    """The column's path in ``folder`` (history, VTK, progress), then killed and resumed."""
    run = RunDirectory(folder, params={"case": "column"})
    prob, shortening = column_problem(parallel.distribute_mesh(column), "masterinverse")
    vtk = VTKSeries(prob.mesh, {"displacement": prob.displacement}, run.series("column"))
    with History(run.file("whole.csv")) as history:
        whole = follow_path(prob, shortening, history=history, vtk=vtk, progress=Progress("column"), **PATH)
    results = {"path": {**path_summary(whole), **vertex_values(prob)}}
    try:
        follow_path(prob, shortening, method="arclength", step=PATH["step"], stability=StabilityOptions())
        results["arclength refused"] = ""
    except NotImplementedError as err:
        results["arclength refused"] = str(err)
    prob, shortening = column_problem(parallel.distribute_mesh(column), "masterinverse")
    with pytest.raises(Killed), KilledHistory(run.file("part.csv"), KILL_AT) as history:
        follow_path(prob, shortening, history=history, checkpoint_file=run.file("part.npz"), **PATH)
    checkpoint = Checkpoint.load(run.file("part.npz"))
    prob, shortening = column_problem(parallel.distribute_mesh(column), "masterinverse")
    with History(run.file("part.csv")) as history:
        resumed = follow_path(prob, shortening, history=history, resume=checkpoint, **PATH)
    gap = np.max(np.abs(prob.save_state() - whole.checkpoint.state), initial=0.0)
    results["resumed"] = {**path_summary(resumed), "checkpoint points": len(checkpoint.points),
                          "checkpoint ranks": checkpoint.ranks, "state gap": prob.mesh.comm.Max(float(gap)),
                          "state scale": prob.mesh.comm.Max(float(np.max(np.abs(whole.checkpoint.state), initial=0.0)))}
    return results


def distributed_run() -> None:
    """Under mpiexec: the problems on distributed meshes; rank 0 prints the results, with the
    vertices of all ranks."""
    ngs.SetNumThreads(1)
    comm = parallel.world()
    results = {f"swell-{inverse}": swell(parallel.distribute_mesh(swelling_block), inverse)[1]
               for inverse in ("bddc", "masterinverse")}
    # BDDC-CG through the bifurcation: an indefinite tangent at the second state
    results["compress"] = compress(parallel.distribute_mesh(column), "bddc", parallel.negative_count)[1]
    results["ramp"] = ramp_block(parallel.distribute_mesh(swelling_block), "masterinverse")[1]
    # paced chord steps decide from measured times: each rank's own would differ, so they use the
    # slowest rank's, and every rank must take the same sequence of chord and full steps
    results["ramp-paced"] = ramp_block(parallel.distribute_mesh(swelling_block), "masterinverse", PACED)[1]
    results["ramp-paced"]["kinds"] = comm.gather(results["ramp-paced"]["kinds"], root=0)
    results.update(distributed_paths(Path(sys.argv[1])))
    results.update(distributed_march(Path(sys.argv[1])))
    elements = comm.gather(parallel.distribute_mesh(swelling_block).ne, root=0)
    try:
        transient_block(parallel.distribute_mesh(swelling_block), "umfpack").form
        refused = ""
    except ValueError as err:
        refused = str(err)
    for result in (results[key] for key in ("swell-bddc", "swell-masterinverse", "compress", "ramp", "ramp-paced",
                                            "path", "march")):
        for key in ("points", "values", "mu"):
            if key not in result:
                continue
            parts = comm.gather(result[key], root=0)
            result[key] = [row for part in parts for row in part] if comm.rank == 0 else None
    if comm.rank == 0:
        print(MARKER + json.dumps({**results, "serial inverse refused": refused, "elements": elements}), flush=True)


def _mpiexec() -> str | None:
    here = os.path.dirname(sys.executable)  # the mpich wheel installs mpiexec beside python
    return shutil.which("mpiexec", path=here) or shutil.which("mpiexec")


MISSING = ("mpi4py is not installed" if importlib.util.find_spec("mpi4py") is None
           else "mpiexec is not installed" if _mpiexec() is None else None)
needs_mpi = pytest.mark.skipif(MISSING is not None, reason=f"{MISSING}: pip install ngsgel[mpi] runs this test")


@pytest.fixture(scope="module")
def distributed(tmp_path_factory) -> dict:
    # MPICH's waits spin by default; on a machine with fewer free cores than ranks a spinning rank
    # holds the core its partner needs (a 441-dof solve: 2.8 s spinning, 0.8 s yielding)
    env = {**os.environ, "MPIR_CVAR_ENABLE_HEAVY_YIELD": "1"}
    folder = tmp_path_factory.mktemp("mpi_run")
    run = subprocess.run([_mpiexec(), "-n", "3", sys.executable, __file__, str(folder)], capture_output=True,
                         text=True, timeout=300, env=env,
                         cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert run.returncode == 0, run.stdout[-3000:] + run.stderr[-3000:]
    (line,) = [line for line in run.stdout.splitlines() if line.startswith(MARKER)]
    return {**json.loads(line[len(MARKER):]), "folder": folder, "stderr": run.stderr}


def assert_same_displacement(serial: EquilibriumProblem, result: dict) -> None:
    """The distributed displacement at every vertex equals the serial one to 1e-8 of its largest entry."""
    points, values = np.array(result["points"]), np.array(result["values"])
    assert {tuple(np.round(p, 12)) for p in points} == {tuple(np.round(v.point, 12)) for v in serial.mesh.vertices}
    expected = np.array([serial.displacement(serial.mesh(*p)) for p in points])
    scale = np.max(np.abs(expected))
    assert scale > 0
    assert np.max(np.abs(values - expected)) <= 1e-8 * scale


@needs_mpi
@pytest.mark.parametrize("inverse", ["bddc", "masterinverse"])
def test_swelling_block_equals_serial(distributed, inverse):
    result = distributed[f"swell-{inverse}"]
    prob, serial = swell(swelling_block(), "sparsecholesky")
    assert result["energy"] == pytest.approx(serial["energy"], rel=1e-8)
    if inverse == "masterinverse":  # exact steps: the same Newton path (BDDC's are solved to 1e-10)
        assert result["iterations"] == serial["iterations"]
    assert_same_displacement(prob, result)


@needs_mpi
def test_compressed_column_counts_as_serial(distributed):
    result = distributed["compress"]
    prob, serial = compress(column(), "sparsecholesky", serial_count)
    assert serial["negative"] == [0, 2]  # before and past the first (double) Euler load
    assert result["negative"] == serial["negative"]
    assert result["energy"] == pytest.approx(serial["energy"], rel=1e-8)
    assert_same_displacement(prob, result)


@needs_mpi
def test_two_compute_ranks_hold_the_elements(distributed):
    zero, *compute = distributed["elements"]
    assert zero == 0 and len(compute) == 2 and min(compute) > 0
    assert sum(compute) == swelling_block().ne


@needs_mpi
def test_what_does_not_run_distributed_says_so(distributed):
    assert "inverse on a distributed mesh must be one of" in distributed["serial inverse refused"]
    assert "follow_path runs method='natural'" in distributed["arclength refused"]


def test_bddc_solver_matches_the_direct_solve():
    # BDDC needs no MPI: the distributed solver on a serial mesh, at a swollen bonded block
    prob, _ = swell(swelling_block(), "sparsecholesky")
    freedofs = prob.space.FreeDofs()
    solver = parallel.DistributedSolver(prob.form, freedofs, inverse="bddc")  # before the next assembly
    K = prob.tangent(prob.state)
    rhs = prob.state.CreateVector()
    rhs.FV().NumPy()[:] = np.random.default_rng(0).standard_normal(len(rhs))
    direct = (K.Inverse(freedofs, inverse="sparsecholesky") * rhs).Evaluate().FV().NumPy()

    def solve(inv) -> np.ndarray:
        out = prob.state.CreateVector()
        out.data = inv * rhs
        return out.FV().NumPy().copy()

    # CG to 1e-10 of the preconditioned residual; BDDC's condition number here is about 180
    inv = solver.factor(K)
    assert np.linalg.norm(solve(inv) - direct) <= 180 * 1e-10 * np.linalg.norm(direct)
    assert inv.fallbacks == 0 and len(solver.krylov_iterations) == 1
    inv = solver.factor(K)
    inv.solvers[0].maxiter = 1  # CG cannot finish: GMRES takes over from scratch
    assert np.linalg.norm(solve(inv) - direct) <= 180 * 1e-10 * np.linalg.norm(direct)
    assert inv.fallbacks == 1 and solver.krylov_iterations[-1] > 1
    inv = solver.factor(K)
    for krylov in inv.solvers:
        krylov.maxiter = 1
    with pytest.raises(parallel.KrylovError, match="masterinverse"):
        solve(inv)


def test_unknown_distributed_inverse_is_refused():
    prob, _ = swell(swelling_block(), "sparsecholesky")
    with pytest.raises(ValueError, match="inverse on a distributed mesh must be one of"):
        parallel.DistributedSolver(prob.form, prob.space.FreeDofs(), inverse="sparsecholesky")


def test_missing_mpi_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "mpi4py", None)  # import mpi4py raises ImportError
    with pytest.raises(parallel.MPIUnavailable, match=r"pip install ngsgel\[mpi\]"):
        parallel.world()


@needs_mpi
def test_ramp_equals_serial(distributed):
    result = distributed["ramp"]
    prob, serial = ramp_block(swelling_block(), "sparsecholesky")
    assert len(serial["parameters"]) == 3 and serial["parameters"][-1] == RAMP["target"]  # grown, then shortened
    assert result["parameters"] == serial["parameters"]
    assert result["iterations"] == serial["iterations"]  # exact solves, the same predictors
    assert result["energy"] == pytest.approx(serial["energy"], rel=1e-8)
    assert_same_displacement(prob, result)


@needs_mpi
def test_paced_chord_steps_decide_alike_on_every_rank(distributed):
    result = distributed["ramp-paced"]
    kinds = result["kinds"]
    assert len(kinds) == 3 and kinds[1] == kinds[2] == kinds[0]  # rank 0 holds no elements, takes part
    assert "chord" in kinds[0] and "newton" in kinds[0]
    prob, serial = ramp_block(swelling_block(), "sparsecholesky")
    assert result["parameters"] == serial["parameters"]
    assert result["energy"] == pytest.approx(serial["energy"], rel=1e-8)
    assert_same_displacement(prob, result)


@pytest.fixture(scope="module")
def serial_path():
    prob, shortening = column_problem(column(), "sparsecholesky")
    lines = io.StringIO()
    result = follow_path(prob, shortening, progress=Progress("column", stream=lines, quiet=False), **PATH)
    return prob, result, lines.getvalue().splitlines()


@needs_mpi
def test_path_locates_the_bifurcation_as_serially(distributed, serial_path):
    prob, whole, _ = serial_path
    result, serial = distributed["path"], path_summary(whole)
    assert serial["negative"] == [0, 0, 2, 2] and [e[0] for e in serial["events"]] == ["bifurcation"]
    assert result["negative"] == serial["negative"] and result["steps"] == serial["steps"]
    assert [e[0::2] for e in result["events"]] == [e[0::2] for e in serial["events"]]  # kind, counts
    assert [e[3] for e in result["events"]] == [e[3] for e in serial["events"]]
    assert result["events"][0][1] == pytest.approx(serial["events"][0][1], abs=1e-6)
    assert result["parameters"] == pytest.approx(serial["parameters"], abs=1e-6)
    assert_same_displacement(prob, result)


@needs_mpi
def test_path_output_is_written_once(distributed, serial_path):
    folder, rows = distributed["folder"], distributed["path"]
    with open(folder / "whole.csv") as f:
        written = list(csv.DictReader(f))
    assert [int(r["negative"]) for r in written] == rows["negative"]
    assert [float(r["parameter"]) for r in written] == rows["parameters"]
    assert json.loads((folder / "params.json").read_text()) == {"case": "column"}
    # progress: the serial run's lines, once (rank 0), not once per rank
    progress = [line for line in distributed["stderr"].splitlines() if line.startswith("[column")]
    assert len(progress) == len(serial_path[2]) == len(rows["parameters"])
    # VTK: a piece per compute rank and write (every point), one index over all of them
    pieces = sorted(p.name for p in folder.glob("column*.vtu"))
    assert pieces == sorted([f"column_proc{rank}.vtu" for rank in (1, 2)]
                            + [f"column_proc{rank}_step{k:05d}.vtu" for rank in (1, 2) for k in range(1, 4)])
    assert (folder / "column.pvd").read_text().count("<DataSet") == len(pieces)


@needs_mpi
def test_killed_path_resumes_on_the_same_ranks(distributed):
    whole, resumed = distributed["path"], distributed["resumed"]
    assert resumed["checkpoint ranks"] == 3 and resumed["checkpoint points"] == KILL_AT - 1
    assert resumed["stop"] == whole["stop"] == "target"
    assert resumed["events"] == whole["events"] and resumed["negative"] == whole["negative"]
    assert resumed["parameters"] == pytest.approx(whole["parameters"], rel=1e-14, abs=0)
    assert resumed["state gap"] <= 1e-10 * resumed["state scale"]  # the tangent predictor: to Newton's tolerance
    with open(distributed["folder"] / "part.csv") as part, open(distributed["folder"] / "whole.csv") as f:
        assert len(list(csv.DictReader(part))) == len(list(csv.DictReader(f)))
    with pytest.raises(ValueError, match="written by 3 MPI processes, this run has 1"):
        Checkpoint.load(distributed["folder"] / "part.npz")


@pytest.fixture(scope="module")
def serial_march():
    prob = transient_block(small_block())
    return prob, march(prob, MARCH_END, **MARCH)


def step_records(rows) -> list[StepRecord]:
    return [StepRecord(*row) for row in rows]


@needs_mpi
def test_march_equals_serial(distributed, serial_march):
    prob, serial = serial_march
    result = distributed["march"]
    records = step_records(result["records"])
    assert sum(r.order == 2 for r in serial.records) >= 3  # BDF2 steps, under error control
    assert [r.order for r in records] == [r.order for r in serial.records]  # as many steps, the same schemes
    assert [r.iterations for r in records] == [r.iterations for r in serial.records]  # exact solves
    for name in ("time", "dt", "content", "uptake", "exchanged"):
        assert [getattr(r, name) for r in records] == pytest.approx(serial.column(name).tolist(), rel=1e-8), name
    assert result["initial content"] == pytest.approx(prob.initial_content, rel=1e-8)
    assert_same_displacement(prob, result)
    points, mu = np.array(result["points"]), np.array(result["mu"])
    expected = np.array([prob.chemical_potential(prob.mesh(*p)) for p in points])
    assert np.max(np.abs(mu - expected)) <= 1e-8 * np.max(np.abs(expected))
    assert np.max(np.abs(expected - MU0)) > 0.1 * abs(WETTED_MU - MU0)  # the solvent has moved in


@needs_mpi
def test_distributed_march_balances_the_solvent(distributed):
    result = distributed["march"]
    assert_balanced(types.SimpleNamespace(initial_content=result["initial content"]),
                    TransientResult(completed=True, records=step_records(result["records"])))


@needs_mpi
def test_killed_march_resumes_on_the_same_ranks(distributed):
    resumed, folder = distributed["resumed march"], distributed["folder"]
    whole = step_records(distributed["march"]["records"])
    assert whole[MARCH_KILL_AT - 1].order == 2  # killed after a BDF2 step
    assert resumed["checkpoint ranks"] == 3 and resumed["checkpoint steps"] == MARCH_KILL_AT - 1
    assert resumed["checkpoint data"] == [r.time for r in whole[:MARCH_KILL_AT - 1]]  # the caller's, after step 7
    assert "written by 1 MPI process(es), this problem runs on 3" in resumed["serial checkpoint refused"]
    assert resumed["same records"]  # every step, its length, iterations, balance and error estimate
    assert resumed["state gap"] == 0.0
    assert sorted(p.name for p in folder.glob("march*")) == ["march.pkl"]  # one file, by rank 0
    with pytest.raises(ValueError, match="written by 3 MPI processes, this run has 1"):
        MarchCheckpoint.load(folder / "march.pkl")


def test_transient_bddc_is_refused():
    with pytest.raises(NotImplementedError, match="inverse='bddc' does not serve transient problems"):
        transient_block(small_block(), "bddc")


if __name__ == "__main__":
    try:
        distributed_run()
    except BaseException:
        # a rank that fails alone leaves the others waiting in a collective call: end them all
        import traceback

        traceback.print_exc()
        sys.stderr.flush()
        parallel.world().Abort(1)
