"""Recorders: everything a run produces goes into one folder, written as it happens.

``RunDirectory`` makes the folder and writes the run's parameters; ``History`` appends one CSV row
per step (and mirrors it as JSON lines) and flushes, so a stopped run keeps what it computed;
``VTKSeries`` writes ParaView files of named fields with a ``.pvd`` index over time or load.
``scene_parser`` gives every scene script the same ``--out``/``--quick`` flags (and the gel's and
the bath's parameters for swelling scenes); ``quick_run`` adds the CI environment to ``--quick``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import sys
import time
from collections.abc import Mapping
from pathlib import Path

import ngsolve as ngs

__all__ = ["RunDirectory", "History", "VTKSeries", "Progress", "scene_parser", "quick_run"]


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
    """One output folder per run: ``params.json`` first, then whatever the run writes."""

    def __init__(self, path: str | Path, *, params: Mapping | None = None):
        self.path = Path(path)
        self.path.mkdir(parents=True, exist_ok=True)
        if params is not None:
            self.write_json("params.json", params)

    def file(self, name: str) -> Path:
        return self.path / name

    def write_json(self, name: str, data) -> Path:
        target = self.file(name)
        target.write_text(json.dumps(_jsonable(data), indent=2, default=str) + "\n")
        return target


class History:
    """Step-by-step table: ``append(row)`` writes a CSV line and a JSON line and flushes.

    The columns are fixed by the first row; later rows may leave some out (written empty) but
    may not add new ones, so the CSV stays rectangular.
    """

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self.rows: list[dict] = []
        self._columns: list[str] | None = None
        self._csv = open(self.path, "w", newline="")
        self._jsonl = open(self.path.with_suffix(".jsonl"), "w")
        self._writer = None

    def append(self, row: Mapping) -> None:
        row = {k: _jsonable(v) for k, v in row.items()}
        if self._columns is None:
            self._columns = list(row)
            self._writer = csv.DictWriter(self._csv, fieldnames=self._columns)
            self._writer.writeheader()
        extra = set(row) - set(self._columns)
        if extra:
            raise ValueError(f"row has columns {sorted(extra)} not in the history's columns {self._columns}")
        self._writer.writerow({k: (json.dumps(v) if isinstance(v, (list, dict)) else v) for k, v in row.items()})
        self._jsonl.write(json.dumps(row, default=str) + "\n")
        self._csv.flush()
        self._jsonl.flush()
        self.rows.append(row)

    def column(self, name: str) -> list:
        return [row.get(name) for row in self.rows]

    def close(self) -> None:
        self._csv.close()
        self._jsonl.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


class VTKSeries:
    """ParaView output of named fields, one ``.vtu`` per call of ``write(time)``, indexed by a
    ``.pvd`` file rewritten after each write (readable while the run goes on). A mesh without
    volume elements (a shell's mid-surface in 3D) writes its surface elements."""

    def __init__(self, mesh: ngs.Mesh, fields: Mapping[str, ngs.CoefficientFunction], path: str | Path,
                 *, subdivision: int = 1):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._vtk = ngs.VTKOutput(mesh, coefs=list(fields.values()), names=list(fields.keys()),
                                  filename=str(self.path), subdivision=subdivision)
        self._vb = ngs.VOL if mesh.ne > 0 else ngs.BND
        self.times: list[float] = []

    def write(self, time: float) -> None:
        self._vtk.Do(time=time, vb=self._vb)
        self.times.append(time)


class Progress:
    """One status line per step on stderr, with elapsed wall time."""

    def __init__(self, label: str, *, stream=None):
        self.label = label
        self.stream = stream or sys.stderr
        self.start = time.perf_counter()

    def __call__(self, message: str) -> None:
        self.stream.write(f"[{self.label} {time.perf_counter() - self.start:7.1f}s] {message}\n")
        self.stream.flush()


def scene_parser(doc: str, *, out: str, quick: str, swelling: Mapping[str, float] | None = None
                 ) -> argparse.ArgumentParser:
    """Command line of a scene script: ``--out`` (default ``out``), ``--quick`` (``quick`` says
    what it coarsens) and, given ``swelling`` defaults for ``Nv``, ``chi``, ``mu0``, ``mu_ext``
    and ``ramp``, the options of a gel immersed in a bath."""
    parser = argparse.ArgumentParser(description=doc, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--out", default=out, help="output folder")
    parser.add_argument("--quick", action="store_true", help=f"{quick} (also set by env CI)")
    if swelling is not None:
        helps = {"Nv": "cross-link density N v", "chi": "Flory-Huggins parameter",
                 "mu0": "initial (dry-ish) chemical potential", "mu_ext": "chemical potential of the bath",
                 "ramp": "duration of the immersion ramp"}
        for name, default in swelling.items():
            parser.add_argument("--" + name.replace("_", "-"), type=float, default=default, help=helps[name])
    return parser


def quick_run(args: argparse.Namespace) -> bool:
    """``--quick`` given, or running under CI (environment variable ``CI`` set)."""
    return bool(args.quick or os.environ.get("CI"))
