"""Stability of axisymmetric equilibria against non-axisymmetric perturbations, one angular
wave number at a time.

An axisymmetric state (``Axisymmetric`` kinematics, an r-z section) is perturbed by

    u_r = a(r, z) cos k theta,   u_z = b(r, z) cos k theta,   u_theta = c(r, z) sin k theta

(``k = 0``: ``a, b, c`` independent of theta, ``c`` the torsion). With the physical components
of the displacement gradient in the reference cylindrical basis,

    grad u = [[u_r,r, u_r,z, (u_r,theta - u_theta)/r],
              [u_z,r, u_z,z,  u_z,theta/r          ],
              [u_theta,r, u_theta,z, (u_theta,theta + u_r)/r]]     (rows/columns r, z, theta)

the perturbation of ``F`` is ``A cos k theta + B sin k theta`` with ``A`` holding the r-z block
and the hoop entry ``(a + k c)/r``, ``B`` the entries ``-(k a + c)/r``, ``-k b/r``, ``c,r``,
``c,z``. Because the base state and the energy are axisymmetric and isotropic, the second
variation over the full circle is ``pi int (W''[A, A] + W''[B, B]) r`` for ``k >= 1`` (and
``2 pi int W''[A + B, A + B] r`` for ``k = 0``): wave numbers decouple, and each is a 2D
eigenproblem on the section. Its eigenvalues equal those of the 3D tangent for modes of that
wave number, with the same mass normalisation (``int |u|^2 dV``).

Regularity on the axis ``r = 0``: ``a = c = 0`` for ``k = 0``; ``b = 0`` and ``a + c = 0`` for
``k = 1`` (a translation, ``a = -c``, is allowed); ``a = b = c = 0`` for ``k >= 2``. For
``k = 1`` the unknowns are ``(a - c, b, a + c)`` so that the axis condition is a plain
Dirichlet condition.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp
import scipy.linalg

from .kinematics import Axisymmetric
from .newton import NewtonError
from .stability import Spectrum, free_matrix, load_rate, spectrum, state_rate
from .stepping import ramp
from .supports import vertex_at

_DENSE_LIMIT = 8000  # unknowns of one wave number for the dense linear buckling solve

__all__ = ["HarmonicStability", "HarmonicScan", "InstabilityOnset", "first_harmonic_instability", "stress_rate"]


class _HarmonicSystem:
    """What ``stability.spectrum`` needs of a problem: free dofs, a tangent, a volume."""

    def __init__(self, free_mask: np.ndarray, volume: float):
        self.free_mask = free_mask
        self._volume = volume

    def integrate(self, cf) -> float:  # only asked for the volume (mode normalisation)
        return self._volume


class HarmonicStability:
    """Second variation of an axisymmetric ``EquilibriumProblem`` for wave numbers ``k``.

    ``axis``: the boundary on ``r = 0`` (None if the section does not touch the axis; by
    default ``"axis"`` when the mesh has it). Perturbations vanish in every component the problem
    fixes or prescribes on a boundary; ``u_theta`` also vanishes on ``theta_fixed`` (default: the
    boundaries where the problem fixes both ``r`` and ``z``, i.e. clamped ones). ``pins``: section
    points (mesh vertices) held in every component, rings in 3D: the perturbations of a problem
    whose vertex there is fixed (``ngsgel.supports.pin_vertex_component``, e.g. a hinged edge).
    Tractions are dead loads and add nothing; surface energies (e.g. contact penalties) are not
    included.
    """

    def __init__(self, problem, *, axis: str | None = "axis", theta_fixed: str | None = None,
                 pins: Sequence[Sequence[float]] = ()):
        if not isinstance(problem.kinematics, Axisymmetric):
            raise ValueError(f"problem must use Axisymmetric kinematics, got {problem.kinematics.name!r}")
        names = set(problem.mesh.GetBoundaries())
        if axis is not None and axis not in names:
            if axis != "axis":
                raise ValueError(f"unknown axis boundary {axis!r}; the mesh has {sorted(names)}")
            axis = None
        self.problem = problem
        self.axis = axis
        fixed_r = set(_split(problem._fixed[0]))
        fixed_z = set(_split(problem._fixed[1]))
        if theta_fixed is None:
            fixed_theta = (fixed_r & fixed_z) - {axis}
        else:
            problem._check_boundary(theta_fixed)
            fixed_theta = set(_split([theta_fixed]))
        self._fixed = {"a": fixed_r - {axis}, "b": fixed_z - {axis}, "c": fixed_theta - {axis}}
        self._pins = [vertex_at(problem.mesh, point) for point in pins]
        self._cache: dict[int, tuple] = {}

    # ------------------------------------------------------------------ the discrete forms
    def _space(self, k: int) -> ngs.FESpace:
        fixed = {name: set(bnds) for name, bnds in self._fixed.items()}
        if self.axis is not None:
            on_axis = {0: ("a", "c"), 1: ("b",)}.get(k, ("a", "b", "c"))
            for name in on_axis:
                fixed[name].add(self.axis)
        if k == 1:
            # unknowns (a - c, b, a + c): a condition on u_r alone would couple two of them
            off_axis = {name: bnds - {self.axis} for name, bnds in fixed.items()}
            if off_axis["a"] != off_axis["c"]:
                raise ValueError("k = 1 needs u_theta fixed exactly where u_r is fixed (theta_fixed); "
                                 f"u_r on {sorted(off_axis['a'])}, u_theta on {sorted(off_axis['c'])}")
            parts = (off_axis["a"], fixed["b"], fixed["c"])  # the axis fixes a + c only
        else:
            parts = (fixed["a"], fixed["b"], fixed["c"])
        mesh, order = self.problem.mesh, self.problem.order
        spaces = [ngs.H1(mesh, order=order, dirichlet="|".join(sorted(p))) for p in parts]
        return spaces[0] * spaces[1] * spaces[2]

    @staticmethod
    def _abc(k: int, w) -> tuple:
        """Physical amplitudes ``(a, b, c)`` and their gradients from the unknowns."""
        if k == 1:
            a = 0.5 * (w[0] + w[2])
            c = 0.5 * (w[2] - w[0])
            da = 0.5 * (ngs.Grad(w[0]) + ngs.Grad(w[2]))
            dc = 0.5 * (ngs.Grad(w[2]) - ngs.Grad(w[0]))
        else:
            a, c, da, dc = w[0], w[2], ngs.Grad(w[0]), ngs.Grad(w[2])
        return a, w[1], c, da, ngs.Grad(w[1]), dc

    def _perturbations(self, k: int, w) -> tuple:
        a, b, c, da, db, dc = self._abc(k, w)
        r = ngs.x
        zero = ngs.CF(0.0)

        def matrix(entries):
            return ngs.CF(tuple(entries), dims=(3, 3))

        A = matrix((da[0], da[1], zero, db[0], db[1], zero, zero, zero, (a + k * c) / r))
        B = matrix((zero, zero, -(k * a + c) / r, zero, zero, -k * b / r, dc[0], dc[1], zero))
        return A, B

    def _forms(self, k: int):
        if k in self._cache:
            return self._cache[k]
        prob = self.problem
        X = self._space(k)
        w = X.TrialFunction()
        F0 = prob.deformation_gradient(prob.displacement)
        A, B = self._perturbations(k, w)
        mu, lam0 = prob.mu, prob.lam0_of
        if k == 0:
            energy = prob.region_sum(lambda mat, name: mat.reference_energy(F0 + A + B, mu, lam0(name)))
            weight = 1.0
        else:
            energy = 0.5 * prob.region_sum(lambda mat, name: mat.reference_energy(F0 + A, mu, lam0(name))
                                           + mat.reference_energy(F0 + B, mu, lam0(name)))
            weight = 0.5
        stiffness = ngs.BilinearForm(X, symmetric=True)
        stiffness += ngs.Variation(energy)
        a, b, c, *_ = self._abc(k, w)
        ta, tb, tc, *_ = self._abc(k, X.TestFunction())
        mass = ngs.BilinearForm(X, symmetric=True)
        mass += weight * prob.kinematics.volume_weight() * (a * ta + b * tb + c * tc) * ngs.dx
        free = np.array(list(X.FreeDofs()), dtype=bool)
        for vertex in self._pins:
            free[list(X.GetDofNrs(ngs.NodeId(ngs.VERTEX, vertex)))] = False
        zero = ngs.GridFunction(X)
        self._cache[k] = (X, stiffness, mass, free, zero, weight)
        return self._cache[k]

    def matrices(self, k: int) -> tuple[sp.csc_matrix, sp.csc_matrix, np.ndarray]:
        """Free-dof stiffness and mass of wave number ``k`` at the problem's current state."""
        k = _check_k(k)
        X, stiffness, mass, free, zero, _ = self._forms(k)
        stiffness.AssembleLinearization(zero.vec)
        mass.Assemble()
        return free_matrix(stiffness.mat, free), free_matrix(mass.mat, free), free

    def spectrum(self, k: int, *, count: int = 3, exclude_rigid: bool = False,
                 past_negative: bool = False) -> Spectrum:
        """Lowest eigenvalues, modes (free-dof vectors of the unknowns) and the exact negative
        count for wave number ``k``; comparable across ``k`` and with the 3D tangent. With more
        than ``count`` negative eigenvalues the ones nearest zero are returned, unless
        ``past_negative`` raises ``count`` past them (``ngsgel.stability.spectrum``).

        ``exclude_rigid``: drop the zero eigenvalues of rigid motions the constraints leave free
        (``k = 0``: rotation about and translation along the axis; ``k = 1``: translation across
        and tilt), found as
        the computed modes closest to their span; eigenvalues within ``1e-10`` of the matrix scale
        below zero are not counted as negative."""
        K, M, free = self.matrices(k)
        volume = self._forms(k)[5] * self.problem.integrate(ngs.CF(1.0))
        rigid = self.rigid_modes(k) if exclude_rigid else np.zeros((len(free), 0))[free]
        n = rigid.shape[1]
        if n == 0:
            return spectrum(_HarmonicSystem(free, volume), count=count, K=K, M=M, past_negative=past_negative)
        # The inertia of a singular K is decided by round-off in its zero pivots; shifted by a
        # hair, the rigid zeros count as positive and only eigenvalues below -shift as negative.
        shift = 1e-10 * float(np.max(np.abs(K.diagonal() / M.diagonal())))
        full = spectrum(_HarmonicSystem(free, volume), count=count + n, K=K + shift * M, M=M,
                        past_negative=past_negative)
        full.eigenvalues = full.eigenvalues - shift
        # M-orthonormal basis of the rigid span, then each mode's share in it
        Q, _ = np.linalg.qr(rigid)
        G = Q.T @ (M @ Q)
        L = np.linalg.cholesky(G)
        Q = np.linalg.solve(L, Q.T).T
        share = np.linalg.norm(Q.T @ (M @ full.modes), axis=0) ** 2 / np.einsum(
            "ij,ij->j", full.modes, M @ full.modes)
        drop = np.argsort(share)[-n:]
        keep = np.setdiff1d(np.arange(len(full.eigenvalues)), drop)
        return Spectrum(eigenvalues=full.eigenvalues[keep], modes=full.modes[:, keep], negative=full.negative,
                        zero_band=full.zero_band)

    def rigid_modes(self, k: int) -> np.ndarray:
        """Free-dof vectors of the rigid motions of the current configuration that wave number
        ``k`` contains and the constraints allow (columns; possibly none)."""
        k = _check_k(k)
        free = self._forms(k)[3]
        u = self.problem.displacement
        r, z = ngs.x + u[0], ngs.y + u[1]  # current position: rotations turn the deformed body
        one, zero = ngs.CF(1.0), ngs.CF(0.0)
        motions = {0: [(zero, zero, r), (zero, one, zero)], 1: [(one, zero, -one), (-z, r, z)]}.get(k, [])
        columns = []
        for a, b, c in motions:
            v = self.vector(k, a, b, c)
            if np.allclose(v[~free], 0.0, atol=1e-12 * max(1.0, np.abs(v).max())):
                columns.append(v[free])
        return np.array(columns).T if columns else np.zeros((int(free.sum()), 0))

    def mode(self, k: int, vector: np.ndarray) -> tuple[ngs.CoefficientFunction, ...]:
        """The amplitudes ``(a, b, c)`` of a free-dof mode vector as coefficient functions."""
        X = self._forms(_check_k(k))[0]
        gf = ngs.GridFunction(X)
        gf.vec.FV().NumPy()[:] = 0.0
        gf.vec.FV().NumPy()[self._forms(k)[3]] = vector
        a, b, c, *_ = self._abc(k, gf.components)
        return a, b, c

    def vector(self, k: int, a, b, c) -> np.ndarray:
        """Interpolate amplitudes ``(a, b, c)`` (coefficient functions) into the unknowns of ``k``
        (full vector, constrained dofs included)."""
        X = self._forms(_check_k(k))[0]
        gf = ngs.GridFunction(X)
        values = (a - c, b, a + c) if k == 1 else (a, b, c)
        for comp, value in zip(gf.components, values):
            comp.Set(value)
        return gf.vec.FV().NumPy().copy()

    def geometric_stiffness(self, k: int, stress) -> sp.csc_matrix:
        """Free-dof initial-stress matrix of wave number ``k`` for a second Piola–Kirchhoff stress
        field ``stress`` of the swollen reference (3x3 in the r, z, theta basis; e.g.
        ``stress_rate``): the second variation of ``int S : (F^T F) / 2`` at fixed ``S`` for the
        harmonic perturbation, ``S : (A^T A)`` per unit volume and phase (as in ``matrices``)."""
        k = _check_k(k)
        X, _, _, free, zero, weight = self._forms(k)
        A, B = self._perturbations(k, X.TrialFunction())
        if k == 0:
            density = 0.5 * ngs.InnerProduct(stress, (A + B).trans * (A + B))
        else:
            density = 0.25 * (ngs.InnerProduct(stress, A.trans * A) + ngs.InnerProduct(stress, B.trans * B))
        form = ngs.BilinearForm(X, symmetric=True)
        form += ngs.Variation(self.problem.kinematics.volume_weight() * density * ngs.dx)
        form.AssembleLinearization(zero.vec)
        return free_matrix(form.mat, free)

    def linear_buckling(self, k: int, stress, *, count: int = 1) -> np.ndarray:
        """Load multipliers ``lambda`` of the linear buckling problem of wave number ``k``,
        ``(K_k + lambda G_k) phi = 0`` with ``K_k`` the tangent of the current (stable) state and
        ``G_k`` the initial-stress matrix of ``stress`` (the stress per unit load increment:
        ``stress_rate``): the eigenvalue buckling step of commercial codes (Abaqus ``*BUCKLE``),
        whose modes are the usual seeds of imperfections. Unlike ``ngsgel.stability.linear_buckling``
        (the whole tangent's change per unit load, material softening included) only the initial
        stress enters, as in those codes. The ``count`` smallest positive ones,
        ascending (``inf`` where the increment compresses nothing this mode can use); ``k = 0, 1``
        need a tangent without rigid motions."""
        K, _, _ = self.matrices(k)
        G = self.geometric_stiffness(k, stress)
        n = K.shape[0]
        if n > _DENSE_LIMIT:
            raise ValueError(f"{n} unknowns for k = {k}: the dense linear buckling solve takes at most {_DENSE_LIMIT}")
        # -G phi = w K phi with w = 1 / lambda: the largest positive w are the smallest lambda. A
        # dense solve: the w spectrum spans both signs (the reversed increment buckles too) with
        # huge values from the soft modes of thin sections, where Lanczos did not converge.
        count = min(count, n)
        w = scipy.linalg.eigh(-G.toarray(), K.toarray(), eigvals_only=True, subset_by_index=[n - count, n - 1])
        return np.array([1.0 / v if v > 0 else np.inf for v in w[::-1]])

    def scan(self, ks: Iterable[int], *, count: int = 1, exclude_rigid: bool = False) -> HarmonicScan:
        """Lowest eigenvalues for each wave number in ``ks`` (at least ``count``, and every
        negative one: ``lowest`` is the lowest even where a wave number has several)."""
        spectra = {int(k): self.spectrum(k, count=count, exclude_rigid=exclude_rigid, past_negative=True)
                   for k in ks}
        return HarmonicScan(spectra)


