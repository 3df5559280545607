"""Recorders: everything a run produces goes into one folder, written as it happens.

``RunDirectory`` makes the folder and writes the run's parameters; ``History`` appends one CSV row
per step (and mirrors it as JSON lines) and flushes, so a stopped run keeps what it computed;
``VTKSeries`` writes ParaView files of named fields with a ``.pvd`` index over time or load.
``Progress`` prints status lines (with percent done and time left where the driver knows them);
``report_progress`` is how the drivers call a user's ``progress``.
In an MPI run (``ngsgel.parallel``) rank 0 writes the folder, the histories and the progress
(``writing_process``); every rank keeps a history's rows and writes its own VTK piece.
``scene_parser`` gives every scene script the same ``--out``/``--quick``/``--quiet`` flags (and the
gel's and the bath's parameters for swelling scenes) and ``SceneHelpFormatter``'s help, which shows
every option's default; ``quick_run`` adds the CI environment to ``--quick``; ``silence_progress``
carries ``--quiet`` to the progress of the functions a scene calls.
"""

from __future__ import annotations

import argparse
import contextlib
import contextvars
import csv
import json
import math
import os
import sys
import time
from collections import deque
from collections.abc import Callable, Mapping
from pathlib import Path

import ngsolve as ngs

__all__ = ["RunDirectory", "History", "VTKSeries", "Progress", "report_progress", "silence_progress",
           "SceneHelpFormatter", "scene_parser", "quick_run", "command_options", "resume_arguments",
           "writing_process"]


def writing_process() -> bool:
    """Whether this process writes the run's files and progress: any process of a serial run,
    rank 0 of an MPI run (one that loaded mpi4py's MPI, as ``ngsgel.parallel`` does; every rank
    runs the same script, and one copy of each file and line is wanted)."""
    mpi = sys.modules.get("mpi4py.MPI")
    return mpi is None or mpi.COMM_WORLD.rank == 0


def _jsonable(value):
    if isinstance(value, float) and not math.isfinite(value):
        return str(value)
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if hasattr(value, "item"):  # numpy scalars
        return value.item()
    return value


class RunDirectory:
    """One output folder per run: ``params.json`` first, then whatever the run writes.

    ``resume``: the folder of a stopped run that goes on; its ``params.json`` stays, and must hold
    ``params`` (the run goes on as it started: a code change in between is refused)."""

    def __init__(self, path: str | Path, *, params: Mapping | None = None, resume: bool = False):
        self.path = Path(path)
        self.resume = resume
        if resume:
            stored = json.loads(self.file("params.json").read_text())
            now = json.loads(json.dumps(_jsonable(params or {}), default=str))
            differ = sorted(key for key in stored.keys() | now.keys() if stored.get(key) != now.get(key))
            if differ:
                raise ValueError(f"the run in {self.path} started with other parameters {differ} than it would now "
                                 f"({ {key: stored.get(key) for key in differ} } against "
                                 f"{ {key: now.get(key) for key in differ} }): it cannot be resumed")
            return
        if not writing_process():
            return
        self.path.mkdir(parents=True, exist_ok=True)
        if params is not None:
            self.write_json("params.json", params)

    def file(self, name: str) -> Path:
        return self.path / name

    def series(self, stem: str) -> Path:
        """Where a ``VTKSeries`` named ``stem`` goes: ``stem``, or in a resumed run ``stem_resumedN``
        (the first N not taken; NGSolve numbers a new series from 0, which would overwrite the
        files of the run's first part)."""
        if not self.resume:
            return self.file(stem)
        n = 1
        while self.file(f"{stem}_resumed{n}.pvd").exists() or self.file(f"{stem}_resumed{n}.vtu").exists():
            n += 1
        return self.file(f"{stem}_resumed{n}")

    def write_json(self, name: str, data) -> Path:
        """``data`` as ``name`` (by the writing process only, ``writing_process``)."""
        target = self.file(name)
        if writing_process():
            target.write_text(json.dumps(_jsonable(data), indent=2, default=str) + "\n")
        return target


