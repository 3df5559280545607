"""Hollow spheres (gel shells of radii ``inner .. outer`` about the origin), three ways: a 3D
octant, an axisymmetric section and the radial line of a spherically symmetric model.

Names
-----
region ``"gel"``; boundaries ``"inner"`` (r = inner) and ``"outer"`` (r = outer), plus
sphere_octant: ``"xsym"``, ``"ysym"``, ``"zsym"`` (the symmetry planes x, y, z = 0; with
rollers there the octant stands for the whole shell);
sphere_section: ``"axis"`` (r = 0) and ``"equator"`` (z = 0): the quarter annulus
``inner <= |(r, z)| <= outer``, ``r, z >= 0``, the upper half of the shell (with rollers on
the equator it stands for the whole shell);
sphere_radial: the interval ``[inner, outer]`` on the x axis (x = r), model
``"spherical"``; ``inner = 0`` is a ball, its ``"inner"`` end the centre.

A ball in 3D and in r-z section: :func:`geometries.ball_octant`, :func:`geometries.ball_section`.
"""

from __future__ import annotations

import math

import netgen.meshing as nm
from netgen import occ

from .common import (AXISYMMETRIC, SOLID3D, SPHERICAL, MeshBundle, cells_for, generate, require_below,
                     require_curve_order, require_int, require_nonnegative, require_positive, to_ngsolve)

GEL = "gel"
INNER, OUTER = "inner", "outer"
AXIS, EQUATOR = "axis", "equator"
SYMMETRY_PLANES = ("xsym", "ysym", "zsym")


def _radii(inner: float, outer: float, *, hollow: bool) -> tuple[float, float]:
    outer = require_positive("outer", outer)
    inner = require_positive("inner", inner) if hollow else require_nonnegative("inner", inner)
    require_below("inner", inner, "outer", outer)
    return inner, outer


def sphere_octant(*, inner: float, outer: float, maxh: float, curve_order: int = 2) -> MeshBundle:
    """The octant ``x, y, z >= 0`` of the hollow sphere ``inner <= r <= outer`` (tetrahedra curved
    to ``curve_order``); ``inner > 0`` (a ball: :func:`geometries.ball_octant`)."""
    inner, outer = _radii(inner, outer, hollow=True)
    maxh = require_positive("maxh", maxh)
    curve_order = require_curve_order(curve_order)
    outer_ball, inner_ball = occ.Sphere(occ.Pnt(0, 0, 0), outer), occ.Sphere(occ.Pnt(0, 0, 0), inner)
    outer_ball.faces.name = OUTER
    inner_ball.faces.name = INNER
    # a box reaching past the sphere: no face of it touches the sphere
    box = occ.Box(occ.Pnt(0, 0, 0), occ.Pnt(2 * outer, 2 * outer, 2 * outer))
    for name, axis in zip(SYMMETRY_PLANES, (occ.X, occ.Y, occ.Z)):
        box.faces.Min(axis).name = name
    shape = (outer_ball - inner_ball) * box
    shape.solids.name = GEL
    geometry = occ.OCCGeometry(shape)
    volume = math.pi * (outer**3 - inner**3) / 6
    return MeshBundle(mesh=to_ngsolve(generate(geometry, maxh=maxh), curve_order), geometry=geometry,
                      model=SOLID3D, exact_measure=volume, exact_volume=volume,
                      params=dict(inner=inner, outer=outer, maxh=maxh, curve_order=curve_order),
                      boundaries=SYMMETRY_PLANES + (INNER, OUTER), regions=(GEL,))


def sphere_section(*, inner: float, outer: float, maxh: float, curve_order: int = 2) -> MeshBundle:
    """The r-z section of the upper half of the hollow sphere ``inner <= r <= outer``: a quarter
    annulus (axisymmetric, curved to ``curve_order``); ``inner > 0`` (a ball:
    :func:`geometries.ball_section`)."""
    inner, outer = _radii(inner, outer, hollow=True)
    maxh = require_positive("maxh", maxh)
    curve_order = require_curve_order(curve_order)
    # drawn edge by edge, so the axis lies exactly on r = 0
    face = (occ.WorkPlane().MoveTo(inner, 0).Line(outer - inner, name=EQUATOR).Rotate(90)
            .Arc(outer, 90, name=OUTER).Rotate(90).Line(outer - inner, name=AXIS).Rotate(90)
            .Arc(inner, -90, name=INNER).Face())
    face.name = GEL
    geometry = occ.OCCGeometry(face, dim=2)
    return MeshBundle(mesh=to_ngsolve(generate(geometry, maxh=maxh), curve_order), geometry=geometry,
                      model=AXISYMMETRIC, exact_measure=math.pi * (outer**2 - inner**2) / 4,
                      exact_volume=2 * math.pi * (outer**3 - inner**3) / 3,
                      params=dict(inner=inner, outer=outer, maxh=maxh, curve_order=curve_order),
                      boundaries=(AXIS, EQUATOR, INNER, OUTER), regions=(GEL,))


def sphere_radial(*, inner: float = 0.0, outer: float, maxh: float, cells: int | None = None) -> MeshBundle:
    """The radial line ``[inner, outer]`` of a spherically symmetric shell (``inner = 0``: a ball)
    in ``cells`` equal segments (default: segment length ``<= maxh``)."""
    inner, outer = _radii(inner, outer, hollow=False)
    maxh = require_positive("maxh", maxh)
    cells = cells_for(outer - inner, maxh) if cells is None else require_int("cells", cells, 1)
    # as ngsolve.meshes.Make1DMesh: points inner + (outer - inner) i / cells, segments oriented inwards
    ngmesh = nm.Mesh(dim=1)
    points = [ngmesh.Add(nm.MeshPoint(nm.Pnt(inner + (outer - inner) * (i / cells), 0, 0))) for i in range(cells + 1)]
    gel = ngmesh.AddRegion(GEL, dim=1)
    for a, b in zip(points, points[1:]):
        ngmesh.Add(nm.Element1D([b, a], index=gel))
    for name, point in ((INNER, points[0]), (OUTER, points[-1])):
        ngmesh.Add(nm.Element0D(point, index=ngmesh.AddRegion(name, dim=0)))
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=None, model=SPHERICAL, exact_measure=outer - inner,
                      exact_volume=4 * math.pi * (outer**3 - inner**3) / 3,
                      params=dict(inner=inner, outer=outer, maxh=maxh, cells=cells),
                      boundaries=(INNER, OUTER), regions=(GEL,))
