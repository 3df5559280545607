"""Scenes before and after a change: ``ngsgel run SCENE --quick`` timed with two package roots.

Each scene runs in fresh processes, before and after alternating (before, after, before, after,
...), every run under ``flock LOCK`` (so no two timed runs of the machine's users overlap) and
``/usr/bin/time -v`` (wall and CPU time, peak memory), with the load average read inside the
lock just before it starts. A scene whose first pair took under ``--short`` CPU seconds gets
``--short-repeats`` pairs, the others ``--repeats``. The end states are compared: every number
in the run's JSON files (``params.json`` aside) and in the last row of its CSV / JSON-lines files,
timings excepted, to ``--rtol`` and ``--atol``; the before runs among themselves and the after
runs among themselves too, since a difference across versions means something only if each
version repeats itself.

"before" is a package root put first on ``PYTHONPATH`` (a git worktree of the old commit);
"after" is another root, or by default the installed package. The script refuses a root that
is not what Python imports from it (an editable install's finder taking precedence, say).

    git worktree add /tmp/old35 281646e
    python scripts/bench_scenes.py --before /tmp/old35 --out results/bench_scenes [--after PATH]
    python scripts/bench_scenes.py --before /tmp/old35 --out DIR --scenes graded-plate-shell

Prints the table (scene, before / after median wall time, ratio after / before, CPU times,
peak memory, same end state) and writes ``runs.csv`` (one row per run), ``scenes.csv`` and
``scenes.json`` (the table, the end-state differences, the load averages) to ``--out``.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import os
import re
import shlex
import statistics
import subprocess
import sys
from pathlib import Path

DEFAULT_SCENES = ("gears", "graded-plate", "creases", "microlens")
# keys of the scenes' outputs that are measured times, not results
TIMING_KEY = re.compile(r"seconds|wall|elapsed|duration|cpu_s", re.IGNORECASE)
TIME_V_FIELDS = {"wall_s": "Elapsed (wall clock) time", "user_s": "User time (seconds)",
                 "system_s": "System time (seconds)", "peak_rss_kb": "Maximum resident set size (kbytes)"}


def imported_from(python: str, root: Path | None, cwd: Path) -> list[str]:
    """Where ``ngsgel`` and ``geometries`` come from with ``root`` first on the path (None: installed)."""
    code = "import ngsgel, geometries; print(ngsgel.__file__); print(geometries.__file__)"
    result = subprocess.run([python, "-c", code], env=environment(root), cwd=cwd, capture_output=True, text=True,
                            check=True)
    return result.stdout.split()


def check_root(python: str, root: Path | None, cwd: Path, other: Path | None) -> list[str]:
    files = imported_from(python, root, cwd)
    for file in files:
        resolved = Path(file).resolve()
        if root is not None and root not in resolved.parents:
            raise SystemExit(f"--before/--after {root}: Python imports {file} instead (an editable install's finder "
                             "wins?); install the old tree into a scratch venv and pass its --python")
        if root is None and other is not None and other in resolved.parents:
            raise SystemExit(f"the installed package is {file}, inside --before {other}: pass --after explicitly")
    return files


def environment(root: Path | None) -> dict:
    env = dict(os.environ)
    env.pop("PYTHONPATH", None)
    if root is not None:
        env["PYTHONPATH"] = str(root)
    return env


def parse_time_v(text: str) -> dict:
    values = {}
    for line in text.splitlines():
        line = line.strip()
        for key, label in TIME_V_FIELDS.items():
            if line.startswith(label):
                value = line.rsplit(": ", 1)[1]
                if key == "wall_s":  # h:mm:ss or m:ss.ss
                    seconds = 0.0
                    for part in value.split(":"):
                        seconds = 60 * seconds + float(part)
                    values[key] = seconds
                else:
                    values[key] = float(value)
    missing = set(TIME_V_FIELDS) - set(values)
    if missing:
        raise RuntimeError(f"/usr/bin/time -v output lacks {sorted(missing)}:\n{text[-2000:]}")
    return values


def flatten(value, prefix: str, out: dict) -> dict:
    if isinstance(value, dict):
        for key, item in value.items():
            if not TIMING_KEY.search(str(key)):
                flatten(item, f"{prefix}/{key}", out)
    elif isinstance(value, list):
        for index, item in enumerate(value):
            flatten(item, f"{prefix}[{index}]", out)
    else:
        out[prefix] = value
    return out


def end_state(run_dir: Path) -> dict:
    """The run's results: its JSON files (options aside) and the last row of each table."""
    state: dict = {}
    for path in sorted(run_dir.rglob("*")):
        name = str(path.relative_to(run_dir))
        if path.suffix == ".json" and path.name != "params.json":
            flatten(json.loads(path.read_text()), name, state)
        elif path.suffix == ".jsonl":
            lines = path.read_text().splitlines()
            if lines:
                flatten(json.loads(lines[-1]), f"{name}:last", state)
        elif path.suffix == ".csv":
            with path.open(newline="") as handle:
                rows = list(csv.DictReader(handle))
            if rows:
                flatten({k: as_number(v) for k, v in rows[-1].items()}, f"{name}:last", state)
    return state


