"""Progress lines: percent done and time left on a fake clock, quiet runs, and what the drivers
(follow_path, ramp, march) report."""

import io

import ngsolve as ngs
import pytest
from ngsolve.meshes import MakeStructured2DMesh

from ngsgel import EquilibriumProblem, FloryRehnerGel, NeoHookeanFilm, PlaneStrain
from ngsgel.continuation import follow_path
from ngsgel.output import Progress, report_progress, silence_progress
from ngsgel.scenes import buckling_demo
from ngsgel.stepping import ramp
from ngsgel.transient import TransientProblem, march


class FakeClock:
    def __init__(self):
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


class Recorder(Progress):
    """A ``Progress`` that keeps what the drivers hand it instead of printing."""

    def __init__(self):
        super().__init__("recorder", quiet=True)
        self.reports: list[tuple[str, float | None]] = []

    def __call__(self, message, *, fraction=None):
        self.reports.append((message, fraction))


def lines_at(progress: Progress, clock: FakeClock, stream: io.StringIO, reports) -> list[str]:
    for now, message, fraction in reports:
        clock.now = now
        progress(message, fraction=fraction)
    return stream.getvalue().splitlines()


def test_percent_done_and_time_left_from_the_recent_rate():
    clock, stream = FakeClock(), io.StringIO()
    progress = Progress("run", stream=stream, clock=clock, window=2)
    lines = lines_at(progress, clock, stream, [
        (5.0, "setting up", None),
        (10.0, "start", 0.0),
        (20.0, "a", 0.25),  # 10 s for a quarter: 30 s left
        (30.0, "b", 0.5),  # 20 s for half: 20 s left
        (40.0, "c", 0.6),  # the last 2 reports: 20 s for 0.35, 0.4 left: 22.9 s
        (50.0, "d", 0.6),  # nothing since the last report; since (30 s, 0.5): 0.1 in 20 s, 80 s left
        (3700.0, "e", 0.9),  # since (40 s, 0.6): 0.3 in 3660 s, 0.1 left: 1220 s
        (9000.0, "f", 1.0),
    ])
    assert lines == [
        "[run     5.0s] setting up",
        "[run    10.0s]   0% start",
        "[run    20.0s]  25% (about 30s left) a",
        "[run    30.0s]  50% (about 20s left) b",
        "[run    40.0s]  60% (about 23s left) c",
        "[run    50.0s]  60% (about 1m20s left) d",
        "[run  3700.0s]  90% (about 20m20s left) e",
        "[run  9000.0s] 100% f",
    ]


def test_time_left_in_hours_and_a_new_count_when_the_fraction_falls():
    clock, stream = FakeClock(), io.StringIO()
    progress = Progress("run", stream=stream, clock=clock)
    lines = lines_at(progress, clock, stream, [
        (0.0, "first path", 0.0),
        (3600.0, "", 0.3),  # 0.7 left at 0.3 per hour: 2 h 20 min
        (3601.0, "second path", 0.0),  # a new run: its rate counts from here
        (3611.0, "", 0.5),
        (3612.0, "", 0.29),  # 0.29 * 100 = 28.999999999999996 is still 29 %
    ])
    assert lines[1] == "[run  3600.0s]  30% (about 2h20m left) "
    assert lines[2] == "[run  3601.0s]   0% second path"
    assert lines[3] == "[run  3611.0s]  50% (about 10s left) "
    assert lines[4] == "[run  3612.0s]  29% "
    with pytest.raises(ValueError, match="fraction"):
        progress("", fraction=1.5)
    with pytest.raises(ValueError, match="fraction"):
        progress("", fraction=float("nan"))


def test_quiet_progress_prints_nothing_and_silence_progress_sets_the_default(capsys):
    stream = io.StringIO()
    Progress("run", stream=stream, quiet=True)("message", fraction=0.5)
    assert stream.getvalue() == ""
    with silence_progress():
        Progress("run")("silenced")
        Progress("run", quiet=False)("explicitly loud")
        with silence_progress(False):
            Progress("run")("loud again inside")
    Progress("run")("loud after the block")
    err = capsys.readouterr().err
    assert "silenced" not in err
    assert "explicitly loud" in err and "loud again inside" in err and "loud after the block" in err
    with pytest.raises(RuntimeError), silence_progress():  # the block ends with an exception too
        raise RuntimeError
    Progress("run")("loud after a failed block")
    assert "loud after a failed block" in capsys.readouterr().err