@dataclass
class HarmonicScan:
    spectra: dict[int, Spectrum]

    @property
    def lowest(self) -> dict[int, float]:
        return {k: float(s.eigenvalues[0]) for k, s in self.spectra.items()}

    @property
    def critical_k(self) -> int:
        """The wave number with the lowest eigenvalue."""
        return min(self.lowest, key=self.lowest.get)

    @property
    def unstable(self) -> list[int]:
        return [k for k, s in self.spectra.items() if s.negative > 0]


@dataclass
class InstabilityOnset:
    """First loss of stability along a ramp: ``parameter`` to within ``tolerance``, the critical
    wave number ``k`` and its spectrum there; ``path`` holds ``(parameter, lowest eigenvalue by
    k)`` at every converged step. ``found`` is False if the ramp reached its target stable."""

    found: bool
    parameter: float
    k: int | None
    spectrum: Spectrum | None
    path: list[tuple[float, dict[int, float]]]


def first_harmonic_instability(problem, parameter: ngs.Parameter, target: float, *, ks: Sequence[int],
                               step: float | None = None, max_step: float | None = None,
                               tolerance: float = 1e-6, exclude_rigid: bool = True,
                               on_step: Callable[[float, HarmonicScan], None] | None = None,
                               stability: HarmonicStability | None = None) -> InstabilityOnset:
    """Ramp ``parameter`` towards ``target`` along the axisymmetric path, scanning the lowest
    eigenvalue of every ``k`` in ``ks`` after each converged step (rigid motions excluded); at
    the first step where one turns negative, bisect between the last stable and the first
    unstable parameter to ``tolerance``. The problem is left at the last stable state found.
    """
    hs = HarmonicStability(problem) if stability is None else stability
    path: list[tuple[float, dict[int, float]]] = []

    def check() -> HarmonicScan:
        return hs.scan(ks, exclude_rigid=exclude_rigid)

    start = parameter.Get()
    scan = check()
    path.append((start, scan.lowest))
    if scan.unstable:
        raise ValueError(f"the starting state at {start:g} is already unstable for k in {scan.unstable}")
    state: dict = {"stable": (start, problem.save_state()), "unstable": None}

    def after_step(value, _newton) -> bool:
        sc = check()
        path.append((value, sc.lowest))
        if on_step is not None:
            on_step(value, sc)
        key = "unstable" if sc.unstable else "stable"
        state[key] = (value, problem.save_state())
        return bool(sc.unstable)

    ramp(problem, parameter, target, step=step, max_step=max_step, on_step=after_step)
    if state["unstable"] is None:
        return InstabilityOnset(False, parameter.Get(), None, None, path)
    (lo, x_lo), (hi, x_hi) = state["stable"], state["unstable"]
    # a bisection solve starts next to its solution: a relative tolerance alone would ask for
    # less than the residual's round-off (the floor follow_path uses)
    floor = 1e-10 * abs(hi - lo) * float(np.linalg.norm(load_rate(problem, parameter).residual))

    def solve_at(value: float, guess: np.ndarray) -> HarmonicScan:
        problem.restore_state(guess)
        parameter.Set(value)
        problem.solve(atol=floor)
        return check()

    while abs(hi - lo) > tolerance:
        mid = 0.5 * (lo + hi)
        try:
            sc = solve_at(mid, 0.5 * (x_lo + x_hi))
        except NewtonError:
            solve_at(lo, x_lo)
            raise
        if sc.unstable:
            hi, x_hi = mid, problem.save_state()
        else:
            lo, x_lo = mid, problem.save_state()
    sc = solve_at(hi, x_hi)
    k_crit = sc.critical_k
    solve_at(lo, x_lo)
    return InstabilityOnset(True, 0.5 * (lo + hi), k_crit, sc.spectra[k_crit], path)


