"""Pattern analysis of sampled fields and load paths: wave numbers, vertices, creases,
penetration depth, load and stiffness drops, and square-root post-buckling growth.

Everything except the two samplers works on plain numpy arrays, so a scene can analyse
saved data without NGSolve. The samplers evaluate an NGSolve CoefficientFunction (or
GridFunction) at points through ``mesh(x, y[, z])``, which locates all points in one call.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import ArrayLike
from scipy.optimize import least_squares
from scipy.signal import find_peaks

if TYPE_CHECKING:
    import ngsolve

__all__ = [
    "Creases",
    "FieldSamples",
    "LineWaveAnalysis",
    "LoadDrop",
    "Peaks",
    "SqrtGrowthFit",
    "StiffnessDrop",
    "WaveAnalysis",
    "count_vertices",
    "crease_positions",
    "fit_sqrt_growth",
    "line_wave_number",
    "load_drops",
    "penetration_depth",
    "periodic_peaks",
    "power_law_fit",
    "sample_on_circle",
    "sample_on_line",
    "stiffness_drops",
    "wave_number",
]

# Least-squares fits on scattered angles are refused beyond this condition number: the mode
# amplitudes would be dominated by round-off and noise rather than by the signal.
_MAX_CONDITION = 1e8


# --------------------------------------------------------------------------- results


@dataclass(frozen=True, eq=False)
class WaveAnalysis:
    """Fourier content of a signal sampled around a closed circle.

    ``spectrum[m]`` is the amplitude (half peak-to-peak) of mode ``m`` for ``m = 0 ...
    max_mode`` (``spectrum[0]`` is ``|mean|``). ``k`` is the dominant mode ``>= 1`` with
    amplitude ``amplitude``, ``second`` the runner-up, and ``purity`` the fraction of the
    energy of modes ``>= 1`` that sits in mode ``k`` (1 for a pure wave).
    """

    k: int
    amplitude: float
    purity: float
    spectrum: np.ndarray
    second: int


@dataclass(frozen=True, eq=False)
class Peaks:
    """Peaks of a periodic signal: sample indices (ascending) and their prominences."""

    count: int
    indices: np.ndarray
    prominences: np.ndarray


@dataclass(frozen=True)
class LineWaveAnalysis:
    """Dominant wave along an open line: ``wavelength``, ``amplitude`` (half peak-to-peak)
    and ``waves`` = line length / wavelength."""

    wavelength: float
    amplitude: float
    waves: float


@dataclass(frozen=True, eq=False)
class Creases:
    """Local minima deeper than the threshold: positions, depths (prominence of the
    minimum) and the mean spacing of neighbours (NaN with fewer than two creases)."""

    positions: np.ndarray
    depths: np.ndarray
    mean_spacing: float


@dataclass(frozen=True)
class LoadDrop:
    """A fall of the force from a peak to the following trough along the path."""

    displacement: float
    force: float
    trough_displacement: float
    trough_force: float
    relative_drop: float


@dataclass(frozen=True)
class StiffnessDrop:
    """A kink: the slope ``dF/dd`` falls from ``slope_before`` to ``slope_after`` at
    ``displacement``; ``relative_drop = (slope_before - slope_after) / slope_before``."""

    displacement: float
    slope_before: float
    slope_after: float
    relative_drop: float


@dataclass(frozen=True)
class SqrtGrowthFit:
    """``amplitude = A sqrt(eps/eps_cr - 1)`` above ``eps_cr`` (zero below); ``residual`` is
    the root-mean-square misfit of the amplitudes."""

    A: float
    eps_cr: float
    residual: float


@dataclass(frozen=True, eq=False)
class FieldSamples:
    """Field values at sample points: ``parameter`` is the angle (circle) or the distance
    from the start (line), ``points`` has shape ``(n, mesh.dim)``, ``values`` shape ``(n,)``
    for a scalar field and ``(n, components)`` otherwise."""

    parameter: np.ndarray
    points: np.ndarray
    values: np.ndarray


# --------------------------------------------------------------------------- validation


def _signal(name: str, values: ArrayLike, *, min_length: int) -> np.ndarray:
    array = np.asarray(values, dtype=float)
    if array.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional, got shape {array.shape}")
    if array.size < min_length:
        raise ValueError(f"{name} needs at least {min_length} samples, got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite everywhere")
    return array


def _paired(name_x: str, x: ArrayLike, name_y: str, y: ArrayLike, *, min_length: int) -> tuple[np.ndarray, np.ndarray]:
    xa = _signal(name_x, x, min_length=min_length)
    ya = _signal(name_y, y, min_length=min_length)
    if xa.size != ya.size:
        raise ValueError(f"{name_x} and {name_y} must have the same length, got {xa.size} and {ya.size}")
    return xa, ya


def _increasing(name: str, x: np.ndarray) -> None:
    if np.any(np.diff(x) <= 0):
        raise ValueError(f"{name} must be strictly increasing")


def _fraction(name: str, value: float, *, high: float = 1.0, zero_allowed: bool = False) -> float:
    ok = isinstance(value, (int, float, np.floating)) and not math.isnan(value)
    if not ok or not (0.0 <= value if zero_allowed else 0.0 < value) or not value < high:
        opening = "[" if zero_allowed else "("
        raise ValueError(f"{name} must lie in {opening}0, {high}), got {value!r}")
    return float(value)


def _threshold(values: np.ndarray, absolute: float | None, relative: float, names: tuple[str, str]) -> float:
    """An absolute level if given, else a fraction of the signal's range."""
    relative = _fraction(names[1], relative, zero_allowed=True)
    if absolute is None:
        return relative * float(np.ptp(values))
    if not isinstance(absolute, (int, float, np.floating)) or not math.isfinite(absolute) or absolute < 0:
        raise ValueError(f"{names[0]} must be a finite number >= 0, got {absolute!r}")
    return float(absolute)