def as_number(text: str):
    try:
        return float(text)
    except (TypeError, ValueError):
        return text


def differences(a: dict, b: dict, rtol: float, atol: float) -> tuple[list[str], float]:
    """Keys whose values differ, numbers by more than ``atol + rtol`` times the larger magnitude, and
    the largest relative difference of the numbers larger than ``atol``."""
    differing, largest = [], 0.0
    for key in sorted(set(a) | set(b)):
        x, y = a.get(key), b.get(key)
        numbers = all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in (x, y))
        if numbers and math.isfinite(x) and math.isfinite(y):
            scale = max(abs(x), abs(y))
            if scale > atol:
                largest = max(largest, abs(x - y) / scale)
            if abs(x - y) > atol + rtol * scale:
                differing.append(f"{key}: {x!r} / {y!r}")
        elif x != y and not (numbers and math.isnan(x) and math.isnan(y)):
            differing.append(f"{key}: {x!r} / {y!r}")
    return differing, largest


def timed_run(args, version: str, root: Path | None, scene: str, run_dir: Path, cwd: Path) -> dict:
    load_file, time_file = run_dir.with_suffix(".uptime"), run_dir.with_suffix(".time")
    scene_command = [args.python, "-m", "ngsgel.cli", "--threads", str(args.threads), "run", scene, "--quick",
                     "--quiet", "--out", str(run_dir)]
    # the load is read inside the lock, right before the run, not while waiting for it
    inner = (f"uptime > {shlex.quote(str(load_file))} && exec /usr/bin/time -v -o {shlex.quote(str(time_file))} "
             + shlex.join(scene_command))
    with run_dir.with_suffix(".log").open("w") as log:
        result = subprocess.run(["flock", args.lock, "sh", "-c", inner], env=environment(root), cwd=cwd,
                                stdout=log, stderr=subprocess.STDOUT)
    load = load_file.read_text().strip()
    row = {"scene": scene, "version": version, "run_dir": str(run_dir), "returncode": result.returncode,
           "uptime": load, "load_1min": float(load.rsplit("load average:", 1)[1].split(",")[0]),
           **parse_time_v(time_file.read_text())}
    row["cpu_s"] = row["user_s"] + row["system_s"]
    print(f"  {scene:<14} {version:<6} wall {row['wall_s']:7.1f} s  cpu {row['cpu_s']:7.1f} s  "
          f"rss {row['peak_rss_kb'] / 1024:6.0f} MB  exit {result.returncode}  [{load}]", flush=True)
    return row


def write_runs(path: Path, runs: list[dict]) -> None:
    with path.open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=list(runs[0]))
        writer.writeheader()
        writer.writerows(runs)


def compare_scene(scene: str, runs: list[dict], rtol: float, atol: float) -> dict:
    by_version = {v: [r for r in runs if r["version"] == v] for v in ("before", "after")}
    states = {v: [end_state(Path(r["run_dir"])) for r in rs if r["returncode"] == 0] for v, rs in by_version.items()}
    row: dict = {"scene": scene}
    for version, rs in by_version.items():
        for field in ("wall_s", "cpu_s"):
            row[f"{version}_{field}"] = statistics.median(r[field] for r in rs)
            row[f"{version}_{field}_all"] = [round(r[field], 1) for r in rs]
        row[f"{version}_peak_rss_mb"] = max(r["peak_rss_kb"] for r in rs) / 1024
        row[f"{version}_failed_runs"] = sum(r["returncode"] != 0 for r in rs)
        row[f"{version}_repeats_itself"] = all(not differences(states[version][0], s, rtol, atol)[0]
                                               for s in states[version][1:]) if states[version] else None
    row["ratio_wall"] = row["after_wall_s"] / row["before_wall_s"]
    row["ratio_cpu"] = row["after_cpu_s"] / row["before_cpu_s"]
    if states["before"] and states["after"]:
        differing, largest = differences(states["before"][0], states["after"][0], rtol, atol)
        row["same_end_state"] = not differing
        row["largest_relative_difference"] = largest
        row["differences"] = differing
    else:
        row["same_end_state"], row["largest_relative_difference"], row["differences"] = None, None, ["a run failed"]
    row["load_1min"] = [r["load_1min"] for r in runs]
    return row


