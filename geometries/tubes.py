"""Tubes and annuli with optional bonded films (gears, MODEL.md scenes B and D).

Geometry
--------
The gel wall spans radii ``Ri .. Ro`` about the z axis.  The films are bonded *outside*
it, so the gel keeps the thesis's dimensions: an inner film ``Ri - tfi .. Ri`` and an
outer film ``Ro .. Ro + tfo`` (a thickness 0 means no film).  Tubes run from z = 0 to
``Hz``; r-z sections use x = r, y = z.

Names
-----
regions ``"gel"``, ``"film_inner"``, ``"film_outer"`` (films only when present);
boundaries ``"inner"`` (innermost surface, r = Ri - tfi) and ``"outer"`` (r = Ro + tfo),
internal interfaces ``"interface_inner"`` (r = Ri) and ``"interface_outer"``
(r = Ro) when the film exists; tubes and sections add ``"base"`` (z = 0) and
``"head"`` (z = Hz).  Interface normals point radially outward.

Thin meshes
-----------
The annulus and the section are structured in (r, theta) and (r, z): ``film_layers``
cells across each film, and across the gel either ``wall_layers`` equal cells or, by
default, cells graded from the film cell size up to ``maxh``.  The 3D tube is made of
prisms: Netgen meshes the outer cylinder with triangles of size ``maxh``, copies the
mesh radially inwards and fills each film with ``film_layers`` and the gel with
``wall_layers`` prism layers.  Aspect ratio (:func:`geometries.common.aspect_ratios`)
stays below :func:`geometries.common.aspect_bound` ``(maxh, cell thicknesses)`` with
cell thicknesses ``tfi / film_layers``, ``tfo / film_layers`` and the gel's
``(Ro - Ri) / wall_layers`` (the gel's smallest graded cell when ``wall_layers`` is
None).
"""

from __future__ import annotations

import math

import numpy as np
from netgen import occ

from .common import (AXISYMMETRIC, PLANE, SOLID3D, MeshBundle, cells_for, chord_limit,
                     curved_face, graded_nodes, identify_layers, layered_mesh, require_below,
                     require_curve_order, require_int, require_nonnegative,
                     require_positive, revolve, tensor_mesh_2d, to_ngsolve)

GEL, FILM_INNER, FILM_OUTER = "gel", "film_inner", "film_outer"
INNER, OUTER = "inner", "outer"
INTERFACE_INNER, INTERFACE_OUTER = "interface_inner", "interface_outer"
BASE, HEAD = "base", "head"


class _Wall:
    """Validated radii and the radial layers (film, gel, film) that are present."""

    def __init__(self, Ri: float, Ro: float, tfi: float, tfo: float, maxh: float,
                 film_layers: int, wall_layers: int | None) -> None:
        self.Ri = require_positive("Ri", Ri)
        self.Ro = require_positive("Ro", Ro)
        require_below("Ri", Ri, "Ro", Ro)
        self.tfi = require_below("tfi", require_nonnegative("tfi", tfi), "Ri", Ri)
        self.tfo = require_nonnegative("tfo", tfo)
        require_below("tfi + tfo", tfi + tfo, "the wall thickness Ro - Ri", Ro - Ri)
        self.maxh = require_positive("maxh", maxh)
        self.film_layers = require_int("film_layers", film_layers, 1)
        self.wall_layers = None if wall_layers is None else require_int("wall_layers",
                                                                        wall_layers, 1)
        # (inner radius, outer radius, region, inner surface name, outer surface name)
        self.layers: list[tuple[float, float, str, str, str]] = []
        if self.tfi > 0:
            self.layers.append((Ri - tfi, Ri, FILM_INNER, INNER, INTERFACE_INNER))
        self.layers.append((Ri, Ro, GEL, INTERFACE_INNER if self.tfi > 0 else INNER,
                            INTERFACE_OUTER if self.tfo > 0 else OUTER))
        if self.tfo > 0:
            self.layers.append((Ro, Ro + tfo, FILM_OUTER, INTERFACE_OUTER, OUTER))
        self.r_in, self.r_out = self.layers[0][0], self.layers[-1][1]

    @property
    def regions(self) -> tuple[str, ...]:
        return tuple(layer[2] for layer in self.layers)

    @property
    def surfaces(self) -> tuple[str, ...]:
        """Names of the cylindrical surfaces from the inside out."""
        return (self.layers[0][3],) + tuple(layer[4] for layer in self.layers)

    def chord(self, radius: float) -> float:
        """Longest chord on the circle of ``radius`` next to the thinnest cell."""
        r_nodes, _, _ = self.radial_nodes()
        return chord_limit(radius, float(np.diff(r_nodes).min()))

    def radial_nodes(self) -> tuple[np.ndarray, list[str], dict[int, str]]:
        """Radial nodes, the region of each radial cell and the interface node indices."""
        nodes, cell_regions, interfaces = [np.array([self.r_in])], [], {}
        h_film = {INTERFACE_INNER: self.tfi / self.film_layers,
                  INTERFACE_OUTER: self.tfo / self.film_layers}
        for a, b, region, name_in, name_out in self.layers:
            if region != GEL:
                r = np.linspace(a, b, self.film_layers + 1)
            elif self.wall_layers is not None:
                r = np.linspace(a, b, self.wall_layers + 1)
            else:
                r = graded_nodes(a, b, h=self.maxh, h_a=h_film.get(name_in),
                                 h_b=h_film.get(name_out))
            if name_in != INNER:
                interfaces[sum(len(n) for n in nodes) - 1] = name_in
            nodes.append(r[1:])
            cell_regions += [region] * (len(r) - 1)
        return np.concatenate(nodes), cell_regions, interfaces

    def areas(self) -> dict[str, float]:
        return {region: math.pi * (b**2 - a**2) for a, b, region, _, _ in self.layers}

    def params(self, **extra) -> dict:
        return dict(Ri=self.Ri, Ro=self.Ro, tfi=self.tfi, tfo=self.tfo, maxh=self.maxh,
                    film_layers=self.film_layers, wall_layers=self.wall_layers, **extra)


