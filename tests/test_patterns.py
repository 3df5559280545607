"""Pattern analysis on synthetic signals with known answers, and the samplers on a small mesh
with fields whose values are known in closed form."""

import math

import ngsolve as ngs
import numpy as np
import pytest
from ngsolve.meshes import MakeStructured2DMesh, MakeStructured3DMesh

from ngsgel.patterns import (
    count_vertices,
    crease_positions,
    fit_sqrt_growth,
    line_wave_number,
    load_drops,
    penetration_depth,
    periodic_peaks,
    sample_on_circle,
    sample_on_line,
    stiffness_drops,
    wave_number,
)


def uniform_angles(n: int) -> np.ndarray:
    return 2 * np.pi * np.arange(n) / n


def polygon_radius(theta: np.ndarray, k: int, phase: float = 0.0) -> np.ndarray:
    """Distance from the centre to the boundary of a regular k-gon with unit circumradius,
    a vertex at angle ``phase``: sharp corners, far from a sinusoid."""
    sector = 2 * np.pi / k
    local = np.mod(theta - phase, sector) - sector / 2
    return np.cos(np.pi / k) / np.cos(local)


# --------------------------------------------------------------------------- wave_number


@pytest.mark.parametrize("k", range(2, 51))
def test_wave_number_at_four_samples_per_wave_with_noise(k):
    rng = np.random.default_rng(k)
    theta = uniform_angles(4 * k)
    signal = 3.0 + 0.8 * np.cos(k * theta + rng.uniform(0, 2 * np.pi)) + 0.1 * rng.standard_normal(theta.size)
    result = wave_number(signal)
    assert result.k == k
    assert result.amplitude == pytest.approx(0.8, abs=0.1)
    assert result.purity > 0.6


@pytest.mark.parametrize("k", [2, 7, 23, 50])
def test_pure_mode_amplitude_is_half_peak_to_peak(k):
    theta = uniform_angles(16 * k)
    signal = -1.0 + 0.37 * np.sin(k * theta + 0.4)
    result = wave_number(signal)
    assert result.k == k
    assert result.amplitude == pytest.approx(0.37, rel=1e-12)
    assert result.amplitude == pytest.approx(np.ptp(signal) / 2, rel=1e-3)
    assert result.purity == pytest.approx(1.0, abs=1e-12)
    assert result.spectrum[0] == pytest.approx(1.0, rel=1e-12)


def test_mixed_mode_reports_dominant_second_and_purity():
    theta = uniform_angles(128)
    result = wave_number(np.cos(12 * theta) + 0.3 * np.cos(25 * theta + 1.0))
    assert (result.k, result.second) == (12, 25)
    assert result.amplitude == pytest.approx(1.0, rel=1e-12)
    assert result.spectrum[25] == pytest.approx(0.3, rel=1e-12)
    assert result.purity == pytest.approx(1 / 1.09, rel=1e-12)


def test_mean_is_not_a_wave():
    theta = uniform_angles(64)
    assert wave_number(100.0 + 1e-3 * np.cos(3 * theta)).k == 3


def test_scattered_angles_by_least_squares():
    rng = np.random.default_rng(1)
    n = 200
    theta = rng.permutation(uniform_angles(n) + rng.uniform(-0.4, 0.4, n) * 2 * np.pi / n)
    signal = 0.5 + np.cos(12 * theta + 0.3) + 0.3 * np.cos(25 * theta)
    result = wave_number(signal, angles=theta, max_mode=40)
    assert (result.k, result.second) == (12, 25)
    assert result.amplitude == pytest.approx(1.0, rel=1e-10)
    assert result.purity == pytest.approx(1 / 1.09, rel=1e-10)


def test_scattered_angles_on_an_arc_are_refused():
    theta = np.linspace(0, 0.5, 100)
    with pytest.raises(ValueError, match="angles do not resolve"):
        wave_number(np.cos(3 * theta), angles=theta, max_mode=20)


def test_wave_number_input_checks():
    theta = uniform_angles(20)
    with pytest.raises(ValueError, match=r"max_mode must be an integer in \[2, 9\]"):
        wave_number(np.cos(3 * theta), max_mode=10)
    with pytest.raises(ValueError, match="no non-constant component"):
        wave_number(np.ones(20))
    with pytest.raises(ValueError, match="values needs at least 5"):
        wave_number([1.0, 2.0, 3.0])


