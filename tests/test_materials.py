"""Material models: closed forms against MODEL.md, stresses and tangents against the energy."""

import math

import numpy as np
import ngsolve as ngs
import pytest
from ngsolve.meshes import MakeStructured2DMesh

from ngsgel import FloryRehnerGel, NeoHookeanFilm

MESH = MakeStructured2DMesh(nx=1, ny=1)
POINT = MESH(0.3, 0.3)


def value(cf) -> np.ndarray:
    return np.array(cf(POINT)).reshape(cf.dims if cf.dim > 1 else ())


def matrix_cf(A: np.ndarray) -> ngs.CoefficientFunction:
    return ngs.CF(tuple(A.ravel()), dims=(3, 3))


def random_gradient(seed: int, scale: float = 0.2) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.eye(3) + scale * rng.standard_normal((3, 3))


def test_free_swelling_matches_model_numbers():
    # MODEL.md section 2: Nv = 1e-3, chi = 0.5, mu = 0 -> lam = 2.1520, J = 9.966; chi = 0.1 -> 3.390
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam = gel.lam_free(0.0)
    assert lam == pytest.approx(2.1520, abs=5e-5)
    assert lam**3 == pytest.approx(9.966, abs=5e-4)
    assert FloryRehnerGel(Nv=1e-3, chi=0.1).lam_free(0.0) == pytest.approx(3.390, abs=5e-4)


@pytest.mark.parametrize("chi", [0.1, 0.5, 0.8, 1.0, 1.2])
@pytest.mark.parametrize("Nv", [1e-4, 1e-3, 1e-2])
def test_closed_forms_invert_each_other(Nv, chi):
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    for mu in [-5.0, -0.5, -0.01, 0.0]:
        lam = gel.lam_free(mu)
        assert gel.mu_free(lam) == pytest.approx(mu, abs=1e-12)
        lamL = 0.9 * lam
        assert gel.mu_constrained(gel.lam_constrained(mu, lamL), lamL) == pytest.approx(mu, abs=1e-12)
        lamz = 1.1 * lam
        assert gel.mu_plane_strain(gel.lam_plane_strain(mu, lamz), lamz) == pytest.approx(mu, abs=1e-12)


def test_closed_forms_are_the_stress_free_states_of_the_field_formulas():
    gel = FloryRehnerGel(Nv=1e-2, chi=0.3)
    mu, lamL = -0.2, 1.7
    lam = gel.lam_constrained(mu, lamL)
    sigma = value(gel.cauchy(matrix_cf(np.diag([lamL, lamL, lam])), mu))
    assert abs(sigma[2, 2]) < 1e-13
    assert sigma[0, 0] > 0  # the constrained directions carry the tension of the held network
    lam_p = gel.lam_plane_strain(mu, lamL)
    sigma = value(gel.cauchy(matrix_cf(np.diag([lam_p, lam_p, lamL])), mu))
    assert abs(sigma[0, 0]) < 1e-13 and abs(sigma[1, 1]) < 1e-13


def taylor_remainders(f, df, X: np.ndarray, dX: np.ndarray) -> np.ndarray:
    """|f(X + h dX) - f(X) - h df(X):dX| for h = 2^-k: shrinks by 4 per halving when df is f's derivative."""
    hs = [2.0**-k for k in range(4, 9)]
    f0 = f(X)
    slope = df(X, dX)
    return np.array([np.linalg.norm(np.atleast_1d(f(X + h * dX) - f0 - h * slope)) for h in hs])


def assert_second_order(rem: np.ndarray):
    rates = np.log2(rem[:-1] / rem[1:])
    assert np.all(rates > 1.9), rates


MATERIALS = [
    (FloryRehnerGel(Nv=1e-3, chi=0.5), 2.0, -0.05),
    (FloryRehnerGel(Nv=1e-2, chi=1.0), 1.2, 0.01),
    (NeoHookeanFilm(E=3.0, nu=0.3), 1.0, 0.0),
]


@pytest.mark.parametrize("material,scale,mu", MATERIALS)
def test_stress_is_derivative_of_energy(material, scale, mu):
    X = scale * random_gradient(1)
    dX = np.random.default_rng(2).standard_normal((3, 3))
    rem = taylor_remainders(lambda A: float(value(material.energy(matrix_cf(A), mu))),
                            lambda A, D: float(np.sum(value(material.first_piola(matrix_cf(A), mu)) * D)),
                            X, dX)
    assert_second_order(rem)