def tube_plane(*, Ri: float, Ro: float, maxh: float, tfi: float = 0.0, tfo: float = 0.0,
               film_layers: int = 2, wall_layers: int | None = None,
               n_theta: int | None = None, quad: bool = False,
               curve_order: int = 2) -> MeshBundle:
    """Plane-strain annulus with optional bonded films, structured in (r, theta).

    ``n_theta`` cells around (default: arc length ``<= maxh`` on the outermost circle,
    at least enough that curved edges stay clear of the straight internal lines, see
    :func:`geometries.common.chord_limit`; a smaller ``n_theta`` is a ValueError);
    quads or triangles.  ``0 < Ri < Ro``, ``0 <= tfi < Ri``, ``tfo >= 0``,
    ``tfi + tfo < Ro - Ri``.  Regions ``"gel"`` (+ ``"film_inner"``,
    ``"film_outer"``); boundaries ``"inner"``, ``"outer"`` (+ ``"interface_inner"``,
    ``"interface_outer"``).  The circles are exact to ``curve_order``.
    """
    wall = _Wall(Ri, Ro, tfi, tfo, maxh, film_layers, wall_layers)
    curve_order = require_curve_order(curve_order)
    # equal angles: the outermost circle has the longest chords for its curvature
    n_min = cells_for(2 * math.pi * wall.r_out, wall.chord(wall.r_out), minimum=8)
    n_theta = (max(n_min, cells_for(2 * math.pi * wall.r_out, wall.maxh)) if n_theta is None
               else require_int("n_theta", n_theta, n_min))
    disks = []
    for a, b, region, name_in, name_out in wall.layers:
        rings = []
        for radius, name in ((a, name_in), (b, name_out)):
            disk = occ.WorkPlane().Circle(0, 0, radius).Face()
            disk.edges.name = name
            rings.append(disk)
        ring = rings[1] - rings[0]
        ring.faces.name = region
        disks.append(ring)
    geometry = occ.OCCGeometry(occ.Glue(disks), dim=2)
    r_nodes, cell_regions, interfaces = wall.radial_nodes()
    ngmesh = tensor_mesh_2d(
        r_nodes, np.linspace(0.0, 2 * math.pi, n_theta + 1),
        mapping=lambda r, th: (r * math.cos(th), r * math.sin(th)),
        region=lambda i, j: cell_regions[i], sides={"s_min": INNER, "s_max": OUTER},
        interfaces=interfaces, periodic_t=True, quad=quad, geometry=geometry)
    areas = wall.areas()
    return MeshBundle(mesh=to_ngsolve(ngmesh, curve_order), geometry=geometry, model=PLANE,
                      exact_measure=sum(areas.values()),
                      params=wall.params(n_theta=n_theta, quad=quad,
                                         curve_order=curve_order),
                      boundaries=wall.surfaces, regions=wall.regions,
                      region_measures=areas)


