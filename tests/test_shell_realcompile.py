"""GelShell compiled to C++ (``realcompile=True``: the energy and its first derivative, for the
residual): the same residual and energy as the interpreted form, on a coarse bent and swollen
half cap. (The tangent is interpreted either way.)"""

from __future__ import annotations

import shutil

import numpy as np
import pytest

from geometries import cap_midsurface
from ngsgel import FloryRehnerGel
from ngsgel.shell import GelShell
from ngsgel.stability import free_matrix

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)


@pytest.mark.slow  # the C++ compilation alone takes 10-60 s
@pytest.mark.skipif(shutil.which("c++") is None and shutil.which("g++") is None, reason="needs a C++ compiler")
def test_compiled_shell_has_the_same_residual_and_energy():
    bundle = cap_midsurface(H=0.3, maxh=0.5, apex_radius=0.1, curve_order=2, half=True)
    shells = []
    for realcompile in (False, True):
        shell = GelShell(bundle.mesh, material=GEL, lam0=GEL.lam_free(-0.05), thickness=0.02, mu=-0.04, order=2,
                         realcompile=realcompile)
        shell.clamp("base")
        shell.symmetry("sym", normal="y")
        shell.form  # build (compiles when asked to)
        shells.append(shell)
    # a generic admissible state: the reference (thickness stretches 1) plus a random perturbation
    rng = np.random.default_rng(3)
    state = shells[0].state.FV().NumPy() + 1e-3 * rng.standard_normal(shells[0].state.size) * shells[0].free_mask
    results = []
    for shell in shells:
        shell.state.FV().NumPy()[:] = state
        r = shell.state.CreateVector()
        shell.residual(shell.state, r)
        results.append((r.FV().NumPy()[shell.free_mask].copy(), shell.energy()))
    (r0, e0), (r1, e1) = results
    assert np.linalg.norm(r1 - r0) <= 1e-10 * np.linalg.norm(r0)
    assert abs(e1 - e0) <= 1e-12 * abs(e0)

    # the compiled shell's residual and tangent are two forms: the tangent must be the derivative
    # of the compiled residual (central difference along a random free direction)
    shell = shells[1]
    direction = 1e-3 * rng.standard_normal(shell.state.size) * shell.free_mask
    K = free_matrix(shell.tangent(shell.state), shell.free_mask)
    eps = 1e-6
    sides = []
    for sign in (1, -1):
        shell.state.FV().NumPy()[:] = state + sign * eps * direction
        r = shell.state.CreateVector()
        shell.residual(shell.state, r)
        sides.append(r.FV().NumPy()[shell.free_mask].copy())
    difference = (sides[0] - sides[1]) / (2 * eps)
    linear = K @ direction[shell.free_mask]
    assert np.linalg.norm(difference - linear) <= 1e-6 * np.linalg.norm(linear)


def test_realcompile_must_be_a_bool():
    bundle = cap_midsurface(H=0.3, maxh=0.5, curve_order=2)
    with pytest.raises(ValueError, match="realcompile"):
        GelShell(bundle.mesh, material=GEL, lam0=GEL.lam_free(0.0), thickness=0.02, realcompile="yes")