def test_report_progress_gives_the_fraction_only_to_a_progress():
    messages = []
    report_progress(messages.append, "step 1", fraction=0.5)
    report_progress(None, "nobody listens", fraction=0.5)
    recorder = Recorder()
    report_progress(recorder, "step 1", fraction=0.5)
    assert messages == ["step 1"]
    assert recorder.reports == [("step 1", 0.5)]


def column(ny=8):
    """Plane-strain column clamped at the bottom, its top shortened by ``load`` (as in
    test_continuation.py): a tiny problem whose path needs several steps."""
    mesh = MakeStructured2DMesh(quads=True, nx=2, ny=ny, mapping=lambda x, y: (x - 0.5, y * 20.0))
    load = ngs.Parameter(0.0)
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=NeoHookeanFilm(E=1.0, nu=0.3), lam0=2.0,
                              order=2, inverse="umfpack")
    prob.fix("bottom")
    prob.prescribe("top", "y", -load * 0.005)
    return prob, load


def test_follow_path_reports_the_share_of_the_way_to_its_target():
    prob, load = column()
    recorder = Recorder()
    result = follow_path(prob, load, method="natural", step=0.2, max_step=0.2, target=0.8, progress=recorder)
    fractions = [f for _, f in recorder.reports]
    assert len(fractions) == len(result.points) == 5
    assert fractions == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert recorder.reports[2][0].startswith("step 2: parameter 0.4, iterations ")

    # arclength across the snap of an arch: the load falls past the first limit point, the share
    # reached does not; a plain callable gets the same lines, without the fraction
    def arch():
        return buckling_demo.arch_problem(rise=0.055, thickness=0.03, elements=8, order=2, load_scale=1e-4)[:2]

    lines = []
    follow_path(*arch(), step=0.01, max_step=0.02, target=0.05, progress=lines.append)
    recorder = Recorder()
    result = follow_path(*arch(), step=0.01, max_step=0.02, target=0.05, progress=recorder)
    assert result.stop_reason == "target"
    assert [m for m, _ in recorder.reports] == lines and len(lines) == len(result.points)
    parameters = result.column("parameter")
    assert any(b < a for a, b in zip(parameters, parameters[1:]))  # the path turned back
    fractions = [f for _, f in recorder.reports]
    assert fractions[0] == 0.0 and fractions[-1] == 1.0
    assert all(b >= a for a, b in zip(fractions, fractions[1:]))
    assert fractions == pytest.approx([max(parameters[: i + 1]) / 0.05 for i in range(len(parameters))])


def test_ramp_and_march_report_their_fraction_done():
    prob, load = column()
    recorder = Recorder()
    result = ramp(prob, load, 0.8, step=0.2, max_step=0.2, progress=recorder)
    assert result.converged
    assert [f for _, f in recorder.reports] == pytest.approx([0.0, 0.25, 0.5, 0.75, 1.0])
    assert recorder.reports[0][0] == "start: parameter 0, target 0.8"

    gel = FloryRehnerGel(Nv=1e-2, chi=0.5)
    mesh = MakeStructured2DMesh(nx=1, ny=4, mapping=lambda x, y: (0.1 * x, y))
    layer = TransientProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=gel.lam_free(-0.5), mu0=-0.5)
    layer.fix("bottom")
    layer.fix("left|right", "x")
    layer.immerse("top", -0.4)
    recorder = Recorder()
    result = march(layer, 0.5, dt_start=0.01, progress=recorder)
    fractions = [f for _, f in recorder.reports]
    assert len(fractions) == result.steps + 1
    assert fractions == pytest.approx([0.0] + [r.time / 0.5 for r in result.records])
    assert all(b > a for a, b in zip(fractions, fractions[1:])) and fractions[-1] == 1.0