# --------------------------------------------------------------------------- vertices


@pytest.mark.parametrize("k", [3, 4, 5, 6, 8])
def test_polygon_vertices_agree_with_wave_number(k):
    theta = uniform_angles(720)
    # A vertex exactly on the seam theta = 0 must be counted once.
    radius = polygon_radius(theta, k, phase=0.0)
    assert count_vertices(radius) == k
    assert wave_number(radius).k == k
    assert wave_number(radius).purity < 0.999  # a polygon is not a pure sinusoid


def test_vertex_count_ignores_ripples_below_the_prominence_threshold():
    theta = uniform_angles(400)
    signal = np.cos(5 * theta) + 0.05 * np.cos(40 * theta)
    peaks = periodic_peaks(signal)
    assert peaks.count == 5
    assert np.all(peaks.prominences > 1.5)
    assert count_vertices(signal, relative_prominence=0.0) > 5
    assert count_vertices(signal, min_prominence=3.0) == 0


def test_seam_peak_has_its_full_prominence():
    theta = uniform_angles(90)
    peaks = periodic_peaks(np.cos(theta))
    assert peaks.count == 1 and peaks.indices[0] == 0
    assert peaks.prominences[0] == pytest.approx(2.0, rel=1e-12)


# --------------------------------------------------------------------------- lines


@pytest.mark.parametrize("method", ["fft", "peaks"])
def test_line_wavelength_with_trend_noise_and_uneven_sampling(method):
    rng = np.random.default_rng(3)
    x = np.sort(np.concatenate([[0.0, 5.0], rng.uniform(0, 5, 998)]))
    wavelength = 0.37
    values = 0.2 * x + 0.05 * np.sin(2 * np.pi * x / wavelength + 0.7) + 0.002 * rng.standard_normal(x.size)
    result = line_wave_number(values, x, method=method)
    assert result.wavelength == pytest.approx(wavelength, rel=0.01)
    assert result.waves == pytest.approx(5 / wavelength, rel=0.01)
    assert result.amplitude == pytest.approx(0.05, rel=0.1)


def test_line_fft_ignores_a_bow_longer_than_the_window():
    x = np.linspace(0, 4, 801)
    values = 0.5 * (x / 4) ** 2 + 0.02 * np.cos(2 * np.pi * x / 0.25)
    assert line_wave_number(values, x).wavelength == pytest.approx(0.25, rel=0.01)


def test_line_wave_number_needs_two_peaks():
    x = np.linspace(0, 1, 50)
    with pytest.raises(ValueError, match="fewer than two peaks"):
        line_wave_number(np.sin(np.pi * x) ** 4, x, method="peaks")
    with pytest.raises(ValueError, match="x must be strictly increasing"):
        line_wave_number(x, x[::-1])


def test_crease_positions_and_spacing():
    # Cusped creases |sin| at spacing 0.3 from x = 0.05, on a tilted surface, plus a shallow
    # smooth dimple at x = 0.5 that is not a crease.
    x = np.linspace(0, 3, 3001)
    spacing = 0.3
    profile = 0.5 * x + 0.1 * np.abs(np.sin(np.pi * (x - 0.05) / spacing))
    profile -= 0.01 * np.exp(-((x - 0.5) / 0.01) ** 2)
    assert crease_positions(profile, x, min_depth=0.0).positions.size == 11
    creases = crease_positions(profile, x, min_depth=0.02)
    expected = 0.05 + spacing * np.arange(10)
    assert creases.positions == pytest.approx(expected, abs=2e-3)
    assert creases.mean_spacing == pytest.approx(spacing, rel=1e-3)
    assert np.all(creases.depths > 0.02)
    assert math.isnan(crease_positions(profile[:200], x[:200], min_depth=0.02).mean_spacing)


