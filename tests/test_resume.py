"""Resumable runs: a path stopped at any point goes on from its checkpoint to the end an
uninterrupted run reaches (``follow_path(resume=...)``, the scenes' ``--resume DIR``)."""

import csv
import dataclasses
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time

import numpy as np
import ngsolve as ngs
import pytest
from ngsolve.meshes import Make1DMesh, MakeStructured2DMesh

from ngsgel import EquilibriumProblem, FloryRehnerGel, NeoHookeanFilm, PlaneStrain, SphericalSymmetric
from ngsgel.continuation import Checkpoint, ContinuationError, StabilityOptions, follow_path
from ngsgel.output import History
from ngsgel.scenes import creases, gears, graded_plate_shell, microlens
from ngsgel.transient import MarchCheckpoint, TransientProblem, march

from killed_runs import Killed, KilledHistory

# With threads the assembly's and the solvers' sums come in a varying order: two runs of the
# quick microlens differ by up to 5e-9 relative (in eigenvalues next to zero). One thread makes
# a path reproducible bit for bit, so a resumed path must then equal the uninterrupted one exactly.
ONE_THREAD = {"NGS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


@pytest.fixture
def one_thread():
    threads = ngs.GetNumThreads()
    ngs.SetNumThreads(1)
    yield
    ngs.SetNumThreads(threads)


def column(control: str):
    """Plane-strain column 1 x 20 clamped at the bottom: a dead compressive load on its top in
    units of the Euler load (``force``; it buckles at ~1.002), or the top shortened (``displacement``)."""
    length = 20.0
    mesh = MakeStructured2DMesh(quads=True, nx=2, ny=20, mapping=lambda x, y: (x - 0.5, y * length))
    load = ngs.Parameter(0.0)
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=NeoHookeanFilm(E=1.0, nu=0.3), lam0=2.0,
                              order=3, inverse="umfpack")
    prob.fix("bottom")
    sigma_cr = math.pi**2 / (1 - 0.3**2) / (48 * length**2)
    if control == "force":
        prob.add_traction("top", ngs.CF((0, -load * sigma_cr)))
    else:
        prob.prescribe("top", "y", -load * 4 * sigma_cr * length * (1 - 0.3**2))
    top = mesh(0.0, length)
    return prob, load, {"tip": lambda: prob.displacement(top)[0]}


def test_a_resumed_arclength_path_is_the_uninterrupted_one(tmp_path, one_thread):
    # the column buckles, the driver locates the bifurcation and switches; the run is stopped
    # three rows after the switch, between a row and its checkpoint
    options = dict(step=0.3, max_step=20.0, target=1.2, max_steps=40,
                   stability=StabilityOptions(eigenvalues=2, tol=1e-6, switch=True, amplitude=0.05, length=1.0),
                   stop=lambda point: abs(point.qoi["tip"]) > 1.0)
    prob, load, qoi = column("force")
    with History(tmp_path / "whole.csv") as history:
        whole = follow_path(prob, load, qoi=qoi, history=history, **options)
    assert [e.kind for e in whole.events] == ["bifurcation", "branch switch"]
    kill_at = next(i for i, p in enumerate(whole.points) if "branch switch" in p.events) + 4
    assert kill_at < len(whole.points)
    prob, load, qoi = column("force")
    with pytest.raises(Killed), KilledHistory(tmp_path / "part.csv", kill_at) as history:
        follow_path(prob, load, qoi=qoi, history=history, checkpoint_file=tmp_path / "part.npz", **options)
    checkpoint = Checkpoint.load(tmp_path / "part.npz")
    assert len(checkpoint.points) == kill_at - 1 and not checkpoint.stop_reason
    assert isinstance(checkpoint.events[0].mode, np.ndarray)  # a dof vector in the file

    prob, load, qoi = column("force")  # as a new process would: nothing but the file
    with History(tmp_path / "part.csv") as history:
        resumed = follow_path(prob, load, qoi=qoi, history=history, checkpoint_file=tmp_path / "part.npz",
                              resume=checkpoint, **options)
    assert (tmp_path / "part.csv").read_bytes() == (tmp_path / "whole.csv").read_bytes()
    assert resumed.stop_reason == whole.stop_reason == "criterion"
    assert np.array_equal(prob.save_state(), whole.checkpoint.state)
    assert [(e.kind, e.step, e.parameter, e.eigenvalue) for e in resumed.events] == \
        [(e.kind, e.step, e.parameter, e.eigenvalue) for e in whole.events]
    # the bifurcation's critical mode (found before the stop) is a GridFunction again
    assert np.array_equal(resumed.events[0].mode.vec.FV().NumPy(), whole.events[0].mode.vec.FV().NumPy())

    # the ended path's checkpoint, resumed, gives the path as it ended and its end state
    prob, load, qoi = column("force")
    again = follow_path(prob, load, qoi=qoi, resume=Checkpoint.load(tmp_path / "part.npz"), **options)
    assert again.stop_reason == "criterion" and len(again.points) == len(whole.points)
    assert np.array_equal(prob.save_state(), whole.checkpoint.state) and load.Get() == whole.points[-1].parameter
    with pytest.raises(ValueError, match="not both"):
        follow_path(prob, load, qoi=qoi, restart=checkpoint, resume=checkpoint, **options)


