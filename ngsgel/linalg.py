"""Sparse direct solves of Newton's tangent on the free dofs, and the inertia of that tangent.

Two kinds of backend behind ``LinearSolver`` (``ngsgel.newton``):

- NGSolve's own inverses by name (``"sparsecholesky"``, ``"umfpack"``, ...): ``matrix.Inverse``
  with the free dofs, the numeric factorisation redone by ``Update()`` while the matrix object
  stays the same. They give no inertia.
- ``"pardiso"``: MKL PARDISO's symmetric indefinite LDL^T (matrix type -2, Bunch-Kaufman pivots)
  of the free block, called through ``ctypes`` from the ``mkl`` wheel's ``libmkl_rt`` (the optional
  extra ``pip install ngsgel[pardiso]``). Its factorisation reports the inertia (numbers of
  positive and negative eigenvalues, Sylvester), so a stability check at a factorised state costs
  no second factorisation. The ordering (METIS) is computed once per sparsity pattern; every
  later factorisation of the same matrix object is numeric only. It runs on as many threads as
  NGSolve's parallel parts at the time of the call (``ngsgel.set_threads``; one outside a
  ``TaskManager``), in MKL's conditional numerical reproducibility mode (``iparm(34)`` = that
  count), so the same run gives the same bits on the same machine and thread count. Pivots that PARDISO had to perturb
  (``iparm(14) > 0``: a tangent singular to working precision) make the inertia untrustworthy:
  ``inertia`` is then None and callers count with SuperLU instead.

NGSolve's wheel has ``inverse="pardiso"`` but it does not load here (no MKL link), and the
PyPI wrappers do not fit: ``pypardiso`` (0.4.7) offers only analysis-plus-factorisation per call
(phase 12; no numeric-only refactorisation) and compares or hashes the whole matrix at every
solve, ``pydiso`` has no wheel (it builds against an MKL development install). The wrapper here
is the few PARDISO calls Newton needs: analysis (phase 11), numeric factorisation (22), solve
(33), release (-1).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import glob
import logging
import os
import sys
import weakref

import numpy as np
import ngsolve as ngs

__all__ = ["PardisoUnavailable", "pardiso_available", "resolve_inverse", "PardisoLDLT", "FreeDofInverse"]

log = logging.getLogger(__name__)



class PardisoUnavailable(ImportError):
    """MKL's runtime library (``libmkl_rt``) is not installed: ``pip install ngsgel[pardiso]``."""


_MKL = None


def _mkl() -> ctypes.CDLL:
    """MKL's single dynamic library, loaded once: from the environment's ``lib`` folder (where the
    ``mkl`` wheel puts it) or the system's library path."""
    global _MKL
    if _MKL is None:
        candidates = sorted(glob.glob(os.path.join(sys.prefix, "lib", "libmkl_rt.so*")), key=len)
        found = ctypes.util.find_library("mkl_rt")
        candidates += [found] if found else []
        errors = []
        for path in candidates:
            try:
                lib = ctypes.CDLL(path)
                break
            except OSError as err:
                errors.append(f"{path}: {err}")
        else:
            raise PardisoUnavailable(
                "inverse='pardiso' needs MKL's libmkl_rt, which is not installed: pip install ngsgel[pardiso] "
                "(or pip install mkl)" + (f" ({'; '.join(errors)})" if errors else ""))
        lib.pardiso.restype = None
        lib.MKL_Set_Num_Threads_Local.restype = ctypes.c_int
        _MKL = lib
    return _MKL


def pardiso_available() -> bool:
    """Whether ``inverse="pardiso"`` can run (MKL's runtime library loads)."""
    try:
        _mkl()
    except PardisoUnavailable:
        return False
    return True


_logged: set[str] = set()


def resolve_inverse(inverse: str, *, fallback: str = "sparsecholesky") -> str:
    """The backend an ``inverse`` option names: ``"auto"`` becomes ``"pardiso"`` where MKL is
    installed, else ``fallback`` (the choice and its reason logged once per process);
    ``"pardiso"`` without MKL raises ``PardisoUnavailable`` naming the extra; other names are
    NGSolve's and pass unchanged."""
    if not (isinstance(inverse, str) and inverse):
        raise ValueError(f"inverse must be 'auto', 'pardiso' or an NGSolve inverse name, got {inverse!r}")
    if inverse == "auto":
        if pardiso_available():
            inverse, reason = "pardiso", (
                "MKL PARDISO LDL^T (inverse='auto', MKL installed): its numeric refactorisation of 3D tangents "
                "took 0.4-0.5x sparsecholesky's at 28k and 53k unknowns on one thread (docs/benchmarks.md, issue 35), "
                "it gives the inertia for stability checks, and runs in MKL's reproducible (CNR) mode on "
                "NGSolve's thread count")
        else:
            inverse, reason = fallback, (
                f"NGSolve {fallback} (inverse='auto'; MKL PARDISO, faster and with the inertia, "
                "is not installed: pip install ngsgel[pardiso])")
        if reason not in _logged:
            _logged.add(reason)
            log.info("linear solver: %s", reason)
    elif inverse == "pardiso":
        _mkl()
    return inverse


