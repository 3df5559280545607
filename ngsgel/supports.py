"""Supports that only remove the rigid-body motions of a free body.

A body loaded only by ``mu`` (a free tube shrinking in solvent) has a tangent with three zero
modes in plane strain: two translations and the rotation. Fixing them with loaded supports
(symmetry lines, a clamped point) would change the problem: symmetry lines admit only the
wave numbers compatible with them, and a clamped point on an annulus that shrinks carries a
force and makes a singular stress. The supports here are **statically determinate**: three
scalar constraints, each on the tangential displacement of one vertex, at the polar angles 0,
pi/2 and pi on a circle of radius ``R`` about ``center``:

    u_y(c + R e_x) = 0,   u_x(c + R e_y) = 0,   u_y(c - R e_x) = 0.

Why they change nothing but the rigid motion:

- Statics. The reactions ``(Y1, X2, Y3)`` must balance the internal forces, whose resultant
  force and moment vanish identically (the energy is invariant under rigid motions). Force in
  x: ``X2 = 0``; in y: ``Y1 + Y3 = 0``; moment about the centre (current positions
  ``c + R' e_x``, ``c + R' e_y``, ``c - R'' e_x``): ``R' Y1 - R'' Y3 = 0`` with
  ``R', R'' > 0``. Hence all reactions are zero: every constrained equilibrium is an
  equilibrium of the free body.
- Kinematics. Any displacement ``v`` becomes admissible after adding the one rigid motion that
  cancels its three constrained values (the 3x3 matrix of rigid motions on the constraints is
  regular), so no deformation is excluded and no wave number or phase is favoured. The
  constrained tangent is the free tangent on a complement of its rigid null space: the same
  inertia, singular at the same loads, with the same critical modes up to a rigid motion.
- Axisymmetric pre-buckling states have ``u_theta = 0`` and satisfy the constraints exactly.

Use a radius where the mesh has vertices at those angles (a structured annulus with a number of
cells around divisible by 4 has them on every radius).
"""

from __future__ import annotations

import math

import numpy as np
import ngsolve as ngs

__all__ = ["pin_rigid_modes", "pin_vertex_component", "vertex_dof", "nearest_vertex"]


def nearest_vertex(mesh: ngs.Mesh, point: np.ndarray) -> tuple[int, float]:
    """Number of the mesh vertex nearest to ``point`` and its distance."""
    coords = np.array([v.point for v in mesh.vertices])
    distance = np.sum((coords - point) ** 2, axis=1)
    index = int(np.argmin(distance))
    return index, float(math.sqrt(distance[index]))


def pin_rigid_modes(problem, *, radius: float, center=(0.0, 0.0), tolerance: float | None = None) -> list[int]:
    """Remove the rigid motions of a free plane body with the three tangential point constraints
    described in the module docstring. Call before the first solve. Returns the vertex numbers.

    ``tolerance`` (default 1e-6 radius): how far the nearest vertex may lie from each intended
    point; farther is a ValueError (move ``radius`` onto a circle of vertices).
    """
    mesh = problem.mesh
    if mesh.dim != 2 or len(problem.kinematics.components) != 2:
        raise ValueError("pin_rigid_modes is for plane (2D, two-component) problems")
    if not isinstance(radius, (int, float)) or not math.isfinite(radius) or radius <= 0:
        raise ValueError(f"radius must be a finite number > 0, got {radius!r}")
    if getattr(problem, "_form", None) is not None:
        raise RuntimeError("pin_rigid_modes must be called before the first solve")
    c = np.asarray(center, dtype=float)
    if c.shape != (2,) or not np.all(np.isfinite(c)):
        raise ValueError(f"center must be two finite coordinates, got {center!r}")
    tolerance = 1e-6 * radius if tolerance is None else tolerance
    space = problem.space
    free = space.FreeDofs()  # a reference to the space's own bits: clearing one fixes that dof
    vertices = []
    for direction, component in (((1.0, 0.0), 1), ((0.0, 1.0), 0), ((-1.0, 0.0), 1)):
        target = c + radius * np.array(direction)
        vertex, distance = nearest_vertex(mesh, target)
        if distance > tolerance:
            raise ValueError(f"no mesh vertex within {tolerance:g} of {tuple(target)} (nearest at distance "
                             f"{distance:g}): choose a radius with vertices at the angles 0, pi/2, pi")
        free.Clear(space.GetDofNrs(ngs.NodeId(ngs.VERTEX, vertex))[component])
        vertices.append(vertex)
    return vertices


def vertex_dof(problem, *, point, component: int, tolerance: float = 1e-6) -> int:
    """Number of the dof of displacement ``component`` at the vertex at ``point`` (within
    ``tolerance``) in ``problem.space``."""
    if component not in range(problem.mesh.dim):
        raise ValueError(f"component must be in 0 .. {problem.mesh.dim - 1}, got {component!r}")
    vertex = vertex_at(problem.mesh, point, tolerance=tolerance)
    return problem.space.GetDofNrs(ngs.NodeId(ngs.VERTEX, vertex))[component]


def vertex_at(mesh: ngs.Mesh, point, *, tolerance: float = 1e-6) -> int:
    """Number of the mesh vertex at ``point`` (within ``tolerance``)."""
    p = np.asarray(point, dtype=float)
    if p.shape != (mesh.dim,) or not np.all(np.isfinite(p)):
        raise ValueError(f"point must be {mesh.dim} finite coordinates, got {point!r}")
    vertex, distance = nearest_vertex(mesh, p)
    if distance > tolerance:
        raise ValueError(f"no mesh vertex within {tolerance:g} of {tuple(p)} (nearest at distance {distance:g})")
    return vertex


def pin_vertex_component(problem, *, point, component: int, tolerance: float = 1e-6) -> int:
    """Fix displacement ``component`` (0: x, 1: y) of the vertex at ``point`` (within
    ``tolerance``), also after the problem has been solved (``EquilibriumProblem.fix_dof``).
    Returns the dof number.

    Used to pin the phase of a wave pattern on a ring (``u_y = 0`` at a vertex on the x axis):
    on a rotationally symmetric body the rotation of a buckling pattern relative to the material
    is a zero mode of the continuum, broken only by the mesh (tangent eigenvalue ~1e-12 of the
    next one at the gears' buckled state), which stalls Newton. The pin carries no load in every
    state that is mirror-symmetric about the x axis (a periodic pattern with a crest or trough
    at angle 0); its reaction is the check."""
    dof = vertex_dof(problem, point=point, component=component, tolerance=tolerance)
    problem.fix_dof(dof)
    return dof
