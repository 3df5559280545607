"""The number of threads, set in one place: NGSolve's worker threads and the BLAS/LAPACK pools.

NGSolve runs assembly, factorisation and solves on its own worker threads (under ``TaskManager``)
and calls BLAS from them; numpy, scipy and NGSolve each bring an OpenBLAS (or MKL) with a pool of
as many threads as cores. Both at once oversubscribe the cores: on a 2-core machine a chord-step
ramp ran 1.7-2x slower with the BLAS pools at their default than with them at one thread
(docs/benchmarks.md). So the BLAS libraries get one thread while NGSolve has ``n``. The limits
reach the libraries loaded when they are set; ``import ngsgel`` loads all three.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from numbers import Integral

import ngsolve as ngs
import threadpoolctl

__all__ = ["set_threads", "using_threads", "configured_threads"]


def _check(n) -> None:
    if isinstance(n, bool) or not isinstance(n, Integral) or n < 1:
        raise ValueError(f"threads must be an integer >= 1, got {n!r}")


def set_threads(n: int) -> None:
    """From now on: NGSolve's parallel parts on ``n`` threads, and every BLAS/LAPACK library
    loaded in the process (OpenBLAS of ngsolve, numpy and scipy; MKL) on one. Call it outside a
    ``TaskManager`` (NGSolve takes a new count when the next one starts)."""
    _check(n)
    ngs.SetNumThreads(int(n))
    threadpoolctl.threadpool_limits(1, user_api="blas")


def configured_threads() -> int:
    """The number of threads NGSolve's parallel parts run on. (``ngs.GetNumThreads()`` says how
    many run now: 1 outside a ``TaskManager``, whatever was set.)"""
    with ngs.TaskManager():
        return ngs.GetNumThreads()


@contextmanager
def using_threads(n: int) -> Iterator[None]:
    """``set_threads(n)`` for the block; NGSolve's count and the BLAS limits are restored after."""
    _check(n)
    before = configured_threads()
    with threadpoolctl.threadpool_limits(1, user_api="blas"):
        ngs.SetNumThreads(int(n))
        try:
            yield
        finally:
            ngs.SetNumThreads(before)
