"""Ring on an elastic foundation: the Michell stiffness of an annulus against its closed-form
limits (half-space, Lame, thin confined layer, thin ring) and the critical mode against the
flat-film wrinkling result."""

import math

import pytest

from ngsgel.scenes.ring_foundation import (
    bending_stiffness,
    critical_hoop_force,
    critical_mode,
    critical_strain,
    foundation_stiffness_annulus,
)


def annulus_K(n, *, a=1.0, b=2.0, G=1.0, nu=0.3, loaded="inner", **options):
    return foundation_stiffness_annulus(n, inner_radius=a, outer_radius=b, shear_modulus=G, nu=nu,
                                        loaded=loaded, **options)


# --------------------------------------------------------------------------- foundation stiffness


@pytest.mark.parametrize("loaded, R", [("inner", 1.0), ("outer", 2.0)])
@pytest.mark.parametrize("nu", [0.0, 0.3, 0.5])
def test_large_mode_tends_to_half_space(loaded, R, nu):
    # Half-space under a load of wavenumber q, plane strain: K = G q / (1 - nu) with a
    # shear-free surface, 4 G (1 - nu) q / (3 - 4 nu) with no slip. Curvature corrections are O(1/n).
    G = 2.5
    errors = {}
    for n in (100, 1000):
        q = n / R
        free = annulus_K(n, G=G, nu=nu, loaded=loaded)
        no_slip = annulus_K(n, G=G, nu=nu, loaded=loaded, interface="no_slip")
        errors[n] = (abs(free / (G * q / (1 - nu)) - 1), abs(no_slip / (4 * G * (1 - nu) * q / (3 - 4 * nu)) - 1))
    assert max(errors[1000]) < 1.5e-3
    for before, after in zip(errors[100], errors[1000]):
        assert after < before / 5 or after < 1e-12


def test_incompressible_half_space_is_two_G_q_for_both_interfaces():
    n, R, G = 2000, 1.0, 0.7
    for interface in ("shear_free", "no_slip"):
        K = annulus_K(n, G=G, nu=0.5, interface=interface)
        assert K == pytest.approx(2 * G * n / R, rel=1e-6)


@pytest.mark.parametrize("nu", [0.2, 0.45])
def test_axisymmetric_mode_is_lame(nu):
    # Lame, plane strain, pressure on one face, the other free: the thesis's mode-independent K.
    a, b, G = 1.0, 2.0, 3.0
    E = 2 * G * (1 + nu)
    inner = E * (b**2 - a**2) / ((1 + nu) * a * ((1 - 2 * nu) * a**2 + b**2))
    outer = E * (b**2 - a**2) / ((1 + nu) * b * ((1 - 2 * nu) * b**2 + a**2))
    assert annulus_K(0, a=a, b=b, G=G, nu=nu, loaded="inner") == pytest.approx(inner, rel=1e-12)
    assert annulus_K(0, a=a, b=b, G=G, nu=nu, loaded="outer") == pytest.approx(outer, rel=1e-12)


@pytest.mark.parametrize("n", [0, 2, 10])
def test_thin_layer_on_rigid_core_is_confined_compression(n):
    # A layer h << R, R/n bonded to a rigid surface is an oedometer: K = (lambda + 2G)/h.
    G, nu, h = 1.0, 0.3, 1e-3
    K = annulus_K(n, a=1.0, b=1.0 + h, G=G, nu=nu, loaded="inner", far="fixed")
    assert K == pytest.approx(2 * G * (1 - nu) / ((1 - 2 * nu) * h), rel=2e-4)


def test_fixed_far_surface_stiffens_as_layer_thins_and_is_irrelevant_when_thick():
    values = [annulus_K(6, a=1.0, b=1.0 + h, loaded="inner", far="fixed") for h in (2.0, 1.0, 0.5, 0.2, 0.1)]
    assert all(later > earlier for earlier, later in zip(values, values[1:]))
    # A short wave does not reach a distant far surface: free and fixed agree.
    assert annulus_K(60, far="fixed") == pytest.approx(annulus_K(60, far="free"), rel=1e-9)
    assert annulus_K(6, far="fixed") > annulus_K(6, far="free")


