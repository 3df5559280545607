"""Simple shapes: rectangle (2D), block (3D), disk (2D), and a ball as a 3D octant or an
axisymmetric quarter-disk section.

Names
-----
rectangle: region ``"gel"``; boundaries ``"left"`` (x = x0), ``"right"`` (x = x0 + width),
``"bottom"`` (y = y0), ``"top"`` (y = y0 + height).
block: region ``"gel"``; boundaries ``"left"``/``"right"`` (x min/max),
``"front"``/``"back"`` (y min/max), ``"bottom"``/``"top"`` (z min/max).
disk: region ``"gel"``; boundary ``"outer"``.
ball_octant: region ``"gel"``; boundaries ``"xsym"``, ``"ysym"``, ``"zsym"`` (the symmetry planes
x, y, z = 0) and ``"surface"``.
ball_section: region ``"gel"``; boundaries ``"axis"`` (r = 0), ``"equator"`` (z = 0) and
``"surface"``; the upper half of the ball.
"""

from __future__ import annotations

import math

import numpy as np
from netgen import occ

from .common import (AXISYMMETRIC, PLANE, SOLID3D, MeshBundle, cells_for, extrude, generate,
                     require_curve_order, require_int, require_positive, tensor_mesh_2d,
                     to_ngsolve)

GEL = "gel"
LEFT, RIGHT, BOTTOM, TOP, FRONT, BACK = "left", "right", "bottom", "top", "front", "back"
OUTER = "outer"
SURFACE_NAME, AXIS, EQUATOR = "surface", "axis", "equator"
BALL_PLANES = ("xsym", "ysym", "zsym")
RECTANGLE_BOUNDARIES = (LEFT, RIGHT, BOTTOM, TOP)
BLOCK_BOUNDARIES = (LEFT, RIGHT, FRONT, BACK, BOTTOM, TOP)


def rectangle_face(x0: float, y0: float, width: float, height: float, *,
                   top_split: float | None = None) -> occ.Face:
    """OCC rectangle, face ``"gel"``, edges ``"left"``, ``"right"``, ``"bottom"``, ``"top"``.
    ``top_split`` (``0 < top_split < width``): the top is two edges, both ``"top"``, meeting at
    ``x0 + top_split`` (so that each can get its own mesh size)."""
    if top_split is None:
        face = occ.WorkPlane().MoveTo(x0, y0).Rectangle(width, height).Face()
    else:
        if not 0 < top_split < width:
            raise ValueError(f"top_split must be in (0, width={width}), got {top_split!r}")
        face = (occ.WorkPlane().MoveTo(x0, y0).LineTo(x0 + width, y0).LineTo(x0 + width, y0 + height)
                .LineTo(x0 + top_split, y0 + height).LineTo(x0, y0 + height).Close().Face())
    face.name = GEL
    face.edges.Min(occ.X).name = LEFT
    face.edges.Max(occ.X).name = RIGHT
    face.edges.Min(occ.Y).name = BOTTOM
    if top_split is None:
        face.edges.Max(occ.Y).name = TOP
    else:
        for edge in face.edges:
            if abs(edge.center.y - (y0 + height)) <= 1e-9 * height:
                edge.name = TOP
    return face


def named_box(origin: tuple[float, float, float],
              lengths: tuple[float, float, float]) -> occ.Solid:
    """OCC box, material ``"gel"``, faces named as in :func:`block`."""
    x0, y0, z0 = origin
    lx, ly, lz = lengths
    box = occ.Box(occ.Pnt(x0, y0, z0), occ.Pnt(x0 + lx, y0 + ly, z0 + lz)).mat(GEL)
    for sel, name in ((box.faces.Min(occ.X), LEFT), (box.faces.Max(occ.X), RIGHT),
                      (box.faces.Min(occ.Y), FRONT), (box.faces.Max(occ.Y), BACK),
                      (box.faces.Min(occ.Z), BOTTOM), (box.faces.Max(occ.Z), TOP)):
        sel.name = name
    return box


def _divisions(name: str, given: int | None, length: float, maxh: float) -> int:
    return cells_for(length, maxh) if given is None else require_int(name, given, 1)


