"""The linear-algebra backends of Newton's tangent (``ngsgel.linalg``): MKL PARDISO's LDL^T solves
as NGSolve's Cholesky does and its inertia counts the negative eigenvalues exactly (dense
eigenvalues as the reference, also next to a singular tangent); the stability checks of a path
take their count from it; the backend is chosen and named at run time."""

import math

import numpy as np
import ngsolve as ngs
import pytest
from ngsolve.meshes import MakeStructured2DMesh

from geometries import block
from ngsgel import EquilibriumProblem, FloryRehnerGel, NeoHookeanFilm, PlaneStrain, Solid3D, linalg, stability
from ngsgel.continuation import StabilityOptions, follow_path
from ngsgel.newton import LinearSolver
from ngsgel.stability import free_matrix

needs_pardiso = pytest.mark.skipif(not linalg.pardiso_available(),
                                   reason="MKL PARDISO not installed (pip install ngsgel[pardiso])")

E, NU = 1.0, 0.3
E_PLANE = E / (1 - NU**2)


def column(load_value: float, *, inverse: str = "umfpack", length: float = 20.0):
    """Plane-strain column (thickness 1, clamped at the bottom) under a dead compressive traction
    ``load * sigma_cr`` on its top, ``sigma_cr`` the clamped-free Euler stress; solved on its
    straight branch at ``load_value`` (symmetric mesh: no imperfection makes it bend)."""
    mesh = MakeStructured2DMesh(quads=True, nx=2, ny=10, mapping=lambda x, y: (x - 0.5, y * length))
    load = ngs.Parameter(0.0)
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=NeoHookeanFilm(E=E, nu=NU), lam0=2.0,
                              order=3, inverse=inverse)
    prob.fix("bottom")
    prob.add_traction("top", ngs.CF((0, -load * math.pi**2 * E_PLANE / (48 * length**2))))
    for value in np.linspace(0, load_value, 4)[1:]:
        load.Set(value)
        prob.solve()
    return prob, load


def dense_negative(K) -> tuple[int, np.ndarray]:
    eigenvalues = np.linalg.eigvalsh(K.toarray())
    return int(np.count_nonzero(eigenvalues < 0)), eigenvalues


def ldlt_of(prob) -> linalg.PardisoLDLT:
    factorisation = linalg.PardisoLDLT(prob.free_mask)
    factorisation.factor(prob.tangent(prob.state))
    return factorisation


@needs_pardiso
@pytest.mark.parametrize("load_value, negative", [(0.5, 0), (2.0, 1), (12.0, 2)])
def test_inertia_counts_the_negative_eigenvalues_of_a_column_before_and_past_buckling(load_value, negative):
    # straight clamped-free column: Euler modes at 1, 9, 25 ... times sigma_cr (long-column limit;
    # this one, L/h = 20, buckles at 1.003), so 0, 1 and 2 of them are past
    prob, _ = column(load_value)
    K = free_matrix(prob.tangent(prob.state), prob.free_mask)
    count, eigenvalues = dense_negative(K)
    assert count == negative
    factorisation = ldlt_of(prob)
    assert factorisation.inertia == (len(eigenvalues) - count, count, 0)
    assert stability.negative_count(K) == count  # SuperLU, the fallback, agrees


def _shift_diagonal(matrix, free_mask: np.ndarray, shift: float) -> None:
    """``matrix -= shift * I`` on the free dofs, in place."""
    _, cols, indptr = matrix.CSR()
    cols, indptr = np.asarray(cols).astype(np.int64), np.asarray(indptr).astype(np.int64)
    rows = np.repeat(np.arange(len(indptr) - 1), np.diff(indptr))
    diagonal = np.flatnonzero((rows == cols) & free_mask[rows])
    matrix.AsVector().FV().NumPy()[diagonal] -= shift


@needs_pardiso
@pytest.mark.parametrize("side", [-1.0, 1.0])
def test_inertia_next_to_a_singular_tangent(side):
    # K - c I with c within 1e-8 of the largest eigenvalue beside the tenth: its eigenvalue nearest
    # zero is +-1e-8 of the largest, and the count must give it its sign
    prob, _ = column(0.5)
    matrix = prob.tangent(prob.state)
    eigenvalues = np.linalg.eigvalsh(free_matrix(matrix, prob.free_mask).toarray())
    gap = 1e-8 * np.max(np.abs(eigenvalues))
    shift = eigenvalues[9] - side * gap
    _shift_diagonal(matrix, prob.free_mask, shift)
    K = free_matrix(matrix, prob.free_mask)
    count, shifted = dense_negative(K)
    assert np.min(np.abs(shifted)) == pytest.approx(gap, rel=1e-3)
    assert count == (9 if side > 0 else 10)
    factorisation = linalg.PardisoLDLT(prob.free_mask)
    factorisation.factor(matrix)
    assert factorisation.perturbed == 0
    assert factorisation.negative == count


