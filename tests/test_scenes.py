"""Scenes are importable and double as regression tests (run with --quick); the ``ngsgel``
command runs them through the installed entry point; ``ngsgel reproduce`` writes its report."""

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest

from ngsgel import reproduce
from ngsgel.scenes import SCENES, free_swelling, scene


def test_free_swelling_scene(tmp_path):
    free_swelling.main(["--out", str(tmp_path), "--quick"])
    rows = list(csv.DictReader(open(tmp_path / "stretch.csv")))
    assert {r["model"] for r in rows} == {"solid3d", "axisymmetric", "plane"}
    assert max(float(r["rel_error"]) for r in rows) < 1e-9
    assert (tmp_path / "stretch.png").stat().st_size > 0
    assert (tmp_path / "params.json").exists()


def test_installed_entry_point_runs_a_scene(tmp_path):
    # the console script pip puts next to the interpreter (pyproject's [project.scripts])
    command = Path(sys.executable).parent / "ngsgel"
    assert command.exists(), f"no ngsgel entry point next to {sys.executable}: is the package installed?"
    listed = subprocess.run([str(command), "list"], capture_output=True, text=True, check=True).stdout
    assert all(name in listed for name in SCENES)
    done = subprocess.run([str(command), "run", "free-swelling", "--quick", "--out", str(tmp_path)],
                          capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    rows = list(csv.DictReader(open(tmp_path / "stretch.csv")))
    assert max(float(r["rel_error"]) for r in rows) < 1e-9


def test_unknown_scene_is_named_with_the_list():
    with pytest.raises(ValueError, match="unknown scene 'microlense'.*microlens"):
        scene("microlense")
    assert scene("graded_plate_shell").module == "graded_plate_shell"


def test_every_scene_module_has_a_main():
    for entry in SCENES.values():
        assert callable(entry.load().main), entry.name


def test_reproduce_report_has_the_tables_and_embedded_figures(tmp_path):
    report = reproduce.closed_form_case(tmp_path / "closed-forms", True)
    assert report.rows and all(row.verdict == "agrees" for row in report.rows)
    reproduce.write_report(tmp_path, [report], quick=True, chapters=["checks"])
    text = (tmp_path / "report.md").read_text()
    assert "| free swelling, 3D / axisymmetric / plane strain" in text
    assert "Documented results" not in text  # no documented rows in this chapter
    page = (tmp_path / "report.html").read_text()
    assert page.count("data:image/png;base64,") == len(report.figures) == 2
    assert json.loads((tmp_path / "report.json").read_text())[0]["chapter"] == "checks"


def test_reproduce_rejects_an_unknown_chapter(tmp_path, capsys):
    with pytest.raises(SystemExit):
        reproduce.main(["--only", "ch3,ch9", "--out", str(tmp_path)])
    assert "--only" in capsys.readouterr().err