def rectangle(*, width: float, height: float, maxh: float,
              origin: tuple[float, float] = (0.0, 0.0), structured: bool = False,
              nx: int | None = None, ny: int | None = None,
              quad: bool = False) -> MeshBundle:
    """Plane rectangle ``[x0, x0+width] x [y0, y0+height]``, region ``"gel"``.

    Boundaries ``"left"`` (x = x0), ``"right"``, ``"bottom"`` (y = y0), ``"top"``.
    Unstructured (OCC + Netgen) by default, quad-dominated with ``quad``.  With
    ``structured`` a tensor grid of ``nx x ny`` cells (default: cell size <= maxh),
    quads or each quad split into two triangles.
    """
    width = require_positive("width", width)
    height = require_positive("height", height)
    maxh = require_positive("maxh", maxh)
    x0, y0 = (float(c) for c in origin)
    params = dict(width=width, height=height, maxh=maxh, origin=(x0, y0),
                  structured=structured, nx=nx, ny=ny, quad=quad)
    if structured:
        nx = _divisions("nx", nx, width, maxh)
        ny = _divisions("ny", ny, height, maxh)
        ngmesh = tensor_mesh_2d(
            np.linspace(x0, x0 + width, nx + 1), np.linspace(y0, y0 + height, ny + 1),
            mapping=lambda x, y: (x, y), region=lambda i, j: GEL,
            sides={"s_min": LEFT, "s_max": RIGHT, "t_min": BOTTOM, "t_max": TOP}, quad=quad)
        geometry = None
    else:
        geometry = occ.OCCGeometry(rectangle_face(x0, y0, width, height), dim=2)
        ngmesh = generate(geometry, maxh=maxh, quad_dominated=quad)
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=geometry, model=PLANE,
                      exact_measure=width * height, params=params,
                      boundaries=RECTANGLE_BOUNDARIES, regions=(GEL,))


def block(*, lx: float, ly: float, lz: float, maxh: float,
          origin: tuple[float, float, float] = (0.0, 0.0, 0.0), structured: bool = False,
          nx: int | None = None, ny: int | None = None, nz: int | None = None,
          hexes: bool = True) -> MeshBundle:
    """Box ``[x0, x0+lx] x [y0, y0+ly] x [z0, z0+lz]``, region ``"gel"``.

    Boundaries ``"left"``/``"right"`` (x = x0 / x0+lx), ``"front"``/``"back"``
    (y = y0 / y0+ly), ``"bottom"``/``"top"`` (z = z0 / z0+lz).  Unstructured tetrahedra
    by default; with ``structured`` an ``nx x ny x nz`` grid (default: cell size
    <= maxh) of hexahedra, or of prisms when ``hexes`` is False.
    """
    lx = require_positive("lx", lx)
    ly = require_positive("ly", ly)
    lz = require_positive("lz", lz)
    maxh = require_positive("maxh", maxh)
    x0, y0, z0 = (float(c) for c in origin)
    params = dict(lx=lx, ly=ly, lz=lz, maxh=maxh, origin=(x0, y0, z0),
                  structured=structured, nx=nx, ny=ny, nz=nz, hexes=hexes)
    if structured:
        nx = _divisions("nx", nx, lx, maxh)
        ny = _divisions("ny", ny, ly, maxh)
        nz = _divisions("nz", nz, lz, maxh)
        base = tensor_mesh_2d(
            np.linspace(x0, x0 + lx, nx + 1), np.linspace(y0, y0 + ly, ny + 1),
            mapping=lambda x, y: (x, y), region=lambda i, j: GEL,
            sides={"s_min": LEFT, "s_max": RIGHT, "t_min": FRONT, "t_max": BACK},
            quad=hexes)
        ngmesh = extrude(base, np.linspace(z0, z0 + lz, nz + 1),
                         lift=lambda x, y, z: (x, y, z), bottom=BOTTOM, top=TOP)
        geometry = None
    else:
        geometry = occ.OCCGeometry(named_box((x0, y0, z0), (lx, ly, lz)))
        ngmesh = generate(geometry, maxh=maxh)
    volume = lx * ly * lz
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=geometry, model=SOLID3D,
                      exact_measure=volume, exact_volume=volume, params=params,
                      boundaries=BLOCK_BOUNDARIES, regions=(GEL,))


