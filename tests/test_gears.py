"""Film-coated gel tube (gears, thesis ch. 4): the radial pre-buckling model, the rigid-mode
supports, the foundation moduli of the gel and the gears script on a coarse case."""

import json
import math
from dataclasses import replace

import numpy as np
import ngsolve as ngs
import pytest
from ngsolve.meshes import Make1DMesh

import geometries as geo
from ngsgel import EquilibriumProblem, FloryRehnerGel, GeneralizedPlaneStrain, PlaneStrain, ramp
from ngsgel.scenes.film_tube import (FILM_INNER, FILM_OUTER, FilmTube, RadialTube, gel_plane_strain_moduli, linear_film_stresses,
                              linear_switch, ring_onset)
from ngsgel.kinematics import PolarPlaneStrain
from ngsgel.supports import pin_rigid_modes

from ngsgel.scenes import gears


@pytest.fixture(autouse=True, scope="module")
def one_thread():
    """Small problems run much faster without thread synchronisation (radial 1D model: 30x on the
    shared 2-core machine); the thread count is restored afterwards."""
    threads = ngs.GetNumThreads()
    ngs.SetNumThreads(1)
    yield
    ngs.SetNumThreads(threads)

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
ES = 3e-3
MU = -2e-4  # before any film buckles for the tubes below (onsets are below -4e-4 or absent)


def test_polar_plane_strain_gel_annulus_shrinks_homogeneously():
    """A free gel annulus in plane strain shrinks to the closed-form in-plane stretch."""
    lam0 = GEL.lam_free(0.0)
    mesh = Make1DMesh(8, mapping=lambda t: 1.0 + t)
    prob = EquilibriumProblem(mesh, kinematics=PolarPlaneStrain(), materials=GEL, lam0=lam0, mu=0.0, order=2)
    ramp(prob, prob.mu, -5e-4)
    ratio = GEL.lam_plane_strain(-5e-4, lam0) / lam0
    u = prob.displacement
    for r in (1.0, 1.3, 2.0):
        assert u(mesh(r)) / r == pytest.approx(ratio - 1.0, rel=1e-8)


def test_gel_foundation_moduli():
    """At free swelling the plane-strain moduli are the drained G and Poisson ratio; away from it
    the area modulus is the derivative of the in-plane stress (finite difference)."""
    lam0 = GEL.lam_free(0.0)
    G, nu = gel_plane_strain_moduli(GEL, 0.0, lam0)
    assert G == pytest.approx(GEL.shear_modulus(lam0), rel=1e-12)
    assert nu == pytest.approx(GEL.drained_poisson_ratio(lam0), rel=1e-10)
    mu = -5e-4
    lam = GEL.lam_plane_strain(mu, lam0)
    G, nu = gel_plane_strain_moduli(GEL, mu, lam0)
    kappa = G / (1.0 - 2.0 * nu)

    def in_plane_stress(area_strain):
        s = lam * math.exp(area_strain / 2)
        return GEL.mu_plane_strain(s, lam0) - mu  # sigma_rr of the homogeneous state at fixed mu

    h = 1e-6
    assert (in_plane_stress(h) - in_plane_stress(-h)) / (2 * h) == pytest.approx(kappa, rel=1e-5)


@pytest.fixture(scope="module")
def tube():
    return FilmTube(Ri=1.0, Ro=2.0, tfi=0.02, tfo=0.02, Efi=12.5 * ES, Efo=7.23 * ES)


@pytest.fixture(scope="module")
def radial_reference(tube):
    return RadialTube(tube, order=4, gel_cells=64).solve(MU)


def test_radial_model_is_converged(tube, radial_reference):
    coarse = RadialTube(tube, order=2, gel_cells=16, film_cells=2).solve(MU)
    assert coarse.sigma_inner == pytest.approx(radial_reference.sigma_inner, rel=2e-3)
    assert coarse.sigma_outer == pytest.approx(radial_reference.sigma_outer, rel=2e-3)
    # the films hold the gel back: the coated gel keeps more volume than a free one
    free = (GEL.lam_plane_strain(MU, tube.lam0) / tube.lam0) ** 2
    assert free < radial_reference.volume_fraction < 1.0
    # shrinking compresses both films (positive hoop forces)
    assert radial_reference.N_inner > 0 and radial_reference.N_outer > 0


