"""``stability.spectrum`` on matrices with a known spectrum: negative eigenvalues far below a cluster
next to zero (a state in the middle of a snap) are found, with few eigen solves."""

import numpy as np
import pytest
import scipy.sparse as sp

from ngsgel import stability
from ngsgel.stability import spectrum


class _Matrices:
    """What ``spectrum`` asks of a problem when given ``K`` and ``M``: free dofs and a volume."""

    def __init__(self, n: int):
        self.free_mask = np.ones(n, dtype=bool)

    def integrate(self, cf) -> float:
        return 1.0


def _pencil(eigenvalues: np.ndarray, seed: int = 0) -> tuple[sp.csc_matrix, sp.csc_matrix]:
    """A sparse symmetric ``K`` and SPD ``M`` whose generalised eigenvalues are ``eigenvalues``:
    both congruent to diagonals by one sparse, well-conditioned bidiagonal ``B``."""
    rng = np.random.default_rng(seed)
    n = len(eigenvalues)
    B = sp.diags([np.ones(n), 0.3 * rng.standard_normal(n - 1)], [0, 1], format="csc")
    weights = rng.uniform(0.5, 2.0, n)
    M = (B.T @ sp.diags(weights) @ B).tocsc()
    K = (B.T @ sp.diags(weights * eigenvalues) @ B).tocsc()
    return K, M


def _counting_eigsh(monkeypatch) -> list:
    calls = []
    real = stability.sla.eigsh

    def eigsh(*args, **kwargs):
        calls.append(kwargs.get("sigma"))
        return real(*args, **kwargs)

    monkeypatch.setattr(stability.sla, "eigsh", eigsh)
    return calls


@pytest.mark.parametrize("far", [-0.05, -3.0])
def test_negative_eigenvalues_far_below_a_cluster_at_zero_are_found_in_two_solves(monkeypatch, far):
    # a stiff spectrum up to 1e5 (the shift's scale) with many soft modes near zero, as a thin
    # shell's, and a negative pair 5e3 ... 3e5 times the cluster's width below it
    rng = np.random.default_rng(1)
    exact = np.concatenate([[far, 0.8 * far], rng.uniform(1e-6, 1e-5, 300), rng.uniform(1.0, 1e5, 300)])
    K, M = _pencil(exact)
    calls = _counting_eigsh(monkeypatch)
    found = spectrum(_Matrices(len(exact)), count=1, K=K, M=M, past_negative=True)
    lowest = np.sort(exact)[:3]
    assert found.negative == 2
    # about a shift next to the pair, eigenvalues are exact to round-off of their distance from it
    np.testing.assert_allclose(found.eigenvalues, lowest, rtol=1e-8, atol=1e-12 * abs(far))
    assert len(calls) == 2  # one about the shift next to zero, one below the pair


def test_the_negatives_nearest_zero_when_more_are_negative_than_asked():
    exact = np.concatenate([[-2.0, -1.5, -1.0, -0.4], np.linspace(1e-4, 1e-3, 50), np.linspace(1.0, 1e4, 50)])
    K, M = _pencil(exact, seed=3)
    found = spectrum(_Matrices(len(exact)), count=2, K=K, M=M)
    assert found.negative == 4
    assert np.all(found.eigenvalues < 0) and len(found.eigenvalues) == 2


def test_negatives_next_to_zero_need_one_solve(monkeypatch):
    exact = np.concatenate([[-2e-7, -1e-7], np.linspace(1e-6, 1e-5, 100), np.linspace(1.0, 1e5, 100)])
    K, M = _pencil(exact, seed=2)
    calls = _counting_eigsh(monkeypatch)
    found = spectrum(_Matrices(len(exact)), count=1, K=K, M=M, past_negative=True)
    np.testing.assert_allclose(found.eigenvalues, np.sort(exact)[:3], rtol=1e-8)
    assert len(calls) == 1


@pytest.mark.parametrize("zero", [-1e-14, 1e-14])
def test_a_zero_eigenvalue_of_a_singular_tangent_is_found_whatever_sign_round_off_gives_it(zero):
    # a free rigid motion: its eigenvalue is zero to round-off of the scale 1e3, and the inertia
    # counts it as negative or not by that round-off
    exact = np.concatenate([[zero], np.linspace(1e-3, 1e-2, 60), np.linspace(1.0, 1e3, 60)])
    K, M = _pencil(exact, seed=4)
    found = spectrum(_Matrices(len(exact)), count=3, K=K, M=M)
    assert found.negative == (1 if zero < 0 else 0)
    assert abs(found.eigenvalues[0]) < 1e-10 * 1e3
    np.testing.assert_allclose(found.eigenvalues[1:], exact[1:3], rtol=1e-8)


def test_a_negative_eigenvalue_returned_as_a_round_off_zero_is_the_crossing_one():
    # at a critical point to round-off the inertia may count the tracked eigenvalue negative while
    # the eigen solve returns it as a tiny non-negative number (the graded disk p = 10, h = 0.4, in
    # the driver's location): it is still the crossing eigenvalue, found inside the zero band only
    modes = np.eye(3)
    at_critical = stability.Spectrum(eigenvalues=np.array([-0.5, 3e-15, 1.0]), modes=modes, negative=2,
                                      zero_band=1e-10)
    assert at_critical.crossing(0)[0] == -0.5
    value, mode = at_critical.crossing(1)
    assert value == 3e-15 and np.array_equal(mode, modes[:, 1])
    assert at_critical.crossing(2)[0] == 1.0
    for spectrum_without_it in (stability.Spectrum(eigenvalues=np.array([-0.5, 3e-15, 1.0]), modes=modes, negative=2),
                                stability.Spectrum(eigenvalues=np.array([-0.5, 1e-6, 1.0]), modes=modes, negative=2,
                                                   zero_band=1e-10)):
        # read as the set above a missing lowest one, as before the band
        with pytest.raises(ValueError, match="eigenvalue number 0 is not in this spectrum"):
            spectrum_without_it.crossing(0)


@pytest.mark.parametrize("zero", [-1e-14, 1e-14])
def test_the_spectrum_holds_the_crossing_eigenvalue_at_a_critical_point_to_round_off(zero):
    exact = np.concatenate([[-0.5, zero], np.linspace(1e-3, 1e-2, 60), np.linspace(1.0, 1e3, 60)])
    K, M = _pencil(exact, seed=5)
    found = spectrum(_Matrices(len(exact)), count=1, K=K, M=M, past_negative=True)
    assert found.zero_band == pytest.approx(1e-10 * np.max(np.abs(K.diagonal() / M.diagonal())))
    for index in range(found.negative + 1):  # each eigenvalue whose sign change the count can see
        value, _ = found.crossing(index)
        assert value == pytest.approx(exact[index], abs=1e-10 * 1e3)