def main(argv=None) -> list[dict]:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--before", type=Path, required=True, help="package root of the old code (holds ngsgel/)")
    parser.add_argument("--after", type=Path, default=None, help="package root of the new code (default: installed)")
    parser.add_argument("--out", type=Path, required=True, help="directory for the runs and the tables")
    parser.add_argument("--scenes", default=",".join(DEFAULT_SCENES), help="comma-separated scene names")
    parser.add_argument("--threads", type=int, default=1, help="ngsgel --threads N for every run (default 1)")
    parser.add_argument("--repeats", type=int, default=2, help="before/after pairs per scene (default 2)")
    parser.add_argument("--short", type=float, default=60.0,
                        help="a scene whose first pair took under this many CPU seconds (its own cost, unlike the "
                             "wall time on a shared machine) gets --short-repeats pairs (default 60)")
    parser.add_argument("--short-repeats", type=int, default=3, help="pairs for short scenes (default 3)")
    parser.add_argument("--rtol", type=float, default=1e-6,
                        help="relative difference up to which two end-state numbers count as the same (default 1e-6)")
    parser.add_argument("--atol", type=float, default=1e-9,
                        help="absolute difference always allowed: round-off zeros, eigenvalues at a located onset "
                             "(default 1e-9)")
    parser.add_argument("--lock", default="/tmp/ngsgel-bench.lock", help="flock file shared by timed runs")
    parser.add_argument("--python", default=sys.executable, help="interpreter for the runs (default: this one)")
    args = parser.parse_args(argv)
    for name in ("repeats", "short_repeats", "threads"):
        if getattr(args, name) < 1:
            parser.error(f"--{name.replace('_', '-')} must be at least 1, got {getattr(args, name)}")
    if not 0 < args.rtol < 1:
        parser.error(f"--rtol must lie in (0, 1), got {args.rtol}")
    if not args.atol >= 0:
        parser.error(f"--atol must be >= 0, got {args.atol}")
    roots = {"before": args.before.resolve(), "after": args.after.resolve() if args.after else None}
    for version, root in roots.items():
        if root is not None and not (root / "ngsgel" / "__init__.py").is_file():
            parser.error(f"--{version} {root} holds no ngsgel/__init__.py")
    scenes = [s for s in args.scenes.split(",") if s]
    if not scenes:
        parser.error("--scenes names no scene")
    runs_dir = args.out / "runs"  # also the runs' working directory: no package lies in it
    runs_dir.mkdir(parents=True, exist_ok=True)
    imports = {v: check_root(args.python, r, runs_dir, roots["before"]) for v, r in roots.items()}
    for version, files in imports.items():
        print(f"{version}: {' '.join(files)}")

    runs, table = [], []
    for scene in scenes:
        pairs, index = args.repeats, 0
        while index < pairs:
            for version, root in roots.items():
                run_dir = (runs_dir / f"{scene}_{version}_{index}").resolve()
                runs.append(timed_run(args, version, root, scene, run_dir, runs_dir))
                write_runs(args.out / "runs.csv", runs)  # kept up to date: a long benchmark may be stopped
            if index == 0 and max(r["cpu_s"] for r in runs[-2:]) < args.short:
                pairs = max(pairs, args.short_repeats)
            index += 1
        table.append(compare_scene(scene, [r for r in runs if r["scene"] == scene], args.rtol, args.atol))

    header = (f"{'scene':<14} {'before s':>9} {'after s':>9} {'ratio':>6} {'cpu before':>10} {'cpu after':>9} "
              f"{'ratio':>6} {'MB before':>9} {'MB after':>9}  same end state")
    print(header)
    for row in table:
        same = {True: "yes", False: "no", None: "failed"}[row["same_end_state"]]
        print(f"{row['scene']:<14} {row['before_wall_s']:9.1f} {row['after_wall_s']:9.1f} {row['ratio_wall']:6.2f} "
              f"{row['before_cpu_s']:10.1f} {row['after_cpu_s']:9.1f} {row['ratio_cpu']:6.2f} "
              f"{row['before_peak_rss_mb']:9.0f} {row['after_peak_rss_mb']:9.0f}  {same}"
              + ("" if row["largest_relative_difference"] is None
                 else f" (largest relative difference {row['largest_relative_difference']:.1e})"))
        for line in row["differences"]:
            print(f"    differs: {line}")
    columns = [k for k in table[0] if k != "differences"]
    with (args.out / "scenes.csv").open("w", newline="") as handle:
        writer = csv.DictWriter(handle, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(table)
    (args.out / "scenes.json").write_text(json.dumps({"imports": imports, "threads": args.threads, "rtol": args.rtol,
                                                      "atol": args.atol,
                                                      "scenes": table, "runs": runs}, indent=1))
    return table


if __name__ == "__main__":
    main()