def test_linear_film_stresses_are_the_small_shrink_limit(tube):
    """The linear pre-buckling film stresses (three bonded Lame cylinders, thesis eq. 4-4) with
    the gel's drained moduli are the limit of the nonlinear radial model for a small shrink
    (error of order mu: 4e-4 at mu = -1e-6); in the thin-film, incompressible limit their ratio
    is the closed form ``(Efi/Efo)(g - alpha_o)/(g + alpha_i)``, ``g = 2G``."""
    G, nu = gel_plane_strain_moduli(tube.gel, 0.0, tube.lam0)
    s_i, s_o = linear_film_stresses(tube, E_gel=2 * G * (1 + nu), nu_gel=nu)
    mu = -1e-6
    state = RadialTube(tube, order=4, gel_cells=64).solve(mu)
    shrink = 1.0 - tube.gel.lam_plane_strain(mu, tube.lam0) / tube.lam0
    assert state.sigma_inner == pytest.approx(shrink * s_i, rel=1e-3)
    assert state.sigma_outer == pytest.approx(shrink * s_o, rel=1e-3)
    thin = FilmTube(Ri=1.0, Ro=2.0, tfi=1e-5, tfo=1e-5, Efi=2.5e4 * ES, Efo=5e3 * ES)
    s_i, s_o = linear_film_stresses(thin, E_gel=ES, nu_gel=0.5)
    g, bar = 2 * ES / 3, 1 / (1 - thin.nu_film**2)
    a_i, a_o = bar * thin.Efi * thin.tfi / thin.Ri, bar * thin.Efo * thin.tfo / thin.Ro
    assert s_i / s_o == pytest.approx(thin.Efi / thin.Efo * (g - a_o) / (g + a_i), rel=1e-4)


def test_linear_switch_thesis_lame_closed_form():
    """The thesis's switch with its Lame stiffness, nu_s = 0.5 and thin films of equal thickness
    has a closed form: K_i/K_o = Ri/Ro, so the critical stress ratio is sqrt(Efi Ri/(Efo Ro)) and
    the switch solves (Efi/Efo)(g - alpha_o)/(g + alpha_i) = sqrt(Efi Ri/(Efo Ro))."""
    t, efi = 1e-4, 2500.0
    thin = FilmTube(Ri=1.0, Ro=2.0, tfi=t, tfo=t, Efi=efi * ES, Efo=ES)
    efo = linear_switch(thin, E_gel=ES, nu_gel=0.5, stiffness="lame") / ES
    g, bar = 2 / 3, 1 / (1 - thin.nu_film**2)
    a_i, a_o = bar * efi * t, bar * efo * t / 2
    assert efi / efo * (g - a_o) / (g + a_i) == pytest.approx(math.sqrt(efi / (2 * efo)), rel=1e-3)


def pinned_annulus(tube, radius, *, kinematics=None, quadrature_order=None):
    bundle = geo.tube_plane(Ri=1.0, Ro=2.0, tfi=tube.tfi, tfo=tube.tfo, maxh=0.5, n_theta=64, quad=True)
    prob = EquilibriumProblem(bundle.mesh, kinematics=kinematics or PlaneStrain(), materials=tube.materials(),
                              lam0=tube.lam0, mu=0.0, order=2, quadrature_order=quadrature_order)
    pin_rigid_modes(prob, radius=radius)
    return bundle, prob


