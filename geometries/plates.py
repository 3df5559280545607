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
sector (:func:`plate_sector_midsurface`): surface region ``"gel"``, boundary curves
``"rim"`` and, unless the copies close the disk, the mirror edges ``"sym"`` (on the x
axis) and ``"sym_end"`` (at the sector's end angle).

Thin meshes: the solid is ``layers`` prism layers under a triangle mesh of size
``maxh`` (``mesh.ne == layers * (triangles on "top")``); the section is structured
with ``layers`` cells across.  Aspect ratio
(:func:`geometries.common.aspect_ratios`) stays below
:func:`geometries.common.aspect_bound` ``(maxh, [t / layers])``.
"""

from __future__ import annotations

import math

import netgen.meshing as nm
import ngsolve
import numpy as np
from netgen import occ

from .common import (AXISYMMETRIC, SOLID3D, SURFACE, MeshBundle, cells_for, curved_face,
                     generate, identify_layers, layered_mesh, require_below,
                     require_curve_order, require_int, require_positive, revolve,
                     tensor_mesh_2d, to_ngsolve)

GEL = "gel"
TOP, BOTTOM, RIM, AXIS = "top", "bottom", "rim", "axis"
SYM, SYM_END = "sym", "sym_end"
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


def _mirror_matrix(angle: float) -> np.ndarray:
    """Reflection of the plane z = 0 across the line through the origin at polar ``angle``."""
    c, s = math.cos(2 * angle), math.sin(2 * angle)
    return np.array([[c, s, 0.0], [s, -c, 0.0], [0.0, 0.0, 1.0]])


def sector_copy_map(angle: float, copy: int) -> np.ndarray:
    """The orthogonal map taking the base sector ``0 <= theta <= angle`` onto copy ``copy`` of
    :func:`plate_sector_midsurface` (``angle * copy <= theta <= angle * (copy + 1)``): a rotation
    for even copies, a reflection for odd ones (across the line at ``(copy + 1) angle / 2``), so
    that neighbours are mirror images across their common edge."""
    copy = require_int("copy", copy, 0)
    if copy % 2 == 0:
        c, s = math.cos(copy * angle), math.sin(copy * angle)
        return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return _mirror_matrix((copy + 1) * angle / 2)


def mirrored_sector_mesh(base: nm.Mesh, *, angle: float, copies: int, outer: tuple[str, ...]) -> nm.Mesh:
    """Netgen surface mesh of ``copies`` mirror images (:func:`sector_copy_map`) of ``base``, a
    surface mesh of the sector ``0 <= theta <= angle`` about the z axis whose straight edges are
    named ``"sym"`` (theta = 0) and ``"sym_end"`` (theta = angle). The edges named in ``outer``
    are kept on every copy, the mirror edges only where they bound the result (none when the
    copies close the circle); surface regions keep their names. Reflected copies reverse their
    triangles, so every normal keeps its side."""
    closed = abs(copies * angle - 2 * math.pi) < 1e-9
    points = np.array([p.p for p in base.Points()])
    scale = float(np.max(np.abs(points)))
    triangles = [([v.nr - 1 for v in el.vertices], el.index) for el in base.Elements2D()]
    segments = [([v.nr - 1 for v in seg.vertices], base.EdgeDescriptor(seg.index).name) for seg in base.Elements1D()]
    mesh = nm.Mesh(dim=3)
    for i, face in enumerate(base.FaceDescriptors()):
        mesh.Add(nm.FaceDescriptor(surfnr=i + 1, domin=1, domout=0, bc=i + 1))
        mesh.SetBCName(i, base.GetBCName(i))
    names = list(outer) if closed else [*outer, SYM, SYM_END]
    descriptors = {}
    for name in names:
        descriptor = nm.EdgeDescriptor()
        descriptor.name = name
        descriptors[name] = mesh.Add(descriptor)
    tolerance = 1e-9 * scale
    index: dict[tuple[int, int, int], nm.PointId] = {}  # rounded coordinates -> point (shared edges merge)

    def point(xyz: np.ndarray) -> nm.PointId:
        key = tuple(round(c / tolerance) for c in xyz)
        if key not in index:
            index[key] = mesh.Add(nm.MeshPoint(nm.Pnt(*xyz)))
        return index[key]

    for copy in range(copies):
        Q = sector_copy_map(angle, copy)
        ids = [point(Q @ p) for p in points]
        reflected = np.linalg.det(Q) < 0
        for tri, region in triangles:
            mesh.Add(nm.Element2D(region, [ids[v] for v in (reversed(tri) if reflected else tri)]))
        for vertices, name in segments:
            if name in outer:
                edge = name
            elif name == SYM and copy == 0 and not closed:
                edge = SYM
            elif not closed and copy == copies - 1 and name == (SYM if reflected else SYM_END):  # a
                # reflection maps the base's sym edge onto the copy's end
                edge = SYM_END
            else:
                continue
            a, b = (ids[v] for v in vertices)
            mesh.Add(nm.Element1D([b, a] if reflected else [a, b], index=descriptors[edge]))
    return mesh


def plate_sector_midsurface(*, R: float = 1.0, angle: float, maxh: float, copies: int = 1,
                            t: float | None = None, curve_order: int = 2) -> MeshBundle:
    """Disk sector ``0 <= theta <= copies * angle`` (z = 0) made of ``copies`` mirror images of
    one Netgen mesh of the sector ``0 <= theta <= angle``, for shells with mirror symmetry.

    Copy ``j`` covers ``j angle <= theta <= (j + 1) angle`` and is the base mesh mapped by
    :func:`sector_copy_map` (neighbours are mirror images across their common edge), so a
    pattern computed on a sector of ``m`` copies maps onto any larger one (e.g. the full disk,
    ``copies * angle = 2 pi``, ``copies`` even) node by node. Surface region ``"gel"``;
    boundary curves ``"rim"`` and, unless the copies close the disk, ``"sym"`` (theta = 0) and
    ``"sym_end"`` (theta = copies angle). The rim's chords are moved onto the circle by a
    deformation of order ``curve_order`` (``mesh.SetDeformation``; the mesh has no geometry to
    curve against), the same on every copy. ``exact_measure``: the sector's area.
    """
    _check(R, t, maxh, curve_order)
    copies = require_int("copies", copies, 1)
    if not 0 < angle <= math.pi:
        raise ValueError(f"angle must be in (0, pi], got {angle!r}")
    span = copies * angle
    closed = abs(span - 2 * math.pi) < 1e-9
    if span > 2 * math.pi + 1e-9:
        raise ValueError(f"copies * angle must be at most 2 pi, got {copies} * {angle!r} = {span!r}")
    if closed and copies % 2:
        raise ValueError(f"a closed disk needs an even number of copies (mirror images alternate), got {copies}")
    arc = [(R * math.cos(a), R * math.sin(a)) for a in (0.0, angle / 2, angle)]
    pieces = [occ.Segment(occ.Pnt(0, 0, 0), occ.Pnt(*arc[0], 0)),
              occ.ArcOfCircle(*(occ.Pnt(x, y, 0) for x, y in arc)),
              occ.Segment(occ.Pnt(*arc[2], 0), occ.Pnt(0, 0, 0))]
    face = occ.Face(occ.Wire(pieces))
    face.name = GEL
    for edge in face.edges:  # (names given to the pieces do not survive the wire)
        c = edge.center
        straight = abs(math.hypot(c.x, c.y) - R / 2) < 1e-9 * R
        edge.name = SYM if straight and abs(c.y) < 1e-12 * R else SYM_END if straight else RIM
    base = generate(occ.OCCGeometry(face), maxh=maxh)
    mesh = mirrored_sector_mesh(base, angle=angle, copies=copies, outer=(RIM,))
    bundle_mesh = ngsolve.Mesh(mesh)
    if curve_order > 1:
        r = ngsolve.sqrt(ngsolve.x**2 + ngsolve.y**2)
        deformation = ngsolve.GridFunction(ngsolve.VectorH1(bundle_mesh, order=curve_order))
        deformation.Set(ngsolve.CF((ngsolve.x, ngsolve.y, 0)) * (R / r - 1), ngsolve.BBND,
                        definedon=bundle_mesh.BBoundaries(RIM))
        for vertex in bundle_mesh.vertices:  # on the circle already; the projection moves them ~h^4
            for dof in deformation.space.GetDofNrs(vertex):
                deformation.vec[dof] = 0.0
        bundle_mesh.SetDeformation(deformation)
    area = 0.5 * span * R**2
    return MeshBundle(mesh=bundle_mesh, geometry=None, model=SURFACE, exact_measure=area,
                      exact_volume=None if t is None else area * t,
                      params=dict(R=R, t=t, angle=angle, maxh=maxh, copies=copies, curve_order=curve_order),
                      boundaries=(RIM,) if closed else (RIM, SYM, SYM_END), regions=(GEL,),
                      region_measures={GEL: area})