@pytest.mark.parametrize("loaded", ["inner", "outer"])
@pytest.mark.parametrize("n", [2, 3, 6])
def test_thin_free_annulus_is_an_inextensional_ring(loaded, n):
    # A free annulus of thickness h << R is a ring of bending stiffness D = 2 G h^3/(12 (1 - nu)):
    # a pressure p cos(n theta) on the face r = R_L deflects it by p R_L R_m^3 / (D (n^2 - 1)^2).
    G, nu, a, h = 1.0, 0.3, 1.0, 1e-2
    R_m = a + h / 2
    R_L = a if loaded == "inner" else a + h
    D = 2 * G * h**3 / (12 * (1 - nu))
    expected = D * (n * n - 1) ** 2 / (R_L * R_m**3)
    assert annulus_K(n, a=a, b=a + h, G=G, nu=nu, loaded=loaded) == pytest.approx(expected, rel=1e-3)


def test_bulk_modulus_gives_the_same_answer_as_poisson_ratio():
    G, nu = 1.3, 0.27
    bulk = 2 * G * (1 + nu) / (3 * (1 - 2 * nu))
    for n in (0, 2, 7.5, 40):
        by_nu = annulus_K(n, G=G, nu=nu, loaded="outer")
        by_bulk = foundation_stiffness_annulus(n, inner_radius=1.0, outer_radius=2.0, shear_modulus=G,
                                               bulk_modulus=bulk, loaded="outer")
        assert by_bulk == pytest.approx(by_nu, rel=1e-12)


def test_stiffness_scales_as_G_over_R():
    base = annulus_K(12, a=1.0, b=2.0, G=1.0)
    assert annulus_K(12, a=3.0, b=6.0, G=5.0) == pytest.approx(base * 5.0 / 3.0, rel=1e-12)


@pytest.mark.parametrize("kwargs, name", [
    (dict(n=1), "n"),
    (dict(n=1.5), "n"),
    (dict(n=4, b=0.5), "outer_radius"),
    (dict(n=4, nu=0.6), "nu"),
    (dict(n=4, G=-1.0), "shear_modulus"),
    (dict(n=4, loaded="middle"), "loaded"),
    (dict(n=4, far="clamped"), "far"),
    (dict(n=4, interface="glued"), "interface"),
])
def test_foundation_rejects_bad_input(kwargs, name):
    n = kwargs.pop("n")
    with pytest.raises(ValueError, match=rf"^{name} must"):
        annulus_K(n, **kwargs)


def test_foundation_needs_exactly_one_compressibility():
    with pytest.raises(ValueError, match="nu and bulk_modulus"):
        foundation_stiffness_annulus(4, inner_radius=1.0, outer_radius=2.0, shear_modulus=1.0, loaded="inner")


# --------------------------------------------------------------------------- critical mode


def test_large_radius_gives_flat_film_wrinkling():
    # Allen: N_cr = 2 sqrt(K D) at wavenumber (K/D)^(1/4); the ring's n_cr ~ R (K/D)^(1/4).
    t, Ef, nu, K = 0.01, 10.0, 0.3, 0.02
    D = bending_stiffness(t, Ef, nu)
    R = 50.0
    mode = critical_mode(R, t, Ef, nu, K)
    assert mode.N_cr == pytest.approx(2 * math.sqrt(K * D), rel=1e-5)
    assert mode.n_continuous == pytest.approx(R * (K / D) ** 0.25, rel=1e-5)
    assert abs(mode.n - mode.n_continuous) <= 1
    sigma_cr = math.sqrt(Ef / (1 - nu**2) * K * t / 3)  # thesis eq. 4-2
    assert mode.N_cr / t == pytest.approx(sigma_cr, rel=1e-5)
    assert critical_strain(R, t, Ef, nu, K) == pytest.approx(sigma_cr * (1 - nu**2) / Ef, rel=1e-5)


