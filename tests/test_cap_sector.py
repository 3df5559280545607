"""Three-fold cap on a 60-degree mirror sector (issue 39): the whole cap's check and its rotation mode."""

from __future__ import annotations

import math

import ngsolve as ngs
import pytest

from ngsgel.scenes import cap_sector


@pytest.fixture(scope="module")
def coarse_cap():
    return cap_sector.SectorCap(H=0.3, maxh=0.15, apex_maxh=0.02, apex=0.02, order=2, realcompile=False)


def test_rotation_generator_vanishes_on_axisymmetric_fields_and_turns_a_wavy_one(coarse_cap):
    # g = e_z x u - grad(u) (e_z x X): a radial field turned about the axis is itself (g = 0);
    # w e_z with w = x^2 - y^2 = rho^2 cos 2 theta turns into g = -dw/dtheta e_z = 4 x y e_z
    cap = coarse_cap
    u = cap.full.displacement
    mesh = cap.full_mesh

    def norm(f):
        return math.sqrt(ngs.Integrate(f * f, mesh, ngs.BND))

    # (the mesh's triangles are curved onto the sphere, so even a linear field is interpolated
    # with an error of order h^2; a sign error in either term would give |g| ~ 2 |u|)
    u.Set(ngs.CF((ngs.x, ngs.y, 0.0)), definedon=mesh.Boundaries(".*"))
    assert norm(cap.rotation_generator()) < 1e-3 * norm(u)
    u.Set(ngs.CF((0.0, 0.0, ngs.x**2 - ngs.y**2)), definedon=mesh.Boundaries(".*"))
    expected = ngs.CF((0.0, 0.0, 4 * ngs.x * ngs.y))
    # order-2 interpolation on curved triangles of size 0.15: error of the derivative ~ h^2
    assert norm(cap.rotation_generator() - expected) < 0.05 * norm(expected)

    mode = ngs.GridFunction(u.space)
    mode.Set(expected, definedon=mesh.Boundaries(".*"))
    assert cap.rotation_overlap(mode, cap.rotation_generator()) == pytest.approx(1.0, abs=0.01)
    # x y against rho^2 (or cos 2 theta) is odd under the mirror y -> -y: orthogonal to the rotation
    for w in (ngs.x**2 + ngs.y**2, ngs.x**2 - ngs.y**2):
        mode.Set(ngs.CF((0.0, 0.0, w)), definedon=mesh.Boundaries(".*"))
        assert cap.rotation_overlap(mode, cap.rotation_generator()) < 1e-6


def test_bad_check_depth_is_rejected_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="check_from"):
        cap_sector.run(str(tmp_path / "run"), depth=0.6, check_from=0.8)
    with pytest.raises(ValueError, match="maxh"):
        cap_sector.run(str(tmp_path / "run"), maxh=0.0)
    assert not (tmp_path / "run").exists()


def test_shallow_indent_maps_onto_an_equilibrium_of_the_whole_cap(coarse_cap):
    # d = 0.02 H, axisymmetric: the six mirror images carry the sector's state as an equilibrium of
    # the whole cap (the same force, up to the 60-degree mirror's penalty compliance), which is
    # stable, and its k = 1 modes come as a pair of equal eigenvalues (the mesh has the rotations
    # by 120 degrees, under which k = 1 and 2 are two-dimensional representations)
    cap = coarse_cap
    cap.depth.Set(0.02 * cap.H)
    cap.sector.solve()
    whole = cap.whole_cap(eigenvalues=4)
    assert whole["negative"] == 0 and whole["unstable"] == 0
    from ngsgel.stability import conjugate_force

    assert conjugate_force(cap.full, cap.full_depth) / cap.force_scale == pytest.approx(cap.force(), rel=1e-4)
    pair = [m for m in whole["modes"] if m["k"] == 1]
    assert len(pair) == 2
    assert pair[0]["eigenvalue"] == pytest.approx(pair[1]["eigenvalue"], rel=1e-8)