def stress_rate(problem, parameter: ngs.Parameter, *, relative_step: float = 1e-6) -> ngs.CoefficientFunction:
    """Rate of the second Piola–Kirchhoff stress of the swollen reference (``J F^-1 sigma F^-T``,
    r-z-theta basis) with the load ``parameter`` along the linearised path of the current
    converged state: the state rate ``dx/dlambda = -K^-1 dR/dlambda`` (constrained dofs at their
    prescribed rate), then central differences of the stress along the straight line
    ``(x + eps dx/dlambda, lambda + eps)``, ``eps = relative_step * max(|lambda|, 1)`` (a
    difference of predicted states instead is spoiled by the predictor's second-order error,
    large where ``mu`` depends steeply on the load, near the dry state), interpolated elementwise
    (discontinuous polynomials of the problem's order). Leaves the state and the parameter as
    they were."""
    if not 0 < relative_step < 1e-2:
        raise ValueError(f"relative_step must be in (0, 1e-2), got {relative_step!r}")
    start, state = parameter.Get(), problem.save_state()
    # near the dry state the gel's bulk stiffness (~1 / (J (J - 1))) turns a relative error of
    # 1e-5 in the state rate into a stress rate larger than a graded disk's mismatch stresses
    dx = state_rate(problem, parameter, relative_step=relative_step)
    eps = relative_step * max(abs(start), 1.0)
    u = problem.displacement
    F = problem.deformation_gradient(u)
    S = ngs.Det(F) * ngs.Inv(F) * problem.cauchy_stress(u, problem.mu) * ngs.Inv(F).trans
    space = ngs.L2(problem.mesh, order=problem.order) ** 9
    values = []
    try:
        for sign in (1.0, -1.0):
            parameter.Set(start + sign * eps)
            problem.restore_state(state + sign * eps * dx)
            gf = ngs.GridFunction(space)
            gf.Set(S.Reshape((9,)))
            values.append(gf.vec.FV().NumPy().copy())
    finally:
        parameter.Set(start)
        problem.restore_state(state)
    result = ngs.GridFunction(space)
    result.vec.FV().NumPy()[:] = (values[0] - values[1]) / (2 * eps)
    return ngs.CF(tuple(result.components), dims=(3, 3))


def _split(boundaries: Iterable[str]) -> list[str]:
    return [part for b in boundaries for part in b.split("|")]


def _check_k(k) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 0:
        raise ValueError(f"k (the angular wave number) must be an integer >= 0, got {k!r}")
    return int(k)