def tube_section(*, Ri: float, Ro: float, Hz: float, maxh: float, tfi: float = 0.0,
                 tfo: float = 0.0, film_layers: int = 2, wall_layers: int | None = None,
                 quad: bool = False) -> MeshBundle:
    """Axisymmetric r-z section (x = r, y = z) of a tube of height ``Hz``, structured.

    Radial cells as in :func:`tube_plane`, axial cells of height ``<= maxh``.
    ``exact_measure`` is the section area, ``exact_volume`` the tube's volume.  Regions
    ``"gel"`` (+ films); boundaries ``"inner"``, ``"outer"``, ``"base"``, ``"head"``
    (+ interfaces).
    """
    wall = _Wall(Ri, Ro, tfi, tfo, maxh, film_layers, wall_layers)
    Hz = require_positive("Hz", Hz)
    r_nodes, cell_regions, interfaces = wall.radial_nodes()
    ngmesh = tensor_mesh_2d(
        r_nodes, np.linspace(0.0, Hz, cells_for(Hz, wall.maxh) + 1),
        mapping=lambda r, z: (r, z), region=lambda i, j: cell_regions[i],
        sides={"s_min": INNER, "s_max": OUTER, "t_min": BASE, "t_max": HEAD},
        interfaces=interfaces, quad=quad)
    areas = {region: (b - a) * Hz for a, b, region, _, _ in wall.layers}
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=None, model=AXISYMMETRIC,
                      exact_measure=sum(areas.values()),
                      exact_volume=sum(wall.areas().values()) * Hz,
                      params=wall.params(Hz=Hz, quad=quad),
                      boundaries=wall.surfaces + (BASE, HEAD), regions=wall.regions,
                      region_measures=areas)


def tube_solid(*, Ri: float, Ro: float, Hz: float, maxh: float, tfi: float = 0.0,
               tfo: float = 0.0, film_layers: int = 2, wall_layers: int = 2,
               curve_order: int = 2) -> MeshBundle:
    """3D tube of height ``Hz`` made of prism layers through the wall and films.

    Triangles on the cylinders have size ``maxh``, capped at the chord limit of
    :func:`geometries.common.chord_limit` for the thinnest cell.

    Regions ``"gel"`` (+ films); boundaries ``"inner"``, ``"outer"``, ``"base"``,
    ``"head"`` (+ interfaces).  ``mesh.ne == (wall_layers + film_layers * number of
    films) * (triangles on "outer")``.
    """
    wall = _Wall(Ri, Ro, tfi, tfo, maxh, film_layers, wall_layers)
    Hz = require_positive("Hz", Hz)
    curve_order = require_curve_order(curve_order)
    solids, layers = [], {}
    for a, b, region, name_in, name_out in wall.layers:
        solid = revolve(curved_face([
            (BASE, [(a, 0.0), (b, 0.0)]), (name_out, [(b, 0.0), (b, Hz)]),
            (HEAD, [(b, Hz), (a, Hz)]), (name_in, [(a, Hz), (a, 0.0)])], region=region))
        solid.mat(region)
        # radial scaling in x, y only: a general affine map, not a similarity
        identify_layers(solid, [(name_out, name_in)], name=region,
                        trafo=occ.gp_GTrsf([a / b, 0, 0, 0, a / b, 0, 0, 0, 1]))
        layers[region] = wall.film_layers if region != GEL else wall.wall_layers
        solids.append(solid)
    geometry, ngmesh = layered_mesh(occ.Glue(solids), maxh=min(wall.maxh, wall.chord(wall.r_in)),
                                    layers=layers)
    volumes = {region: area * Hz for region, area in wall.areas().items()}
    volume = sum(volumes.values())
    return MeshBundle(mesh=to_ngsolve(ngmesh, curve_order), geometry=geometry,
                      model=SOLID3D, exact_measure=volume, exact_volume=volume,
                      params=wall.params(Hz=Hz, curve_order=curve_order),
                      boundaries=wall.surfaces + (BASE, HEAD), regions=wall.regions,
                      region_measures=volumes)