@needs_pardiso
def test_solve_agrees_with_sparse_cholesky():
    gel = FloryRehnerGel(Nv=1e-2, chi=0.5)
    mesh = block(lx=1, ly=1, lz=0.4, maxh=1.0, structured=True, nx=4, ny=4, nz=2).mesh
    prob = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=gel, lam0=1.3, mu=gel.mu_free(1.3), order=2,
                              inverse="sparsecholesky")
    prob.fix("bottom")
    prob.mu.Set(gel.mu_free(1.4))
    prob.solve()  # a swollen, bonded block: a stable tangent
    K = prob.tangent(prob.state)
    rhs = prob.state.CreateVector()
    rhs.FV().NumPy()[:] = np.random.default_rng(0).standard_normal(len(rhs))
    cholesky = (K.Inverse(prob.space.FreeDofs(), inverse="sparsecholesky") * rhs).Evaluate().FV().NumPy()
    solver = LinearSolver(prob.space.FreeDofs(), inverse="pardiso")
    out = prob.state.CreateVector()
    out.data = solver.factor(K) * rhs
    ours = out.FV().NumPy()
    assert np.all(ours[~prob.free_mask] == 0.0)
    assert np.linalg.norm(ours - cholesky) <= 1e-10 * np.linalg.norm(cholesky)
    assert solver.inertia == (int(prob.free_mask.sum()), 0, 0)
    # a second factorisation of the same matrix object reuses the analysis and gives the same bits
    again = prob.state.CreateVector()
    again.data = solver.factor(K) * rhs
    assert np.array_equal(again.FV().NumPy(), ours)


@needs_pardiso
def test_a_tracked_path_counts_with_its_newton_factorisation(monkeypatch):
    # the Euler column through its bifurcation, tracked with PARDISO: the bifurcation where
    # UMFPACK + SuperLU put it, no SuperLU count, and each step's check is one factorisation
    located = {}
    for inverse in ("umfpack", "pardiso"):
        prob, load = column(0.0, inverse=inverse)
        calls = []
        real = stability.negative_count
        monkeypatch.setattr(stability, "negative_count", lambda K: calls.append(1) or real(K))
        result = follow_path(prob, load, method="natural", step=0.3, target=1.2,
                             stability=StabilityOptions(eigenvalues=2, tol=1e-6))
        monkeypatch.setattr(stability, "negative_count", real)
        [event] = [e for e in result.events if e.kind == "bifurcation"]
        located[inverse] = event.parameter
        checks = [r for s in result.steps for r in s.records if r.kind == "stability"]
        assert len(checks) >= len(result.points)  # every point checked (located ones too)
        assert all(c.factorisations == (1 if inverse == "pardiso" else 0) for c in checks)
        assert len(result.steps) == result.points[-1].step + 1
        if inverse == "pardiso":
            assert not calls
            # the check's factorisation starts the next solve: a chord step in each step after the first
            assert sum(1 for s in result.steps[2:] if any(r.kind in ("chord", "rejected chord") for r in s.records))\
                == len(result.steps) - 2
        else:
            assert calls
    assert located["pardiso"] == pytest.approx(located["umfpack"], abs=2e-6)


def test_auto_names_its_choice_and_a_missing_extra_is_named(monkeypatch, caplog):
    monkeypatch.setattr(linalg, "_MKL", None)
    monkeypatch.setattr(linalg.glob, "glob", lambda pattern: [])
    monkeypatch.setattr(linalg.ctypes.util, "find_library", lambda name: None)
    monkeypatch.setattr(linalg, "_logged", set())
    with pytest.raises(linalg.PardisoUnavailable, match=r"ngsgel\[pardiso\]"):
        LinearSolver(ngs.BitArray(4), inverse="pardiso")
    with caplog.at_level("INFO", logger="ngsgel.linalg"):
        assert LinearSolver(ngs.BitArray(4), inverse="auto").inverse == "sparsecholesky"
    assert "not installed" in caplog.text and "sparsecholesky" in caplog.text


def test_bad_inverse_is_named():
    with pytest.raises(ValueError, match="inverse"):
        LinearSolver(ngs.BitArray(4), inverse="")
