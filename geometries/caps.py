"""Spherical caps (microlens, MODEL.md scene A): thin solid, r-z section, mid-surface.

Geometry
--------
The mid-surface is a spherical cap of base radius ``R`` and apex height ``H`` (base
circle in the plane z = 0, apex at (0, 0, H)), radius ``r = (R^2 + H^2) / (2 H)`` and
centre (0, 0, H - r).  The wall spans radii ``r - t/2 .. r + t/2`` about that centre
and ends at the *radial* cone through the base circle, so the base face is normal to
the shell and the solid is exactly the spherical-coordinate box
``rho in [r - t/2, r + t/2], polar angle in [0, theta0]``, ``sin theta0 = R / r``.
The apex patch is the part with polar angle below ``asin(a / r)``, ``a`` =
``apex_radius`` (its horizontal radius on the mid-surface).

Names
-----
solid (:func:`cap_solid`) and section (:func:`cap_section`): region ``"gel"``;
boundaries ``"outer"`` (convex face without the apex patch), ``"apex"`` (apex patch of
the outer face), ``"inner"`` and ``"apex_inner"`` (the same split of the concave face),
``"base"`` (clamped edge face / segment); the section also has ``"axis"``.
mid-surface (:func:`cap_midsurface`): regions ``"gel"`` and ``"apex"`` (surface
patches), boundary curve ``"base"``.

Thin meshes
-----------
The solid is meshed by prisms: Netgen meshes the outer surface with triangles of size
``maxh`` (``apex_maxh`` on the apex patches; both capped at
:func:`geometries.common.chord_limit` ``(r - t/2, t / layers)`` so that curved faces
never cross the flat internal ones), maps that mesh radially onto the inner
surface (close-surface identification) and ``layers`` equally thick prism layers fill
the wall, so ``mesh.ne == layers * (surface triangles on "outer" and "apex")``.  The
section is a structured mesh of ``layers`` cells across the wall, with the same cap on
the cell length along it.  Aspect ratio
(:func:`geometries.common.aspect_ratios`) stays below
:func:`geometries.common.aspect_bound` ``(maxh, [t / layers])``.
"""

from __future__ import annotations

import math

import ngsolve
import numpy as np
from netgen import occ

from .common import (AXISYMMETRIC, SOLID3D, SURFACE, MeshBundle, chord_limit,
                     curved_face, generate, graded_nodes, identify_layers, layered_mesh,
                     named_face, require_below, require_curve_order, require_int,
                     require_positive, revolve, tensor_mesh_2d, to_ngsolve)

GEL = "gel"
OUTER, INNER, APEX, APEX_INNER, BASE, AXIS = ("outer", "inner", "apex", "apex_inner",
                                              "base", "axis")
SYM = "sym"
APEX_RIM = "apex_rim"  # the circle between the apex patch and the rest (cap sectors only)
SOLID_BOUNDARIES = (OUTER, APEX, INNER, APEX_INNER, BASE)
SECTION_BOUNDARIES = SOLID_BOUNDARIES + (AXIS,)
_LAYERS = "cap_wall"


class _Cap:
    """Validated cap parameters and the derived sphere."""

    def __init__(self, R: float, H: float, t: float | None, apex_radius: float | None,
                 apex_maxh: float | None, maxh: float, curve_order: int) -> None:
        self.R = require_positive("R", R)
        self.H = require_positive("H", H)
        require_below("H", H, "R (caps up to a hemisphere)", R, inclusive=True)
        self.r = (R**2 + H**2) / (2 * H)
        self.t = None if t is None else require_below("t", require_positive("t", t),
                                                      "mid-surface radius r", self.r)
        self.maxh = require_positive("maxh", maxh)
        self.a = 0.05 * R if apex_radius is None else require_below(
            "apex_radius", require_positive("apex_radius", apex_radius), "R", R)
        self.apex_maxh = None if apex_maxh is None else require_positive("apex_maxh",
                                                                         apex_maxh)
        self.curve_order = require_curve_order(curve_order)
        self.zc = H - self.r
        self.theta0 = math.asin(min(1.0, R / self.r))
        self.theta_a = math.asin(self.a / self.r)

    def sizes(self, layers: int) -> tuple[float, float]:
        """Element size and apex-patch size, capped so curved faces stay clear."""
        limit = chord_limit(self.r - self.t / 2, self.t / layers)
        h = min(self.maxh, limit)
        return h, min(h, self.apex_maxh or h)

    def point(self, rho: float, theta: float) -> tuple[float, float]:
        """(x = r, y = z) of polar radius rho and polar angle theta about the centre."""
        return rho * math.sin(theta), self.zc + rho * math.cos(theta)

    def arc(self, rho: float, th1: float, th2: float) -> list[tuple[float, float]]:
        return [self.point(rho, th1), self.point(rho, 0.5 * (th1 + th2)),
                self.point(rho, th2)]

    def section_face(self) -> occ.Face:
        """The r-z section with named edges (x = r, y = z)."""
        ri, ro = self.r - self.t / 2, self.r + self.t / 2
        ta, t0 = self.theta_a, self.theta0
        return curved_face([
            (AXIS, [self.point(ri, 0), self.point(ro, 0)]),
            (APEX, self.arc(ro, 0, ta)),
            (OUTER, self.arc(ro, ta, t0)),
            (BASE, [self.point(ro, t0), self.point(ri, t0)]),
            (INNER, self.arc(ri, t0, ta)),
            (APEX_INNER, self.arc(ri, ta, 0)),
        ], region=GEL)

    def volume(self) -> float:
        ri, ro = self.r - self.t / 2, self.r + self.t / 2
        return 2 * math.pi / 3 * (1 - math.cos(self.theta0)) * (ro**3 - ri**3)

    def params(self, **extra) -> dict:
        return dict(R=self.R, H=self.H, t=self.t, r=self.r, apex_radius=self.a,
                    apex_maxh=self.apex_maxh, maxh=self.maxh,
                    curve_order=self.curve_order, **extra)