def test_a_resumed_natural_path_takes_the_same_steps(tmp_path, one_thread):
    # natural steps: the resumed ramp starts from the tangent predictor, not the secant of the
    # last two states, so the states agree to the solver's tolerance, the step sizes to round-off
    options = dict(method="natural", step=0.1, max_step=0.4, target=2.0)
    prob, load, qoi = column("displacement")
    whole = follow_path(prob, load, qoi=qoi, **options)
    assert len(whole.points) >= 6
    prob, load, qoi = column("displacement")
    with pytest.raises(Killed), KilledHistory(tmp_path / "part.csv", 4) as history:
        follow_path(prob, load, qoi=qoi, history=history, checkpoint_file=tmp_path / "part.npz", **options)
    prob, load, qoi = column("displacement")
    resumed = follow_path(prob, load, qoi=qoi, resume=Checkpoint.load(tmp_path / "part.npz"), **options)
    assert [p.step for p in resumed.points] == [p.step for p in whole.points]
    assert np.allclose([p.parameter for p in resumed.points], [p.parameter for p in whole.points], rtol=1e-14, atol=0)
    scale = np.max(np.abs(whole.checkpoint.state))
    # measured: 7e-14 of the largest displacement
    assert np.max(np.abs(prob.save_state() - whole.checkpoint.state)) < 1e-10 * scale


def test_a_stalled_path_resumed_stalls_as_it_did(tmp_path):
    # Newton allowed one iteration: the first step fails down to min_step; the checkpoint says so
    options = dict(method="natural", step=0.2, min_step=0.15, target=0.8, newton_options={"maxit": 1})
    prob, load, qoi = column("displacement")
    with pytest.raises(ContinuationError) as stalled:
        follow_path(prob, load, qoi=qoi, checkpoint_file=tmp_path / "path.npz", **options)
    checkpoint = Checkpoint.load(tmp_path / "path.npz")
    assert checkpoint.stop_reason == "min_step" and checkpoint.message == str(stalled.value)
    prob, load, qoi = column("displacement")
    with pytest.raises(ContinuationError) as again:
        follow_path(prob, load, qoi=qoi, resume=checkpoint, **options)
    assert str(again.value) == str(stalled.value) and len(again.value.result.points) == 1


def swelling_sphere():
    """A ball (spherically symmetric line, 16 cells) immersed at once: mu -1 -> 0."""
    gel = FloryRehnerGel(Nv=1e-2, chi=0.5)
    prob = TransientProblem(Make1DMesh(16), kinematics=SphericalSymmetric(), materials=gel, lam0=gel.lam_free(-1.0),
                            mu0=-1.0)
    prob.fix("left")
    prob.immerse("right", 0.0)
    return prob


@pytest.mark.parametrize("scheme", ["bdf2", "backward_euler"])
def test_a_resumed_march_takes_the_same_steps_to_the_same_states(tmp_path, one_thread, scheme):
    # error control (the default): the resumed march needs the step size it would take next and
    # the last states behind its predictor and error estimate; killed in on_step three steps past
    # the first output (BDF2 runs, the step after an output grows again), after a row and before its checkpoint, as a kill between the two
    options = dict(output_times=[0.1, 1.0], scheme=scheme)
    prob = swelling_sphere()
    whole = march(prob, 3.0, **options)
    kill_at = next(i for i, r in enumerate(whole.records) if r.time > 0.1) + 3
    assert kill_at < whole.steps - 5
    seen = []

    def record(p, r):
        seen.append(r.time)
        if len(seen) == kill_at:
            raise Killed

    prob = swelling_sphere()
    with pytest.raises(Killed):
        march(prob, 3.0, on_step=record, checkpoint_file=tmp_path / "march.pkl",
              checkpoint_data=lambda: list(seen), **options)
    checkpoint = MarchCheckpoint.load(tmp_path / "march.pkl")
    assert len(checkpoint.records) == kill_at - 1 and checkpoint.data == seen[:-1]

    prob = swelling_sphere()  # as a new process would: nothing but the file
    with pytest.raises(ValueError, match="t_end"):
        march(prob, 2.0, resume=checkpoint, **options)
    resumed = march(prob, 3.0, resume=checkpoint, **options)
    assert same_records(resumed.records, whole.records)  # every step, its length, iterations and balance
    assert np.array_equal(prob.save_state(), whole_state(whole, options))


