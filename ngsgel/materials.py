"""Constitutive models: pure objects that give an energy density, its stresses and closed forms.

A material knows nothing of meshes or solvers. Energies are NGSolve CoefficientFunctions of a
3x3 deformation gradient ``F`` (any CoefficientFunction: a constant, a trial function's
gradient, a GridFunction's gradient), so the solvers differentiate the one formula that is the
model. Closed forms (homogeneous swelling, linearised moduli) work on plain floats and exist for
set-up and checks.

Units (MODEL.md section 1): stresses and energies by ``kT/v``, chemical potential by ``kT``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Real

import ngsolve as ngs
from scipy.optimize import brentq, minimize_scalar

__all__ = ["FloryRehnerGel", "NeoHookeanFilm", "Material"]

# Search window for homogeneous states, in log(J - 1): from J - 1 ~ 2e-12 (drier is lost in
# double precision) to a 10^12-fold volume.
_LOG_JM1_RANGE = (-27.0, math.log(1e12))


def _inv_transpose(F: ngs.CoefficientFunction) -> ngs.CoefficientFunction:
    return ngs.Inv(F).trans


class Material:
    """Interface of a material as the problems use it.

    ``reference_energy(Fp, mu, lam0)`` is the energy per unit volume of the computational
    reference (the mesh), ``Fp`` the deformation gradient from that reference. ``margin`` is a
    CoefficientFunction that is positive exactly where the state is admissible. ``lam0`` is the
    region's stretch of the mesh from the dry state (a number or a field); it acts only on
    materials with ``swollen_reference`` (gels), whose mesh is a swollen state of the dry
    material; the others are stress-free in the mesh state and ignore it.
    """

    swollen_reference = False

    def reference_energy(self, Fp, mu, lam0):  # pragma: no cover - interface
        raise NotImplementedError

    def reference_cauchy(self, Fp, mu, lam0):  # pragma: no cover - interface
        raise NotImplementedError

    def margin(self, Fp, lam0):  # pragma: no cover - interface
        raise NotImplementedError


def _check_positive_number(name: str, value, *, allow_cf: bool) -> None:
    if isinstance(value, Real):
        if not math.isfinite(value) or value <= 0:
            raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    elif not (allow_cf and isinstance(value, ngs.CoefficientFunction)):
        kind = "a number > 0 or a CoefficientFunction" if allow_cf else "a number > 0"
        raise ValueError(f"{name} must be {kind}, got {type(value).__name__}")


def _check_lam0(lam0) -> None:
    """A free-swollen state ``lam0``, about which moduli are linearised: strictly swollen."""
    if not isinstance(lam0, Real) or not math.isfinite(lam0) or lam0 <= 1.0:
        raise ValueError(f"lam0 must be a number > 1 (the dry state is lam0 = 1), got {lam0!r}")


def check_reference_stretch(lam0, *, what: str = "lam0") -> float | ngs.CoefficientFunction:
    """A reference's stretch from the dry state: a finite number >= 1 (1: the mesh is the dry
    body) or a scalar CoefficientFunction (whose values the caller checks on its mesh)."""
    if isinstance(lam0, ngs.CoefficientFunction):
        if lam0.dim != 1:
            raise ValueError(f"{what} must be a scalar CoefficientFunction, got one of dimension {lam0.dim}")
        return lam0
    if isinstance(lam0, bool) or not isinstance(lam0, Real) or not math.isfinite(lam0) or lam0 < 1.0:
        raise ValueError(f"{what} must be a number >= 1 (1: the dry state) or a CoefficientFunction, got {lam0!r}")
    return float(lam0)


@dataclass(frozen=True)
class FloryRehnerGel(Material):
    """Hong–Zhao–Zhou–Suo gel: Flory–Rehner network plus Flory–Huggins mixing, ``mu`` given.

    ``W(F, mu) = Nv/2 (I1 - 3 - 2 ln J) + (J-1) ln(1 - 1/J) - chi/J - mu (J - 1)``
    per unit dry volume (MODEL.md section 2). ``Nv`` is a number or a CoefficientFunction
    (graded cross-link density); ``chi`` the Flory–Huggins parameter.
    """

    Nv: float | ngs.CoefficientFunction
    chi: float

    CHI_RANGE = (0.0, 1.5)
    swollen_reference = True

    def __post_init__(self):
        _check_positive_number("Nv", self.Nv, allow_cf=True)
        lo, hi = self.CHI_RANGE
        if not isinstance(self.chi, Real) or not (lo <= self.chi <= hi):
            raise ValueError(f"chi must be a number in [{lo}, {hi}], got {self.chi!r}")

    # ------------------------------------------------------------------ fields
    def mixing_pressure(self, J, mu):
        """``Pi(J, mu) = ln(1 - 1/J) + 1/J + chi/J^2 - mu``: minus the solvent's osmotic part."""
        return ngs.log(1 - 1 / J) + 1 / J + self.chi / J**2 - mu

    def energy(self, F, mu):
        """Energy per unit dry volume, ``F`` from the dry state."""
        J = ngs.Det(F)
        return self._energy(ngs.InnerProduct(F, F), J, mu)

    def _energy(self, I1, J, mu):
        return (self.Nv / 2 * (I1 - 3 - 2 * ngs.log(J)) + (J - 1) * ngs.log(1 - 1 / J)
                - self.chi / J - mu * (J - 1))

    def swollen_energy(self, Fp, mu, lam0: float | ngs.CoefficientFunction):
        """``W'(F', mu) = W(lam0 F', mu) / lam0^3``: per unit volume of the swollen reference
        (``lam0`` a number or a field, pointwise: ``lam0 I`` maps the dry state to the reference
        locally, an intermediate state that need not be compatible).

        ``lam0 = 1`` (the mesh is the dry body) is well defined: ``W`` is finite at ``J = 1``
        (``(J-1) ln(1 - 1/J) -> 0``), but the mixing pressure ``ln(1 - 1/J) -> -inf`` there, so the
        undeformed mesh is outside the admissible set ``J > 1`` and a solve must start from a
        swollen state."""
        lam0 = check_reference_stretch(lam0)
        J = lam0**3 * ngs.Det(Fp)
        return self._energy(lam0**2 * ngs.InnerProduct(Fp, Fp), J, mu) / lam0**3

    def first_piola(self, F, mu):
        """``P = Nv (F - F^-T) + J Pi F^-T`` (dry reference)."""
        J = ngs.Det(F)
        FinvT = _inv_transpose(F)
        return self.Nv * (F - FinvT) + J * self.mixing_pressure(J, mu) * FinvT

    def cauchy(self, F, mu):
        """``sigma = Nv/J (F F^T - I) + Pi I`` (F from the dry state)."""
        J = ngs.Det(F)
        return self.Nv / J * (F * F.trans - ngs.Id(3)) + self.mixing_pressure(J, mu) * ngs.Id(3)

    # Problem interface -------------------------------------------------------
    def reference_energy(self, Fp, mu, lam0):
        return self.swollen_energy(Fp, mu, lam0)

    def reference_cauchy(self, Fp, mu, lam0):
        return self.cauchy(lam0 * Fp, mu)

    def margin(self, Fp, lam0):
        """Positive where ``J > 1``: a gel cannot hold less than no solvent."""
        return lam0**3 * ngs.Det(Fp) - 1

    # ------------------------------------------------------------ closed forms
    def _Nv_number(self) -> float:
        if not isinstance(self.Nv, Real):
            raise ValueError("closed forms need Nv as a number; this gel has a field Nv")
        return float(self.Nv)

    def _mix(self, J: float) -> float:
        return math.log1p(-1.0 / J) + 1.0 / J + self.chi / J**2

    def mu_traction_free(self, lam_free: float, J: float) -> float:
        """``mu`` at which a homogeneous state with volume ratio ``J`` carries no stress in a
        principal direction stretched by ``lam_free`` (from ``sigma_ii = 0``)."""
        return self._Nv_number() * (lam_free**2 - 1.0) / J + self._mix(J)

    def mu_free(self, lam: float) -> float:
        """Chemical potential in equilibrium with free swelling ``F = lam I``."""
        if lam <= 1.0:
            raise ValueError(f"lam must be > 1, got {lam!r}")
        return self.mu_traction_free(lam, lam**3)

    def mu_constrained(self, lam: float, lamL: float) -> float:
        """Laterally constrained layer: in-plane stretch ``lamL``, thickness stretch ``lam``."""
        return self.mu_traction_free(lam, lamL**2 * lam)

    def mu_plane_strain(self, lam: float, lamz: float) -> float:
        """Plane strain: equal in-plane stretches ``lam``, out-of-plane stretch held at ``lamz``."""
        return self.mu_traction_free(lam, lam**2 * lamz)

    def lam_free(self, mu: float) -> float:
        """Free-swelling stretch in equilibrium with ``mu`` (the stable branch)."""
        return self._stable_root(lambda x: self.mu_free(x), mu, lo=1.0, power=3.0, what="free swelling")

    def lam_constrained(self, mu: float, lamL: float) -> float:
        """Thickness stretch of a layer held at in-plane stretch ``lamL``, in equilibrium with ``mu``."""
        if lamL <= 0:
            raise ValueError(f"lamL must be > 0, got {lamL!r}")
        return self._stable_root(lambda x: self.mu_constrained(x, lamL), mu, lo=1.0 / lamL**2,
                                 power=1.0, what=f"a layer constrained at lamL={lamL}")

    def lam_plane_strain(self, mu: float, lamz: float) -> float:
        """In-plane stretch of plane-strain free swelling with the out-of-plane stretch ``lamz``."""
        if lamz <= 0:
            raise ValueError(f"lamz must be > 0, got {lamz!r}")
        return self._stable_root(lambda x: self.mu_plane_strain(x, lamz), mu, lo=lamz**-0.5,
                                 power=2.0, what=f"plane strain at lamz={lamz}")

    def _stable_root(self, mu_of, mu: float, *, lo: float, power: float, what: str) -> float:
        """Root of ``mu_of(x) = mu`` on the stable branch ``x in (lo, x_max)``.

        ``mu_of`` rises from -inf at ``x = lo`` (dry, ``J = 1``) to a maximum slightly above
        zero and then decays to 0: states beyond the maximum are unstable, and a ``mu`` above it
        has no swollen state. ``x = lo (1 + s)^(1/power)`` with ``s = J - 1`` makes the search
        uniform in ``log(J - 1)``.
        """
        if not isinstance(mu, Real) or not math.isfinite(mu):
            raise ValueError(f"mu must be a finite number, got {mu!r}")

        def x_of(log_s: float) -> float:
            return lo * (1.0 + math.exp(log_s)) ** (1.0 / power)

        a, b = _LOG_JM1_RANGE
        peak = minimize_scalar(lambda t: -mu_of(x_of(t)), bounds=(a, b), method="bounded",
                               options={"xatol": 1e-12})
        mu_max = -peak.fun
        if mu >= mu_max:
            raise ValueError(f"mu = {mu!r} is above mu_max = {mu_max:.6g}: no stable swollen state "
                             f"exists for {what} (Nv={self.Nv}, chi={self.chi}); mu must be < mu_max")
        if mu <= mu_of(x_of(a)):
            raise ValueError(f"mu = {mu!r} is too negative: the gel would be dry to J - 1 < 2e-12 "
                             f"({what}); mu must be > {mu_of(x_of(a)):.6g}")
        t = brentq(lambda t: mu_of(x_of(t)) - mu, a, peak.x, xtol=1e-15, rtol=1e-15, maxiter=400)
        return x_of(t)

    # Linearised moduli about free swelling at lam0 (mu held: drained) ------------------------
    def shear_modulus(self, lam0: float) -> float:
        """``G = Nv / lam0``."""
        _check_lam0(lam0)
        return self._Nv_number() / lam0

    def youngs_modulus(self, lam0: float) -> float:
        """``E0 = 3 Nv / lam0``: the undrained (incompressible) Young's modulus, the thesis's
        initial stiffness."""
        return 3.0 * self.shear_modulus(lam0)

    def bulk_modulus(self, lam0: float) -> float:
        """Drained bulk modulus ``K = J dsigma/dJ`` at fixed ``mu``."""
        _check_lam0(lam0)
        J0 = lam0**3
        return self._Nv_number() * (1 / J0 - 1 / (3 * lam0)) + 1 / (J0 * (J0 - 1)) - 2 * self.chi / J0**2

    def drained_poisson_ratio(self, lam0: float) -> float:
        K, G = self.bulk_modulus(lam0), self.shear_modulus(lam0)
        return (3 * K - 2 * G) / (2 * (3 * K + G))


