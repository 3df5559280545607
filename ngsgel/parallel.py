"""MPI-distributed meshes: equilibrium problems on many processes, with NGSolve's own MPI.

NGSolve's pip wheels run under MPI once ``mpi4py`` and an MPI library are installed (the extra
``pip install ngsgel[mpi]``: ``mpi4py`` and the ``mpich`` wheel, whose ``mpiexec`` lands in the
environment's ``bin``). A mesh is built on rank 0 and distributed (``distribute_mesh``); rank 0
then keeps no elements and only coordinates, so ``mpiexec -n P+1`` gives ``P`` compute ranks.
Vectors are NGSolve parallel vectors: each rank holds its subdomain's dofs, a dof on a
subdomain interface is held by every rank that touches it (one of them is its master).

An ``EquilibriumProblem`` or a ``TransientProblem`` (``ngsgel.transient``, its ``march``) on a
distributed mesh (3D kinematics; ``Solid3D``) solves with:

- a parallel linear solver for Newton (``inverse``, ``DistributedSolver``): ``"bddc"``,
  NGSolve's BDDC preconditioner with CG (GMRES where CG fails), or ``"masterinverse"``, the
  free tangent gathered to rank 0 and factorised there by NGSolve's sparse direct solver
  (exact, but serial in time and memory on rank 0; the default);
- global reductions (``DistributedReductions``): residual norms over the master copies of the
  free dofs, the largest entry and "any constrained motion left" over all ranks, energies summed
  (NGSolve's ``Integrate`` already sums over ranks, so the admissibility test ``J > 1`` is global);
- the exact negative count of the free tangent (``negative_count``), by Sylvester's law and
  Haynsworth's inertia additivity over the subdomains: the interior block of each subdomain is
  counted on its own rank, the Schur complement on the interfaces is summed on rank 0;
- eigenpairs (``spectrum``) of the free tangent gathered to rank 0 in one global free-dof
  numbering (``FreeDofNumbering``) and solved there by the serial ``stability.spectrum``, with
  ``load_rate`` and ``mode_function`` in that numbering: what ``ramp`` and natural-parameter
  ``follow_path`` (its count-only checks, the location and classification of a count change)
  use on a distributed mesh.

Every rank runs the same Python code; every decision Newton and the drivers take depends on
global numbers only, so the ranks stay in step. What does not run distributed yet
(docs/parallel.md): kinematics with an axial unknown and ``fix_dof`` (refused with a
ValueError), self-contact, arclength continuation, stabilisation and branch switching
(refused with a NotImplementedError), point evaluation, ``ngsgel.stability``'s
own functions (they fail on the parallel matrix: no ``CSR``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import ngsolve as ngs
import scipy.sparse as sp
import scipy.sparse.linalg as sla

from . import stability
from .stability import free_matrix, negative_count as _serial_negative_count

__all__ = ["MPIUnavailable", "world", "distribute_mesh", "is_distributed", "runs_distributed", "DistributedReductions",
           "DistributedSolver", "KrylovError", "negative_count", "FreeDofNumbering", "spectrum", "load_rate",
           "mode_function", "INVERSES"]

MPI_EXTRA = "pip install ngsgel[mpi]"


class MPIUnavailable(ImportError):
    """``mpi4py`` (or the MPI library it loads) is missing: ``pip install ngsgel[mpi]``."""


def world():
    """mpi4py's ``COMM_WORLD``; ``MPIUnavailable`` naming the extra where MPI is not installed."""
    try:
        from mpi4py import MPI
    except ImportError as err:  # also a missing libmpi, which mpi4py reports as ImportError
        raise MPIUnavailable(f"MPI runs need mpi4py and an MPI library: {MPI_EXTRA} ({err})") from err
    return MPI.COMM_WORLD


def distribute_mesh(make: Callable[[], ngs.Mesh], *, comm=None) -> ngs.Mesh:
    """The mesh ``make()`` builds, distributed over the ranks of ``comm`` (default: all of them):
    only rank 0 calls ``make`` (returning an NGSolve or a Netgen mesh), the others receive their
    part; rank 0 keeps no elements. On one process: the mesh itself, not distributed."""
    import netgen.meshing

    comm = world() if comm is None else comm
    if comm.size == 1:
        mesh = make()
        return mesh if isinstance(mesh, ngs.Mesh) else ngs.Mesh(mesh)
    if comm.rank == 0:
        mesh = make()
        ngmesh = mesh.ngmesh if isinstance(mesh, ngs.Mesh) else mesh
        if ngmesh.dim != 3:
            raise ValueError(f"distributed meshes must be 3D here, got a {ngmesh.dim}D mesh")
        return ngs.Mesh(ngmesh.Distribute(comm))
    return ngs.Mesh(netgen.meshing.Mesh.Receive(comm))