_int_p = ctypes.POINTER(ctypes.c_int32)


class PardisoLDLT:
    """LDL^T of the free block of a symmetric NGSolve sparse matrix (full storage, as the
    problems assemble it) by MKL PARDISO, with the inertia of each factorisation.

    ``factor(matrix)`` factorises (analysis again only for a new matrix object);
    ``solve(b)`` solves with free-dof vectors (one column or several); ``inertia``:
    ``(positive, negative, zero)`` counts of the last factorisation, None where pivots were
    perturbed."""

    MTYPE = -2  # real symmetric indefinite

    def __init__(self, free_mask: np.ndarray):
        self._lib = _mkl()
        self.free_mask = np.asarray(free_mask, dtype=bool)
        self.n = int(self.free_mask.sum())
        self._pt = np.zeros(64, dtype=np.int64)  # PARDISO's handle: must stay in place between calls
        self._iparm = np.zeros(64, dtype=np.int32)
        iparm = self._iparm
        iparm[0] = 1   # the values below, not PARDISO's defaults
        iparm[1] = 2   # METIS nested dissection (the parallel one, 3, excludes CNR)
        iparm[7] = 0   # iterative refinement only where pivots were perturbed
        iparm[9] = 13  # perturb pivots below 1e-13 |A| (default 1e-8 would hide near-zero eigenvalues)
        iparm[10] = 0  # no scaling and no weighted matching: keep the analysis symbolic (values
        iparm[12] = 0  # change between Newton iterations, the ordering is reused)
        iparm[17] = -1  # report the factor's nonzeros
        iparm[20] = 1  # Bunch-Kaufman 1x1 and 2x2 pivots
        iparm[34] = 1  # zero-based indices
        self.threads = 0  # the thread count of the last analysis
        self._matrix = None
        self._select = None
        self._indptr = self._indices = self._values = None
        self.inertia: tuple[int, int, int] | None = None
        self.perturbed = 0
        self.factorised = False
        self._release = None

    def _call(self, phase: int, b: np.ndarray | None = None, x: np.ndarray | None = None, nrhs: int = 1) -> None:
        # the analysis's thread count (CNR's), set for this thread only and restored after
        before = self._lib.MKL_Set_Num_Threads_Local(self.threads or 1)
        try:
            _pardiso(self._lib, self._pt, self._iparm, phase, self.n, self._values, self._indptr, self._indices,
                     b, x, nrhs)
        finally:
            self._lib.MKL_Set_Num_Threads_Local(before)

    def _analyse(self, matrix: ngs.BaseMatrix) -> None:
        """The upper triangle of the free block in CSR (zero-based, sorted columns, every
        diagonal entry present, as PARDISO's symmetric types need), as a selection from the
        NGSolve matrix's value array, then PARDISO's ordering and symbolic factorisation."""
        if self._release is not None:  # the previous pattern's analysis and factors
            self._call(-1)
            self.factorised = False
        _, cols, indptr = matrix.CSR()
        cols, indptr = np.asarray(cols).astype(np.int64), np.asarray(indptr).astype(np.int64)
        n_all = len(self.free_mask)
        if len(indptr) != n_all + 1:
            raise ValueError(f"the matrix has {len(indptr) - 1} rows, the free-dof mask {n_all}")
        rows = np.repeat(np.arange(n_all), np.diff(indptr))
        keep = self.free_mask[rows] & self.free_mask[cols] & (cols >= rows)
        number = np.cumsum(self.free_mask) - 1  # free-dof numbering
        order = np.lexsort((cols[keep], rows[keep]))  # row by row, columns ascending
        self._select = np.flatnonzero(keep)[order]
        free_rows, free_cols = number[rows[self._select]], number[cols[self._select]]
        if not np.array_equal(np.unique(free_rows[free_rows == free_cols]), np.arange(self.n)):
            raise ValueError("the matrix lacks diagonal entries on some free dofs")
        self._indices = np.ascontiguousarray(free_cols, dtype=np.int32)
        self._indptr = np.searchsorted(free_rows, np.arange(self.n + 1)).astype(np.int32)
        self._values = np.ascontiguousarray(matrix.AsVector().FV().NumPy()[self._select])
        self.threads = _threads()
        self._iparm[33] = self.threads  # conditional numerical reproducibility for this thread count
        self._call(11)
        if self._release is None:  # PARDISO's memory goes with this object (or at exit)
            self._release = weakref.finalize(self, _pardiso, self._lib, self._pt, self._iparm, -1, 0)
        self._matrix = matrix

    def factor(self, matrix: ngs.BaseMatrix) -> "PardisoLDLT":
        if matrix is not self._matrix or self.threads != _threads():
            self._analyse(matrix)
        else:
            self._values[:] = matrix.AsVector().FV().NumPy()[self._select]
        self._call(22)
        self.factorised = True
        self.perturbed = int(self._iparm[13])
        positive, negative = int(self._iparm[21]), int(self._iparm[22])
        self.inertia = None if self.perturbed else (positive, negative, self.n - positive - negative)
        return self

    @property
    def negative(self) -> int | None:
        """Negative eigenvalues of the last factorised free block (None if pivots were perturbed)."""
        return None if self.inertia is None else self.inertia[1]

    def solve(self, b: np.ndarray) -> np.ndarray:
        if not self.factorised:
            raise RuntimeError("solve before factor")
        b = np.asfortranarray(b, dtype=float)
        if b.shape[0] != self.n:
            raise ValueError(f"right-hand side has {b.shape[0]} rows, the free block {self.n}")
        x = np.zeros_like(b)
        self._call(33, b, x, nrhs=1 if b.ndim == 1 else b.shape[1])
        return x



