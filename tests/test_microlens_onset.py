"""Point-loaded microlens (thesis ch. 3): first non-axisymmetric instability from the harmonic scan."""

from __future__ import annotations

import pytest

from ngsgel.scenes import microlens_onset


def test_fitch_parameter_matches_the_thesis_values():
    # MODEL.md: lambda = 14.08, 9.6, 4.87 for H/R = 0.3, 0.2, 0.1 at t = 0.005 r
    for H, expected in ((0.3, 14.08), (0.2, 9.6), (0.1, 4.87)):
        r = (1 + H * H) / (2 * H)
        assert microlens_onset.fitch_lambda(H, 0.005 * r) == pytest.approx(expected, abs=0.01)


def test_inward_loaded_cap_first_goes_three_fold_as_fitch_predicts(tmp_path):
    # H = 0.3R (lambda = 14.08 > 13.5): the first non-axisymmetric mode has 3 waves. The depth is
    # mesh-converged at d/H = 0.491 (apex patch 0.05 R; 0.4914 / 0.4909 at h = 0.02 / 0.01) and
    # 0.479 (patch 0.01 R), against the thesis's 0.78 for the first visible 3-vertex state.
    (row,) = microlens_onset.main(["--out", str(tmp_path), "--quick"])
    assert row["found"] and row["k"] == 3 and row["fitch_waves"] == "3"
    assert 0.3 < row["depth_over_H"] < 0.7
    assert (tmp_path / "onset.csv").stat().st_size > 0


def test_bad_height_is_rejected():
    with pytest.raises(ValueError, match="H"):
        microlens_onset.onset(1.5, maxh=0.1)