def is_distributed(mesh: ngs.Mesh) -> bool:
    """Whether ``mesh`` is spread over more than one MPI rank."""
    return mesh.comm.size > 1


def runs_distributed(problem) -> bool:
    """Whether ``problem`` (anything with a ``mesh``, or without one) lives on a distributed mesh."""
    mesh = getattr(problem, "mesh", None)
    return isinstance(mesh, ngs.Mesh) and is_distributed(mesh)


def _on_every_rank(comm, compute: Callable[[], object], *, root: int | None = None):
    """``compute()`` run on every rank (or on ``root`` only, its result broadcast), with an error
    on any rank raised on all of them: a rank that raised alone would leave the others waiting in
    the next collective call."""
    result, error = None, None
    if root is None or comm.rank == root:
        try:
            result = compute()
        except Exception as err:  # re-raised below, on every rank
            error = err
    if root is not None:
        result, error = comm.bcast((result, error), root=root)
    else:
        errors = [e for e in comm.allgather(error) if e is not None]
        error = errors[0] if errors else None
    if error is not None:
        raise error  # on the other ranks a copy, without the traceback
    return result


def _mask(bits: ngs.BitArray) -> np.ndarray:
    return np.array(list(bits), dtype=bool)


class DistributedReductions:
    """Newton's norms and tests over all ranks (the interface of ``ngsgel.newton.FreeDofReductions``):
    entries of cumulated vectors (every copy of a dof holds its value) are counted once, on the
    dof's master rank; a distributed vector (a residual: each copy holds its subdomain's share)
    is cumulated first."""

    def __init__(self, space: ngs.FESpace):
        self.comm = space.mesh.comm
        owned = _mask(space.ParallelDofs().MasterDofs())
        self._owned_free = owned & _mask(space.FreeDofs())
        self.free_count = int(round(self.comm.Sum(int(self._owned_free.sum()))))
        self._scratch = None

    def sum(self, value: float) -> float:
        return self.comm.Sum(float(value))

    def free_norm(self, v: ngs.BaseVector) -> float:
        if v.GetParallelStatus() == ngs.la.PARALLEL_STATUS.DISTRIBUTED:
            if self._scratch is None:
                self._scratch = v.CreateVector()
            self._scratch.data = v
            self._scratch.SetParallelStatus(ngs.la.PARALLEL_STATUS.DISTRIBUTED)
            self._scratch.Cumulate()
            v = self._scratch
        local = v.FV().NumPy()[self._owned_free]
        return math.sqrt(self.comm.Sum(float(local @ local)))

    def max(self, value: float) -> float:
        return self.comm.Max(float(value))

    def max_abs(self, values: np.ndarray) -> float:
        return self.comm.Max(float(np.max(np.abs(values), initial=0.0)))

    def any(self, values: np.ndarray) -> bool:
        return self.comm.Max(float(values.any())) > 0


class KrylovError(RuntimeError):
    """A Krylov solve of Newton's linear system did not reach its tolerance."""


INVERSES = ("auto", "bddc", "masterinverse")


class _BDDCKrylov(ngs.BaseMatrix):
    """The inverse of ``matrix`` by Krylov iterations preconditioned with BDDC: CG, then GMRES
    from scratch where CG does not reach the tolerance (CG may break down on an indefinite
    tangent), ``KrylovError`` where GMRES does not either (NGSolve's solvers return an
    unconverged solution with at most a printed warning)."""

    def __init__(self, matrix: ngs.BaseMatrix, preconditioner: ngs.BaseMatrix, *, rtol: float, maxiter: int,
                 iterations: list[int]):
        super().__init__()
        self.matrix = matrix
        self.solvers = [method(matrix, preconditioner, tol=rtol, maxiter=maxiter)
                        for method in (ngs.krylovspace.CGSolver, ngs.krylovspace.GMResSolver)]
        self.iterations = iterations  # appended per solve: the iterations of the solver(s) it took
        self.fallbacks = 0  # solves that CG did not finish

    def Height(self) -> int:
        return self.matrix.height

    def Width(self) -> int:
        return self.matrix.width

    def CreateColVector(self):
        return self.matrix.CreateColVector()

    def CreateRowVector(self):
        return self.matrix.CreateRowVector()

    def Mult(self, x, y) -> None:
        taken = 0
        for solver in self.solvers:
            solver.Solve(rhs=x, sol=y)
            taken += solver.iterations
            if not solver.residuals or solver.residuals[-1] <= solver._final_residual:
                self.iterations.append(taken)
                return
            self.fallbacks += solver is self.solvers[0]
        raise KrylovError(f"BDDC-preconditioned CG and GMRES did not converge in {solver.maxiter} iterations each: "
                          f"GMRES's preconditioned residual {solver.residuals[-1]:.3e}, target "
                          f"{solver._final_residual:.3e} (start {solver.residuals[0]:.3e}); "
                          "inverse='masterinverse' solves directly")