def same_records(first, second) -> bool:
    """Equal step records (a step without an error estimate has NaN there, in both)."""
    as_array = lambda records: np.array([dataclasses.astuple(r) for r in records], dtype=float)
    return len(first) == len(second) and np.array_equal(as_array(first), as_array(second), equal_nan=True)


def whole_state(whole, options) -> np.ndarray:
    prob = swelling_sphere()
    again = march(prob, 3.0, **options)
    assert same_records(again.records, whole.records)  # one thread: a march repeats bit for bit
    return prob.save_state()


def scene(name: str, *args: str) -> list[str]:
    return [sys.executable, "-m", f"ngsgel.scenes.{name}", "--quiet", *args]


def rows(folder) -> int:
    return len((folder / "path.csv").read_text().splitlines()) - 1


def kill_when(command: list[str], folder, ready, env: dict) -> int:
    """Start ``command`` and SIGKILL it once ``ready()``; the rows of ``folder/path.csv`` then.
    Fails if the run ended by itself."""
    log = folder.parent / f"{folder.name}.log"
    with open(log, "w") as stderr:
        process = subprocess.Popen(command, env=env, stdout=subprocess.DEVNULL, stderr=stderr)
        while process.poll() is None:
            if ready():
                process.send_signal(signal.SIGKILL)
                break
            time.sleep(0.05)
        process.wait()
    assert process.returncode == -signal.SIGKILL, f"the run ended by itself (exit {process.returncode}): " \
                                                  f"{log.read_text()[-2000:]}"
    return rows(folder)


def assert_same_run(resumed, whole, files) -> None:
    """The same files bit for bit, and the same summary but for the wall time."""
    for name in files:
        assert (resumed / name).read_bytes() == (whole / name).read_bytes(), name
    summaries = [json.loads((folder / "summary.json").read_text()) for folder in (resumed, whole)]
    for summary in summaries:
        summary.pop("wall_s")
    assert summaries[0] == summaries[1]


def test_a_killed_microlens_run_resumed_ends_as_an_uninterrupted_one(tmp_path):
    # --quick: the axisymmetric cap H = 0.3 to d/H = 0.6, 28 steps (~25 s on one thread);
    # killed after 6 rows (the kill usually lands before the 6th step's checkpoint)
    env = {**os.environ, **ONE_THREAD}
    whole, part = tmp_path / "whole", tmp_path / "part"
    subprocess.run(scene("microlens", "--quick", "--out", str(whole)), env=env, check=True)
    six_rows = lambda: (part / "path.csv").exists() and rows(part) >= 6
    assert kill_when(scene("microlens", "--quick", "--out", str(part)), part, six_rows, env) < rows(whole)
    assert not (part / "summary.json").exists()

    with pytest.raises(ValueError, match="goes on with the run's own options"):
        microlens.main(["--resume", str(part), "--H", "0.2"])
    with pytest.raises(ValueError, match="a resumed run writes into its own folder"):
        microlens.main(["--resume", str(part), "--out", str(whole)])
    empty = tmp_path / "empty"
    shutil.copytree(part, empty)
    (empty / "checkpoint.npz").unlink()
    with pytest.raises(ValueError, match="no checkpoint"):
        microlens.main(["--resume", str(empty)])
    with pytest.raises(ValueError, match="no params.json there"):
        microlens.main(["--resume", str(tmp_path)])

    # an option given as the run had it is accepted
    subprocess.run(scene("microlens", "--resume", str(part), "--quick"), env=env, check=True)
    assert_same_run(part, whole, ("path.csv", "path.jsonl", "growth.csv"))
    with pytest.raises(ValueError, match="has finished"):
        microlens.main(["--resume", str(part)])


