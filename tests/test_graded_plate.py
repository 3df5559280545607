"""Graded disk (thesis ch. 5): onset of non-axisymmetric buckling from the harmonic scan."""

from __future__ import annotations

import json

import numpy as np
import pytest

import graded_plate


def test_softer_edge_buckles_non_axisymmetrically_with_compressive_hoop_stress_at_the_edge(tmp_path):
    # softer edge (n0 = 1e-2, nR = 1e-3, p = 10): the edge swells more, its hoop stress turns
    # compressive and the flat disk loses stability to a wave number k >= 2 before mu = 0
    summary = graded_plate.main(["--out", str(tmp_path), "--quick", "--t", "0.05", "--kmax", "5"])
    assert summary["found"] and summary["k_critical"] >= 2
    assert -1.0 < summary["mu_critical"] < 0.0
    assert 0.5 < summary["hoop_compressive_from_r"] < 1.0
    assert summary["critical_swelling_strain"] > 0
    profile = np.loadtxt(tmp_path / "onset_profile.csv", delimiter=",", skiprows=1)
    r, hoop = profile[:, 0], profile[:, 2]
    assert np.all(hoop[r < 0.4] > 0)  # the stiff centre is stretched by the swelling edge
    for name in ("onset.png", "path.csv", "params.json", "section.pvd", "profile_end.csv"):
        assert (tmp_path / name).stat().st_size > 0
    assert json.loads((tmp_path / "summary.json").read_text())["k_critical"] == summary["k_critical"]


def test_softer_centre_swells_into_an_axisymmetric_bowl(tmp_path):
    # softer centre (n0 = 1e-3, nR = 1e-2): the centre swells more, the flat (mid-plane
    # symmetric) disk reaches an axisymmetric pitchfork, the driver switches onto the bowl
    # branch and follows it to mu = 0 with no non-axisymmetric instability on the way
    summary = graded_plate.main(["--out", str(tmp_path), "--quick", "--n0", "1e-3", "--nR", "1e-2", "--p", "2",
                                 "--t", "0.05", "--kmax", "3"])
    kinds = [e["kind"] for e in summary["axisymmetric_events"]]
    assert kinds[:2] == ["bifurcation", "branch switch"], summary["axisymmetric_events"]
    assert -1.0 < summary["axisymmetric_events"][0]["mu"] < 0.0
    assert not summary["found"] and summary["mu_end"] == pytest.approx(0.0, abs=1e-12)
    assert summary["lowest_nonaxisymmetric_eigenvalue"] > 0
    assert abs(summary["rim_rise_end"]) > 0.1  # a bowl, not a flat disk
    assert 1.0 < summary["profile_exponent_end"] < 3.0
    profile = np.loadtxt(tmp_path / "profile_end.csv", delimiter=",", skiprows=1)
    z = profile[:, 2] * np.sign(summary["rim_rise_end"])
    assert np.all(np.diff(z) > 0)  # the rise grows monotonically from the centre to the rim


def test_graded_plate_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="layers"):
        graded_plate.build(n0=1e-2, nR=1e-3, p=10, t=0.05, maxh=0.1, layers=3)
    with pytest.raises(ValueError, match="t "):
        graded_plate.build(n0=1e-2, nR=1e-3, p=10, t=0.7, maxh=0.1)
    with pytest.raises(ValueError, match="p"):
        graded_plate.build(n0=1e-2, nR=1e-3, p=-1, t=0.05, maxh=0.1)
    with pytest.raises(ValueError, match="kmax"):
        graded_plate.run(str(tmp_path), kmax=1)


def test_graded_tube_rejects_bad_input():
    import graded_tube

    with pytest.raises(ValueError, match="t "):
        graded_tube.build(n0=1e-2, nL=1e-3, p=5, t=1.5, L=2, maxh=0.1, order=2, mu0=-1.0)
    with pytest.raises(ValueError, match="p"):
        graded_tube.build(n0=1e-2, nL=1e-3, p=0, t=0.02, L=2, maxh=0.1, order=2, mu0=-1.0)
    with pytest.raises(ValueError, match="kmax"):
        graded_tube.run("unused", kmax=1)
