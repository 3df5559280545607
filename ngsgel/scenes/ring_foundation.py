"""Buckling of a thin ring bonded to an elastic annulus (thesis ch. 4, eqs. 4-1 ... 4-4).

Plane strain throughout; every force and stiffness is per unit length of the tube axis.

Ring on a Winkler foundation
----------------------------
A thin ring (film) of mid-surface radius ``R``, thickness ``t``, modulus ``Ef`` and Poisson
ratio ``nu`` has the plane-strain modulus ``Ef_bar = Ef / (1 - nu^2)`` and the bending
stiffness ``D = Ef_bar t^3 / 12`` (the thesis's ``Ef I``). It carries a uniform compressive
hoop force ``N`` and rests on radial springs of stiffness ``K`` (pressure per unit radial
deflection). With the inextensional mode ``w = a cos(n theta)`` the energy balance of the
classical ring under hydrostatic pressure (Timoshenko & Gere, *Theory of Elastic
Stability*, ch. 7; Brush & Almroth, *Buckling of Bars, Plates and Shells*, ch. 5) with the
foundation energy ``K w^2 / 2`` added gives

    N_cr(n) = D (n^2 - 1) / R^2 + K R^2 / (n^2 - 1),            n = 2, 3, ...

For a constant ``K`` the minimum over real ``m = n^2 - 1`` is at ``m = R^2 sqrt(K/D)``, i.e.

    n_cr = sqrt(1 + R^2 sqrt(K/D)) ~ R (K/D)^(1/4)                    (thesis eq. 4-1)
    N_cr = 2 sqrt(K D),  sigma_cr = N_cr / t = sqrt(Ef_bar K t / 3),

the flat-film (Allen) wrinkling result and, as far as the text export shows, the thesis's
eq. 4-2; the ring curvature only enters through the integer ``n`` and the ``n^2 - 1``. For
large ``n`` the loading variants (hydrostatic, centrally directed, constant direction) all
reduce to this. The critical strain is ``N_cr / (Ef_bar t)``.

Foundation stiffness of an annulus
----------------------------------
The gel annulus ``a < r < b`` (shear modulus ``G``, Poisson ratio ``nu_s``, Kolosov constant
``kappa = 3 - 4 nu_s``) is loaded on one surface ``r = R_L`` by the normal traction
``sigma_rr = -p cos(n theta)``; ``K(n) = p / w`` with ``w`` the amplitude of the surface's
displacement into the annulus. The exact solution is Michell's: the Airy function

    phi = (A r^n + B r^-n + C r^(n+2) + D r^(2-n)) cos(n theta)          (n >= 2)

whose term ``r^m cos(n theta)`` gives ``sigma_rr = (m - n^2) r^(m-2) cos``,
``sigma_rt = n (m - 1) r^(m-2) sin``, and the displacements (Barber, *Elasticity*, the
Michell displacement table; checked symbolically against plane-strain Hooke's law)

    m = n:      2G u_r = -n r^(n-1) cos,          2G u_t = n r^(n-1) sin
    m = -n:     2G u_r = n r^(-n-1) cos,          2G u_t = n r^(-n-1) sin
    m = n+2:    2G u_r = (kappa-n-1) r^(n+1) cos, 2G u_t = (kappa+n+1) r^(n+1) sin
    m = 2-n:    2G u_r = (kappa+n-1) r^(1-n) cos, 2G u_t = -(kappa-n+1) r^(1-n) sin.

Four conditions fix ``A ... D`` (solved numerically, no approximation): on the loaded surface
the normal traction and either zero shear traction (``interface="shear_free"``, the classical
Winkler idealisation) or zero tangential displacement (``"no_slip"``, a film that is
inextensible along the interface); on the far surface zero traction (``far="free"``, the
thesis's choice: the other film is ignored) or zero displacement (``far="fixed"``, the stiff
bound). For ``n = 0`` the Lame terms ``phi = A ln r + B r^2`` (``2G u_r = -A/r +
(kappa - 1) B r``) give the mode-independent stiffness the thesis used; for
``loaded="outer"``, ``far="free"`` it is the thesis's ``K_o = E (b^2 - a^2) / ((1 + nu_s) b
((1 - 2 nu_s) b^2 + a^2))``, for ``loaded="inner"`` the same with ``a`` and ``b`` swapped in
the last factor and the leading ``b`` replaced by ``a``. At the gear's wave numbers (10-50)
the mode-``n`` stiffness is far larger than this Lame value, so the two choices predict
different tooth counts; pass ``K`` as a callable of ``n`` to :func:`critical_mode` for the
consistent one.

For ``n -> infinity`` the annulus looks like a half-space under a load of wavenumber
``q = n / R_L``; the same Airy analysis in Cartesian coordinates gives

    shear-free surface:  K = G q / (1 - nu_s) = E q / (2 (1 - nu_s^2))
    no-slip surface:     K = 4 G (1 - nu_s) q / (3 - 4 nu_s),

equal for an incompressible solid (``2 G q``). Which moduli to pass (drained or
instantaneous, reference or current state) is the caller's choice: this module is linear
elasticity about whatever state those moduli describe.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import minimize_scalar

__all__ = [
    "RingMode",
    "bending_stiffness",
    "critical_hoop_force",
    "critical_mode",
    "critical_strain",
    "foundation_stiffness_annulus",
]

# Above this mode number the search for the critical mode gives up: a film that thin would
# need a mesh nobody can afford, so the inputs are almost certainly in the wrong units.
_MAX_MODE = 1_000_000

Stiffness = float | Callable[[float], float]


@dataclass(frozen=True)
class RingMode:
    """Critical mode of a ring on a foundation.

    ``n`` is the integer wave number with the lowest critical hoop force ``N_cr`` (compressive
    force per unit axial length); ``n_continuous`` minimises ``N_cr(n)`` over real ``n >= 2``.
    """

    n: int
    N_cr: float
    n_continuous: float


def _check_positive(name: str, value: float) -> float:
    if not isinstance(value, (int, float, np.floating, np.integer)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def _check_poisson(name: str, value: float, *, upper_inclusive: bool) -> float:
    ok = isinstance(value, (int, float, np.floating, np.integer)) and math.isfinite(value)
    ok = ok and -1.0 < value and (value <= 0.5 if upper_inclusive else value < 0.5)
    if not ok:
        bound = "<=" if upper_inclusive else "<"
        raise ValueError(f"{name} must lie in (-1, 0.5{']' if upper_inclusive else ')'} "
                         f"(-1 < {name} {bound} 0.5), got {value!r}")
    return float(value)


def bending_stiffness(t: float, Ef: float, nu: float) -> float:
    """Plane-strain bending stiffness ``D = Ef t^3 / (12 (1 - nu^2))`` of a film."""
    t = _check_positive("t", t)
    Ef = _check_positive("Ef", Ef)
    nu = _check_poisson("nu", nu, upper_inclusive=True)
    return Ef * t**3 / (12.0 * (1.0 - nu**2))


def _foundation(K: Stiffness) -> Callable[[float], float]:
    if callable(K):
        def checked(n: float) -> float:
            value = float(K(n))
            if not math.isfinite(value) or value < 0:
                raise ValueError(f"K({n}) must be a finite number >= 0, got {value!r}")
            return value
        return checked
    value = _check_positive("K", K)
    return lambda n: value


def critical_hoop_force(n: float, R: float, t: float, Ef: float, nu: float, K: Stiffness) -> float:
    """Hoop force ``N_cr(n) = D (n^2 - 1)/R^2 + K R^2/(n^2 - 1)`` at which mode ``n`` buckles.

    ``K`` is a number or a callable ``K(n)`` (e.g. from :func:`foundation_stiffness_annulus`).
    ``n`` must be > 1 (``n = 1`` is a rigid translation of the ring).
    """
    if not isinstance(n, (int, float, np.floating, np.integer)) or not math.isfinite(n) or n <= 1:
        raise ValueError(f"n must be a finite number > 1, got {n!r}")
    R = _check_positive("R", R)
    D = bending_stiffness(t, Ef, nu)
    m = n * n - 1.0
    return D * m / R**2 + _foundation(K)(n) * R**2 / m


def critical_mode(R: float, t: float, Ef: float, nu: float, K: Stiffness) -> RingMode:
    """Integer and continuous critical wave numbers of a ring (``R``, ``t``, ``Ef``, ``nu``)
    on a foundation ``K`` (a number, or a callable ``K(n)`` accepting real ``n >= 2``).

    The integer search stops once the bending term alone exceeds the best force found, which
    is exact because the foundation term is never negative.
    """
    R = _check_positive("R", R)
    D = bending_stiffness(t, Ef, nu)
    foundation = _foundation(K)

    def force(n: float) -> float:
        m = n * n - 1.0
        return D * m / R**2 + foundation(n) * R**2 / m

    best_n, best = 2, force(2)
    n = 3
    while D * (n * n - 1.0) / R**2 < best:
        if n > _MAX_MODE:
            raise ValueError(f"critical mode exceeds n = {_MAX_MODE}: check the units of R, t, Ef and K")
        value = force(n)
        if value < best:
            best_n, best = n, value
        n += 1

    if callable(K):
        lo, hi = max(2.0, best_n - 1.0), best_n + 1.0
        result = minimize_scalar(force, bounds=(lo, hi), method="bounded",
                                 options={"xatol": 1e-8 * hi})
        n_continuous = float(result.x)
    else:
        n_continuous = max(2.0, math.sqrt(1.0 + R**2 * math.sqrt(float(K) / D)))
    return RingMode(n=best_n, N_cr=best, n_continuous=n_continuous)


def critical_strain(R: float, t: float, Ef: float, nu: float, K: Stiffness) -> float:
    """Critical hoop strain ``N_cr / (Ef_bar t)`` of the critical mode, ``Ef_bar = Ef/(1-nu^2)``."""
    mode = critical_mode(R, t, Ef, nu, K)
    return mode.N_cr * (1.0 - nu**2) / (Ef * t)


def _michell_rows(n: float, r: float, kappa: float, scales: np.ndarray) -> np.ndarray:
    """Rows (sigma_rr, sigma_rt, 2G u_r, 2G u_t) at radius ``r`` for the four Michell terms.

    Each term ``r^m`` is written as ``s^2 (r/s)^m`` with ``s`` the radius where it is largest
    (the outer radius for growing powers, the inner for decaying ones), so no entry overflows
    for wave numbers in the hundreds.
    """
    m = np.array([n, -n, n + 2.0, 2.0 - n])
    ur = np.array([-n, n, kappa - n - 1.0, kappa + n - 1.0])
    ut = np.array([n, n, kappa + n + 1.0, -(kappa - n + 1.0)])
    rho = r / scales
    stress_scale = rho ** (m - 2.0)
    disp_scale = scales * rho ** (m - 1.0)
    return np.array([
        (m - n * n) * stress_scale,
        n * (m - 1.0) * stress_scale,
        ur * disp_scale,
        ut * disp_scale,
    ])


def foundation_stiffness_annulus(
    n: float,
    *,
    inner_radius: float,
    outer_radius: float,
    shear_modulus: float,
    loaded: Literal["inner", "outer"],
    nu: float | None = None,
    bulk_modulus: float | None = None,
    far: Literal["free", "fixed"] = "free",
    interface: Literal["shear_free", "no_slip"] = "shear_free",
) -> float:
    """Winkler stiffness ``K(n) = p / w`` of a plane-strain elastic annulus loaded on one face.

    ``n`` is the circumferential wave number: 0 (axisymmetric, Lame) or any real ``n >= 2``
    (real values serve the continuous minimisation in :func:`critical_mode`). Give exactly one
    of ``nu`` (Poisson ratio, -1 < nu <= 0.5) and ``bulk_modulus`` (3D bulk modulus); see the
    module docstring for the solution and the meaning of ``far`` and ``interface``.
    """
    a = _check_positive("inner_radius", inner_radius)
    b = _check_positive("outer_radius", outer_radius)
    if b <= a:
        raise ValueError(f"outer_radius must be > inner_radius, got {b!r} <= {a!r}")
    G = _check_positive("shear_modulus", shear_modulus)
    if (nu is None) == (bulk_modulus is None):
        raise ValueError("give exactly one of nu and bulk_modulus")
    if bulk_modulus is not None:
        Kb = _check_positive("bulk_modulus", bulk_modulus)
        nu = (3.0 * Kb - 2.0 * G) / (2.0 * (3.0 * Kb + G))
    nu = _check_poisson("nu", nu, upper_inclusive=True)
    if loaded not in ("inner", "outer"):
        raise ValueError(f"loaded must be 'inner' or 'outer', got {loaded!r}")
    if far not in ("free", "fixed"):
        raise ValueError(f"far must be 'free' or 'fixed', got {far!r}")
    if interface not in ("shear_free", "no_slip"):
        raise ValueError(f"interface must be 'shear_free' or 'no_slip', got {interface!r}")
    if not isinstance(n, (int, float, np.floating, np.integer)) or not math.isfinite(n) or not (n == 0 or n >= 2):
        raise ValueError(f"n must be 0 or a finite number >= 2, got {n!r}")

    kappa = 3.0 - 4.0 * nu
    # Lengths in units of the loaded radius and stresses in units of G, so K = G k / R_L.
    R_L = a if loaded == "inner" else b
    a_, b_ = a / R_L, b / R_L
    r_load, r_far = (a_, b_) if loaded == "inner" else (b_, a_)
    # Displacement into the annulus is +u_r on the inner face and -u_r on the outer face.
    into = 1.0 if loaded == "inner" else -1.0

    if n == 0:
        if far == "fixed" and nu == 0.5:
            raise ValueError("nu = 0.5 with far='fixed' and n = 0 is rigid (incompressible and confined)")
        # Unknowns (A, B) of phi = A ln r + B r^2: sigma_rr = A/r^2 + 2B, 2G u_r = -A/r + (kappa-1) B r.
        def sigma(r: float) -> list[float]:
            return [1.0 / r**2, 2.0]

        def disp(r: float) -> list[float]:
            return [-1.0 / r, (kappa - 1.0) * r]

        matrix = np.array([sigma(r_load), sigma(r_far) if far == "free" else disp(r_far)])
        coef = np.linalg.solve(matrix, np.array([-1.0, 0.0]))
        w = into * float(np.dot(disp(r_load), coef)) / 2.0
        return G / R_L / w

    scales = np.array([b_, a_, b_, a_])
    load_rows = _michell_rows(float(n), r_load, kappa, scales)
    far_rows = _michell_rows(float(n), r_far, kappa, scales)
    matrix = np.array([
        load_rows[0],
        load_rows[1] if interface == "shear_free" else load_rows[3],
        far_rows[0] if far == "free" else far_rows[2],
        far_rows[1] if far == "free" else far_rows[3],
    ])
    coef = np.linalg.solve(matrix, np.array([-1.0, 0.0, 0.0, 0.0]))
    w = into * float(load_rows[2] @ coef) / 2.0
    return G / R_L / w