def cap_solid(*, R: float = 1.0, H: float, t: float, maxh: float, layers: int = 2,
              apex_radius: float | None = None, apex_maxh: float | None = None,
              curve_order: int = 2, half: bool = False) -> MeshBundle:
    """3D thin spherical cap meshed by ``layers`` prism layers through ``t``.

    ``0 < H <= R``, ``0 < t < r``; ``apex_radius`` (default ``0.05 R``) in ``(0, R)``;
    ``apex_maxh`` refines the apex patches.  Region ``"gel"``; boundaries ``"outer"``,
    ``"apex"``, ``"inner"``, ``"apex_inner"``, ``"base"``. ``half``: only the part with
    ``y >= 0``, the two cut faces in the plane ``y = 0`` named ``"sym"`` (as ``cap_midsurface``);
    measures halved.
    """
    cap = _Cap(R, H, t, apex_radius, apex_maxh, maxh, curve_order)
    layers = require_int("layers", layers, 1)
    if not isinstance(half, bool):
        raise ValueError(f"half must be True or False, got {half!r}")
    h, h_apex = cap.sizes(layers)
    shape = revolve(cap.section_face(), 180.0 if half else 360.0)
    if half:
        for face in shape.faces:
            (_, y0, _), (_, y1, _) = face.bounding_box
            if abs(y0) < 1e-6 * cap.R and abs(y1) < 1e-6 * cap.R:
                face.name = SYM
    shape.mat(GEL)
    for name in (APEX, APEX_INNER):
        named_face(shape, name).maxh = h_apex
    # the radial map from outer to inner sphere is a scaling about the centre
    ratio = (cap.r - cap.t / 2) / (cap.r + cap.t / 2)
    identify_layers(shape, [(OUTER, INNER), (APEX, APEX_INNER)], name=_LAYERS,
                    trafo=occ.gp_Trsf.Scale(occ.Pnt(0, 0, cap.zc), ratio))
    geometry, ngmesh = layered_mesh(shape, maxh=h, layers={_LAYERS: layers})
    volume = cap.volume() * (0.5 if half else 1.0)
    return MeshBundle(mesh=to_ngsolve(ngmesh, cap.curve_order), geometry=geometry,
                      model=SOLID3D, exact_measure=volume, exact_volume=volume,
                      params={**cap.params(layers=layers), "half": half},
                      boundaries=SOLID_BOUNDARIES + ((SYM,) if half else ()),
                      regions=(GEL,), region_measures={GEL: volume})