def _threads() -> int:
    """NGSolve's thread count now (its set count inside a ``TaskManager``, else 1)."""
    return max(1, ngs.GetNumThreads())


def _pardiso(lib, pt, iparm, phase, n, values=None, indptr=None, indices=None, b=None, x=None, nrhs=1) -> None:
    """One call of MKL's ``pardiso`` on the handle ``pt`` (one matrix, ``mtype`` -2)."""
    error = ctypes.c_int32(0)
    dummy, index_dummy = np.zeros(1), np.zeros(1, np.int32)
    lib.pardiso(
        pt.ctypes.data_as(ctypes.c_void_p), ctypes.byref(ctypes.c_int32(1)), ctypes.byref(ctypes.c_int32(1)),
        ctypes.byref(ctypes.c_int32(PardisoLDLT.MTYPE)), ctypes.byref(ctypes.c_int32(phase)),
        ctypes.byref(ctypes.c_int32(n)), (dummy if values is None else values).ctypes.data_as(ctypes.c_void_p),
        (index_dummy if indptr is None else indptr).ctypes.data_as(_int_p),
        (index_dummy if indices is None else indices).ctypes.data_as(_int_p),
        None, ctypes.byref(ctypes.c_int32(nrhs)), iparm.ctypes.data_as(_int_p), ctypes.byref(ctypes.c_int32(0)),
        (dummy if b is None else b).ctypes.data_as(ctypes.c_void_p),
        (dummy if x is None else x).ctypes.data_as(ctypes.c_void_p), ctypes.byref(error))
    if error.value != 0:
        raise RuntimeError(f"PARDISO phase {phase} failed with error {error.value} "
                           f"({_ERRORS.get(error.value, 'see the MKL PARDISO documentation')})")


_ERRORS = {-1: "input inconsistent", -2: "not enough memory", -3: "reordering problem",
           -4: "zero pivot, numerical factorisation or iterative refinement problem",
           -7: "diagonal matrix is singular", -8: "32-bit integer overflow", -12: "wrong parameters"}


class FreeDofInverse(ngs.BaseMatrix):
    """A free-block factorisation (``PardisoLDLT``) as an NGSolve operator on full vectors, zero
    on the constrained dofs, like ``matrix.Inverse(freedofs)``: ``out.data = inv * rhs``."""

    def __init__(self, factorisation: PardisoLDLT):
        super().__init__()
        self.factorisation = factorisation
        self._size = len(factorisation.free_mask)

    def Mult(self, x: ngs.BaseVector, y: ngs.BaseVector) -> None:
        free = self.factorisation.free_mask
        out = y.FV().NumPy()
        solution = self.factorisation.solve(x.FV().NumPy()[free])
        out[:] = 0.0
        out[free] = solution

    def Height(self) -> int:
        return self._size

    def Width(self) -> int:
        return self._size

    def CreateColVector(self) -> ngs.BaseVector:
        return ngs.BaseVector(self._size)

    def CreateRowVector(self) -> ngs.BaseVector:
        return ngs.BaseVector(self._size)

    @property
    def inertia(self) -> tuple[int, int, int] | None:
        return self.factorisation.inertia