def mean_hoop_stresses(bundle, prob):
    sigma = prob.stress()
    e_t = ngs.CF((-ngs.y, ngs.x)) / ngs.sqrt(ngs.x**2 + ngs.y**2)
    sigma2 = ngs.CF((sigma[0, 0], sigma[0, 1], sigma[1, 0], sigma[1, 1]), dims=(2, 2))
    hoop = ngs.InnerProduct(sigma2 * e_t, e_t)
    return [prob.integrate(hoop, region=region) / bundle.region_measures[region] for region in (FILM_INNER, FILM_OUTER)]


def test_pinned_annulus_matches_radial_model_with_zero_reactions(tube, radial_reference):
    """The 2D annulus held only by the three tangential pins: the pre-buckling state is the
    axisymmetric one (hoop stresses as the 1D model), the pins carry no force, and pins on
    another circle give the same stresses (the supports only fix the rigid motion)."""
    hoops = {}
    for radius in (1.0, 2.0):
        bundle, prob = pinned_annulus(tube, radius)
        assert np.count_nonzero(~np.array(list(prob.space.FreeDofs()))) == 3
        prob.mu.Set(MU)
        unbalanced = prob.state.CreateVector()
        prob.residual(prob.state, unbalanced)  # the force scale: residual of the unrelaxed state
        prob.mu.Set(0.0)
        ramp(prob, prob.mu, MU)
        residual = prob.state.CreateVector()
        prob.residual(prob.state, residual)
        reactions = residual.FV().NumPy()[~prob.free_mask]
        assert np.max(np.abs(reactions)) < 1e-8 * np.max(np.abs(unbalanced.FV().NumPy()))
        hoops[radius] = mean_hoop_stresses(bundle, prob)
        e_t = ngs.CF((-ngs.y, ngs.x)) / ngs.sqrt(ngs.x**2 + ngs.y**2)
        # the discrete annulus is symmetric only under rotations by 2 pi / n_theta: a tangential
        # displacement at the level of the geometry error, not of the pins
        u = prob.displacement
        u_t = math.sqrt(prob.integrate(ngs.InnerProduct(u, e_t) ** 2) / bundle.exact_measure)
        u_rms = math.sqrt(prob.integrate(ngs.InnerProduct(u, u)) / bundle.exact_measure)
        assert u_t < 1e-4 * u_rms
    assert hoops[1.0][0] == pytest.approx(radial_reference.sigma_inner, rel=5e-3)
    assert hoops[1.0][1] == pytest.approx(radial_reference.sigma_outer, rel=5e-3)
    assert hoops[2.0] == pytest.approx(hoops[1.0], rel=1e-7)


def test_generalized_plane_strain_tube_has_zero_axial_force_and_matches_radial_model(tube):
    """The coated tube with free ends (generalized plane strain, one axial stretch for gel and
    films): the 2D annulus held by the three pins carries no pin force and no net axial force
    (films squeezed axially, the gel pulled, cancelling to round-off: the energy's quadrature rule
    is the one of the force integral), and its axial stretch and film hoop stresses are those of
    the 1D radial model with a free axial stretch. The tube shrinks axially less than a free gel
    (the films resist) but more than not at all."""
    free = replace(tube, axial="free")
    radial = RadialTube(free, order=4, gel_cells=64).solve(MU)
    bundle, prob = pinned_annulus(free, 1.0, kinematics=GeneralizedPlaneStrain(), quadrature_order=6)
    prob.mu.Set(MU)
    unbalanced = prob.state.CreateVector()
    prob.residual(prob.state, unbalanced)
    prob.mu.Set(0.0)
    ramp(prob, prob.mu, MU)
    residual = prob.state.CreateVector()
    prob.residual(prob.state, residual)
    assert np.max(np.abs(residual.FV().NumPy()[~prob.free_mask])) < 1e-8 * np.max(np.abs(unbalanced.FV().NumPy()))
    forces = {region: prob.axial_force(region=region) for region in (FILM_INNER, "gel", FILM_OUTER)}
    assert forces["gel"] > 0 > max(forces[FILM_INNER], forces[FILM_OUTER])
    assert abs(sum(forces.values())) < 1e-10 * forces["gel"]
    assert prob.axial_stretch() == pytest.approx(radial.axial_stretch, rel=1e-5)
    assert GEL.lam_free(MU) / free.lam0 < radial.axial_stretch < 1.0
    assert mean_hoop_stresses(bundle, prob) == pytest.approx([radial.sigma_inner, radial.sigma_outer], rel=5e-3)
    assert free.mu_at_volume_fraction(0.7) == pytest.approx(GEL.mu_free(free.lam0 * 0.7 ** (1 / 3)), rel=1e-14)