def test_penetration_depth_of_exponential_decay():
    # A = exp(-(R - r)/l) reaches a fraction f at R - r = l ln(1/f).
    r = np.linspace(0, 1, 2001)
    ell = 0.08
    amplitude = 0.3 * np.exp(-(1 - r) / ell)
    assert penetration_depth(amplitude, r) == pytest.approx(ell * math.log(20), rel=1e-4)
    assert penetration_depth(amplitude[::-1], r[::-1], fraction=0.5) == pytest.approx(ell * math.log(2), rel=1e-4)
    # The edge can sit inside the samples (e.g. a plate's rim zone excluded).
    assert penetration_depth(amplitude, r, edge=0.9) == pytest.approx(ell * math.log(20), rel=1e-4)


def test_penetration_depth_of_a_wave_filling_the_plate():
    r = np.linspace(0.0, 1.0, 11)
    assert penetration_depth(np.full(11, 0.2), r) == pytest.approx(1.0)
    # Linear decay to zero at r = 0.5: 5 % of the edge value is reached at R - r = 0.475.
    assert penetration_depth(np.clip(2 * r - 1, 0, None), r) == pytest.approx(0.475, rel=1e-12)
    with pytest.raises(ValueError, match=r"fraction must lie in \(0, 1.0\)"):
        penetration_depth(r, r, fraction=1.5)


# --------------------------------------------------------------------------- load paths


def sawtooth_path(noise: float, seed: int = 0):
    """Rising force with drops of 5 %, 7 % and 40 % at d = 1, 2, 3 and small wiggles."""
    d = np.linspace(0, 4, 4001)
    force = d.copy()
    for at, drop in ((1.0, 0.05), (2.0, 0.07), (3.0, 0.40)):
        force = np.where(d > at, force - drop * np.interp(at, d, force) * np.clip((d - at) / 0.002, 0, 1), force)
    rng = np.random.default_rng(seed)
    return d, force + noise * np.sin(200 * d) * (d > 0.1) + 1e-4 * rng.standard_normal(d.size)


def test_load_drops_found_with_their_size():
    d, force = sawtooth_path(noise=1e-3)
    events = load_drops(d, force, min_relative=0.01)
    assert [round(e.displacement, 2) for e in events] == [1.0, 2.0, 3.0]
    assert [e.relative_drop for e in events] == pytest.approx([0.05, 0.07, 0.40], abs=0.005)
    assert all(e.trough_displacement == pytest.approx(e.displacement + 0.002, abs=0.002) for e in events)


def test_load_drop_threshold_filters_small_events_and_wiggles():
    d, force = sawtooth_path(noise=1e-3)
    assert [round(e.relative_drop, 2) for e in load_drops(d, force, min_relative=0.06)] == [0.07, 0.40]
    monotone = np.sqrt(np.linspace(0, 1, 500)) + 1e-4 * np.sin(np.linspace(0, 300, 500))
    assert load_drops(np.linspace(0, 1, 500), monotone) == ()


def test_drop_at_the_end_of_the_path_is_reported():
    d = np.linspace(0, 1, 11)
    force = np.array([0, 1, 2, 3, 4, 5, 5, 4, 3, 2, 1], dtype=float)
    (event,) = load_drops(d, force)
    # On a plateau the drop starts where the force begins to fall.
    assert (event.displacement, event.trough_displacement) == pytest.approx((0.6, 1.0))
    assert event.relative_drop == pytest.approx(0.8)


def test_stiffness_drop_at_a_kink():
    rng = np.random.default_rng(5)
    d = np.linspace(0, 1, 201)
    force = np.where(d < 0.5, d, 0.5 + 0.68 * (d - 0.5)) + 1e-5 * rng.standard_normal(d.size)
    (kink,) = stiffness_drops(d, force, min_relative=0.1, window=5)
    assert kink.displacement == pytest.approx(0.5, abs=0.005)
    assert kink.relative_drop == pytest.approx(0.32, abs=0.01)
    assert kink.slope_before == pytest.approx(1.0, abs=0.01)
    assert kink.slope_after == pytest.approx(0.68, abs=0.01)


def test_smooth_response_has_no_stiffness_drop():
    d = np.linspace(1, 2, 201)
    assert stiffness_drops(d, np.sqrt(d), min_relative=0.05) == ()
    with pytest.raises(ValueError, match=r"window must be an integer in \[1, 100\]"):
        stiffness_drops(d, d, window=101)