class DistributedSolver:
    """Newton's linear solves on a distributed mesh (the interface of ``ngsgel.newton.LinearSolver``,
    without inertia). ``inverse``:

    - ``"bddc"``: NGSolve's BDDC preconditioner, set up from the element matrices during each
      assembly of ``form`` (so it is registered here, before the first), with CG, GMRES where CG
      fails (``_BDDCKrylov``), to ``rtol`` of the preconditioned residual in at most ``maxiter``
      iterations each, ``KrylovError`` otherwise. Memory is spread over the ranks, but the
      iterations grow with the ratio of the gel's bulk to shear stiffness: BDDC's condition
      number on a bonded block (``chi = 0.5``) is 23 at ``Nv = 1e-2`` and 160-180 at ``Nv = 1e-3``,
      where a 24k-dof block took 140-460 CG iterations per Newton solve to 1e-10, and CG
      failed in 1 of 5 solves on 2 ranks (GMRES finished it);
    - ``"masterinverse"``: the free tangent gathered to rank 0 and factorised there by NGSolve's
      sparse direct solver: exact for any tangent (stable or not), but rank 0 holds the whole
      factor (1.2 GiB at 24k dofs against 0.3 GiB on the compute ranks);
    - ``"auto"``: ``AUTO``, ``"masterinverse"``: 1.8-2.8x faster per Newton iteration than
      ``"bddc"`` on that block (``scripts/mpi_block.py``, docs/parallel.md) and exact."""

    AUTO = "masterinverse"

    def __init__(self, form: ngs.BilinearForm, freedofs: ngs.BitArray, *, inverse: str = "auto",
                 rtol: float = 1e-10, maxiter: int = 500):
        if inverse not in INVERSES:
            raise ValueError(f"inverse on a distributed mesh must be one of {INVERSES}, got {inverse!r}")
        self.inverse = self.AUTO if inverse == "auto" else inverse
        self.freedofs = freedofs
        self.rtol, self.maxiter = rtol, maxiter
        self._preconditioner = ngs.Preconditioner(form, "bddc") if self.inverse == "bddc" else None
        self._inv = None
        self.krylov_iterations: list[int] = []  # of every solve with "bddc"
        self.iteration_seconds: float | None = None  # this rank's; newton paces on the slowest rank's

    current = property(lambda self: self._inv, doc="The last solver (None before the first ``factor``).")
    inertia = None  # no distributed factorisation gives it; see negative_count
    ldlt = None

    def factor(self, matrix: ngs.BaseMatrix):
        if self.inverse == "bddc":
            self._inv = _BDDCKrylov(matrix, self._preconditioner.mat, rtol=self.rtol, maxiter=self.maxiter,
                                    iterations=self.krylov_iterations)
        else:
            self._inv = matrix.Inverse(self.freedofs, inverse="masterinverse")
        return self._inv


def newton_parts(problem) -> tuple[DistributedSolver, DistributedReductions]:
    """The linear solver and the reductions of an ``EquilibriumProblem`` or a ``TransientProblem``
    on a distributed mesh, on the space of its form (a transient problem's: displacement and
    chemical potential), once the form exists and before its first assembly; ValueError for
    what does not run distributed, NotImplementedError for self-contact."""
    if problem.kinematics.axial_unknown:
        raise ValueError(f"kinematics {problem.kinematics.name!r} (an axial unknown) does not run on a "
                         "distributed mesh; use Solid3D")
    if problem._self_contacts:
        # NGSolve's ContactBoundary searches partners in this rank's subdomain only: two blocks
        # pressed 0.1 into each other (penalty energy 0.5 serially), one block per compute rank,
        # gave energy 0 and residual 0 on 2 compute ranks, without an error (docs/parallel.md)
        raise NotImplementedError("self-contact does not run on a distributed mesh: NGSolve's ContactBoundary "
                                  "finds no partner on another rank")
    space = problem._form.space
    return (DistributedSolver(problem._form, space.FreeDofs(), inverse=problem.inverse),
            DistributedReductions(space))


