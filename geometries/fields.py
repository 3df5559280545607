"""Graded cross-link density fields (MODEL.md scenes C and D).

``Nv(r) = n0 + (nR - n0) (r / R)^p`` (radial) and ``Nv(z) = n0 + (nL - n0)
((z - z0) / L)^p`` (axial), as NGSolve coefficient functions for any mesh of this
package, plus plain numpy versions for checks.  Both are evaluated as
``n0 (1 - q) + n1 q`` with ``q = s^p``, which returns ``n0`` and ``n1`` exactly at the
two ends and is monotone in ``s``.

Which coordinate is used depends on the model of the mesh (``MeshBundle.model``):
the radius is the distance from the z axis through ``center`` in 3D and on surfaces,
from ``center`` in the plane, and ``|x - center[0]|`` in an r-z section (x = r); the
axial coordinate is z in 3D and on surfaces, and y in plane and r-z meshes.
"""

from __future__ import annotations

import numpy as np
import ngsolve

from .common import AXISYMMETRIC, MODELS, PLANE, SOLID3D, require_positive


def _check(p: float, length_name: str, length: float, model: str) -> None:
    require_positive("p", p)
    require_positive(length_name, length)
    if model not in MODELS:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")


def _blend(n0: float, n1: float, q):
    return n0 * (1 - q) + n1 * q


def _profile(n0: float, n1: float, p: float, length: float,
             s: np.ndarray | float) -> np.ndarray:
    _check(p, "length", length, SOLID3D)
    return _blend(n0, n1, (np.abs(np.asarray(s, dtype=float)) / length) ** p)


def radial_grading(n0: float, nR: float, p: float, R: float, *,
                   center: tuple[float, float, float] = (0.0, 0.0, 0.0),
                   model: str = SOLID3D) -> ngsolve.CoefficientFunction:
    """``n0 + (nR - n0) (r / R)^p`` as a coefficient function (``p > 0``, ``R > 0``)."""
    _check(p, "R", R, model)
    dx = ngsolve.x - center[0]
    if model == AXISYMMETRIC:
        r = ngsolve.sqrt(dx * dx)
    else:
        dy = ngsolve.y - center[1]
        r = ngsolve.sqrt(dx * dx + dy * dy)
    return _blend(n0, nR, (r / R) ** p)


def axial_grading(n0: float, nL: float, p: float, L: float, *, z0: float = 0.0,
                  model: str = SOLID3D) -> ngsolve.CoefficientFunction:
    """``n0 + (nL - n0) ((z - z0) / L)^p`` as a coefficient function.

    ``z - z0`` is taken by absolute value so round-off below ``z0`` stays real.
    """
    _check(p, "L", L, model)
    z = ngsolve.y if model in (PLANE, AXISYMMETRIC) else ngsolve.z
    dz = z - z0
    return _blend(n0, nL, (ngsolve.sqrt(dz * dz) / L) ** p)


def radial_grading_np(n0: float, nR: float, p: float, R: float,
                      r: np.ndarray | float) -> np.ndarray:
    """Numpy version of :func:`radial_grading` for radii ``r``."""
    return _profile(n0, nR, p, R, r)


def axial_grading_np(n0: float, nL: float, p: float, L: float, z: np.ndarray | float, *,
                     z0: float = 0.0) -> np.ndarray:
    """Numpy version of :func:`axial_grading` for heights ``z``."""
    return _profile(n0, nL, p, L, np.asarray(z, dtype=float) - z0)
