"""Film-coated gel tube in plane strain (thesis ch. 4, MODEL.md scene B): the axisymmetric
pre-buckling state on a radial line and the ring-on-foundation estimate of the onset.

``FilmTube.axial``: "fixed" is plane strain (MODEL.md: the axial stretch stays at the reference);
"free" is generalized plane strain, a long tube with free ends: one uniform axial stretch of gel
and films, a global unknown set by zero net axial force (``PolarGeneralizedPlaneStrain``). Both
are exact for the axisymmetric state; the linear three-cylinder analysis of the thesis
(``linear_film_stresses``) is plane strain only.

Pre-buckling state
------------------
Until a film buckles the state is axisymmetric, ``u = u_r(r) e_r``, and the plane-strain tube is
exactly a 1D problem on the radial line (``ngsgel.kinematics.PolarPlaneStrain``, the same
energies as the 2D model). :class:`RadialTube` solves it and returns the films' hoop forces
``N = -int sigma_tt dr`` (compression positive, per unit axial length, over the current
thickness), their current radii and the gel's volume fraction.

Ring-on-foundation onset
------------------------
Each film is a ring of current mid-radius ``R`` and thickness ``t`` on the gel annulus
(``ngsgel.scenes.ring_foundation``): it buckles into ``n`` waves when its hoop force reaches
``N_cr = min_n D (n^2-1)/R^2 + K(n) R^2/(n^2-1)``. The onset ``mu`` of a film solves
``N(mu) = N_cr(mu)`` along the radial solution (bisection on ``mu``). The films are treated
separately, as in the thesis (the other film and its stress are ignored in ``K``: the mode
decays into the gel over about ``R/n``, much less than the wall for 10-50 teeth).

The foundation is the gel linearised about its current state with ``mu`` held (drained: the
equilibrium model has no time, the solvent follows every perturbation). About an in-plane
isotropic state ``F = diag(lam, lam, lamz)`` (dry reference, ``J = lam^2 lamz``) with no in-plane
stress, an incremental in-plane shear ``gamma`` gives ``sigma_12 = Nv lam^2 gamma / J``, so the
in-plane shear modulus is ``G = Nv / lamz`` (``= Nv/lam0`` in the plane-strain tube, whose
axial stretch stays ``lam0``; with a free axial stretch the tube's current one); an equibiaxial in-plane strain ``eps`` gives ``dsigma = 2 (Nv/J + J Pi'(J)) eps``,
so the plane-strain area modulus is ``kappa = lambda_L + G = Nv/J + 1/(J(J-1)) - 2 chi/J^2``.
The equivalent isotropic Poisson ratio in Michell's solution is ``nu = (kappa - G)/(2 kappa)``
(at free swelling ``kappa = K + G/3`` with ``K`` the drained bulk modulus, and this ``nu`` is
the drained Poisson ratio, 0.310 for Nv = 1e-3, chi = 0.5). ``lam`` is taken from plane-strain
free swelling at the current ``mu`` (the films' pressure on the gel is of order ``N/R``, a few
percent of ``kappa``). ``stiffness="michell"`` uses the mode-``n`` stiffness of the annulus,
``"lame"`` the mode-independent axisymmetric stiffness the thesis used (its eq. 4-1 with
``K_i``, ``K_o``), which underestimates ``K`` at 10-50 waves by a factor of order ``n``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np
import ngsolve as ngs
from scipy.optimize import brentq
from netgen.meshing import Element0D, Element1D, Mesh as NetgenMesh, MeshPoint, Pnt

from ngsgel.kinematics import PolarGeneralizedPlaneStrain, PolarPlaneStrain
from ngsgel.materials import FloryRehnerGel, NeoHookeanFilm
from ngsgel.problem import EquilibriumProblem
from ngsgel.scenes.ring_foundation import critical_mode, foundation_stiffness_annulus
from ngsgel.stepping import ramp

__all__ = ["FilmTube", "RadialTube", "RingOnset", "gel_plane_strain_moduli", "linear_film_stresses", "linear_switch",
           "ring_onset", "thesis_ring_estimate"]

GEL, FILM_INNER, FILM_OUTER = "gel", "film_inner", "film_outer"


def _positive(name: str, value) -> float:
    if not isinstance(value, (int, float)) or not math.isfinite(value) or value <= 0:
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


@dataclass(frozen=True)
class FilmTube:
    """Gel annulus ``Ri < r < Ro`` (reference = free swollen at ``mu0``) with films of thickness
    ``tfi`` inside (``Ri - tfi < r < Ri``) and ``tfo`` outside, moduli ``Efi``, ``Efo`` (absolute,
    in units of kT/v), Poisson ratio ``nu_film``; films stress-free in the reference. ``axial``:
    "fixed" (plane strain: the axial stretch stays at the reference) or "free" (generalized plane
    strain: a long tube with free ends, one uniform axial stretch of gel and films alike, zero net
    axial force)."""

    Ri: float
    Ro: float
    tfi: float
    tfo: float
    Efi: float
    Efo: float
    nu_film: float = 0.3
    Nv: float = 1e-3
    chi: float = 0.5
    mu0: float = 0.0
    axial: Literal["fixed", "free"] = "fixed"

    def __post_init__(self):
        if self.axial not in ("fixed", "free"):
            raise ValueError(f"axial must be 'fixed' (plane strain) or 'free' (generalized plane strain: "
                             f"uniform axial stretch, zero axial force), got {self.axial!r}")
        for name in ("Ri", "Ro", "tfi", "tfo", "Efi", "Efo", "Nv"):
            _positive(name, getattr(self, name))
        if self.Ro <= self.Ri:
            raise ValueError(f"Ro must be > Ri, got Ro={self.Ro!r}, Ri={self.Ri!r}")
        if self.tfi >= self.Ri:
            raise ValueError(f"tfi must be < Ri (the film must fit inside), got {self.tfi!r}")
        if not -1.0 < self.nu_film < 0.5:
            raise ValueError(f"nu_film must lie in (-1, 0.5), got {self.nu_film!r}")
        self.gel.lam_free(self.mu0)  # raises ValueError naming mu0 and its range

    @property
    def gel(self) -> FloryRehnerGel:
        return FloryRehnerGel(Nv=self.Nv, chi=self.chi)

    @property
    def lam0(self) -> float:
        return self.gel.lam_free(self.mu0)

    def materials(self) -> dict:
        return {GEL: self.gel, FILM_INNER: NeoHookeanFilm(E=self.Efi, nu=self.nu_film),
                FILM_OUTER: NeoHookeanFilm(E=self.Efo, nu=self.nu_film)}

    def film(self, which: Literal["inner", "outer"]) -> tuple[float, float, float]:
        """Reference mid-radius, thickness and modulus of a film."""
        if which == "inner":
            return self.Ri - self.tfi / 2, self.tfi, self.Efi
        if which == "outer":
            return self.Ro + self.tfo / 2, self.tfo, self.Efo
        raise ValueError(f"film must be 'inner' or 'outer', got {which!r}")

    @property
    def radial_kinematics(self):
        """Kinematics of the radial line: plane strain or generalized plane strain."""
        return PolarPlaneStrain() if self.axial == "fixed" else PolarGeneralizedPlaneStrain()

    def mu_at_volume_fraction(self, fraction: float) -> float:
        """``mu`` at which a free gel under the tube's axial condition keeps ``fraction`` of its
        volume (plane strain: in-plane shrink at axial stretch ``lam0``; free axial stretch:
        isotropic shrink): the end of a shrink run (the films hold the gel back a little, so the
        coated gel keeps slightly more)."""
        if not isinstance(fraction, (int, float)) or not 0.2 < fraction < 1.0:
            raise ValueError(f"volume fraction must lie in (0.2, 1), got {fraction!r}")
        if self.axial == "free":
            return self.gel.mu_free(self.lam0 * fraction ** (1.0 / 3.0))
        return self.gel.mu_plane_strain(self.lam0 * math.sqrt(fraction), self.lam0)


def gel_plane_strain_moduli(gel: FloryRehnerGel, mu: float, lamz: float) -> tuple[float, float]:
    """In-plane shear modulus and equivalent Poisson ratio ``(G, nu)`` of a plane-strain gel
    at ``mu`` with axial stretch ``lamz`` (drained, linearised about plane-strain free swelling;
    see the module docstring)."""
    lam = gel.lam_plane_strain(mu, lamz)
    J = lam**2 * lamz
    Nv = gel._Nv_number()
    G = Nv / lamz
    kappa = Nv / J + 1.0 / (J * (J - 1.0)) - 2.0 * gel.chi / J**2
    if kappa <= G / 2:  # nu would leave (-1, 0.5]: the gel is near its volume transition
        raise ValueError(f"the gel at mu={mu!r} has in-plane area modulus {kappa:g} <= G/2: no isotropic "
                         "linear foundation represents it")
    return G, (kappa - G) / (2.0 * kappa)


def radial_line_mesh(tube: FilmTube, *, film_cells: int = 4, gel_cells: int = 64) -> ngs.Mesh:
    """1D mesh of the radial line ``Ri - tfi .. Ro + tfo``: regions film_inner, gel, film_outer;
    boundary points "inner", "outer". Gel cells are graded geometrically towards both films."""
    s = np.linspace(0.0, 1.0, gel_cells + 1)
    gel_nodes = tube.Ri + (tube.Ro - tube.Ri) * 0.5 * (1 - np.cos(np.pi * s))
    nodes = np.concatenate([np.linspace(tube.Ri - tube.tfi, tube.Ri, film_cells + 1)[:-1], gel_nodes,
                            np.linspace(tube.Ro, tube.Ro + tube.tfo, film_cells + 1)[1:]])
    regions = [1] * film_cells + [2] * gel_cells + [3] * film_cells
    m = NetgenMesh(dim=1)
    points = [m.Add(MeshPoint(Pnt(float(x), 0, 0))) for x in nodes]
    for i, index in enumerate(regions):
        m.Add(Element1D([points[i], points[i + 1]], index=index))
    for i, name in enumerate((FILM_INNER, GEL, FILM_OUTER), start=1):
        m.SetMaterial(i, name)
    m.Add(Element0D(points[0], index=1))
    m.Add(Element0D(points[-1], index=2))
    m.SetBCName(0, "inner")
    m.SetBCName(1, "outer")
    return ngs.Mesh(m)


@dataclass
class RadialState:
    """Pre-buckling quantities at one ``mu``: hoop forces (compression positive, per unit current
    axial length), current film mid-radii and gel radii, gel volume fraction, axial stretch
    relative to the reference (1 in plane strain)."""

    mu: float
    N_inner: float
    N_outer: float
    R_inner: float
    R_outer: float
    gel_inner_radius: float
    gel_outer_radius: float
    volume_fraction: float
    sigma_inner: float = field(default=0.0)
    sigma_outer: float = field(default=0.0)
    axial_stretch: float = field(default=1.0)


class RadialTube:
    """The axisymmetric pre-buckling solution on the radial line; ``state(mu)`` ramps from the
    last solved ``mu`` (the path is smooth until a film buckles)."""

    def __init__(self, tube: FilmTube, *, order: int = 3, film_cells: int = 4, gel_cells: int = 64):
        self.tube = tube
        self.mesh = radial_line_mesh(tube, film_cells=film_cells, gel_cells=gel_cells)
        self.problem = EquilibriumProblem(self.mesh, kinematics=tube.radial_kinematics, materials=tube.materials(),
                                          lam0=tube.lam0, mu=tube.mu0, order=order)
        self.problem.solve()

    def _integral(self, cf, region: str) -> float:
        return ngs.Integrate(cf, self.mesh, definedon=self.mesh.Materials(region), order=2 * self.problem.order + 2)

    def solve(self, mu: float) -> RadialState:
        p = self.problem
        ramp(p, p.mu, float(mu))
        u = p.displacement
        F = p.deformation_gradient(u)
        sigma = p.stress()
        # hoop force per unit current axial length: sigma_tt over the current thickness dr = F_rr dR
        N = {name: -self._integral(sigma[1, 1] * F[0, 0], name) for name in (FILM_INNER, FILM_OUTER)}
        thickness = {name: self._integral(F[0, 0], name) for name in (FILM_INNER, FILM_OUTER)}
        t = self.tube
        gel_volume = self._integral(2 * math.pi * ngs.x * ngs.Det(F), GEL)
        gel_reference = math.pi * (t.Ro**2 - t.Ri**2)
        mid_i, mid_o = t.Ri - t.tfi / 2, t.Ro + t.tfo / 2
        return RadialState(mu=float(mu), N_inner=N[FILM_INNER], N_outer=N[FILM_OUTER],
                           R_inner=mid_i + u(self.mesh(mid_i)), R_outer=mid_o + u(self.mesh(mid_o)),
                           gel_inner_radius=t.Ri + u(self.mesh(t.Ri)), gel_outer_radius=t.Ro + u(self.mesh(t.Ro)),
                           volume_fraction=gel_volume / gel_reference,
                           sigma_inner=-N[FILM_INNER] / thickness[FILM_INNER],
                           sigma_outer=-N[FILM_OUTER] / thickness[FILM_OUTER], axial_stretch=p.axial_stretch())


@dataclass(frozen=True)
class RingOnset:
    """Onset of one film by the ring-on-foundation analysis. ``mu`` is None when the film does not
    buckle before ``mu_end``; ``n`` is the critical wave number there (or at ``mu_end``)."""

    film: str
    mu: float | None
    n: int
    n_continuous: float
    N_cr: float
    sigma_cr: float
    volume_fraction: float | None
    stiffness: str


def _critical(tube: FilmTube, state: RadialState, film: str, stiffness: str, interface: str):
    # the gel's current axial stretch (from the dry state): lam0 in plane strain
    G, nu = gel_plane_strain_moduli(tube.gel, state.mu, tube.lam0 * state.axial_stretch)
    a, b = state.gel_inner_radius, state.gel_outer_radius
    R = state.R_inner if film == "inner" else state.R_outer
    _, t, E = tube.film(film)
    if stiffness == "michell":
        def K(n):
            return foundation_stiffness_annulus(n, inner_radius=a, outer_radius=b, shear_modulus=G, nu=nu,
                                                loaded=film, interface=interface)
    else:
        K = foundation_stiffness_annulus(0, inner_radius=a, outer_radius=b, shear_modulus=G, nu=nu, loaded=film)
    return critical_mode(R, t, E, tube.nu_film, K)


def ring_onset(tube: FilmTube, film: Literal["inner", "outer"], *, mu_end: float, steps: int = 40,
               stiffness: Literal["michell", "lame"] = "michell",
               interface: Literal["shear_free", "no_slip"] = "no_slip", tol: float = 1e-9,
               radial: RadialTube | None = None) -> RingOnset:
    """First ``mu`` (going down from ``tube.mu0`` to ``mu_end``) at which ``film`` reaches its
    ring-on-foundation critical hoop force. ``steps`` grid steps bracket it, bisection on ``mu``
    refines it to ``tol``."""
    if film not in ("inner", "outer"):
        raise ValueError(f"film must be 'inner' or 'outer', got {film!r}")
    if stiffness not in ("michell", "lame"):
        raise ValueError(f"stiffness must be 'michell' or 'lame', got {stiffness!r}")
    if not mu_end < tube.mu0:
        raise ValueError(f"mu_end must be below mu0={tube.mu0}, got {mu_end!r}")
    radial = RadialTube(tube) if radial is None else radial
    radial.problem.mu.Set(tube.mu0)
    radial.problem.restore_state(np.zeros_like(radial.problem.save_state()))

    def margin(mu: float):
        state = radial.solve(mu)
        mode = _critical(tube, state, film, stiffness, interface)
        N = state.N_inner if film == "inner" else state.N_outer
        return N - mode.N_cr, state, mode

    previous_mu, previous_state = tube.mu0, radial.problem.save_state()
    for mu in np.linspace(tube.mu0, mu_end, steps + 1)[1:]:
        value, state, mode = margin(float(mu))
        if value >= 0:
            break
        previous_mu, previous_state = float(mu), radial.problem.save_state()
    else:
        return RingOnset(film=film, mu=None, n=mode.n, n_continuous=mode.n_continuous, N_cr=mode.N_cr,
                         sigma_cr=mode.N_cr / tube.film(film)[1], volume_fraction=None, stiffness=stiffness)
    hi, lo, lo_state = float(mu), previous_mu, previous_state  # margin(lo) < 0 <= margin(hi)
    while abs(hi - lo) > tol:
        mid = 0.5 * (lo + hi)
        radial.problem.restore_state(lo_state)
        radial.problem.mu.Set(lo)
        value, state, mode = margin(mid)
        if value >= 0:
            hi = mid
        else:
            lo, lo_state = mid, radial.problem.save_state()
    radial.problem.restore_state(lo_state)
    radial.problem.mu.Set(lo)
    value, state, mode = margin(hi)
    return RingOnset(film=film, mu=hi, n=mode.n, n_continuous=mode.n_continuous, N_cr=mode.N_cr,
                     sigma_cr=mode.N_cr / tube.film(film)[1], volume_fraction=state.volume_fraction,
                     stiffness=stiffness)


# ----------------------------------------------------------------------------- the thesis's linear analysis
def linear_film_stresses(tube: FilmTube, *, E_gel: float, nu_gel: float) -> tuple[float, float]:
    """Mean hoop stresses ``(sigma_fi, sigma_fo)`` of the films (tension positive) per unit free
    in-plane shrink strain of the gel (thesis eq. 4-4, derived here): three bonded plane-strain
    Lame cylinders (inner film, gel, outer film; the films with ``tube.Efi``, ``tube.Efo``,
    ``tube.nu_film``, the gel with ``E_gel``, ``nu_gel``) in the reference geometry; the gel alone
    carries a uniform isotropic in-plane eigenstrain ``-1`` (continuity of radial stress and
    displacement at both interfaces, free faces). Linear, so only the ratio matters.

    Thin-film limit with an incompressible gel (``nu_gel = 0.5``; ``g = E_gel/(1+nu_gel) = 2G``,
    ``alpha = Ef t/((1-nu_f^2) R)`` the membrane stiffness of a film over its radius)::

        sigma_fi/sigma_fo = (Efi/Efo) (g - alpha_o)/(g + alpha_i)

    independent of ``Ro/Ri``; the inner film goes into tension once ``alpha_o > g`` (a stiff outer
    ring holds the gel out, and it pulls away from the bore). ``nu_gel = 0.5`` is taken as the
    limit ``0.5 - 1e-9``."""
    _positive("E_gel", E_gel)
    if not -1.0 < nu_gel <= 0.5:
        raise ValueError(f"nu_gel must lie in (-1, 0.5], got {nu_gel!r}")
    nu_gel = min(nu_gel, 0.5 - 1e-9)
    t = tube
    layers = [(t.Ri - t.tfi, t.Ri, t.Efi, t.nu_film, 0.0), (t.Ri, t.Ro, E_gel, nu_gel, -1.0),
              (t.Ro, t.Ro + t.tfo, t.Efo, t.nu_film, 0.0)]

    def plane(E, nu, eig):  # plane-strain constants as plane-stress ones (the eigenstrain is in-plane)
        return E / (1 - nu**2), nu / (1 - nu), eig

    def radial_stress(i, r):  # sigma_rr = c ((1+nu) (A - eig) - (1-nu) B/r^2), u = A r + B/r
        E, nu, eig = plane(*layers[i][2:])
        c = E / (1 - nu**2)
        row = np.zeros(6)
        row[2 * i], row[2 * i + 1] = c * (1 + nu), -c * (1 - nu) / r**2
        return row, c * (1 + nu) * eig

    def displacement(i, r):
        row = np.zeros(6)
        row[2 * i], row[2 * i + 1] = r, 1.0 / r
        return row

    rows, rhs = [], []
    for i, r in ((0, layers[0][0]), (2, layers[2][1])):  # free faces
        row, b = radial_stress(i, r)
        rows.append(row), rhs.append(b)
    for i in (0, 1):  # interfaces
        r = layers[i][1]
        (r1, b1), (r2, b2) = radial_stress(i, r), radial_stress(i + 1, r)
        rows.append(r1 - r2), rhs.append(b1 - b2)
        rows.append(displacement(i, r) - displacement(i + 1, r)), rhs.append(0.0)
    x = np.linalg.solve(np.array(rows), np.array(rhs))
    out = []
    for i in (0, 2):
        r1, r2 = layers[i][:2]
        E, nu, eig = plane(*layers[i][2:])
        c = E / (1 - nu**2)
        out.append(c * ((1 + nu) * (x[2 * i] - eig) + (1 - nu) * x[2 * i + 1] / (r1 * r2)))  # thickness mean
    return out[0], out[1]


def _linear_critical_stress(tube: FilmTube, film: str, E_gel: float, nu_gel: float, stiffness: str) -> float:
    a, b = tube.Ri, tube.Ro
    G = E_gel / (2 * (1 + nu_gel))
    _, t, E = tube.film(film)
    R = a if film == "inner" else b  # the thesis's radius: the interface
    if stiffness == "michell":
        def K(n):
            return foundation_stiffness_annulus(n, inner_radius=a, outer_radius=b, shear_modulus=G, nu=nu_gel,
                                                loaded=film, interface="no_slip")
    elif stiffness == "lame":
        K = foundation_stiffness_annulus(0, inner_radius=a, outer_radius=b, shear_modulus=G, nu=nu_gel, loaded=film)
    else:
        raise ValueError(f"stiffness must be 'michell' or 'lame', got {stiffness!r}")
    return critical_mode(R, t, E, tube.nu_film, K).N_cr / t


def linear_switch(tube: FilmTube, *, E_gel: float, nu_gel: float, stiffness: Literal["michell", "lame"] = "lame",
                  lo: float = 0.1, hi: float = 1000.0) -> float | None:
    """The thesis's switch (fig. 4-2, its eq. 4-3 against eq. 4-4): the outer-film modulus (same
    units as ``tube.Efo``, which is otherwise ignored) at which the linear pre-buckling stress
    ratio ``sigma_fi/sigma_fo`` (:func:`linear_film_stresses`) equals the ratio of the films'
    critical stresses (ring on the Lame stiffness, the thesis's ``K_i``, ``K_o``, or on the
    mode-``n`` Michell stiffness of the annulus; reference geometry, interface radii). Below it
    the inner film buckles first. Root in ``log Efo`` between ``lo`` and ``hi`` times
    ``tube.Efi``; None if they do not bracket it."""

    def excess(log_efo: float) -> float:  # > 0: the inner film is nearer its critical stress
        t = replace(tube, Efo=math.exp(log_efo))
        si, so = linear_film_stresses(t, E_gel=E_gel, nu_gel=nu_gel)
        return si / so - _linear_critical_stress(t, "inner", E_gel, nu_gel, stiffness) / \
            _linear_critical_stress(t, "outer", E_gel, nu_gel, stiffness)

    a, b = math.log(lo * tube.Efi), math.log(hi * tube.Efi)
    if excess(a) <= 0 or excess(b) >= 0:
        return None
    return math.exp(brentq(excess, a, b, xtol=1e-10))


def thesis_ring_estimate(tube: FilmTube, film: Literal["inner", "outer"], *, E_gel: float | None = None,
                         nu_gel: float = 0.5) -> tuple[float, float]:
    """The thesis's eqs. 4-1, 4-2 for one film: ``n = R (K/(Ef_bar I))^(1/4)`` and
    ``sigma_cr = 2 sqrt(K Ef_bar I)/t`` with its mode-independent Lame stiffness ``K_i`` or ``K_o``
    of the reference annulus, gel modulus ``E_gel`` (default ``3 Nv``, the thesis's ``Es = 3NkT``)
    and ``nu_gel = 0.5``, ``R`` the interface radius. Returns ``(n, sigma_cr)``."""
    E_gel = 3.0 * tube.Nv if E_gel is None else _positive("E_gel", E_gel)
    a, b = tube.Ri, tube.Ro
    K = foundation_stiffness_annulus(0, inner_radius=a, outer_radius=b, shear_modulus=E_gel / (2 * (1 + nu_gel)),
                                     nu=nu_gel, loaded=film)
    _, t, E = tube.film(film)
    D = E * t**3 / (12 * (1 - tube.nu_film**2))
    R = a if film == "inner" else b
    return R * (K / D) ** 0.25, 2 * math.sqrt(K * D) / t