def cap_section(*, R: float = 1.0, H: float, t: float, maxh: float, layers: int = 2,
                apex_radius: float | None = None, apex_maxh: float | None = None,
                curve_order: int = 2, quad: bool = False) -> MeshBundle:
    """Axisymmetric r-z section (x = r, y = z) of the thin cap, structured.

    ``layers`` cells across the wall; along it cells of arc length ``maxh``, graded
    from ``apex_maxh`` on the apex patch.  Quads, or triangles (two per cell).
    ``exact_measure`` is the section area ``theta0 r t``, ``exact_volume`` the cap's
    volume.  Region ``"gel"``; boundaries ``"axis"``, ``"outer"``, ``"apex"``,
    ``"inner"``, ``"apex_inner"``, ``"base"``.
    """
    cap = _Cap(R, H, t, apex_radius, apex_maxh, maxh, curve_order)
    layers = require_int("layers", layers, 1)
    h, h_apex = cap.sizes(layers)
    s_apex = graded_nodes(0.0, cap.r * cap.theta_a, h=h_apex)
    s_rest = graded_nodes(cap.r * cap.theta_a, cap.r * cap.theta0, h=h, h_a=h_apex)
    theta = np.concatenate([s_apex, s_rest[1:]]) / cap.r
    n_apex = len(s_apex) - 1
    face = cap.section_face()
    geometry = occ.OCCGeometry(face, dim=2)
    ngmesh = tensor_mesh_2d(
        np.linspace(cap.r - cap.t / 2, cap.r + cap.t / 2, layers + 1), theta,
        mapping=cap.point, region=lambda i, j: GEL,
        sides={"s_min": lambda j: APEX_INNER if j < n_apex else INNER,
               "s_max": lambda j: APEX if j < n_apex else OUTER,
               "t_min": AXIS, "t_max": BASE},
        quad=quad, geometry=geometry)
    area = cap.theta0 * cap.r * cap.t
    return MeshBundle(mesh=to_ngsolve(ngmesh, cap.curve_order), geometry=geometry,
                      model=AXISYMMETRIC, exact_measure=area, exact_volume=cap.volume(),
                      params=cap.params(layers=layers, quad=quad),
                      boundaries=SECTION_BOUNDARIES, regions=(GEL,),
                      region_measures={GEL: area})


def cap_midsurface(*, R: float = 1.0, H: float, maxh: float, t: float | None = None,
                   apex_radius: float | None = None, apex_maxh: float | None = None,
                   curve_order: int = 2, half: bool = False) -> MeshBundle:
    """Mid-surface of the cap as a triangulated 2D manifold in 3D (shell models).

    Surface regions ``"gel"`` and ``"apex"`` (the apex patch), boundary curve
    ``"base"`` (use :meth:`MeshBundle.region` / :meth:`MeshBundle.boundary`).
    ``exact_measure`` is the mid-surface area ``2 pi r H``; with a thickness ``t`` (kept
    for the shell model, ``0 < t < r``) ``exact_volume`` is area times ``t``.
    ``half``: only the part with ``y >= 0``, the cut meridians in the plane ``y = 0`` named
    ``"sym"`` (a mirror plane: it carries every ``cos k theta`` pattern and removes the rotation
    of a pattern about the axis); measures halved.
    """
    cap = _Cap(R, H, t, apex_radius, apex_maxh, maxh, curve_order)
    if not isinstance(half, bool):
        raise ValueError(f"half must be True or False, got {half!r}")
    fraction = 0.5 if half else 1.0
    patches = []
    for name, (th1, th2) in ((APEX, (0.0, cap.theta_a)), (GEL, (cap.theta_a, cap.theta0))):
        arc = occ.ArcOfCircle(*(occ.Pnt(x, 0.0, z) for x, z in cap.arc(cap.r, th1, th2)))
        arc.name = name
        patch = arc.Revolve(occ.Axis((0, 0, 0), occ.Z), 360 * fraction)
        if name == APEX and cap.apex_maxh is not None:
            patch.faces.maxh = cap.apex_maxh
        patches.append(patch)
    shape = occ.Glue(patches)
    for edge in shape.edges:
        (_, y0, z0), (x1, y1, z1) = edge.bounding_box
        if abs(z0) < 1e-6 * cap.R and abs(z1) < 1e-6 * cap.R and x1 > 0.5 * cap.R:
            edge.name = BASE
        elif half and abs(y0) < 1e-6 * cap.R and abs(y1) < 1e-6 * cap.R:
            edge.name = SYM
    geometry = occ.OCCGeometry(shape)
    ngmesh = generate(geometry, maxh=cap.maxh)
    area = 2 * math.pi * cap.r * cap.H * fraction
    apex_area = 2 * math.pi * cap.r**2 * (1 - math.cos(cap.theta_a)) * fraction
    return MeshBundle(mesh=to_ngsolve(ngmesh, cap.curve_order), geometry=geometry,
                      model=SURFACE, exact_measure=area,
                      exact_volume=None if cap.t is None else area * cap.t,
                      params={**cap.params(), "half": half}, boundaries=(BASE, SYM) if half else (BASE,),
                      regions=(GEL, APEX), region_measures={GEL: area - apex_area, APEX: apex_area})


