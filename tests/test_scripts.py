"""Scene scripts are importable and double as regression tests (run with --quick)."""

import csv

from ngsgel.scenes import free_swelling


def test_free_swelling_script(tmp_path):
    free_swelling.main(["--out", str(tmp_path), "--quick"])
    rows = list(csv.DictReader(open(tmp_path / "stretch.csv")))
    assert {r["model"] for r in rows} == {"solid3d", "axisymmetric", "plane"}
    assert max(float(r["rel_error"]) for r in rows) < 1e-9
    assert (tmp_path / "stretch.png").stat().st_size > 0
    assert (tmp_path / "params.json").exists()