def disk(*, radius: float, maxh: float, center: tuple[float, float] = (0.0, 0.0),
         curve_order: int = 2, quad: bool = False) -> MeshBundle:
    """Plane disk of ``radius`` about ``center``, region ``"gel"``, boundary ``"outer"``.

    Curved to ``curve_order``.
    """
    radius = require_positive("radius", radius)
    maxh = require_positive("maxh", maxh)
    curve_order = require_curve_order(curve_order)
    cx, cy = (float(c) for c in center)
    face = occ.WorkPlane().Circle(cx, cy, radius).Face()
    face.name = GEL
    face.edges.name = OUTER
    geometry = occ.OCCGeometry(face, dim=2)
    ngmesh = generate(geometry, maxh=maxh, quad_dominated=quad)
    return MeshBundle(mesh=to_ngsolve(ngmesh, curve_order), geometry=geometry, model=PLANE,
                      exact_measure=math.pi * radius**2,
                      params=dict(radius=radius, maxh=maxh, center=(cx, cy),
                                  curve_order=curve_order, quad=quad),
                      boundaries=(OUTER,), regions=(GEL,))




def ball_octant(*, radius: float = 1.0, maxh: float, curve_order: int = 2) -> MeshBundle:
    """The octant ``x, y, z >= 0`` of a ball of ``radius`` (3D, tetrahedra curved to
    ``curve_order``): with rollers on the three symmetry planes it stands for the whole ball."""
    radius = require_positive("radius", radius)
    maxh = require_positive("maxh", maxh)
    curve_order = require_curve_order(curve_order)
    shape = occ.Sphere(occ.Pnt(0, 0, 0), radius) * occ.Box(occ.Pnt(0, 0, 0), occ.Pnt(radius, radius, radius))
    shape.solids.name = GEL
    for name, axis in zip(BALL_PLANES, (occ.X, occ.Y, occ.Z)):
        shape.faces.Min(axis).name = name
    shape.faces.Max(occ.X + occ.Y + occ.Z).name = SURFACE_NAME
    geometry = occ.OCCGeometry(shape)
    volume = math.pi * radius**3 / 6
    return MeshBundle(mesh=to_ngsolve(generate(geometry, maxh=maxh), curve_order), geometry=geometry,
                      model=SOLID3D, exact_measure=volume, exact_volume=volume,
                      params=dict(radius=radius, maxh=maxh, curve_order=curve_order),
                      boundaries=BALL_PLANES + (SURFACE_NAME,), regions=(GEL,))


def ball_section(*, radius: float = 1.0, maxh: float, curve_order: int = 2) -> MeshBundle:
    """The r-z section of the upper half of a ball of ``radius`` (axisymmetric quarter disk,
    curved to ``curve_order``): with ``"equator"`` on rollers it stands for the whole ball."""
    radius = require_positive("radius", radius)
    maxh = require_positive("maxh", maxh)
    curve_order = require_curve_order(curve_order)
    # drawn, not cut from a disk: the cut puts the axis end of the arc at r = -3e-16
    face = (occ.WorkPlane().Line(radius, name=EQUATOR).Rotate(90).Arc(radius, 90, name=SURFACE_NAME)
            .Rotate(90).LineTo(0, 0, name=AXIS).Face())
    face.name = GEL
    geometry = occ.OCCGeometry(face, dim=2)
    return MeshBundle(mesh=to_ngsolve(generate(geometry, maxh=maxh), curve_order), geometry=geometry,
                      model=AXISYMMETRIC, exact_measure=math.pi * radius**2 / 4,
                      exact_volume=2 * math.pi * radius**3 / 3,
                      params=dict(radius=radius, maxh=maxh, curve_order=curve_order),
                      boundaries=(AXIS, EQUATOR, SURFACE_NAME), regions=(GEL,))