@pytest.mark.slow
def test_a_killed_graded_plate_shell_run_resumed_ends_as_an_uninterrupted_one(tmp_path):
    # --quick, one thread (the test took 345 s on the loaded 2-core machine: three runs of ~2 min):
    # the first leg switches onto the saddle, the second follows it; killed once the second has its
    # first checkpoint, so the resumed run takes up an ended leg and goes on with the next
    env = {**os.environ, **ONE_THREAD}
    whole, part = tmp_path / "whole", tmp_path / "part"
    subprocess.run(scene("graded_plate_shell", "--quick", "--out", str(whole)), env=env, check=True)
    # the first leg's checkpoint moves to checkpoint_leg0.npz as it ends; checkpoint.npz is the second's
    second_leg = lambda: (part / "checkpoint_leg0.npz").exists() and (part / "checkpoint.npz").exists()
    assert kill_when(scene("graded_plate_shell", "--quick", "--out", str(part)), part, second_leg, env) < rows(whole)
    assert not (part / "summary.json").exists()
    subprocess.run(scene("graded_plate_shell", "--resume", str(part)), env=env, check=True)
    assert_same_run(part, whole, ("path.csv", "path.jsonl", "events.json", "state_end.npz"))
    with pytest.raises(ValueError, match="has finished"):
        graded_plate_shell.main(["--resume", str(part)])


@pytest.mark.slow
def test_a_killed_creases_run_resumed_ends_as_an_uninterrupted_one(tmp_path, one_thread, monkeypatch):
    # the quick crease cell with top_h = 0.05 to t = 0.005 (~100 steps under error control, no
    # crease yet; two runs of ~10 s each on an idle machine, hence slow: the library's march
    # resume is tested above), killed after a row and before its checkpoint, in process (as a
    # kill would: the resumed run has nothing but the files)
    args = ["--quick", "--quiet", "--t-end", "0.005", "--top-h", "0.05"]
    whole, part = tmp_path / "whole", tmp_path / "part"
    creases.main(args + ["--out", str(whole)])
    steps = rows_of(whole / "history.csv")
    kill_at = steps // 2

    class KilledAt(KilledHistory):
        def __init__(self, path):
            super().__init__(path, kill_at)

    with monkeypatch.context() as patch:
        patch.setattr(creases, "History", KilledAt)
        with pytest.raises(Killed):
            creases.main(args + ["--out", str(part)])
    assert rows_of(part / "history.csv") == kill_at and not (part / "summary.json").exists()
    with pytest.raises(ValueError, match="goes on with the run's own options"):
        creases.main(["--resume", str(part), "--equilibrium"])
    creases.main(["--resume", str(part), "--quiet"])
    # the same steps and states: every column of the history but the wall-clock one
    histories = [[{k: v for k, v in row.items() if k != "wall"} for row in csv.DictReader(open(f / "history.csv"))]
                 for f in (part, whole)]
    assert len(histories[0]) == steps and histories[0] == histories[1]
    summaries = [json.loads((f / "summary.json").read_text()) for f in (part, whole)]
    for summary in summaries:
        summary.pop("wall_seconds")
    assert summaries[0] == summaries[1]
    with pytest.raises(ValueError, match="has finished"):
        creases.main(["--resume", str(part)])


def rows_of(history) -> int:
    return len(history.read_text().splitlines()) - 1


@pytest.mark.slow
def test_a_stopped_gears_sweep_resumed_ends_as_an_uninterrupted_one(tmp_path, one_thread, monkeypatch):
    # the onset on two coarse meshes (~10 s each); stopped after the first case's row
    args = ["--quiet", "--sweep", "convergence", "--resolutions", "64:2:0.5:1", "96:2:0.5:1"]
    whole, part = tmp_path / "whole", tmp_path / "part"
    gears.main(args + ["--out", str(whole)])
    add = gears.SweepTable.add

    def add_then_stop(table, row):
        add(table, row)
        raise Killed

    with monkeypatch.context() as patch:
        patch.setattr(gears.SweepTable, "add", add_then_stop)
        with pytest.raises(Killed):
            gears.main(args + ["--out", str(part)])
    assert rows_of(part / "convergence.csv") == 1
    with pytest.raises(ValueError, match="goes on with the run's own options"):
        gears.main(["--resume", str(part), "--resolutions", "48:2:0.5:1"])
    gears.main(["--resume", str(part), "--quiet"])
    tables = [json.loads((f / "convergence.json").read_text()) for f in (part, whole)]
    for table in tables:
        for row in table:
            row.pop("seconds"), row.pop("cpu_seconds")
    assert len(tables[0]) == 2 and tables[0] == tables[1]
    with pytest.raises(ValueError, match="has finished"):
        gears.main(["--resume", str(part)])