def test_pin_rigid_modes_rejects_bad_input(tube):
    bundle = geo.tube_plane(Ri=1.0, Ro=2.0, tfi=tube.tfi, tfo=tube.tfo, maxh=0.5, n_theta=64, quad=True)
    prob = EquilibriumProblem(bundle.mesh, kinematics=PlaneStrain(), materials=tube.materials(), lam0=tube.lam0)
    with pytest.raises(ValueError, match="radius"):
        pin_rigid_modes(prob, radius=-1.0)
    with pytest.raises(ValueError, match="vertex"):
        pin_rigid_modes(prob, radius=1.234)  # no vertex ring there


def test_ring_onset_stiffer_outer_film_takes_over(tube):
    """Analysis: with a soft outer film the inner film buckles first; a stiff one buckles first."""
    mu_end = tube.mu_at_volume_fraction(0.7)
    soft = FilmTube(Ri=1.0, Ro=2.0, tfi=0.02, tfo=0.02, Efi=12.5 * ES, Efo=1.0 * ES)
    stiff = FilmTube(Ri=1.0, Ro=2.0, tfi=0.02, tfo=0.02, Efi=12.5 * ES, Efo=100.0 * ES)
    inner_soft = ring_onset(soft, "inner", mu_end=mu_end, steps=8, tol=1e-6)
    outer_soft = ring_onset(soft, "outer", mu_end=mu_end, steps=8, tol=1e-6)
    assert inner_soft.mu is not None and (outer_soft.mu is None or outer_soft.mu < inner_soft.mu)
    inner_stiff = ring_onset(stiff, "inner", mu_end=mu_end, steps=8, tol=1e-6)
    outer_stiff = ring_onset(stiff, "outer", mu_end=mu_end, steps=8, tol=1e-6)
    assert outer_stiff.mu is not None and (inner_stiff.mu is None or inner_stiff.mu < outer_stiff.mu)


def test_bad_scene_input():
    with pytest.raises(ValueError, match="efo"):
        gears.main(["--efo", "-1", "--out", "/tmp/never"])
    with pytest.raises(ValueError, match="n_theta"):
        gears.main(["--n-theta", "30", "--out", "/tmp/never"])
    with pytest.raises(ValueError, match="volume fraction|volume"):
        gears.main(["--volume", "1.5", "--out", "/tmp/never"])
    with pytest.raises(ValueError, match="axial"):
        gears.check_scene(gears.Scene(axial="loose"))
    with pytest.raises(ValueError, match="axial"):
        FilmTube(Ri=1.0, Ro=2.0, tfi=0.02, tfo=0.02, Efi=ES, Efo=ES, axial="loose")


def test_critical_mode_sign_puts_a_tooth_at_angle_zero():
    """The sign of the critical mode (ARPACK's choice, i.e. round-off) is replaced by a
    convention: a tooth of the buckling film at its phase point on the x axis, outward on the
    outer film and inward on the inner, whichever sign the mode comes with."""
    model = gears.GearModel(gears.Scene(), gears.Resolution(48, 1, 0.5, 1))
    p = model.problem
    wave = ngs.GridFunction(p.space)
    e_r = ngs.CF((ngs.x, ngs.y)) / ngs.sqrt(ngs.x**2 + ngs.y**2)
    wave.Set(ngs.cos(4 * ngs.atan2(ngs.y, ngs.x)) * e_r)  # crests outward at angle 0
    phi = wave.vec.FV().NumPy()[p.free_mask].copy()
    for sign in (1.0, -1.0):
        assert np.array_equal(gears.tooth_at_angle_zero(model, sign * phi, "outer"), phi)
        assert np.array_equal(gears.tooth_at_angle_zero(model, sign * phi, "inner"), -phi)