def _local_free_matrix(matrix: ngs.BaseMatrix, free: np.ndarray) -> sp.csr_matrix:
    """This rank's subdomain matrix (the local part of a parallel matrix; the global one is
    the sum of them over the ranks) on its free dofs."""
    vals, cols, indptr = matrix.local_mat.CSR()
    n = len(free)
    local = sp.csr_matrix((np.array(vals), np.array(cols), np.array(indptr)), shape=(n, n))
    index = np.flatnonzero(free)
    return local[index][:, index]


def negative_count(problem, *, matrix: ngs.BaseMatrix | None = None) -> int:
    """Number of negative eigenvalues of the free tangent at the current state (or of the
    assembled ``matrix``) of a problem on a distributed mesh, exact, on every rank.

    Order the free dofs of each subdomain into interior ``I`` (on this rank only) and interface
    ``B``. The interior blocks do not couple, so ``K = [[K_II, K_IB], [K_BI, K_BB]]`` with a
    block-diagonal ``K_II``, and (Haynsworth) ``inertia(K) = inertia(K_II) + inertia(S)`` with
    the Schur complement ``S = K_BB - K_BI K_II^-1 K_IB = sum_ranks (K_BB^r - K_BI^r (K_II^r)^-1
    K_IB^r)``. Each rank counts its ``K_II^r`` (SuperLU's LDL^T, as the serial count) and forms
    its dense ``S^r``; rank 0 sums them and counts ``S`` by its eigenvalues. Costs: one sparse
    factorisation per rank, dense ``S^r`` (interface dofs squared) per rank and the eigenvalues
    of the global interface's ``S`` on rank 0, so it suits interfaces of a few thousand dofs.
    RuntimeError if an interior block is singular (the split is then not defined). On a serial
    mesh: the serial count (``ngsgel.stability.negative_count``), so one script serves both."""
    matrix = problem.tangent(problem.state) if matrix is None else matrix
    if not is_distributed(problem.mesh):
        return _serial_negative_count(free_matrix(matrix, problem.free_mask))
    comm = problem.mesh.comm.mpi4py
    space = problem.space
    free = _mask(space.FreeDofs())
    pardofs = space.ParallelDofs()
    shared = np.array([len(pardofs.Dof2Proc(d)) > 0 for d in range(space.ndof)], dtype=bool)
    numbers, _ = pardofs.EnumerateGlobally(space.FreeDofs())
    numbers = np.array(numbers)[free]
    K = _local_free_matrix(matrix, free)
    interface = shared[free]
    interior = ~interface
    K_II = K[interior][:, interior].tocsc()
    K_IB = K[interior][:, interface].toarray()
    K_BB = K[interface][:, interface].toarray()

    def count_interior() -> int:
        """The negative count of this rank's interior block; ``K_BB`` becomes its Schur complement."""
        if not K_II.shape[0]:
            return 0
        count = _serial_negative_count(K_II)
        try:
            solve = sla.splu(K_II).solve
        except RuntimeError as err:  # SuperLU: "Factor is exactly singular"
            raise RuntimeError(f"the interior block of rank {comm.rank}'s subdomain is singular ({err}); "
                               "the distributed negative count is not defined here") from err
        K_BB[...] -= K_IB.T @ solve(K_IB)
        return count

    interior_count = comm.allreduce(_on_every_rank(comm, count_interior))
    parts = comm.gather((numbers[interface], K_BB), root=0)

    def schur_count() -> int:
        glob = np.unique(np.concatenate([n for n, _ in parts])) if parts else np.empty(0, int)
        S = np.zeros((len(glob), len(glob)))
        for nums, block in parts:
            where = np.searchsorted(glob, nums)
            S[np.ix_(where, where)] += block
        return int(np.count_nonzero(np.linalg.eigvalsh(S) < 0))

    return interior_count + _on_every_rank(comm, schur_count, root=0)


