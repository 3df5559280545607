"""Contact of a free surface with a rigid plane (penalty) and checks that surfaces do not
interpenetrate.

Symmetric self-contact. A crease centred on a mirror-symmetry line (a plane-strain cell with
roller sides) closes onto its own mirror image: the two crease faces meet exactly on the
symmetry plane. Self-contact of the surface then *is* contact of the surface with that rigid
plane, frictionless because the mirror image slides with it. ``plane_contact`` gives the penalty
energy of that contact,

    W_c = k/2 <g>_+^2   per unit reference surface,   g = side (position - (X + u)_c),

added to the gel's energy with ``GelBody.add_surface_energy`` (the classical penalty method,
Wriggers, *Computational Contact Mechanics*, ch. 6): the contact pressure is ``k <g>_+`` and the
penetration at pressure ``p`` is ``p / k``, so ``k`` must be large against the stiffness of the
surface elements (``G / h``) for the penetration to be a small fraction of ``h``. The
checks here measure it after every step.

General self-contact. Where a crease forms anywhere along the surface, its faces meet at no
known place: ``SelfContact`` pairs every quadrature point of the boundary with the closest point
of the same boundary's deformed image that faces it (NGSolve's ``ContactBoundary``, its pairs
renewed at every state the solver evaluates) and adds

    W_c = k/2 <g>_+^2   per unit reference boundary,   g = (x_1 - x_2) . n_1,

``x_1`` the point, ``x_2`` its partner, ``n_1`` and ``n_2`` the outward normals there (deformed,
functions of the displacement, so that Newton's tangent sees them turn), weighted by how
squarely the two points face each other: with

    c = min((x_1 - x_2) . n_1, -(x_1 - x_2) . n_2) / |x_1 - x_2|

the weight is 1 for ``c >= 0.9``, 0 for ``c <= 0.5``, linear between. Two faces pressed together
give ``c ~ 1`` (the partner is the foot of ``x_1``'s normal, and ``x_1`` lies behind the
partner's face). The closest-point
search also returns partners that are not: a neighbour across a sharp bend of the surface, or
the end of an element on the far side of a mesh-scale groove or slit, which lies behind
``x_1``'s tangent while ``x_1`` is in front of its face. Their ``g`` is positive without any
overlap, and the search keeps or drops them by the sign of ``n_1 . n_2`` at its iterates, so they
switch on and off under round-off-sized moves and their force jumps. Measured on the sharp
layer's mesh-scale grooves: unweighted, a jump of 1.1e-4 that stalled Newton at 4e-6 and ended
the march at t = 5.4e-3; weighted by ``n_1`` alone, 6e-5 at a nearly closed slit (t = 1.44e-2);
a half cell's ramp stuck at 2e-8 where the groove bottom bent by ~100 degrees within an element.
The weight removes them, continuously in the state.

Every face is a master, so two faces overlapping by ``g`` carry the energy twice: the penalty
``k/4`` here is the mirror-plane penalty ``k`` of ``plane_contact`` on a mirror image (the gap is
twice the distance to the plane), which ``tests/test_creases.py`` checks on a closed crease.
NGSolve's pairs freeze the partner's position on its element, so Newton does not see the gap
change as the partner slides; where the faces are not parallel it converges linearly
(docs/creases.md).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import ngsolve as ngs

__all__ = ["plane_contact", "SelfContact", "SurfaceLine", "surface_line", "self_intersections", "crossing_pairs",
           "CrossingLoop", "crossing_loops"]


def plane_contact(*, component: int, position: float, side: int, penalty: float) -> Callable:
    """Penalty density ``u -> k/2 <g>_+^2`` keeping coordinate ``component`` (0 = x, 1 = y, 2 = z)
    of the deformed surface at ``>= position`` (``side = +1``) or ``<= position`` (``side = -1``)."""
    if component not in (0, 1, 2):
        raise ValueError(f"component must be 0, 1 or 2, got {component!r}")
    if side not in (1, -1):
        raise ValueError(f"side must be +1 or -1, got {side!r}")
    if not (isinstance(penalty, (int, float)) and math.isfinite(penalty) and penalty > 0):
        raise ValueError(f"penalty must be a finite number > 0, got {penalty!r}")
    if not (isinstance(position, (int, float)) and math.isfinite(position)):
        raise ValueError(f"position must be a finite number, got {position!r}")
    coordinate = (ngs.x, ngs.y, ngs.z)[component]

    def density(u):
        gap = side * (position - (coordinate + u[component]))  # > 0: penetration
        return 0.5 * penalty * ngs.IfPos(gap, gap * gap, 0.0)

    return density


# ``g / |x_1 - x_2|`` at and above which a pair counts fully, at and below which not at all
SQUARE, OBLIQUE = 0.9, 0.5


class SelfContact:
    """Penalty self-contact of ``boundary`` (2D meshes): ``k/2 <g>_+^2`` per unit
    reference boundary for every point that has passed through the face opposite it, searched
    within ``maxdist`` (default 0: twice the largest boundary element) with ``intorder`` points
    per element, weighted by how squarely the pair faces each other (module docstring).
    ``attach`` adds it to a problem's form; ``update(displacement)`` renews the pairs for a
    state and must precede every residual, tangent and energy evaluation there."""

    def __init__(self, mesh: ngs.Mesh, boundary: str, *, penalty: float, maxdist: float = 0.0,
                 intorder: int = 4):
        if mesh.dim != 2:
            # 3D with NGSolve's normals held fixed was tried on the closed-crease check extruded
            # in depth: an open groove's ramp (no contact at all) stalled at ratio 2.3, residual
            # 1.7e-11, which it passes without the self-contact (energy per depth as the 2D one to 2e-5)
            raise ValueError(f"self-contact is implemented and validated for 2D meshes only, got dim={mesh.dim}")
        if not (isinstance(penalty, (int, float)) and math.isfinite(penalty) and penalty > 0):
            raise ValueError(f"penalty must be a finite number > 0, got {penalty!r}")
        if not (isinstance(maxdist, (int, float)) and math.isfinite(maxdist) and maxdist >= 0):
            raise ValueError(f"maxdist must be a finite number >= 0, got {maxdist!r}")
        if not (isinstance(intorder, int) and intorder >= 1):
            raise ValueError(f"intorder must be an integer >= 1, got {intorder!r}")
        self.mesh, self.boundary, self.penalty = mesh, boundary, float(penalty)
        self.maxdist, self.intorder = float(maxdist), intorder
        self._contact = None
        self._form = None

    def attach(self, form: ngs.BilinearForm, u, weight=1.0) -> None:
        """Add the energy to ``form``; ``u`` is the displacement trial function (a component of
        the form's space), ``weight`` the kinematics' volume weight (``r`` axisymmetric)."""
        region = self.mesh.Boundaries(self.boundary)
        contact = ngs.ContactBoundary(region, region, volume=False)
        X = ngs.CF((ngs.x, ngs.y))
        # normals as functions of u on both sides: Newton sees how they turn (a closed crease:
        # 28 instead of 50 iterations for a jump, 11 instead of 37 for the next small step, than
        # with NGSolve's contact.normal, which is held fixed)
        T, N = ngs.specialcf.tangential(2), ngs.specialcf.normal(2)
        n1 = _deformed_normal(T, N, ngs.Grad(u))
        n2 = _deformed_normal(T.Other(), N.Other(), ngs.Grad(u).Other())
        apart = X + u - (X.Other() + u.Other())
        gap = apart * n1
        # on both faces: the partner is the foot of x_1's normal, and x_1 lies behind the partner's face
        distance = ngs.sqrt(ngs.InnerProduct(apart, apart) + 1e-300)
        behind = -(apart * n2)
        squareness = ngs.IfPos(gap - behind, behind, gap) / distance
        facing = ngs.IfPos(squareness - SQUARE, 1.0,
                           ngs.IfPos(squareness - OBLIQUE, (squareness - OBLIQUE) / (SQUARE - OBLIQUE), 0.0))
        contact.AddEnergy(weight * facing * ngs.IfPos(gap, 0.5 * self.penalty * gap * gap, 0.0))
        self._contact, self._form = contact, form

    def update(self, displacement: ngs.GridFunction) -> None:
        if self._contact is None:
            raise RuntimeError("attach the self-contact to a form first")
        self._contact.Update(displacement, self._form, self.intorder, self.maxdist)


def _deformed_normal(T, N, grad_u):
    """Outward unit normal of a deformed 2D boundary: the reference tangent ``T`` carried by
    ``I + grad u`` and turned by 90 degrees to the side of the reference normal ``N``."""
    t = T + grad_u * T
    side = ngs.CF((T[1], -T[0])) * N  # +-1: which way the turn points outward
    return side * ngs.CF((t[1], -t[0])) / ngs.sqrt(ngs.InnerProduct(t, t))


@dataclass(frozen=True, eq=False)
class SurfaceLine:
    """Points along a 2D boundary curve, ordered by the reference x coordinate: ``reference``
    and ``current`` positions, shape ``(n, 2)``; ``edge_length`` the shortest boundary edge."""

    reference: np.ndarray
    current: np.ndarray
    edge_length: float


def surface_line(displacement: ngs.GridFunction, mesh: ngs.Mesh, boundary: str, *,
                 points_per_edge: int = 4) -> SurfaceLine:
    """The deformed curve of ``boundary`` (2D meshes, a boundary that is a graph over x): each
    boundary edge sampled at ``points_per_edge`` equal parameter steps (P2 displacements bend
    the edges between the vertices), plus the last vertex."""
    if mesh.dim != 2:
        raise ValueError(f"surface_line needs a 2D mesh, got dim={mesh.dim}")
    if not isinstance(points_per_edge, int) or points_per_edge < 1:
        raise ValueError(f"points_per_edge must be an integer >= 1, got {points_per_edge!r}")
    names = set(boundary.split("|"))
    edges = []
    for el in mesh.Elements(ngs.BND):
        if el.mat in names:
            a, b = (np.array(mesh[v].point) for v in el.vertices)
            edges.append((a, b) if a[0] <= b[0] else (b, a))
    if not edges:
        raise ValueError(f"boundary {boundary!r} has no edges; the mesh has {sorted(set(mesh.GetBoundaries()))}")
    edges.sort(key=lambda e: e[0][0])
    s = np.arange(points_per_edge) / points_per_edge
    points = np.vstack([a + np.outer(s, b - a) for a, b in edges] + [edges[-1][1][None, :]])
    values = np.asarray(displacement(mesh(points[:, 0], points[:, 1])))
    lengths = [float(np.linalg.norm(b - a)) for a, b in edges]
    return SurfaceLine(reference=points, current=points + values, edge_length=min(lengths))


def self_intersections(polyline: np.ndarray, *, tolerance: float = 0.0) -> int:
    """Number of pairs of non-adjacent segments of the open ``polyline`` (shape ``(n, 2)``)
    that cross each other by more than ``tolerance`` (a length): a surface that passes through
    itself. Touching segments (a closed crease) do not count."""
    return len(crossing_pairs(polyline, tolerance=tolerance))


def crossing_pairs(polyline: np.ndarray, *, tolerance: float = 0.0) -> list[tuple[int, int]]:
    """The crossing segment pairs ``(i, j)``, ``i < j - 1`` (segment ``i`` joins points ``i`` and
    ``i + 1``), see :func:`self_intersections`."""
    p = np.asarray(polyline, dtype=float)
    if p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 2:
        raise ValueError(f"polyline must have shape (n >= 2, 2), got {p.shape}")
    a, b = p[:-1], p[1:]
    d = b - a
    n = len(a)
    i, j = np.triu_indices(n, k=2)
    r, s = d[i], d[j]
    denom = r[:, 0] * s[:, 1] - r[:, 1] * s[:, 0]
    qp = a[j] - a[i]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (qp[:, 0] * s[:, 1] - qp[:, 1] * s[:, 0]) / denom
        v = (qp[:, 0] * r[:, 1] - qp[:, 1] * r[:, 0]) / denom
    len_r = np.linalg.norm(r, axis=1)
    len_s = np.linalg.norm(s, axis=1)
    # strictly inside both segments by more than ``tolerance``
    mt = np.where(len_r > 0, tolerance / np.where(len_r > 0, len_r, 1), np.inf)
    mv = np.where(len_s > 0, tolerance / np.where(len_s > 0, len_s, 1), np.inf)
    crossing = (denom != 0) & (t > mt) & (t < 1 - mt) & (v > mv) & (v < 1 - mv)
    return [(int(a_), int(b_)) for a_, b_ in zip(i[crossing], j[crossing])]


@dataclass(frozen=True)
class CrossingLoop:
    """The loop that a crossing of a polyline cuts off: segments ``first`` and ``last`` cross,
    the loop runs along the points ``first + 1 ... last``; ``area``, ``perimeter`` and mean
    ``width = 2 area / perimeter`` of that polygon with the loops nested in it cut out (each
    replaced by its crossing point); ``innermost`` if none is nested in it."""

    first: int
    last: int
    area: float
    perimeter: float
    width: float
    innermost: bool


def crossing_loops(polyline: np.ndarray) -> list[CrossingLoop]:
    """The loops cut off by the crossings of the open ``polyline`` (:func:`crossing_pairs`).

    Two faces of a closed crease held by a penalty overlap by a thin sliver (its width is the
    overlap); a surface that passed through itself cuts off a lobe as wide as the fold. Where a
    sliver ends in a crossed lobe (the bottom of a crease that the elements cannot fold), the
    lobe is cut out of the sliver and reported by itself."""
    p = np.asarray(polyline, dtype=float)
    pairs = crossing_pairs(p)

    def crossing_point(i: int, j: int) -> np.ndarray:
        r, s, q = p[i + 1] - p[i], p[j + 1] - p[j], p[j] - p[i]
        return p[i] + (q[0] * s[1] - q[1] * s[0]) / (r[0] * s[1] - r[1] * s[0]) * r

    loops = []
    for i, j in pairs:
        nested = sorted((a, b) for a, b in pairs if i < a and b < j)
        outer = [(a, b) for a, b in nested if not any(c < a and b < d for c, d in nested)]
        points, k = [crossing_point(i, j)], i + 1
        for a, b in outer:
            points.extend(p[k:a + 1])
            points.append(crossing_point(a, b))
            k = b + 1
        points.extend(p[k:j + 1])
        closed = np.vstack(points + [points[0]])
        area = 0.5 * abs(float(np.sum(closed[:-1, 0] * closed[1:, 1] - closed[1:, 0] * closed[:-1, 1])))
        perimeter = float(np.linalg.norm(np.diff(closed, axis=0), axis=1).sum())
        loops.append(CrossingLoop(first=i, last=j, area=area, perimeter=perimeter,
                                  width=2 * area / perimeter if perimeter > 0 else 0.0, innermost=not nested))
    return loops
