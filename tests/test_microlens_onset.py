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


def test_drained_poisson_ratio_is_the_lateral_contraction_of_a_gel_at_fixed_mu():
    # A free-swollen gel block (mu = 0, the cap's state) stretched by a small axial strain at fixed
    # mu (the equilibrium problem: solvent free to move) contracts laterally by nu_drained times
    # that strain; the FE answer is exact up to the strain's second-order terms.
    import ngsolve as ngs
    from ngsolve.meshes import MakeStructured3DMesh

    from ngsgel import EquilibriumProblem, Solid3D

    gel = microlens_onset.GEL
    lam0 = gel.lam_free(0.0)
    prob = EquilibriumProblem(MakeStructured3DMesh(nx=1, ny=1, nz=1), kinematics=Solid3D(), materials=gel,
                              lam0=lam0, mu=0.0, order=1)
    strain = ngs.Parameter(0.0)
    for boundary, component in (("back", "x"), ("left", "y"), ("bottom", "z")):
        prob.fix(boundary, component)
    prob.prescribe("top", "z", strain)
    contractions = []
    for eps in (1e-4, 2e-4):
        strain.Set(eps)
        prob.solve()
        contractions.append(-prob.displacement(prob.mesh(1, 1, 1))[0] / eps)
    # Richardson: the O(eps) term of the finite-strain answer removed
    nu_fe = 2 * contractions[0] - contractions[1]
    assert nu_fe == pytest.approx(microlens_onset.drained_poisson_ratio(0.0), rel=1e-6)
    assert 0.30 < nu_fe < 0.32  # issue 39's estimate for Nv = 1e-3, chi = 0.5


def test_fitch_parameter_with_the_drained_poisson_ratio():
    # issue 39: lambda = 14.75, 10.07, 5.11 for H/R = 0.3, 0.2, 0.1 with nu ~ 0.31 - inside Fitch's
    # bands of 3 and 4 waves and the axisymmetric range
    nu = microlens_onset.drained_poisson_ratio(0.0)
    for H, expected, waves in ((0.3, 14.75, "3"), (0.2, 10.07, "4"), (0.1, 5.11, "axisymmetric")):
        lam = microlens_onset.fitch_lambda(H, 0.005 * (1 + H * H) / (2 * H), nu)
        assert lam == pytest.approx(expected, abs=0.01)
        assert microlens_onset.fitch_waves(lam) == waves