def cap_sector_midsurface(*, R: float = 1.0, H: float, angle: float, maxh: float, copies: int = 1,
                          apex_radius: float | None = None, apex_maxh: float | None = None,
                          curve_order: int = 2) -> MeshBundle:
    """Sector ``0 <= theta <= copies * angle`` of the cap's mid-surface made of ``copies`` mirror
    images of one Netgen mesh of the sector ``0 <= theta <= angle``
    (``geometries.plates.mirrored_sector_mesh``), so that a state of a sector maps onto any
    larger one (e.g. the whole cap, ``copies * angle = 2 pi``) node by node. Surface regions
    ``"gel"`` and ``"apex"``; curves ``"apex_rim"`` (between them), boundary curves ``"base"`` and, unless the copies close the cap,
    ``"sym"`` (theta = 0) and ``"sym_end"`` (theta = copies angle): mirror planes. The mesh has
    no geometry to curve against: a deformation of order ``curve_order`` puts the elements on the
    sphere and the base edges on the base circle (vertices stay where Netgen put them).
    """
    from .plates import SYM_END, mirrored_sector_mesh

    cap = _Cap(R, H, None, apex_radius, apex_maxh, maxh, curve_order)
    copies = require_int("copies", copies, 1)
    if not 0 < angle <= math.pi:
        raise ValueError(f"angle must be in (0, pi], got {angle!r}")
    if copies * angle > 2 * math.pi + 1e-9:
        raise ValueError(f"copies * angle must be at most 2 pi, got {copies} * {angle!r}")
    closed = abs(copies * angle - 2 * math.pi) < 1e-9
    if closed and copies % 2:
        raise ValueError(f"a closed cap needs an even number of copies (mirror images alternate), got {copies}")
    patches = []
    for name, (th1, th2) in ((APEX, (0.0, cap.theta_a)), (GEL, (cap.theta_a, cap.theta0))):
        arc = occ.ArcOfCircle(*(occ.Pnt(x, 0.0, z) for x, z in cap.arc(cap.r, th1, th2)))
        arc.name = name
        patch = arc.Revolve(occ.Axis((0, 0, 0), occ.Z), math.degrees(angle))
        if name == APEX and cap.apex_maxh is not None:
            patch.faces.maxh = cap.apex_maxh
        patches.append(patch)
    shape = occ.Glue(patches)
    normal = (-math.sin(angle), math.cos(angle))
    for edge in shape.edges:
        c = edge.center
        (_, _, z0), (_, _, z1) = edge.bounding_box
        if abs(z0) < 1e-6 * cap.R and abs(z1) < 1e-6 * cap.R:
            edge.name = BASE
        elif abs(c.y) < 1e-9 * cap.R:
            edge.name = SYM
        elif abs(normal[0] * c.x + normal[1] * c.y) < 1e-9 * cap.R:
            edge.name = SYM_END
        else:
            edge.name = APEX_RIM
    base = generate(occ.OCCGeometry(shape), maxh=cap.maxh)
    mesh = ngsolve.Mesh(mirrored_sector_mesh(base, angle=angle, copies=copies, outer=(BASE, APEX_RIM)))
    if cap.curve_order > 1:
        x = ngsolve.CF((ngsolve.x, ngsolve.y, ngsolve.z - cap.zc))
        rho = ngsolve.sqrt(x * x)
        deformation = ngsolve.GridFunction(ngsolve.VectorH1(mesh, order=cap.curve_order))
        deformation.Set(x * (cap.r / rho - 1), definedon=mesh.Boundaries(".*"), dual=True)  # node by node: the
        # same on a mirror seam inside the cap as on the sector's mirror edge
        horizontal = ngsolve.sqrt(ngsolve.x**2 + ngsolve.y**2)
        z_a = cap.zc + cap.r * math.cos(cap.theta_a)
        circles = {BASE: (cap.R, 0.0), APEX_RIM: (cap.a, z_a)}  # horizontal radius, height
        on_circle = ngsolve.GridFunction(deformation.space)
        for name, (radius, height) in circles.items():  # (each Set overwrites the whole vector)
            scale = radius / horizontal - 1
            on_circle.Set(ngsolve.CF((ngsolve.x * scale, ngsolve.y * scale, height - ngsolve.z)), ngsolve.BBND,
                          definedon=mesh.BBoundaries(name))
            for element in mesh.Elements(ngsolve.BBND):
                if element.mat == name:
                    for dof in deformation.space.GetDofNrs(element):
                        deformation.vec[dof] = on_circle.vec[dof]
        for vertex in mesh.vertices:
            for dof in deformation.space.GetDofNrs(vertex):
                deformation.vec[dof] = 0.0
        mesh.SetDeformation(deformation)
    fraction = copies * angle / (2 * math.pi)
    area = 2 * math.pi * cap.r * cap.H * fraction
    apex_area = 2 * math.pi * cap.r**2 * (1 - math.cos(cap.theta_a)) * fraction
    return MeshBundle(mesh=mesh, geometry=None, model=SURFACE, exact_measure=area, exact_volume=None,
                      params={**cap.params(), "angle": angle, "copies": copies},
                      boundaries=(BASE,) if closed else (BASE, SYM, SYM_END),
                      regions=(GEL, APEX), region_measures={GEL: area - apex_area, APEX: apex_area})