@dataclass(frozen=True)
class NeoHookeanFilm(Material):
    """Compressible neo-Hookean solid for elastic films bonded to gels.

    ``W = G/2 (I1 - 3 - 2 ln J) + L/2 (ln J)^2`` with ``G = E/(2(1+nu))``,
    ``L = E nu / ((1+nu)(1-2nu))``: the small-strain limit is linear elasticity with ``E, nu``.
    Its stress-free state is the mesh (the reference it was bonded in); ``mu`` does not act on it.
    """

    E: float
    nu: float

    def __post_init__(self):
        _check_positive_number("E", self.E, allow_cf=False)
        if not isinstance(self.nu, Real) or not (-1.0 < self.nu < 0.5):
            raise ValueError(f"nu must be a number in (-1, 0.5), got {self.nu!r}")

    @property
    def shear_modulus(self) -> float:
        return self.E / (2 * (1 + self.nu))

    @property
    def lame_lambda(self) -> float:
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    def energy(self, F, mu=0.0):
        lnJ = ngs.log(ngs.Det(F))
        return (self.shear_modulus / 2 * (ngs.InnerProduct(F, F) - 3 - 2 * lnJ)
                + self.lame_lambda / 2 * lnJ**2)

    def first_piola(self, F, mu=0.0):
        FinvT = _inv_transpose(F)
        return self.shear_modulus * (F - FinvT) + self.lame_lambda * ngs.log(ngs.Det(F)) * FinvT

    def cauchy(self, F, mu=0.0):
        J = ngs.Det(F)
        return (self.shear_modulus * (F * F.trans - ngs.Id(3)) + self.lame_lambda * ngs.log(J) * ngs.Id(3)) / J

    def reference_energy(self, Fp, mu, lam0):
        return self.energy(Fp)

    def reference_cauchy(self, Fp, mu, lam0):
        return self.cauchy(Fp)

    def margin(self, Fp, lam0):
        return ngs.Det(Fp)
