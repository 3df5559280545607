"""Point-loaded microlens (thesis ch. 3): the indentation force, the axisymmetric path and its events."""

from __future__ import annotations

import numpy as np
import pytest

import microlens


def coarse_cap(H=0.3, direction="inward", mu=0.0):
    case = microlens.Indentation(H=H, direction=direction, depth=1.0, mu=mu)
    return microlens.AxisymmetricCap(case, microlens.SectionResolution(maxh=0.05, layers=1, order=2, apex=0.05))


@pytest.mark.parametrize("direction", ["inward", "outward"])
def test_indentation_force_is_the_derivative_of_the_energy(direction):
    # F = dE/dd along the equilibrium path (the free dofs are stationary), by central differences
    # of re-equilibrated energies; the difference error is O(h^2) ~ 1e-6 relative here.
    cap = coarse_cap(direction=direction, mu=-0.02)
    H, p = cap.case.H, cap.problem
    energies = {}
    for d in (0.049 * H, 0.05 * H, 0.051 * H):
        cap.depth.Set(d)
        p.solve()
        energies[d] = p.energy()
    force = cap.force() * cap.force_scale  # at d = 0.051 H
    cap.depth.Set(0.05 * H)
    p.solve()
    force_mid = cap.force() * cap.force_scale
    fd = (energies[0.051 * H] - energies[0.049 * H]) / (0.002 * H)
    assert force_mid > 0 and force > force_mid  # resists, stiffening
    assert force_mid == pytest.approx(fd, rel=1e-4)


def test_bad_input_is_rejected():
    for kwargs, name in (({"H": 1.5}, "H"), ({"H": 0.3, "direction": "lateral"}, "direction"),
                         ({"H": 0.3, "depth": -1}, "depth"), ({"H": 0.3, "mu": 0.5}, "mu")):
        with pytest.raises(ValueError, match=name):
            microlens.Indentation(**kwargs)
    with pytest.raises(ValueError, match="maxh"):
        microlens.SectionResolution(maxh=0.0)


def test_quick_run_leaves_the_axisymmetric_path_three_fold(tmp_path):
    # H = 0.3R, coarse section (order 2, h = 0.04): the first non-axisymmetric instability has 3
    # waves (Fitch: lambda = 14.08 > 13.5). The converged depth is d/H = 0.477 (h = 0.02, order 3,
    # same patch; with a 0.05 R patch h = 0.02 and 0.01 differ by 0.1 %): the coarse section must
    # be within 10 % of it.
    summary = microlens.main(["--quick", "--out", str(tmp_path)])
    first = summary["first_nonaxisymmetric"]
    assert first is not None and first["k"] == 3
    assert first["d_over_H"] == pytest.approx(0.477, rel=0.1)
    # indentation at fixed mu hardly changes the gel volume (thesis: 0.2 % at most)
    assert summary["max_volume_change"] < 2e-3
    assert summary["snaps"] == [] and summary["force_maxima"] == []
    assert summary["fit"]["C"] > 0 and summary["fit"]["misfit"] < 0.15
    for name in ("path.csv", "summary.json", "force_depth.png"):
        assert (tmp_path / name).stat().st_size > 0
