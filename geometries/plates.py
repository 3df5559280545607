"""Circular plates (graded swelling, MODEL.md scene C): thin solid, r-z section,
mid-surface.

Geometry: a disk of radius ``R`` and thickness ``t``, mid-plane z = 0, axis the z axis
(the r-z section uses x = r, y = z).

Names
-----
solid (:func:`plate_solid`): region ``"gel"``; boundaries ``"top"`` (z = t/2),
``"bottom"`` (z = -t/2), ``"rim"`` (r = R).
section (:func:`plate_section`): the same plus ``"axis"`` (x = 0).
mid-surface (:func:`plate_midsurface`): surface region ``"gel"``, boundary curve
``"rim"``.

Thin meshes: the solid is ``layers`` prism layers under a triangle mesh of size
``maxh`` (``mesh.ne == layers * (triangles on "top")``); the section is structured
with ``layers`` cells across.  Aspect ratio
(:func:`geometries.common.aspect_ratios`) stays below
:func:`geometries.common.aspect_bound` ``(maxh, [t / layers])``.
"""

from __future__ import annotations

import math

import numpy as np
from netgen import occ

from .common import (AXISYMMETRIC, SOLID3D, SURFACE, MeshBundle, cells_for, curved_face,
                     generate, identify_layers, layered_mesh, require_below,
                     require_curve_order, require_int, require_positive, revolve,
                     tensor_mesh_2d, to_ngsolve)

GEL = "gel"
TOP, BOTTOM, RIM, AXIS = "top", "bottom", "rim", "axis"
SOLID_BOUNDARIES = (TOP, BOTTOM, RIM)
SECTION_BOUNDARIES = SOLID_BOUNDARIES + (AXIS,)
_LAYERS = "plate_wall"


def _check(R: float, t: float | None, maxh: float, curve_order: int) -> None:
    require_positive("R", R)
    if t is not None:
        require_below("t", require_positive("t", t), "R", R)
    require_positive("maxh", maxh)
    require_curve_order(curve_order)


def _section_face(R: float, t: float) -> occ.Face:
    return curved_face([
        (BOTTOM, [(0.0, -t / 2), (R, -t / 2)]),
        (RIM, [(R, -t / 2), (R, t / 2)]),
        (TOP, [(R, t / 2), (0.0, t / 2)]),
        (AXIS, [(0.0, t / 2), (0.0, -t / 2)]),
    ], region=GEL)


def plate_solid(*, R: float = 1.0, t: float, maxh: float, layers: int = 2,
                curve_order: int = 2) -> MeshBundle:
    """3D thin circular plate, ``layers`` prism layers through ``t`` (``0 < t < R``).

    Region ``"gel"``; boundaries ``"top"``, ``"bottom"``, ``"rim"``.
    """
    _check(R, t, maxh, curve_order)
    layers = require_int("layers", layers, 1)
    shape = revolve(_section_face(R, t))
    shape.mat(GEL)
    identify_layers(shape, [(TOP, BOTTOM)], name=_LAYERS,
                    trafo=occ.gp_Trsf.Translation(occ.Vec(0, 0, -t)))
    geometry, ngmesh = layered_mesh(shape, maxh=maxh, layers={_LAYERS: layers})
    volume = math.pi * R**2 * t
    return MeshBundle(mesh=to_ngsolve(ngmesh, curve_order), geometry=geometry,
                      model=SOLID3D, exact_measure=volume, exact_volume=volume,
                      params=dict(R=R, t=t, maxh=maxh, layers=layers,
                                     curve_order=curve_order),
                      boundaries=SOLID_BOUNDARIES, regions=(GEL,),
                      region_measures={GEL: volume})


def plate_section(*, R: float = 1.0, t: float, maxh: float, layers: int = 2,
                  quad: bool = False) -> MeshBundle:
    """Axisymmetric r-z section ``[0, R] x [-t/2, t/2]`` (x = r, y = z), structured.

    ``layers`` cells across ``t``, cells of width ``<= maxh`` along r; quads or
    triangles.  ``exact_measure`` is ``R t``, ``exact_volume`` ``pi R^2 t``.  Region
    ``"gel"``; boundaries ``"top"``, ``"bottom"``, ``"rim"``, ``"axis"``.
    """
    _check(R, t, maxh, 1)
    layers = require_int("layers", layers, 1)
    face = _section_face(R, t)
    geometry = occ.OCCGeometry(face, dim=2)
    ngmesh = tensor_mesh_2d(
        np.linspace(0.0, R, cells_for(R, maxh) + 1), np.linspace(-t / 2, t / 2, layers + 1),
        mapping=lambda x, y: (x, y), region=lambda i, j: GEL,
        sides={"s_min": AXIS, "s_max": RIM, "t_min": BOTTOM, "t_max": TOP},
        quad=quad, geometry=geometry)
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=geometry, model=AXISYMMETRIC,
                      exact_measure=R * t, exact_volume=math.pi * R**2 * t,
                      params=dict(R=R, t=t, maxh=maxh, layers=layers, quad=quad),
                      boundaries=SECTION_BOUNDARIES, regions=(GEL,),
                      region_measures={GEL: R * t})


def plate_midsurface(*, R: float = 1.0, maxh: float, t: float | None = None,
                     curve_order: int = 2) -> MeshBundle:
    """Mid-plane disk (z = 0) as a 2D manifold in 3D, for shell models.

    Surface region ``"gel"``, boundary curve ``"rim"``.  ``exact_measure`` is
    ``pi R^2``; with ``t`` (``0 < t < R``) ``exact_volume`` is ``pi R^2 t``.
    """
    _check(R, t, maxh, curve_order)
    face = occ.WorkPlane().Circle(0, 0, R).Face()
    face.name = GEL
    face.edges.name = RIM
    geometry = occ.OCCGeometry(face)  # default dim=3: a surface mesh in space
    ngmesh = generate(geometry, maxh=maxh)
    area = math.pi * R**2
    return MeshBundle(mesh=to_ngsolve(ngmesh, curve_order), geometry=geometry,
                      model=SURFACE, exact_measure=area,
                      exact_volume=None if t is None else area * t,
                      params=dict(R=R, t=t, maxh=maxh, curve_order=curve_order),
                      boundaries=(RIM,), regions=(GEL,), region_measures={GEL: area})