def test_sqrt_growth_fit_recovers_onset_and_prefactor():
    rng = np.random.default_rng(7)
    eps = np.linspace(0.8, 2.0, 60)
    amplitude = 0.3 * np.sqrt(np.maximum(eps / 1.1 - 1, 0)) + 0.002 * rng.standard_normal(eps.size)
    fit = fit_sqrt_growth(eps, amplitude)
    assert fit.eps_cr == pytest.approx(1.1, rel=0.01)
    assert fit.A == pytest.approx(0.3, rel=0.03)
    assert fit.residual == pytest.approx(0.002, rel=0.3)
    with pytest.raises(ValueError, match="at least two samples"):
        fit_sqrt_growth(eps, np.zeros(eps.size))


# --------------------------------------------------------------------------- samplers


@pytest.fixture(scope="module")
def square_mesh():
    return MakeStructured2DMesh(quads=False, nx=8, ny=8, mapping=lambda x, y: (2 * x - 1, 2 * y - 1))


def test_circle_sampling_of_a_gridfunction_counts_its_waves(square_mesh):
    # r^3 cos(3 theta) = x^3 - 3 x y^2 is a cubic, represented exactly by order-3 elements.
    gf = ngs.GridFunction(ngs.H1(square_mesh, order=3))
    gf.Set(ngs.x**3 - 3 * ngs.x * ngs.y**2)
    samples = sample_on_circle(gf, square_mesh, center=(0.0, 0.0), radius=0.8, n=48)
    assert samples.values.shape == (48,)
    assert samples.values == pytest.approx(0.8**3 * np.cos(3 * samples.parameter), abs=1e-10)
    result = wave_number(samples.values)
    assert result.k == 3 and result.amplitude == pytest.approx(0.512, rel=1e-9)


def test_circle_off_centre_and_vector_field(square_mesh):
    samples = sample_on_circle(ngs.CF((ngs.x, ngs.y)), square_mesh, center=(0.1, -0.2), radius=0.5, n=12)
    expected = np.column_stack([0.1 + 0.5 * np.cos(samples.parameter), -0.2 + 0.5 * np.sin(samples.parameter)])
    assert samples.points == pytest.approx(expected, abs=1e-14)
    assert samples.values == pytest.approx(expected, abs=1e-12)


def test_sampling_outside_the_mesh_is_an_error(square_mesh):
    with pytest.raises(ValueError, match="radius: .* points lie outside the mesh"):
        sample_on_circle(ngs.x, square_mesh, center=(0.0, 0.0), radius=1.2, n=16)
    with pytest.raises(ValueError, match="center must be 2 finite coordinates"):
        sample_on_circle(ngs.x, square_mesh, center=(0.0, 0.0, 0.0), radius=0.5, n=16)


def test_line_sampling(square_mesh):
    samples = sample_on_line(ngs.x * ngs.y, square_mesh, start=(-0.9, -0.5), end=(0.9, 0.7), n=7)
    assert samples.parameter[-1] == pytest.approx(math.hypot(1.8, 1.2))
    assert samples.values == pytest.approx(samples.points[:, 0] * samples.points[:, 1], abs=1e-12)


def test_circle_in_a_tilted_plane_of_a_3d_mesh():
    mesh = MakeStructured3DMesh(hexes=False, nx=2, ny=2, nz=2)
    center = np.array([0.5, 0.5, 0.5])
    normal = np.array([1.0, 1.0, 0.0])
    samples = sample_on_circle(ngs.CF((ngs.x, ngs.y, ngs.z)), mesh, center=center, radius=0.3, n=24,
                               normal=normal)
    offsets = samples.points - center
    assert np.linalg.norm(offsets, axis=1) == pytest.approx(np.full(24, 0.3), rel=1e-12)
    assert offsets @ normal == pytest.approx(np.zeros(24), abs=1e-14)
    assert samples.values == pytest.approx(samples.points, abs=1e-12)
    # Counter-clockwise seen from the tip of the normal.
    assert np.dot(np.cross(offsets[0], offsets[1]), normal) > 0