@pytest.mark.parametrize("material,scale,mu", MATERIALS)
def test_tangent_is_derivative_of_stress(material, scale, mu):
    # The tangent the solvers use is NGSolve's derivative of the energy: check it against the
    # stress by a Taylor test, so energy, stress and tangent are one consistent model.
    X = scale * random_gradient(3)
    dX = np.random.default_rng(4).standard_normal((3, 3))

    def piola(A):
        return value(material.first_piola(matrix_cf(A), mu))

    def directional_tangent(A, D):
        F = matrix_cf(A)
        W = material.energy(F, mu)
        dP = W.Diff(F, matrix_cf(D)).Diff(F)  # d/dF (dW/dF : D) = tangent applied to D
        return value(dP)

    assert_second_order(taylor_remainders(piola, directional_tangent, X, dX))


def test_cauchy_is_push_forward_of_piola():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    A = 2.0 * random_gradient(5)
    F = matrix_cf(A)
    P, sigma = value(gel.first_piola(F, -0.1)), value(gel.cauchy(F, -0.1))
    assert np.allclose(sigma, P @ A.T / np.linalg.det(A), rtol=1e-12, atol=1e-15)


def test_swollen_energy_is_scaled_dry_energy():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = 2.1
    A = random_gradient(6, scale=0.05)
    Wp = float(value(gel.swollen_energy(matrix_cf(A), -0.02, lam0)))
    W = float(value(gel.energy(matrix_cf(lam0 * A), -0.02)))
    assert Wp == pytest.approx(W / lam0**3, rel=1e-13)


@pytest.mark.parametrize("Nv,chi,mu", [(1e-3, 0.5, 0.0), (1e-2, 0.1, -0.3), (1e-3, 1.0, -0.1)])
def test_linear_moduli_from_the_stress(Nv, chi, mu):
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    lam0 = gel.lam_free(mu)
    eps = 1e-6
    shear = np.eye(3) * lam0
    shear[0, 1] = lam0 * eps
    sigma = value(gel.cauchy(matrix_cf(shear), mu))
    assert sigma[0, 1] / eps == pytest.approx(gel.shear_modulus(lam0), rel=1e-5)
    # K = d(mean stress)/d(ln J) under a small dilation at fixed mu (drained)
    s = [value(gel.cauchy(matrix_cf(np.eye(3) * lam0 * math.exp(e / 3)), mu))[0, 0] for e in (-eps, eps)]
    assert (s[1] - s[0]) / (2 * eps) == pytest.approx(gel.bulk_modulus(lam0), rel=1e-5)
    assert gel.youngs_modulus(lam0) == pytest.approx(3 * Nv / lam0)
    nu = gel.drained_poisson_ratio(lam0)
    assert -1 < nu < 0.5


def test_film_small_strain_limit_is_linear_elasticity():
    film = NeoHookeanFilm(E=2.0, nu=0.3)
    eps = 1e-7
    # uniaxial stress: sigma_11 = E eps when the lateral strains are -nu eps
    A = np.diag([1 + eps, 1 - 0.3 * eps, 1 - 0.3 * eps])
    sigma = value(film.cauchy(matrix_cf(A)))
    assert sigma[0, 0] / eps == pytest.approx(2.0, rel=1e-5)
    assert abs(sigma[1, 1]) / eps < 1e-5


@pytest.mark.parametrize("kwargs,name", [
    (dict(Nv=0.0, chi=0.5), "Nv"), (dict(Nv=-1e-3, chi=0.5), "Nv"), (dict(Nv="x", chi=0.5), "Nv"),
    (dict(Nv=1e-3, chi=-0.1), "chi"), (dict(Nv=1e-3, chi=2.0), "chi"),
])
def test_bad_gel_parameters(kwargs, name):
    with pytest.raises(ValueError, match=name):
        FloryRehnerGel(**kwargs)


def test_bad_film_parameters():
    with pytest.raises(ValueError, match="nu"):
        NeoHookeanFilm(E=1.0, nu=0.5)
    with pytest.raises(ValueError, match="E"):
        NeoHookeanFilm(E=0.0, nu=0.3)


def test_no_swollen_state_above_mu_max():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    with pytest.raises(ValueError, match="mu"):
        gel.lam_free(0.01)  # the maximum of mu_free is 2.8e-4 (MODEL.md numbers give its location)
    with pytest.raises(ValueError, match="lam0"):
        gel.shear_modulus(1.0)
