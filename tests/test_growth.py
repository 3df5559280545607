"""Which mode an overdamped, load-ramped run shows first (``ngsgel.stability.fastest_growing``)."""

import math

import numpy as np
import pytest

from ngsgel.stability import fastest_growing, growth_exponents

# Two modes with eigenvalues linear in the load, omega_j = a_j (l_j - load): mode j loses
# stability at l_j and grows by G_j = a_j (load - l_j)^2 / 2 after it, so it reaches a threshold
# T at l_j + sqrt(2 T / a_j). Mode 0 (l 0, a 1) goes first; mode 1 (l 0.5, a 16) overtakes it
# for T > 2/9 (sqrt(2 T) 3/4 = 1/2).
ONSET = np.array([0.0, 0.5])
SLOPE = np.array([1.0, 16.0])
LOAD = np.linspace(-0.3, 2.0, 7)  # no sample on either onset: the sign change inside an interval is exact
OMEGA = SLOPE * (ONSET - LOAD[:, None])


def test_growth_exponents_are_the_closed_form():
    G = growth_exponents(LOAD, OMEGA)
    exact = 0.5 * SLOPE * np.maximum(LOAD[:, None] - ONSET, 0.0) ** 2
    assert np.allclose(G, exact, rtol=1e-13, atol=1e-15)


@pytest.mark.parametrize("threshold, mode", [(0.05, 0), (0.2, 0), (0.25, 1), (1.0, 1)])
def test_fastest_growing_mode_and_its_load(threshold, mode):
    selection = fastest_growing(LOAD, OMEGA, threshold)
    assert selection.index == mode
    assert selection.load == pytest.approx(ONSET[mode] + math.sqrt(2 * threshold / SLOPE[mode]), rel=1e-12)
    assert selection.exponents[mode] == pytest.approx(threshold, rel=1e-10)
    assert selection.exponents[1 - mode] < threshold


def test_the_switch_between_the_two_modes_is_where_the_closed_form_puts_it():
    below, above = (fastest_growing(LOAD, OMEGA, 2 / 9 * f) for f in (1 - 1e-6, 1 + 1e-6))
    assert (below.index, above.index) == (0, 1)
    assert below.load == pytest.approx(2 / 3, rel=1e-5) and above.load == pytest.approx(2 / 3, rel=1e-5)


def test_no_mode_reaches_a_threshold_beyond_the_last_load():
    assert fastest_growing(LOAD, OMEGA, 0.5 * 16 * 1.5**2 * 1.001) is None


def test_bad_input_is_refused():
    with pytest.raises(ValueError, match="threshold"):
        fastest_growing(LOAD, OMEGA, 0.0)
    with pytest.raises(ValueError, match="increase"):
        growth_exponents(LOAD[::-1], OMEGA)
    with pytest.raises(ValueError, match="eigenvalues must be"):
        growth_exponents(LOAD, OMEGA[:-1])
