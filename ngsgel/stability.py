"""Stability of equilibrium states: spectra of the tangent, load rates, linear buckling, imperfections.

Everything here sees a ``NonlinearSystem`` that also has ``space``, ``mesh`` and ``kinematics``
(an ``EquilibriumProblem``) and one load parameter (an NGSolve ``Parameter``). Matrices are the
NGSolve tangent restricted to the free dofs and handed to scipy:

- the number of negative eigenvalues is exact (Sylvester's inertia of an LDL^T factorisation:
  SuperLU with diagonal pivots in symmetric mode), so a change between two states is certain;
- the lowest eigenvalues and modes solve ``K phi = omega M phi`` with ``M`` the (volume-weighted)
  L2 Gram matrix of the displacement, so ``omega`` is a stiffness per volume that does not depend
  on the mesh, and modes come out with unit root-mean-square displacement over the body;
- ``dR/dlambda`` (the load rate) is a central difference of the residual at fixed state plus the
  tangent times the rate of the prescribed values. All loads of ``EquilibriumProblem`` are affine
  in their parameter (``W`` is linear in ``mu``, dead tractions and prescribed values are linear
  in their Parameter), so the difference is exact up to round-off; for a nonlinear dependence it
  is second-order accurate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp
import scipy.sparse.linalg as sla

__all__ = ["Spectrum", "LoadRate", "BucklingResult", "free_matrix", "mass_matrix", "negative_count",
           "spectrum", "load_rate", "state_rate", "conjugate_force", "mode_function", "load_projection", "linear_buckling",
           "random_field", "seed_imperfection", "GrowthSelection", "growth_exponents", "fastest_growing",
           "arpack_start"]


def free_matrix(mat: ngs.BaseMatrix, free_mask: np.ndarray) -> sp.csc_matrix:
    """An assembled NGSolve sparse matrix restricted to the free dofs, as scipy CSC."""
    vals, cols, indptr = mat.CSR()
    n = len(free_mask)
    full = sp.csr_matrix((np.array(vals), np.array(cols), np.array(indptr)), shape=(n, n))
    free = np.flatnonzero(free_mask)
    return full[free][:, free].tocsc()


def mass_matrix(problem) -> ngs.BaseMatrix:
    """Volume-weighted L2 Gram matrix of the displacement space (same sparsity as the tangent;
    an axial strain unknown enters as ``int w e f``, which keeps it positive definite).
    A problem with other unknowns than a displacement (a shell) provides its own ``mass_matrix``."""
    if hasattr(problem, "mass_matrix"):
        return problem.mass_matrix()
    V = problem.space
    if problem.kinematics.axial_unknown:  # the axial strain with unit weight
        (u, a), (v, b) = V.TnT()
        gram = ngs.InnerProduct(u, v) + a * b
    else:
        u, v = V.TnT()
        gram = ngs.InnerProduct(u, v)
    form = ngs.BilinearForm(V, symmetric=True)
    form += problem.kinematics.volume_weight() * gram * ngs.dx
    form.Assemble()
    return form.mat


DENSE_INERTIA_LIMIT = 4000  # unknowns up to which a dense eigenvalue count is cheap enough


def negative_count(K: sp.spmatrix) -> int:
    """Number of negative eigenvalues of the symmetric matrix ``K`` (exact, by inertia)."""
    lu = sla.splu(sp.csc_matrix(K), permc_spec="MMD_AT_PLUS_A", diag_pivot_thresh=0.0,
                  options={"SymmetricMode": True})
    # Diagonal pivoting with a symmetric permutation makes L U = P K P^T an LDL^T in disguise:
    # the signs of U's diagonal are the inertia. Any row swap would break that argument.
    if not np.array_equal(lu.perm_r, lu.perm_c):
        if K.shape[0] <= DENSE_INERTIA_LIMIT:  # near-singular K: fall back to its eigenvalues
            return int(np.count_nonzero(np.linalg.eigvalsh(K.toarray()) < 0))
        raise RuntimeError("SuperLU pivoted off the diagonal; the inertia of the tangent is unknown")
    return int(np.count_nonzero(lu.U.diagonal() < 0))


ARPACK_SEED = 37  # any fixed value; 37 is the issue that asked for reproducible runs


def arpack_start(n: int) -> np.ndarray:
    """The start vector of every ARPACK solve (``eigsh``'s ``v0``) of ``n`` unknowns: the same
    seeded random vector in every call. Without one, ARPACK draws it from a generator whose state
    carries over between solves in a process, so a mode's sign and the basis found for a cluster of
    (nearly) equal eigenvalues depend on the eigen solves made before - and so does a path that
    pushes or switches along that mode. Random, not constant: it must not be orthogonal to a
    wanted mode, which a structured vector (all ones) can be by symmetry."""
    return np.random.default_rng(ARPACK_SEED).standard_normal(n)


@dataclass
class Spectrum:
    """Lowest eigenvalues (ascending) of ``K phi = omega M phi`` on the free dofs, their modes
    (columns, free-dof vectors, ``phi^T M phi = volume``) and the exact negative count of ``K``.
    ``zero_band``: eigenvalues in ``[0, zero_band]`` are zero to the eigen solve's round-off, so
    the inertia may count them negative (a state at a critical point to round-off)."""

    eigenvalues: np.ndarray
    modes: np.ndarray
    negative: int
    zero_band: float = 0.0

    def crossing(self, index: int) -> tuple[float, np.ndarray]:
        """Eigenvalue and mode number ``index`` (0 = lowest): the one whose sign change turns
        ``index`` negative eigenvalues into ``index + 1`` or back."""
        missing = self.negative - int(np.count_nonzero(self.eigenvalues < 0))  # lowest ones not in the set
        # negative ones that the eigen solve returned as round-off zeros are in the set
        missing -= min(max(missing, 0), int(np.count_nonzero((self.eigenvalues >= 0)
                                                              & (self.eigenvalues <= self.zero_band))))
        if not 0 <= index - missing < len(self.eigenvalues):
            raise ValueError(f"eigenvalue number {index} is not in this spectrum (eigenvalues {missing} to "
                             f"{missing + len(self.eigenvalues) - 1} of the tangent; compute it with past_negative=True)")
        return float(self.eigenvalues[index - missing]), self.modes[:, index - missing]


def _volume(problem) -> float:
    return problem.integrate(ngs.CF(1.0))


def spectrum(problem, *, count: int = 4, K: sp.spmatrix | None = None, M: sp.spmatrix | None = None,
             past_negative: bool = False, factorisation=None) -> Spectrum:
    """Lowest ``count`` eigenvalues of the tangent at the current state (``K``, ``M``: free-dof
    matrices if already at hand) when it has at most ``count`` negative ones; with more, the
    ``count`` negative eigenvalues nearest zero (those that cross next), not the lowest.
    ``past_negative``: raise ``count`` to the negative count plus one, so that the set is the
    lowest eigenvalues up to the first non-negative one - every eigenvalue whose sign change
    changes the negative count by one, which is what a path driver tracks.
    Shift-invert about a shift a hair below zero: the exact negative count says how many must lie
    below zero. If the set found there lacks some of the ``min(negative, count)`` wanted, they lie
    far below zero (a state in the middle of a snap): the shift is moved down by factors of 4
    until the inertia of ``K - sigma M`` leaves at least that many eigenvalues between it and
    zero, and the set is found about it (or they are zeros of a singular tangent, within
    ``1e-10`` of the matrix scale, whose sign is round-off: then the set stands).
    ``factorisation``: an LDL^T of ``K`` with a known inertia (``ngsgel.linalg.PardisoLDLT``,
    as ``LinearSolver.ldlt`` gives it): its negative count is taken and it is the shift-invert
    operator about zero, so the eigen solve needs no factorisation of its own (an exactly
    singular tangent perturbs PARDISO's pivots, and its inertia is then None: not usable here)."""
    free = problem.free_mask
    if K is None:
        K = free_matrix(problem.tangent(problem.state), free)
    if M is None:
        M = free_matrix(mass_matrix(problem), free)
    n = K.shape[0]
    if factorisation is not None and (factorisation.inertia is None or factorisation.n != n):
        raise ValueError("factorisation must be an LDL^T of K with a known inertia")
    negative = negative_count(K) if factorisation is None else factorisation.inertia[1]
    count = min(max(count, negative + 1) if past_negative else count, n - 1)
    wanted = min(negative, count)
    # A shift a hair below zero keeps K - sigma M regular at an exactly critical state (a
    # factorisation with a known inertia is regular: its unperturbed pivots say so).
    scale = float(np.max(np.abs(K.diagonal() / M.diagonal())))
    near = -1e-10 * scale
    if factorisation is None:
        sigma = near
        values, vectors = _nearest(K, M, count, sigma)
    else:
        sigma = 0.0
        values, vectors = _nearest(K, M, count, sigma, sla.LinearOperator((n, n), matvec=factorisation.solve,
                                                                          dtype=float))
    if np.count_nonzero(values < 0) < wanted:
        # Walking the shift down by the returned values instead costs an eigen solve per step,
        # each slow with the near-zero eigenvalues clustered as seen from a far shift (a 49k-unknown
        # shell mid-snap: 13 solves in 15 minutes without reaching its negative pair).
        sigma = near
        for _ in range(60):
            if negative_count(K - sigma * M) <= negative - wanted:
                break
            sigma *= 4.0
        else:
            raise RuntimeError(f"no shift below the {negative} negative eigenvalues of the tangent down to {sigma:.3g}")
        # Unmoved, the missing ones lie between the shift and zero: zeros of a singular tangent
        # (rigid motions) whose sign is round-off, and the set found is the lowest.
        if sigma != near:
            values, vectors = _nearest(K, M, count, sigma)
            if np.count_nonzero(values < 0) < wanted:
                raise RuntimeError(f"the eigen solve about the shift {sigma:.3g} found {np.count_nonzero(values < 0)} "
                                   f"of the {wanted} negative eigenvalues the inertia puts above it")
    vectors *= np.sqrt(_volume(problem))
    return Spectrum(eigenvalues=values, modes=vectors, negative=negative, zero_band=-near)


def _nearest(K: sp.spmatrix, M: sp.spmatrix, count: int, sigma: float,
             OPinv: sla.LinearOperator | None = None) -> tuple[np.ndarray, np.ndarray]:
    """The ``count`` eigenpairs of ``K phi = omega M phi`` nearest ``sigma``, ascending
    (``OPinv``: ``(K - sigma M)^-1`` if at hand, else scipy factorises it)."""
    values, vectors = sla.eigsh(K, k=count, M=M, sigma=sigma, which="LM", v0=arpack_start(K.shape[0]), OPinv=OPinv)
    order = np.argsort(values)
    return values[order], vectors[:, order]


@dataclass
class LoadRate:
    """``dR/dlambda`` on the free dofs (``residual``) and the rate of the prescribed values
    (``prescribed``, full length, zero on free dofs)."""

    residual: np.ndarray
    prescribed: np.ndarray


def load_rate(problem, parameter: ngs.Parameter, *, x: ngs.BaseVector | None = None,
              K: ngs.BaseMatrix | None = None, relative_step: float = 1e-4,
              move_prescribed: bool = False) -> LoadRate:
    """Total derivative of the free residual with respect to the load parameter along states whose
    constrained dofs follow their prescribed values (central difference, see the module notes).
    ``K``: the tangent at ``x`` if already assembled. ``move_prescribed``: the residuals are taken
    with the constrained dofs at their values at ``lambda +- h``, so the difference carries their
    motion itself and no tangent is needed (exact to ``O(h^2)``; ``K`` is then not used)."""
    x = problem.state if x is None else x
    lam = parameter.Get()
    h = relative_step * (1.0 + abs(lam))
    free = problem.free_mask
    r_plus, r_minus = x.CreateVector(), x.CreateVector()
    g_plus, g_minus = x.CreateVector(), x.CreateVector()
    moved = x.CreateVector()

    def residual_at(out, g) -> None:
        problem.prescribed(g)
        if move_prescribed:
            moved.data = x
            moved.FV().NumPy()[~free] = g.FV().NumPy()[~free]
            problem.residual(moved, out)
        else:
            problem.residual(x, out)

    try:
        parameter.Set(lam + h)
        residual_at(r_plus, g_plus)
        parameter.Set(lam - h)
        residual_at(r_minus, g_minus)
    finally:
        parameter.Set(lam)
    dg = (g_plus.FV().NumPy() - g_minus.FV().NumPy()) / (2 * h)
    dg[free] = 0.0
    dR = (r_plus.FV().NumPy() - r_minus.FV().NumPy()) / (2 * h)
    if np.any(dg) and not move_prescribed:
        # the free rows feel the moving constrained dofs through the coupling block of the tangent
        move = x.CreateVector()
        move.FV().NumPy()[:] = dg
        r_plus.data = (problem.tangent(x) if K is None else K) * move
        dR = dR + r_plus.FV().NumPy()
    return LoadRate(residual=dR[free].copy(), prescribed=dg)


def state_rate(problem, parameter: ngs.Parameter, *, K=None, relative_step: float = 1e-4) -> np.ndarray:
    """``dx/dlambda`` along the equilibrium path at the current converged state (full length): the
    prescribed rate on constrained dofs, ``-K^-1 dR/dlambda`` on the free ones (``K``: the free-dof
    tangent if already at hand; ``relative_step``: of ``load_rate``)."""
    free = problem.free_mask
    rate = load_rate(problem, parameter, relative_step=relative_step)
    K = free_matrix(problem.tangent(problem.state), free) if K is None else K
    dx = rate.prescribed.copy()
    dx[free] = -sla.spsolve(K, rate.residual)
    return dx


def conjugate_force(problem, parameter: ngs.Parameter, *, x: ngs.BaseVector | None = None) -> float:
    """Generalised force work-conjugate to a prescribed-displacement ``parameter`` (e.g. the
    indentation depth): ``dE/dlambda = r(x) . dg/dlambda``, ``r`` the full residual (at an
    equilibrium, the reactions on the constrained dofs) and ``g`` the prescribed values. Exact for
    values affine in the parameter (the rate is a difference over a unit step)."""
    x = problem.state if x is None else x
    lam = parameter.Get()
    g_plus, g_minus, r = x.CreateVector(), x.CreateVector(), x.CreateVector()
    try:
        parameter.Set(lam + 0.5)
        problem.prescribed(g_plus)
        parameter.Set(lam - 0.5)
        problem.prescribed(g_minus)
    finally:
        parameter.Set(lam)
    problem.residual(x, r)
    dg = g_plus.FV().NumPy() - g_minus.FV().NumPy()
    dg[problem.free_mask] = 0.0
    return float(np.dot(r.FV().NumPy(), dg))


def mode_function(problem, vector: np.ndarray, *, name: str = "mode") -> ngs.GridFunction:
    """A free-dof vector as a displacement GridFunction (zero on constrained dofs)."""
    gf = ngs.GridFunction(problem.space, name=name)
    gf.vec.FV().NumPy()[:] = 0.0
    gf.vec.FV().NumPy()[problem.free_mask] = vector
    return gf


def load_projection(mode: np.ndarray, rate: LoadRate) -> float:
    """``|phi . dR/dlambda| / (|phi| |dR/dlambda|)``: O(1) at a limit point, zero at a
    bifurcation (the critical mode does no work with the load increment there)."""
    denom = np.linalg.norm(mode) * np.linalg.norm(rate.residual)
    return float(abs(mode @ rate.residual) / denom) if denom > 0 else 0.0


@dataclass
class BucklingResult:
    """Linear buckling of a prestressed state: ``K0 + alpha dK`` singular at ``load_factors``;
    ``parameters = lambda0 + alpha * increment``; ``modes`` unit-RMS GridFunctions."""

    load_factors: np.ndarray
    parameters: np.ndarray
    modes: list[ngs.GridFunction]


def linear_buckling(problem, parameter: ngs.Parameter, *, increment: float, count: int = 3,
                    relative_step: float = 1e-3) -> BucklingResult:
    """The *Buckle analogue at the current (converged, stable) state ``x0, lambda0``.

    The load increment ``increment`` gives the linear response ``du = -K0^-1 dR/dlambda`` (with the
    prescribed rate on constrained dofs) and the stiffness change ``dK`` per unit of it, a central
    difference of the tangent along ``(du, increment)``; then ``K0 phi = -alpha dK phi`` for the
    smallest positive ``alpha``. Solved as ``(-dK) phi = theta K0 phi``, ``theta = 1/alpha`` largest,
    which needs ``K0`` positive definite (a stable prestressed state)."""
    x0 = problem.save_state()
    free = problem.free_mask
    lam0 = parameter.Get()
    K0 = free_matrix(problem.tangent(problem.state), free)
    if negative_count(K0) != 0:
        raise ValueError("linear buckling needs a stable prestressed state (the tangent has negative eigenvalues)")
    du = state_rate(problem, parameter, K=K0) * increment
    eps = relative_step
    tangents = []
    try:
        for sign in (1.0, -1.0):
            problem.restore_state(x0 + sign * eps * du)
            parameter.Set(lam0 + sign * eps * increment)
            tangents.append(free_matrix(problem.tangent(problem.state), free))
    finally:
        problem.restore_state(x0)
        parameter.Set(lam0)
    dK = (tangents[0] - tangents[1]) / (2 * eps)
    theta, vectors = sla.eigsh(-dK, k=min(count, K0.shape[0] - 1), M=K0, which="LA", v0=arpack_start(K0.shape[0]))
    positive = theta > 0
    order = np.argsort(-theta[positive])
    alpha = 1.0 / theta[positive][order]
    vectors = vectors[:, positive][:, order]
    M = free_matrix(mass_matrix(problem), free)
    volume = _volume(problem)
    modes = []
    for i in range(len(alpha)):
        phi = vectors[:, i] * np.sqrt(volume / (vectors[:, i] @ (M @ vectors[:, i])))
        modes.append(mode_function(problem, phi, name=f"buckling_mode_{i}"))
    return BucklingResult(load_factors=alpha, parameters=lam0 + alpha * increment, modes=modes)


def random_field(problem, *, correlation_length: float, seed: int = 0, terms: int = 64) -> ngs.GridFunction:
    """A smooth random displacement field, zero on constrained dofs, unit RMS over the body: a sum
    of ``terms`` plane waves per component with random directions, phases and wave numbers up to
    ``2 pi / correlation_length``."""
    rng = np.random.default_rng(seed)
    mesh = problem.mesh
    coords = (ngs.x, ngs.y, ngs.z)[:mesh.dim]
    components = []
    for _ in problem.kinematics.components:
        total = ngs.CF(0.0)
        for _ in range(terms):
            direction = rng.normal(size=mesh.dim)
            direction *= rng.uniform(0.0, 2 * np.pi / correlation_length) / np.linalg.norm(direction)
            phase = sum(float(d) * c for d, c in zip(direction, coords)) + rng.uniform(0, 2 * np.pi)
            total = total + rng.normal() * ngs.cos(phase)
        components.append(total)
    gf = ngs.GridFunction(problem.space, name="random_field")
    gf.vec[:] = 0.0  # a global axial unknown (generalized plane strain) stays unperturbed
    u = problem.parts(gf)[0]
    u.Set(ngs.CF(tuple(components)) if len(components) > 1 else components[0])
    gf.vec.FV().NumPy()[~problem.free_mask] = 0.0
    rms = np.sqrt(problem.integrate(ngs.InnerProduct(u, u)) / _volume(problem))
    gf.vec.data *= 1.0 / rms
    return gf


def seed_imperfection(problem, shapes: Sequence[ngs.GridFunction], amplitudes: Sequence[float]) -> ngs.GridFunction:
    """Geometric imperfection (Abaqus *Imperfection): the reference geometry is moved by
    ``sum a_i shape_i`` (shapes as from ``spectrum``/``linear_buckling`` modes or ``random_field``,
    amplitudes in length units), through ``mesh.SetDeformation``. Call before the first solve;
    ``problem.mesh.UnsetDeformation()`` removes it."""
    if len(shapes) != len(amplitudes):
        raise ValueError(f"got {len(shapes)} shapes and {len(amplitudes)} amplitudes")
    if len(problem.kinematics.components) != problem.mesh.dim:
        raise ValueError("imperfections need one displacement component per mesh direction")
    total = ngs.GridFunction(problem.space, name="imperfection")
    total.vec[:] = 0.0
    for shape, a in zip(shapes, amplitudes):
        total.vec.data += float(a) * shape.vec
    problem.mesh.SetDeformation(problem.parts(total)[0])
    return total


# ----------------------------------------------------------------------------- overdamped growth


def _positive_part_integral(f0, f1, width):
    """``int_0^width max(0, f)`` of ``f`` linear from ``f0`` to ``f1`` (arrays, elementwise)."""
    f0, f1 = np.asarray(f0, float), np.asarray(f1, float)
    both = 0.5 * (np.maximum(f0, 0) + np.maximum(f1, 0)) * width
    hi, lo = np.maximum(f0, f1), np.minimum(f0, f1)
    with np.errstate(divide="ignore", invalid="ignore"):
        triangle = 0.5 * width * hi**2 / (hi - lo)  # only the part where f > 0, when the sign changes
    return np.where(lo >= 0, both, np.where(hi <= 0, 0.0, triangle))


def growth_exponents(load: Sequence[float], eigenvalues) -> np.ndarray:
    """Cumulative growth exponents ``G_j(load_i) = int_{load_0}^{load_i} max(0, -omega_j) dload``
    of modes ``j`` whose eigenvalues ``omega_j`` (``K phi = omega M phi``) are sampled at the
    increasing loads ``load_i`` (``eigenvalues[i, j]``, linear in the load between samples).

    Meaning: under the overdamped flow ``c M dx/dtau = -K(lambda) x`` with the load ramped at a
    constant rate ``lambda' = dlambda/dtau`` (a quasi-static run with viscous stabilisation, e.g.
    Abaqus's ``*Static, stabilize``, whose damping matrix is ``c`` times a unit-density mass
    matrix), a mode grows by ``exp(G / (c lambda'))`` from where it loses stability; stable
    modes do not grow."""
    load = np.asarray(load, dtype=float)
    omega = np.asarray(eigenvalues, dtype=float)
    if load.ndim != 1 or omega.ndim != 2 or omega.shape[0] != load.size or load.size < 2:
        raise ValueError(f"eigenvalues must be (len(load), modes) with len(load) >= 2, got {omega.shape} and {load.shape}")
    if not (np.all(np.isfinite(load)) and np.all(np.isfinite(omega))):
        raise ValueError("load and eigenvalues must be finite")
    if not np.all(np.diff(load) > 0):
        raise ValueError("load must increase strictly")
    steps = _positive_part_integral(-omega[:-1], -omega[1:], np.diff(load)[:, None])
    return np.vstack([np.zeros(omega.shape[1]), np.cumsum(steps, axis=0)])


@dataclass
class GrowthSelection:
    """The mode that grows first by ``threshold`` (``fastest_growing``): its column ``index``,
    the ``load`` at which it does, and the exponents ``G`` of all modes at that load."""

    index: int
    load: float
    exponents: np.ndarray


def fastest_growing(load: Sequence[float], eigenvalues, threshold: float) -> GrowthSelection | None:
    """The mode whose growth exponent (``growth_exponents``) first reaches ``threshold`` as the
    load rises, with the load where it does (exact for eigenvalues linear between the samples);
    None if none does by the last load. ``threshold = c lambda' ln(A / a0)``: the damping
    coefficient times the load rate times the log of the growth from the imperfection ``a0`` to a
    visible amplitude ``A``; as it goes to zero the first mode to lose stability is selected."""
    if not (np.isfinite(threshold) and threshold > 0):
        raise ValueError(f"threshold must be a finite number > 0, got {threshold!r}")
    load = np.asarray(load, dtype=float)
    omega = np.asarray(eigenvalues, dtype=float)
    G = growth_exponents(load, omega)
    reached = np.nonzero(np.any(G >= threshold, axis=1))[0]
    if reached.size == 0:
        return None
    i = int(reached[0])  # the threshold is crossed within (load[i-1], load[i]]

    def exponent(j: int, x: float) -> float:
        f0, f1 = -omega[i - 1, j], -omega[i, j]
        fx = f0 + (f1 - f0) * (x - load[i - 1]) / (load[i] - load[i - 1])
        return float(G[i - 1, j] + _positive_part_integral(f0, fx, x - load[i - 1]))

    crossings = []
    for j in np.nonzero(G[i] >= threshold)[0]:
        lo, hi = load[i - 1], load[i]
        for _ in range(100):  # bisection: the exponent is nondecreasing in the load
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if exponent(int(j), mid) < threshold else (lo, mid)
        crossings.append((hi, int(j)))
    at, j = min(crossings)
    return GrowthSelection(index=j, load=float(at),
                           exponents=np.array([exponent(m, at) for m in range(omega.shape[1])]))