# Converged onset of Efo/Es = 100 (Efi/Es = 12.5, Ri/tfi = 50, Ro/tfo = 100) from the convergence
# table of docs/gears.md: n_theta = 384 and 512 (p = 2) give mu_cr = -1.3547e-4 (same bisection
# bracket, 1.6e-7 wide) and 256 cells with p = 3 -1.3538e-4; all fine meshes 24 waves.
CONVERGED_MU_CR = -1.3547e-4
CONVERGED_WAVES = 24


def test_gears_quick_post_buckled_outer_teeth(tmp_path):
    """Coarse thesis case Efi/Es = 12.5, Efo/Es = 100 (outer teeth in the thesis), the whole run:
    the FE onset is on the outer film as a cos/sin pair, within 1 % of the converged onset and
    with the converged wave number (the quick mesh was chosen for that from the convergence
    table; the old one, 96 cells with p = 2, was 5 % off with 22 waves); the buckled branch is
    followed to the end (70 % for a free gel) and the final gear has outer teeth only, as many as
    the converged wave number (the pattern keeps its wave number on the branch), a pure pattern
    (the old mesh's was modulated with the mesh period, purity 0.89), an amplitude of 1.5-5 film
    thicknesses (2.6 measured; the inner film stays within 0.2 t_f of round) and no negative
    eigenvalue (stable in the pinned space, as on the fine mesh); the phase pin carries no load
    (1e-9 of the load scale); the coated gel keeps more than 70 %."""
    summary = gears.main(["--quick", "--efo", "100", "--out", str(tmp_path)])
    onset = summary["onset"]
    assert onset["mode_film"] == "outer" and onset["negative_after"] >= 2  # a pair: cos and sin
    assert onset["mu_cr"] == pytest.approx(CONVERGED_MU_CR, rel=0.01)
    assert onset["mode_k"] == CONVERGED_WAVES
    assert summary["switch"]["mu_past_onset_fraction"] > 0  # supercritical
    final = summary["final"]
    assert final["mu"] == pytest.approx(summary["mu_end"], rel=1e-12)
    assert final["type"] == "outer teeth"
    assert final["outer"]["tooth_count"] == final["outer"]["k"] == CONVERGED_WAVES
    assert final["outer"]["purity"] > 0.99
    assert 1.5 < final["outer"]["amplitude_over_t"] < 5.0
    assert final["inner"]["amplitude_over_t"] < 0.2
    assert final["negative_eigenvalues"] == 0
    assert summary["path"]["phase_pin_reaction_max_relative"] < 1e-9
    assert 0.7 < final["volume_fraction"] < 0.75
    assert json.load(open(tmp_path / "summary.json"))["final"]["type"] == "outer teeth"
    # the switch converges inside Newton's basin, not by wandering into it: quadratic convergence
    # from a first contraction of 1/10 reaches the floor in n = ceil(log2(1 + log10(r0/atol)))
    # iterations (r_k = r0 10^-(2^k - 1)); two more for the pre-asymptotic steps of a guess
    # that is off the branch by O(s^2). An attempt may only have failed by a rise of its residual
    # (``monotone``), never at the iteration limit
    switch = summary["switch"]
    residuals = switch["residuals"]
    assert residuals[1] <= residuals[0] / 10
    quadratic = math.ceil(math.log2(1 + math.log10(residuals[0] / switch["atol"])))
    assert switch["iterations"] <= quadratic + 2 < 15
    assert all("residual rose" in failure["message"] for failure in switch["failed_attempts"])
    assert (tmp_path / "gear.png").stat().st_size > 0
    with open(tmp_path / "path.csv") as f:
        rows = f.read().splitlines()
    assert len(rows) > 10
