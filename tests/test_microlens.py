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