def test_mode_number_scales_with_fourth_root_of_K_over_D():
    R, t, Ef, nu = 20.0, 0.01, 10.0, 0.3
    base = critical_mode(R, t, Ef, nu, 0.01).n_continuous
    assert critical_mode(R, t, Ef, nu, 0.16).n_continuous == pytest.approx(2 * base, rel=1e-3)
    # D ~ t^3: a film 16^(1/3) times thicker halves the wave number.
    assert critical_mode(R, t * 16 ** (1 / 3), Ef, nu, 0.01).n_continuous == pytest.approx(base / 2, rel=1e-3)


@pytest.mark.parametrize("K", [1e-4, 3e-3, 0.5])
def test_returned_mode_minimises_the_hoop_force(K):
    R, t, Ef, nu = 1.0, 0.02, 0.0375, 0.3
    mode = critical_mode(R, t, Ef, nu, K)
    forces = {n: critical_hoop_force(n, R, t, Ef, nu, K) for n in range(2, 4 * mode.n + 10)}
    assert min(forces, key=forces.get) == mode.n
    assert mode.N_cr == forces[mode.n]
    # The continuous optimum is a true stationary point of the real-n formula (or the n = 2 bound).
    if mode.n_continuous > 2:
        eps = 1e-4 * mode.n_continuous
        at = critical_hoop_force(mode.n_continuous, R, t, Ef, nu, K)
        assert at <= critical_hoop_force(mode.n_continuous + eps, R, t, Ef, nu, K)
        assert at <= critical_hoop_force(mode.n_continuous - eps, R, t, Ef, nu, K)
        assert at <= mode.N_cr


def test_weak_foundation_buckles_in_ovalisation():
    # Below K = 9 D / R^4 the n = 2 ring mode wins (n^2 - 1 = 3 beats R^2 sqrt(K/D) < 3).
    R, t, Ef, nu = 1.0, 0.02, 1.0, 0.3
    D = bending_stiffness(t, Ef, nu)
    mode = critical_mode(R, t, Ef, nu, 0.5 * 9 * D / R**4)
    assert mode.n == 2 and mode.n_continuous == 2.0


def test_mode_dependent_foundation_of_the_gel_tube():
    # The gear's inner film on the gel annulus with K(n) from the Michell solution.
    def K(n):
        return foundation_stiffness_annulus(n, inner_radius=1.0, outer_radius=2.0, shear_modulus=1e-3,
                                            nu=0.3, loaded="inner")
    R, t, Ef, nu = 1.0, 0.02, 12.5 * 3e-3, 0.3
    mode = critical_mode(R, t, Ef, nu, K)
    forces = {n: critical_hoop_force(n, R, t, Ef, nu, K) for n in range(2, 3 * mode.n)}
    assert min(forces, key=forces.get) == mode.n
    assert abs(mode.n_continuous - mode.n) < 1
    assert critical_hoop_force(mode.n_continuous, R, t, Ef, nu, K) <= mode.N_cr
    # At these wave numbers the gel is nearly a half-space (K ~ G n / ((1 - nu) R)), so n_cr
    # solves n^3 ~ G R^3 / (2 (1 - nu) D) up to the O(1/n) curvature terms.
    D = bending_stiffness(t, Ef, nu)
    assert mode.n_continuous == pytest.approx((1e-3 * R**3 / (2 * (1 - nu) * D)) ** (1 / 3), rel=0.02)


@pytest.mark.parametrize("args, name", [
    ((1.0, 0.0, 1.0, 0.3, 1.0), "t"),
    ((1.0, 0.1, 1.0, 0.5001, 1.0), "nu"),
    ((-1.0, 0.1, 1.0, 0.3, 1.0), "R"),
    ((1.0, 0.1, 1.0, 0.3, 0.0), "K"),
])
def test_critical_mode_rejects_bad_input(args, name):
    with pytest.raises(ValueError, match=rf"^{name} must"):
        critical_mode(*args)


def test_hoop_force_rejects_rigid_translation_mode():
    with pytest.raises(ValueError, match="n must be"):
        critical_hoop_force(1, 1.0, 0.1, 1.0, 0.3, 1.0)