class History:
    """Step-by-step table: ``append(row)`` writes a CSV line and a JSON line and flushes.

    The columns are fixed by the first row; later rows may leave some out (written empty) but
    may not add new ones, so the CSV stays rectangular. Only the writing process
    (``writing_process``) writes the files; every process keeps the ``rows``.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.rows: list[dict] = []
        self._columns: list[str] | None = None
        self._files = writing_process()
        if self._files:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._csv = open(self.path, "w", newline="")
            self._jsonl = open(self.path.with_suffix(".jsonl"), "w")
        self._writer = None

    def append(self, row: Mapping) -> None:
        row = {k: _jsonable(v) for k, v in row.items()}
        if self._columns is None:
            self._columns = list(row)
            if self._files:
                self._writer = csv.DictWriter(self._csv, fieldnames=self._columns)
                self._writer.writeheader()
        extra = set(row) - set(self._columns)
        if extra:
            raise ValueError(f"row has columns {sorted(extra)} not in the history's columns {self._columns}")
        if self._files:
            self._writer.writerow({k: (json.dumps(v) if isinstance(v, (list, dict)) else v) for k, v in row.items()})
            self._jsonl.write(json.dumps(row, default=str) + "\n")
            self._csv.flush()
            self._jsonl.flush()
        self.rows.append(row)

    def column(self, name: str) -> list:
        return [row.get(name) for row in self.rows]

    def close(self) -> None:
        if self._files:
            self._csv.close()
            self._jsonl.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class VTKSeries:
    """ParaView output of named fields, one ``.vtu`` per call of ``write(time)``, indexed by a
    ``.pvd`` file rewritten after each write (readable while the run goes on). A mesh without
    volume elements (a shell's mid-surface in 3D) writes its surface elements. On a distributed
    mesh every rank calls ``write`` and NGSolve writes one ``.vtu`` piece per rank holding elements
    (``<name>_proc<rank>[_step<n>].vtu``) and the ``.pvd`` index of all pieces.

    ``derived_order``: project every field that is not a ``GridFunction`` (a stress or force
    expression) element by element onto discontinuous polynomials of this order before each
    write, instead of evaluating it at each output point. VTK evaluates a field point by point,
    which for deep expressions (a shell's membrane force and moment: the gel law through the
    thickness with the surface Hessian of ``u``) costs ~100x a vectorised projection: 4.5 s against
    0.04 s per write on the 49k-unknown half cap, more than the Newton solve of a step.
    None (the default): evaluate them directly."""

    def __init__(self, mesh: ngs.Mesh, fields: Mapping[str, ngs.CoefficientFunction], path: str | Path,
                 *, subdivision: int = 1, derived_order: int | None = None):
        if derived_order is not None and not (isinstance(derived_order, int) and derived_order >= 0):
            raise ValueError(f"derived_order must be None or an integer >= 0, got {derived_order!r}")
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._vb = ngs.VOL if mesh.comm.Sum(mesh.ne) > 0 else ngs.BND  # over all ranks: rank 0 holds none
        self._projections: list[tuple[ngs.GridFunction, ngs.CoefficientFunction]] = []
        coefs = []
        for field in fields.values():
            if derived_order is None or isinstance(field, ngs.GridFunction):
                coefs.append(field)
                continue
            space = (ngs.L2 if self._vb == ngs.VOL else ngs.SurfaceL2)(mesh, order=derived_order, dim=field.dim)
            projection = ngs.GridFunction(space)
            self._projections.append((projection, field.Compile()))
            coefs.append(projection.Reshape(tuple(field.dims)) if len(field.dims) > 1 else projection)
        self._definedon = mesh.Boundaries(".*") if self._vb == ngs.BND else None
        self._vtk = ngs.VTKOutput(mesh, coefs=coefs, names=list(fields.keys()),
                                  filename=str(self.path), subdivision=subdivision)
        self.times: list[float] = []

    def write(self, time: float) -> None:
        for projection, field in self._projections:
            projection.Set(field, definedon=self._definedon)
        self._vtk.Do(time=time, vb=self._vb)
        self.times.append(time)


# the setting of the innermost ``silence_progress`` block (a context variable, so that it ends
# with the block even when the block raises)
_SILENCED = contextvars.ContextVar("ngsgel_progress_silenced", default=False)


@contextlib.contextmanager
def silence_progress(quiet: bool = True):
    """Within the block, every ``Progress`` made without an explicit ``quiet`` prints nothing (if
    ``quiet``): how a scene's ``--quiet`` reaches the progress of the functions its ``main`` calls,
    which make their own ``Progress``."""
    token = _SILENCED.set(bool(quiet))
    try:
        yield
    finally:
        _SILENCED.reset(token)


def _duration(seconds: float) -> str:
    seconds = round(seconds)
    if seconds < 60:
        return f"{seconds}s"
    if seconds < 3600:
        return f"{seconds // 60}m{seconds % 60:02d}s"
    return f"{seconds // 3600}h{seconds // 60 % 60:02d}m"


class Progress:
    """Status lines on stderr (flushed), one per call: ``[label  elapsed] message``.

    ``progress(message, fraction=f)`` (``0 <= f <= 1``, the share of the run's work done, e.g. of
    the load ramp) puts the percent done and the estimated time left before the message:
    ``[label   12.3s]  42% (about 17s left) message``. Time left extrapolates linearly the rate of
    the last ``window`` reports (the step size of a continuation run and the time step of a march
    change along the run, so the recent rate predicts better than the average); it is left out
    until a second report has a larger fraction. A fraction below the previous one starts a new
    count: one ``Progress`` followed through several load paths.

    ``quiet=True`` prints nothing; ``quiet=None`` (default) is quiet inside ``silence_progress()``
    and on every rank of an MPI run but the writing one (``writing_process``).
    ``clock`` returns seconds (tests pass a fake one).
    """

    def __init__(self, label: str, *, stream=None, quiet: bool | None = None,
                 clock: Callable[[], float] = time.perf_counter, window: int = 5):
        if not (isinstance(window, int) and window >= 1):
            raise ValueError(f"window must be an integer >= 1, got {window!r}")
        self.label = label
        self.stream = stream or sys.stderr
        self.quiet = (_SILENCED.get() or not writing_process()) if quiet is None else quiet
        self.clock = clock
        self.start = clock()
        self._recent: deque[tuple[float, float]] = deque(maxlen=window + 1)  # (clock, fraction)

    def __call__(self, message: str, *, fraction: float | None = None) -> None:
        if self.quiet:
            return
        now = self.clock()
        done = "" if fraction is None else self._done(now, fraction) + " "
        self.stream.write(f"[{self.label} {now - self.start:7.1f}s] {done}{message}\n")
        self.stream.flush()

    def _done(self, now: float, fraction: float) -> str:
        if not 0 <= fraction <= 1:  # also refuses nan
            raise ValueError(f"fraction must lie in [0, 1], got {fraction!r}")
        if self._recent and fraction < self._recent[-1][1]:
            self._recent.clear()
        self._recent.append((now, fraction))
        then, before = self._recent[0]
        # 1e-9: 0.29 * 100 is 28.999999999999996
        text = f"{math.floor(100 * fraction + 1e-9):3d}%"
        if before < fraction < 1:
            text += f" (about {_duration((now - then) / (fraction - before) * (1 - fraction))} left)"
        return text


def report_progress(progress: Callable[[str], None] | None, message: str, *, fraction: float | None = None) -> None:
    """How the drivers (``follow_path``, ``ramp``, ``march``) report a step: to a ``Progress``
    with the fraction of the run done (if known), to any other callable as ``progress(message)``
    (the drivers' documented protocol, which user callables keep), to ``None`` not at all."""
    if progress is None:
        return
    if isinstance(progress, Progress):
        progress(message, fraction=fraction)
    else:
        progress(message)


class SceneHelpFormatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """A scene's ``--help``: its docstring as written, and every option's default after its help.

    No default is added to a flag (its default is its absence) or to a help that already says
    what the default is: an option whose default (None, "") stands for a rule, such as "the
    resolution's" or "all"."""

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        if action.nargs == 0 or "default" in text.lower():
            return text
        return super()._get_help_string(action)


def scene_parser(doc: str, *, out: str, quick: str | None, swelling: Mapping[str, float] | None = None
                 ) -> argparse.ArgumentParser:
    """Command line of a scene script: ``--out`` (default ``out``), ``--quick`` (``quick`` says
    what it coarsens; None: the scene has no quick variant), ``--quiet`` (the scene's ``main``
    runs within ``silence_progress(args.quiet)``) and, given ``swelling`` defaults for any of
    ``Nv``, ``chi``, ``mu0``, ``mu_ext`` and ``ramp``, the options of a gel immersed in a bath.
    Help by ``SceneHelpFormatter``: an option added later shows its default too, so its help
    states only its meaning and unit (MODEL.md section 1: lengths in the scene length, stresses
    in kT/v, mu in kT, time in L^2/D)."""
    parser = argparse.ArgumentParser(description=doc, formatter_class=SceneHelpFormatter)
    parser.add_argument("--out", default=out, help="output folder")
    if quick is not None:
        parser.add_argument("--quick", action="store_true", help=f"{quick} (also set by env CI)")
    parser.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    if swelling is not None:
        helps = {"Nv": "cross-link density N v (dimensionless)", "chi": "Flory-Huggins parameter (dimensionless)",
                 "mu0": "initial (dry-ish) chemical potential (kT)", "mu_ext": "chemical potential of the bath (kT)",
                 "ramp": "duration of the immersion ramp (L^2/D)"}
        for name, default in swelling.items():
            parser.add_argument("--" + name.replace("_", "-"), type=float, default=default, help=helps[name])
    return parser


# what a resumed run takes as given now, not from the run: where it writes, whether it prints
_NOT_RESUMED = ("out", "resume", "quiet")


def command_options(args: argparse.Namespace) -> dict:
    """A scene's parsed command line as its ``params.json`` keeps it (``options``), for ``--resume``."""
    return {key: value for key, value in vars(args).items() if key not in _NOT_RESUMED}


def resume_arguments(parser: argparse.ArgumentParser, argv: list[str] | None = None) -> argparse.Namespace:
    """Parse the command line of a scene that has ``--resume DIR`` (default None). With it, the
    options are those the run in DIR started with (its ``params.json``'s ``options``,
    ``command_options``; an option the scene got since: its default), ``out`` is DIR, ``--quiet``
    as given now; any other option given must agree with the run's. A folder that is not such a
    run, or whose run has finished (it has ``summary.json``), is refused."""
    args = parser.parse_args(argv)
    if args.resume is None:
        return args
    folder = Path(args.resume)
    params = folder / "params.json"
    if not params.is_file():
        raise ValueError(f"--resume {folder}: no params.json there, not a run folder")
    stored = json.loads(params.read_text()).get("options")
    if stored is None:
        raise ValueError(f"--resume {folder}: its params.json has no command-line options to go on with (a run "
                         f"that keeps no checkpoints, started by a function call, or before runs could be resumed)")
    if (folder / "summary.json").exists():
        raise ValueError(f"--resume {folder}: the run has finished (summary.json): nothing to resume")
    # the options given explicitly: parsed into a namespace whose every value is a marker, which
    # argparse leaves where an option is absent
    unset = object()
    given = vars(parser.parse_args(argv, namespace=argparse.Namespace(
        **{action.dest: unset for action in parser._actions if action.dest != "help"})))
    if given["out"] is not unset and Path(given["out"]).resolve() != folder.resolve():
        raise ValueError(f"--out {given['out']} with --resume {folder}: a resumed run writes into its own folder")
    conflicts = {key: (value, stored.get(key)) for key, value in given.items()
                 if key not in _NOT_RESUMED and value is not unset and value != stored.get(key, value)}
    if conflicts:
        raise ValueError(f"--resume {folder} goes on with the run's own options; given now differently (now, run's): "
                         f"{conflicts}. Drop them, or start a new run")
    for key, value in stored.items():
        setattr(args, key, value)
    args.out = str(folder)
    return args


def quick_run(args: argparse.Namespace) -> bool:
    """``--quick`` given, or running under CI (environment variable ``CI`` set)."""
    return bool(args.quick or os.environ.get("CI"))