class FreeDofNumbering:
    """The free dofs of a distributed space in one global numbering (NGSolve's
    ``EnumerateGlobally``): a global free-dof vector is what the serial code calls a free-dof
    vector (``stability``'s modes and load rates), each rank maps its own dofs into it."""

    def __init__(self, space: ngs.FESpace):
        self.comm = space.mesh.comm.mpi4py
        free = _mask(space.FreeDofs())
        numbers, self.size = space.ParallelDofs().EnumerateGlobally(space.FreeDofs())
        self.numbers = np.array(numbers, dtype=np.int64)[free]  # global number of each local free dof
        self._free = free

    def gather(self, values: np.ndarray) -> np.ndarray:
        """The global free-dof vector, on every rank, of this rank's free-dof entries ``values``
        of a distributed vector (a residual: the copies of a dof sum to its value)."""
        total = np.zeros(self.size)
        np.add.at(total, self.numbers, values)
        return self.comm.allreduce(total)  # summed over the ranks

    def scatter(self, values: np.ndarray) -> np.ndarray:
        """This rank's free-dof entries of the global free-dof vector ``values``."""
        return values[self.numbers]

    def gather_matrix(self, matrix: ngs.BaseMatrix) -> sp.csc_matrix | None:
        """The free block of the parallel ``matrix`` in the global numbering, on rank 0 (None on
        the others): the sum of the ranks' subdomain matrices."""
        local = _local_free_matrix(matrix, self._free).tocoo()
        parts = self.comm.gather((self.numbers[local.row], self.numbers[local.col], local.data), root=0)
        if self.comm.rank != 0:
            return None
        rows, cols, data = (np.concatenate(column) for column in zip(*parts))
        return sp.coo_matrix((data, (rows, cols)), shape=(self.size, self.size)).tocsc()


class _Measured:
    """What ``stability.spectrum`` needs of a problem once ``K`` and ``M`` are given: the body's
    volume (``integrate(CF(1))``, the modes' normalisation), measured over all ranks beforehand
    since rank 0 alone solves."""

    free_mask = None  # K and M are given as free-dof matrices

    def __init__(self, volume: float):
        self.volume = volume

    def integrate(self, cf) -> float:
        return self.volume


def spectrum(problem, *, matrix: ngs.BaseMatrix | None = None, mass: ngs.BaseMatrix | None = None, count: int = 4,
             past_negative: bool = False) -> stability.Spectrum:
    """``stability.spectrum`` of a problem on a distributed mesh, the same on every rank, its
    modes global free-dof vectors (``FreeDofNumbering``). The free tangent (``matrix``, default
    at the current state) and mass matrix (``mass``, default ``stability.mass_matrix``) are
    gathered to rank 0, which solves the eigenproblem as the serial code does (shift-invert
    ARPACK with SuperLU): exact like the serial run, but serial in time and memory on rank 0,
    like ``inverse="masterinverse"``. No distributed eigen solver is used (none was tried):
    NGSolve's LOBPCG and PINVIT expect a positive definite preconditioner, and BDDC of a tangent
    with negative eigenvalues inverts indefinite subdomain and coarse blocks; the eigenvalues a
    path driver tracks are those next to zero of an indefinite tangent. On a serial mesh:
    ``stability.spectrum``."""
    matrix = problem.tangent(problem.state) if matrix is None else matrix
    mass = stability.mass_matrix(problem) if mass is None else mass
    if not runs_distributed(problem):
        free = problem.free_mask
        return stability.spectrum(problem, count=count, K=free_matrix(matrix, free), M=free_matrix(mass, free),
                                  past_negative=past_negative)
    numbering = FreeDofNumbering(problem.space)
    K, M = numbering.gather_matrix(matrix), numbering.gather_matrix(mass)
    body = _Measured(problem.integrate(ngs.CF(1.0)))
    return _on_every_rank(numbering.comm, lambda: stability.spectrum(body, count=count, K=K, M=M,
                                                                     past_negative=past_negative), root=0)


def load_rate(problem, parameter: ngs.Parameter) -> stability.LoadRate:
    """``stability.load_rate``; on a distributed mesh its ``residual`` is the global free-dof
    vector (``FreeDofNumbering``, on every rank), its ``prescribed`` this rank's values."""
    rate = stability.load_rate(problem, parameter)
    if not runs_distributed(problem):
        return rate
    return stability.LoadRate(residual=FreeDofNumbering(problem.space).gather(rate.residual),
                              prescribed=rate.prescribed)


def mode_function(problem, vector: np.ndarray, *, name: str = "mode") -> ngs.GridFunction:
    """``stability.mode_function``; on a distributed mesh ``vector`` is a global free-dof vector."""
    if runs_distributed(problem):
        vector = FreeDofNumbering(problem.space).scatter(vector)
    return stability.mode_function(problem, vector, name=name)