# --------------------------------------------------------------------------- circles


def wave_number(values: ArrayLike, *, angles: ArrayLike | None = None,
                max_mode: int | None = None) -> WaveAnalysis:
    """Dominant circumferential mode of ``values`` sampled around a closed circle.

    Without ``angles`` the ``N`` samples are taken as uniform, ``theta_i = 2 pi i / N``, and
    the spectrum comes from the FFT; with ``angles`` (radians, any order) it is the least
    squares fit of ``a_0 + sum_m (a_m cos m theta + b_m sin m theta)``.

    Sampling: ``N >= 2 max_mode + 1`` is required (one unknown per coefficient; on uniform
    samples it is the Nyquist limit). The default ``max_mode`` is ``(N - 1) // 2`` for uniform
    and ``(N - 1) // 4`` for scattered angles, about four samples per wave, which also keeps
    the least-squares problem well conditioned. For a clean amplitude of the dominant mode use
    at least four samples per wave of it; content above ``N / 2`` aliases onto lower modes.
    """
    v = _signal("values", values, min_length=5)
    n = v.size
    limit = (n - 1) // 2
    if max_mode is None:
        max_mode = limit if angles is None else max(2, (n - 1) // 4)
    if not isinstance(max_mode, (int, np.integer)) or not 2 <= max_mode <= limit:
        raise ValueError(f"max_mode must be an integer in [2, {limit}] for {n} samples "
                         f"(N >= 2 max_mode + 1), got {max_mode!r}")

    if angles is None:
        coefficients = np.fft.rfft(v)[: max_mode + 1] / n
        spectrum = 2.0 * np.abs(coefficients)
        spectrum[0] = abs(coefficients[0].real)
    else:
        theta = _signal("angles", angles, min_length=n)
        if theta.size != n:
            raise ValueError(f"angles and values must have the same length, got {theta.size} and {n}")
        modes = np.arange(1, max_mode + 1)
        phase = np.outer(theta, modes)
        design = np.hstack([np.ones((n, 1)), np.cos(phase), np.sin(phase)])
        solution, _, _, singular = np.linalg.lstsq(design, v, rcond=None)
        if singular[-1] <= 0 or singular[0] / singular[-1] > _MAX_CONDITION:
            raise ValueError(f"angles do not resolve modes up to max_mode={max_mode}: sample "
                             "more evenly or lower max_mode")
        spectrum = np.concatenate([[abs(solution[0])],
                                   np.hypot(solution[1: max_mode + 1], solution[max_mode + 1:])])

    energy = spectrum[1:] ** 2
    total = float(energy.sum())
    if total == 0.0:
        raise ValueError("values has no non-constant component: no wave to count")
    order = np.argsort(energy)[::-1]
    k = int(order[0]) + 1
    return WaveAnalysis(k=k, amplitude=float(spectrum[k]), purity=float(energy[k - 1] / total),
                        spectrum=spectrum, second=int(order[1]) + 1)


def periodic_peaks(values: ArrayLike, *, min_prominence: float | None = None,
                   relative_prominence: float = 0.1) -> Peaks:
    """Peaks of a periodic signal (the last sample neighbours the first) whose prominence is
    at least ``min_prominence`` or, if that is not given, ``relative_prominence * (max - min)``.

    Tiling the signal three times and keeping the middle copy gives every peak, including one
    on the seam, its true periodic prominence.
    """
    v = _signal("values", values, min_length=3)
    level = _threshold(v, min_prominence, relative_prominence, ("min_prominence", "relative_prominence"))
    if np.ptp(v) == 0.0:
        return Peaks(count=0, indices=np.zeros(0, dtype=int), prominences=np.zeros(0))
    n = v.size
    peaks, properties = find_peaks(np.concatenate([v, v, v]), prominence=max(level, np.finfo(float).tiny))
    middle = (peaks >= n) & (peaks < 2 * n)
    return Peaks(count=int(middle.sum()), indices=peaks[middle] - n,
                 prominences=properties["prominences"][middle])


def count_vertices(values: ArrayLike, *, min_prominence: float | None = None,
                   relative_prominence: float = 0.1) -> int:
    """Number of vertices (peaks) of a periodic signal, e.g. the radius of a polygonal
    cross-section against angle; see :func:`periodic_peaks` for the threshold."""
    return periodic_peaks(values, min_prominence=min_prominence,
                          relative_prominence=relative_prominence).count


# --------------------------------------------------------------------------- lines


def _refine_extremum(x: np.ndarray, v: np.ndarray, i: int) -> float:
    """Vertex of the parabola through the samples ``i - 1, i, i + 1`` (the sample itself at an
    end or where the three points are collinear)."""
    if i == 0 or i == v.size - 1:
        return float(x[i])
    c2, c1, _ = np.polyfit(x[i - 1: i + 2] - x[i], v[i - 1: i + 2], 2)
    if c2 == 0.0:
        return float(x[i])
    return float(np.clip(x[i] - c1 / (2.0 * c2), x[i - 1], x[i + 1]))


def line_wave_number(values: ArrayLike, x: ArrayLike, *, method: Literal["fft", "peaks"] = "fft",
                     min_waves: float = 2.0, relative_prominence: float = 0.3) -> LineWaveAnalysis:
    """Dominant wavelength of a non-periodic signal ``values(x)`` (``x`` strictly increasing).

    ``method="fft"``: the linear trend is removed (a tilted or bent layer is not a wave), a
    Hann window suppresses the leakage from the open ends, the spectrum is zero-padded and its
    peak refined by Gaussian interpolation; only wavelengths with at least ``min_waves`` waves
    on the line are searched. ``method="peaks"``: mean spacing of the maxima whose prominence
    exceeds ``relative_prominence`` of the detrended range, located to sub-sample accuracy;
    the amplitude is half the mean prominence. Non-uniform ``x`` is resampled linearly.
    """
    xa, v = _paired("x", x, "values", values, min_length=8)
    _increasing("x", xa)
    if method not in ("fft", "peaks"):
        raise ValueError(f"method must be 'fft' or 'peaks', got {method!r}")
    length = float(xa[-1] - xa[0])
    grid = np.linspace(xa[0], xa[-1], xa.size)
    v = np.interp(grid, xa, v)
    v = v - np.polyval(np.polyfit(grid, v, 1), grid)
    spacing = length / (grid.size - 1)

    if method == "peaks":
        level = _fraction("relative_prominence", relative_prominence) * float(np.ptp(v))
        peaks, properties = find_peaks(v, prominence=max(level, np.finfo(float).tiny))
        if peaks.size < 2:
            raise ValueError("values has fewer than two peaks above relative_prominence: no wavelength")
        positions = [_refine_extremum(grid, v, int(i)) for i in peaks]
        wavelength = (positions[-1] - positions[0]) / (len(positions) - 1)
        amplitude = 0.5 * float(np.mean(properties["prominences"]))
        return LineWaveAnalysis(wavelength=wavelength, amplitude=amplitude, waves=length / wavelength)

    if not isinstance(min_waves, (int, float)) or not 0 < min_waves < (grid.size - 1) / 2:
        raise ValueError(f"min_waves must lie in (0, {(grid.size - 1) / 2}) for {grid.size} samples, "
                         f"got {min_waves!r}")
    window = np.hanning(grid.size)
    n_fft = 1 << int(math.ceil(math.log2(16 * grid.size)))
    magnitude = np.abs(np.fft.rfft(v * window, n_fft))
    frequency = np.fft.rfftfreq(n_fft, d=spacing)
    allowed = np.flatnonzero(frequency >= min_waves / length)
    i = int(allowed[np.argmax(magnitude[allowed])])
    if magnitude[i] == 0.0:
        raise ValueError("values is a straight line after detrending: no wave")
    peak_frequency = frequency[i]
    if 0 < i < magnitude.size - 1 and np.all(magnitude[i - 1: i + 2] > 0):
        # A Hann-windowed sinusoid has a nearly Gaussian main lobe, so a parabola through the
        # log-magnitudes puts the peak within a small fraction of a bin.
        lm, l0, lp = np.log(magnitude[i - 1: i + 2])
        denominator = lm - 2.0 * l0 + lp
        if denominator < 0:
            peak_frequency += 0.5 * (lm - lp) / denominator * (frequency[1] - frequency[0])
    amplitude = 2.0 * float(magnitude[i]) / float(window.sum())
    wavelength = 1.0 / peak_frequency
    return LineWaveAnalysis(wavelength=wavelength, amplitude=amplitude, waves=length / wavelength)


def crease_positions(values: ArrayLike, x: ArrayLike, *, min_depth: float | None = None,
                     relative_depth: float = 0.1) -> Creases:
    """Creases: local minima of ``values(x)`` deeper than ``min_depth`` or, if that is not
    given, ``relative_depth * (max - min)``.

    The depth of a minimum is its prominence, how far it dips below the lower of the highest
    points between it and the nearest deeper minimum on either side, so a surface that is
    tilted or bowed overall still gives each crease its own depth. Positions are refined by a
    parabola through the three samples around each minimum.
    """
    xa, v = _paired("x", x, "values", values, min_length=3)
    _increasing("x", xa)
    level = _threshold(v, min_depth, relative_depth, ("min_depth", "relative_depth"))
    minima, properties = find_peaks(-v, prominence=max(level, np.finfo(float).tiny))
    positions = np.array([_refine_extremum(xa, v, int(i)) for i in minima])
    spacing = float(np.mean(np.diff(positions))) if positions.size >= 2 else math.nan
    return Creases(positions=positions, depths=properties["prominences"], mean_spacing=spacing)


def penetration_depth(amplitude_profile: ArrayLike, r: ArrayLike, *, fraction: float = 0.05,
                      edge: float | None = None) -> float:
    """Distance from the edge inward over which a wave's amplitude decays to ``fraction`` of
    its value at the edge (the thesis's ``l_p``).

    ``r`` are the radii of the amplitude samples (any order); the edge is ``edge`` or, by
    default, ``max(r)``, and the amplitude there is interpolated. Walking inward, the first
    crossing of ``fraction * A(edge)`` is located by linear interpolation. If the amplitude
    never falls that low the wave fills the sampled region and ``edge - min(r)`` is returned.
    """
    ra, amplitude = _paired("r", r, "amplitude_profile", amplitude_profile, min_length=2)
    fraction = _fraction("fraction", fraction)
    order = np.argsort(ra)
    ra, amplitude = ra[order], np.abs(amplitude[order])
    _increasing("r", ra)
    if edge is None:
        edge = float(ra[-1])
    elif not ra[0] < edge <= ra[-1]:
        raise ValueError(f"edge must lie in ({ra[0]}, {ra[-1]}], the sampled radii, got {edge!r}")
    level = fraction * float(np.interp(edge, ra, amplitude))
    if level == 0.0:
        raise ValueError("amplitude_profile is zero at the edge: no wave to follow inward")
    inside = np.flatnonzero(ra < edge)[::-1]
    previous_r, previous_a = edge, float(np.interp(edge, ra, amplitude))
    for j in inside:
        if amplitude[j] <= level:
            t = (previous_a - level) / (previous_a - amplitude[j])
            return edge - (previous_r + t * (ra[j] - previous_r))
        previous_r, previous_a = float(ra[j]), float(amplitude[j])
    return edge - float(ra[0])


# --------------------------------------------------------------------------- load paths


def load_drops(displacement: ArrayLike, force: ArrayLike, *,
               min_relative: float = 0.005) -> tuple[LoadDrop, ...]:
    """Falls of the force along a load path, in path order.

    A drop starts at a peak and is accepted once the force has fallen ``min_relative`` of the
    peak force below it; its trough is the lowest force before the force recovers by that same
    amount. The hysteresis makes wiggles smaller than the threshold (Newton noise, small
    oscillations) neither start nor split a drop. Only positive peak forces start drops: give
    the force with the loading direction positive. ``relative_drop = (peak - trough) / peak``.
    """
    d, f = _paired("displacement", displacement, "force", force, min_length=2)
    min_relative = _fraction("min_relative", min_relative)
    events: list[LoadDrop] = []

    def record(peak: int, trough: int) -> None:
        events.append(LoadDrop(displacement=float(d[peak]), force=float(f[peak]),
                               trough_displacement=float(d[trough]), trough_force=float(f[trough]),
                               relative_drop=float((f[peak] - f[trough]) / f[peak])))

    peak, trough, falling = 0, 0, False
    for i in range(1, f.size):
        threshold = min_relative * f[peak]
        if not falling:
            if f[i] >= f[peak]:
                peak = i
            elif f[peak] > 0 and f[peak] - f[i] >= threshold:
                falling, trough = True, i
        elif f[i] <= f[trough]:
            trough = i
        elif f[i] - f[trough] >= threshold:
            record(peak, trough)
            falling, peak = False, i
    if falling:
        record(peak, trough)
    return tuple(events)


def stiffness_drops(displacement: ArrayLike, force: ArrayLike, *, min_relative: float = 0.1,
                    window: int = 4) -> tuple[StiffnessDrop, ...]:
    """Kinks of a load path where the slope ``dF/dd`` falls by at least ``min_relative``.

    At every sample the slopes of straight-line fits to the ``window + 1`` samples before it
    and the ``window + 1`` after it (both including it) are compared; local maxima of the
    relative fall, at least ``window`` samples apart, are the kinks, located to within a
    sample. The fits average out noise; a smooth but strongly curved response also registers
    if its slope changes by ``min_relative`` across ``2 window`` samples. Only positive
    ``slope_before`` counts (a stiffness, not an unloading branch).
    """
    d, f = _paired("displacement", displacement, "force", force, min_length=3)
    min_relative = _fraction("min_relative", min_relative, high=math.inf)
    if not isinstance(window, (int, np.integer)) or not 1 <= window <= (d.size - 1) // 2:
        raise ValueError(f"window must be an integer in [1, {(d.size - 1) // 2}] for {d.size} samples, "
                         f"got {window!r}")
    n = d.size
    xs = sliding_window_view(d, window + 1)
    ys = sliding_window_view(f, window + 1)
    xs = xs - xs.mean(axis=1, keepdims=True)
    with np.errstate(invalid="ignore", divide="ignore"):
        # slope[j] fits samples j ... j + window; a repeated displacement gives NaN, no kink.
        slope = np.sum(xs * (ys - ys.mean(axis=1, keepdims=True)), axis=1) / np.sum(xs * xs, axis=1)
    before = np.full(n, np.nan)
    after = np.full(n, np.nan)
    before[window: n - window] = slope[: n - 2 * window]
    after[window: n - window] = slope[window: n - window]
    with np.errstate(invalid="ignore", divide="ignore"):
        relative = np.where(before > 0, (before - after) / before, np.nan)
    # Padding with -inf lets a kink at the first or last fitted sample still be a local maximum.
    padded = np.concatenate([[-np.inf], np.nan_to_num(relative, nan=-np.inf), [-np.inf]])
    kinks, _ = find_peaks(padded, height=min_relative, distance=window)
    return tuple(StiffnessDrop(displacement=float(d[i]), slope_before=float(before[i]),
                               slope_after=float(after[i]), relative_drop=float(relative[i]))
                 for i in kinks - 1)


def fit_sqrt_growth(eps_ratio: ArrayLike, amplitude: ArrayLike) -> SqrtGrowthFit:
    """Fit ``amplitude = A sqrt(eps/eps_cr - 1)`` (zero for ``eps < eps_cr``), the
    supercritical-pitchfork growth of a buckling amplitude (thesis fig. 4-5).

    ``eps_ratio`` is the load measure in any scale (e.g. ``eps / eps_cr`` of an analysis, so a
    fitted ``eps_cr`` near 1 means the onsets agree); ``eps_cr`` comes back in that scale.
    Pre-buckling samples with zero amplitude may be included. The start comes from the
    linear law ``amplitude^2 = (A^2/eps_cr) eps - A^2`` on the buckled samples; nonlinear least
    squares on the amplitudes themselves then finishes the fit.
    """
    eps, a = _paired("eps_ratio", eps_ratio, "amplitude", amplitude, min_length=3)
    if np.any(eps <= 0):
        raise ValueError("eps_ratio must be > 0 everywhere")
    a = np.abs(a)
    buckled = a > 0.05 * a.max() if a.max() > 0 else np.zeros(a.size, dtype=bool)
    if buckled.sum() < 2:
        raise ValueError("amplitude needs at least two samples clearly above zero to fit a growth law")
    slope, intercept = np.polyfit(eps[buckled], a[buckled] ** 2, 1)
    if slope > 0 and intercept < 0:
        A0, eps0 = math.sqrt(-intercept), -intercept / slope
    else:
        eps0 = 0.99 * float(eps[buckled].min())
        A0 = float(a[buckled].max()) / math.sqrt(float(eps[buckled].max()) / eps0 - 1.0)

    def misfit(p: np.ndarray) -> np.ndarray:
        return p[0] * np.sqrt(np.maximum(eps / p[1] - 1.0, 0.0)) - a

    result = least_squares(misfit, x0=[A0, eps0], bounds=([0.0, np.finfo(float).tiny], [np.inf, np.inf]),
                           x_scale=[max(A0, 1e-300), eps0])
    residual = float(np.sqrt(np.mean(result.fun**2)))
    return SqrtGrowthFit(A=float(result.x[0]), eps_cr=float(result.x[1]), residual=residual)


# --------------------------------------------------------------------------- samplers


def _evaluate(field: ngsolve.CoefficientFunction, mesh: ngsolve.Mesh, points: np.ndarray,
              what: str) -> np.ndarray:
    coordinates = [points[:, j] for j in range(points.shape[1])]
    mesh_points = mesh(*coordinates)
    outside = np.flatnonzero(mesh_points["nr"] < 0)
    if outside.size:
        raise ValueError(f"{what}: {outside.size} of {points.shape[0]} points lie outside the mesh, "
                         f"first at {tuple(points[outside[0]])} (a curved boundary is approximated "
                         "by element faces: stay a little inside it)")
    values = np.asarray(field(mesh_points))
    return values[:, 0] if values.ndim == 2 and values.shape[1] == 1 else values


def _point(name: str, value: Sequence[float], dim: int) -> np.ndarray:
    array = np.asarray(value, dtype=float)
    if array.shape != (dim,) or not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be {dim} finite coordinates for a {dim}D mesh, got {value!r}")
    return array


def sample_on_circle(field: ngsolve.CoefficientFunction, mesh: ngsolve.Mesh, *, center: Sequence[float],
                     radius: float, n: int, normal: Sequence[float] = (0.0, 0.0, 1.0)) -> FieldSamples:
    """Values of ``field`` at ``n`` uniform angles ``theta_i = 2 pi i / n`` on a circle.

    In 2D the circle lies in the mesh plane and ``theta`` is measured from the x axis. In 3D it
    lies in the plane through ``center`` normal to ``normal``; ``theta`` is measured from the
    projection of the x axis onto that plane (of the y axis if ``normal`` is nearly along x),
    counter-clockwise seen from the tip of ``normal``. The angles suit :func:`wave_number`.
    """
    dim = mesh.dim
    if dim not in (2, 3):
        raise ValueError(f"mesh must be 2D or 3D, got dim={dim}")
    c = _point("center", center, dim)
    if not isinstance(radius, (int, float)) or not math.isfinite(radius) or radius <= 0:
        raise ValueError(f"radius must be a finite number > 0, got {radius!r}")
    if not isinstance(n, (int, np.integer)) or n < 3:
        raise ValueError(f"n must be an integer >= 3, got {n!r}")
    theta = 2.0 * np.pi * np.arange(n) / n
    if dim == 2:
        e1, e2 = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    else:
        axis = _point("normal", normal, 3)
        length = float(np.linalg.norm(axis))
        if length == 0.0:
            raise ValueError("normal must be a non-zero vector")
        axis = axis / length
        reference = np.array([1.0, 0.0, 0.0]) if abs(axis[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        e1 = reference - np.dot(reference, axis) * axis
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(axis, e1)
    points = c + radius * (np.outer(np.cos(theta), e1) + np.outer(np.sin(theta), e2))
    return FieldSamples(parameter=theta, points=points, values=_evaluate(field, mesh, points, "radius"))


def sample_on_line(field: ngsolve.CoefficientFunction, mesh: ngsolve.Mesh, *, start: Sequence[float],
                   end: Sequence[float], n: int) -> FieldSamples:
    """Values of ``field`` at ``n`` equally spaced points from ``start`` to ``end`` (both
    included); ``parameter`` is the distance from ``start``."""
    dim = mesh.dim
    if dim not in (2, 3):
        raise ValueError(f"mesh must be 2D or 3D, got dim={dim}")
    a = _point("start", start, dim)
    b = _point("end", end, dim)
    if np.array_equal(a, b):
        raise ValueError("end must differ from start")
    if not isinstance(n, (int, np.integer)) or n < 2:
        raise ValueError(f"n must be an integer >= 2, got {n!r}")
    s = np.linspace(0.0, 1.0, n)
    points = a + np.outer(s, b - a)
    return FieldSamples(parameter=s * float(np.linalg.norm(b - a)), points=points,
                        values=_evaluate(field, mesh, points, "start/end"))


def power_law_fit(x, y) -> dict:
    """Least-squares fit ``log y = a + b log x``: ``b``, its standard error and the points used."""
    lx, ly = np.log(np.asarray(x, dtype=float)), np.log(np.asarray(y, dtype=float))
    n = len(lx)
    if n < 3:
        raise ValueError(f"a power-law fit with an error needs >= 3 points, got {n}")
    A = np.column_stack([np.ones(n), lx])
    coef, *_ = np.linalg.lstsq(A, ly, rcond=None)
    residual = ly - A @ coef
    sigma2 = float(residual @ residual) / (n - 2)
    covariance = sigma2 * np.linalg.inv(A.T @ A)
    return {"exponent": float(coef[1]), "standard_error": float(math.sqrt(covariance[1, 1])),
            "prefactor": float(math.exp(coef[0])), "points": n}
