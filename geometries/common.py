"""Shared pieces of the geometry builders: the result type, parameter checks and the
structured (tensor-product) mesh generators used wherever a thin layer needs a fixed
number of elements across it.

Conventions used by every builder
---------------------------------
* 2D meshes lie in the x-y plane.  Axisymmetric r-z sections use ``x = r >= 0`` and
  ``y = z``; the boundary on the symmetry axis is always named ``"axis"``.
* Boundary normals (``ngsolve.specialcf.normal``) point out of the meshed body.
* Names are plain strings exported as module constants by each builder module, so
  scenes never guess them.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import netgen.meshing as nm
import ngsolve
import numpy as np
from netgen import occ

SOLID3D = "solid3d"
PLANE = "plane"
AXISYMMETRIC = "axisymmetric"
SURFACE = "surface"
SPHERICAL = "spherical"  # the radial line x = r of a spherically symmetric body
MODELS = (SOLID3D, PLANE, AXISYMMETRIC, SURFACE, SPHERICAL)


@dataclass(frozen=True)
class MeshBundle:
    """A mesh together with what a scene needs to know about it.

    ``exact_measure`` is the exact measure of the idealised geometry in the model's own
    sense: volume for ``"solid3d"``, area for ``"plane"`` and ``"surface"``, the
    area of the r-z section for ``"axisymmetric"`` and the length of the radial line for
    ``"spherical"``.  ``exact_volume`` is the volume of
    the 3D body the mesh stands for: equal to ``exact_measure`` for ``"solid3d"``,
    ``2 pi int r dA`` (the revolved body) for ``"axisymmetric"``, mid-surface area
    times thickness for a ``"surface"`` (shell) mesh, the shell or ball for ``"spherical"``,
    and ``None`` for ``"plane"``
    (per unit depth the volume equals the area).  ``region_measures`` gives the exact
    measure of each region in the same sense as ``exact_measure``.

    ``regions`` and ``boundaries`` list every name the builder guarantees to exist and
    be non-empty; use :meth:`region` and :meth:`boundary` to get them.  In a
    ``"surface"`` mesh (a 2D manifold in 3D) the regions are NGSolve *boundary*
    regions (``mesh.Boundaries``) and the boundary curves are ``mesh.BBoundaries``.
    """

    mesh: ngsolve.Mesh
    geometry: Any
    model: str
    exact_measure: float
    params: dict[str, Any]
    exact_volume: float | None = None
    boundaries: tuple[str, ...] = ()
    regions: tuple[str, ...] = ()
    region_measures: dict[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.model not in MODELS:
            raise ValueError(f"model must be one of {MODELS}, got {self.model!r}")

    def region(self, name: str) -> ngsolve.Region:
        """The named top-dimensional region (a boundary region for ``"surface"``)."""
        if self.model == SURFACE:
            return self.mesh.Boundaries(name)
        return self.mesh.Materials(name)

    def boundary(self, name: str) -> ngsolve.Region:
        """The named codimension-1 boundary (a curve, BBND, for ``"surface"``)."""
        if self.model == SURFACE:
            return self.mesh.BBoundaries(name)
        return self.mesh.Boundaries(name)


# ---------------------------------------------------------------------------
# parameter checks: raise before any meshing, naming the parameter and its range
# ---------------------------------------------------------------------------

def require_positive(name: str, value: float) -> float:
    """``value > 0`` (and finite), else ValueError naming ``name``."""
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
        raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
    return float(value)


def require_nonnegative(name: str, value: float) -> float:
    """``value >= 0`` (and finite), else ValueError naming ``name``."""
    if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
        raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
    return float(value)


def require_below(name: str, value: float, bound_text: str, bound: float,
                  *, inclusive: bool = False) -> float:
    """``value < bound`` (``<=`` if inclusive), else ValueError naming both."""
    ok = value <= bound if inclusive else value < bound
    if not ok:
        op = "<=" if inclusive else "<"
        raise ValueError(f"{name} must be {op} {bound_text} = {bound:g}, got {value!r}")
    return float(value)


def require_int(name: str, value: int, minimum: int) -> int:
    """Integer ``>= minimum``, else ValueError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{name} must be an integer >= {minimum}, got {value!r}")
    return value


def require_curve_order(curve_order: int) -> int:
    """``curve_order`` is an integer >= 1 (1: straight elements)."""
    return require_int("curve_order", curve_order, 1)


def cells_for(length: float, maxh: float, minimum: int = 1) -> int:
    """Number of equal cells of size <= maxh covering ``length``."""
    return max(minimum, math.ceil(length / maxh - 1e-9))


def chord_limit(radius: float, cell: float) -> float:
    """Longest chord on a wall of curvature ``radius`` next to cells ``cell`` thick.

    ``mesh.Curve`` bends only the element faces that lie on the geometry; the internal
    lines of a layered mesh stay straight.  Once the sagitta ``chord^2 / (8 radius)``
    of a curved face nears the cell thickness, the face crosses the straight lines
    (diagonals of split quads first) and thin elements fold over.  Keeping the sagitta
    below a quarter of the cell avoids that.
    """
    return math.sqrt(2.0 * radius * cell)


def to_ngsolve(ngmesh: nm.Mesh, curve_order: int) -> ngsolve.Mesh:
    """Wrap a Netgen mesh and curve it to ``curve_order`` (1 leaves it straight)."""
    mesh = ngsolve.Mesh(ngmesh)
    if curve_order > 1:
        mesh.Curve(curve_order)
    return mesh


def generate(geometry: occ.OCCGeometry, *, maxh: float, **options: Any) -> nm.Mesh:
    """Netgen mesh of an OCC geometry (``options`` are Netgen meshing parameters).

    Netgen's parallel surface meshing busy-waits on its worker threads; our meshes
    are small, and on a loaded machine (tests, sweeps running side by side) the
    serial mesher is several times faster.
    """
    return geometry.GenerateMesh(maxh=maxh, parallel_meshing=False, **options)


def edge_numbers(geometry: Any) -> dict[str, int]:
    """Netgen edge number of each named edge of an OCC geometry.

    Structured meshes made here are attached to an OCC geometry so that
    ``mesh.Curve`` can project onto its edges; the boundary name is the key, so each
    name must label exactly one geometric edge.
    """
    numbers: dict[str, int] = {}
    for i, edge in enumerate(geometry.edges, start=1):
        if edge.name is None:
            continue
        if edge.name in numbers:
            raise RuntimeError(f"geometry edge name {edge.name!r} is not unique")
        numbers[edge.name] = i
    return numbers


Side = str | Callable[[int], str]


def tensor_mesh_2d(s: Sequence[float], t: Sequence[float], *,
                   mapping: Callable[[float, float], tuple[float, float]],
                   region: Callable[[int, int], str],
                   sides: Mapping[str, Side],
                   interfaces: Mapping[int, str] | None = None,
                   periodic_t: bool = False,
                   quad: bool = True,
                   geometry: Any = None) -> nm.Mesh:
    """Structured 2D mesh of the image of the box ``s x t`` under ``mapping``.

    ``s`` and ``t`` are increasing node coordinates.  ``region(i, j)`` names cell
    ``[s_i, s_i+1] x [t_j, t_j+1]``.  ``sides`` maps ``"s_min"``, ``"s_max"``,
    ``"t_min"``, ``"t_max"`` to a boundary name, or to a function of the cell index
    along that side (to split a side into several named boundaries); with
    ``periodic_t`` the last t node is identified with the first, so the t sides are
    ignored.  ``interfaces`` names internal lines ``s = s[i]`` (kept as boundary
    segments so they can be curved and integrated over).  Quads, or each quad split
    into two triangles.  With an OCC ``geometry`` the segments are linked to its
    equally named edges, so ``Curve`` puts them on the exact curves.
    """
    ns, nt = len(s) - 1, len(t) - 1
    interfaces = dict(interfaces or {})
    ngmesh = nm.Mesh(dim=2)
    if geometry is not None:
        ngmesh.SetGeometry(geometry)
    n_t_nodes = nt if periodic_t else nt + 1
    pid = {}
    for i, si in enumerate(s):
        for j in range(n_t_nodes):
            x, y = mapping(si, t[j])
            pid[i, j] = ngmesh.Add(nm.MeshPoint(nm.Pnt(x, y, 0.0)))

    def node(i: int, j: int):
        return pid[i, j % nt] if periodic_t else pid[i, j]

    # Netgen wants counter-clockwise elements; an orientation-reversing mapping
    # (e.g. polar angle measured from the axis) flips every cell the same way.
    (x0, y0), (x1, y1), (x2, y2) = (mapping(s[0], t[0]), mapping(s[1], t[0]),
                                    mapping(s[0], t[1]))
    flip = (x1 - x0) * (y2 - y0) - (y1 - y0) * (x2 - x0) < 0

    region_index: dict[str, int] = {}
    for i in range(ns):
        for j in range(nt):
            name = region(i, j)
            if name not in region_index:
                region_index[name] = ngmesh.AddRegion(name, dim=2)
            corners = [node(i, j), node(i + 1, j), node(i + 1, j + 1), node(i, j + 1)]
            if flip:
                corners.reverse()
            cells = [corners] if quad else [corners[:3], [corners[0], corners[2], corners[3]]]
            for c in cells:
                ngmesh.Add(nm.Element2D(region_index[name], c))

    numbers = edge_numbers(geometry) if geometry is not None else {}
    descriptors: dict[tuple[str, int, int], int] = {}

    def add_segment(name: str, a, b, left: int, right: int) -> None:
        # the cell on the segment's left is 'domin'; Netgen and NGSolve take the
        # outward normal from that orientation
        if flip:
            a, b, left, right = b, a, right, left
        key = (name, left, right)
        if key not in descriptors:
            ed = nm.EdgeDescriptor()
            ed.name = name
            if geometry is None:
                ed.edgenr = len(descriptors) + 1
            elif name in numbers:
                ed.edgenr = numbers[name]
            else:
                raise RuntimeError(f"boundary {name!r} has no geometry edge of that name")
            ed.domin, ed.domout = left, right
            descriptors[key] = ngmesh.Add(ed)
        ngmesh.Add(nm.Element1D([a, b], index=descriptors[key]))

    def side_name(key: str, k: int) -> str:
        side = sides[key]
        return side if isinstance(side, str) else side(k)

    def dom(i: int, j: int) -> int:
        return region_index[region(i, j % nt if periodic_t else j)]

    for j in range(nt):
        add_segment(side_name("s_min", j), node(0, j + 1), node(0, j), dom(0, j), 0)
        add_segment(side_name("s_max", j), node(ns, j), node(ns, j + 1), dom(ns - 1, j), 0)
        for i, name in interfaces.items():
            add_segment(name, node(i, j), node(i, j + 1), dom(i - 1, j), dom(i, j))
    if not periodic_t:
        for i in range(ns):
            add_segment(side_name("t_min", i), node(i, 0), node(i + 1, 0), dom(i, 0), 0)
            add_segment(side_name("t_max", i), node(i + 1, nt), node(i, nt),
                        dom(i, nt - 1), 0)
    return ngmesh


def extrude(base: nm.Mesh, levels: Sequence[float], *,
            lift: Callable[[float, float, float], tuple[float, float, float]],
            bottom: str, top: str) -> nm.Mesh:
    """Structured 3D mesh: a 2D Netgen mesh stacked in ``len(levels) - 1`` layers.

    Node ``(x, y)`` of ``base`` at level ``s`` goes to ``lift(x, y, s)``; ``levels``
    are increasing and ``lift`` must keep each column's orientation (``s`` up means
    away from the base face).  Triangles give prisms, quads hexahedra.  The faces at
    the first and last level are named ``bottom`` and ``top``; each lateral face takes
    the name of the base boundary segment it is swept from, and each element the region
    of its base element.
    """
    nl = len(levels) - 1
    mesh3 = nm.Mesh(dim=3)
    pid: list[list[Any]] = []
    for p in base.Points():
        x, y, _ = p.p
        pid.append([mesh3.Add(nm.MeshPoint(nm.Pnt(*lift(x, y, lev)))) for lev in levels])

    def column(v) -> list[Any]:
        return pid[v.nr - 1]

    materials: dict[str, int] = {}
    for el in base.Elements2D():
        name = base.GetMaterial(el.index)
        if name not in materials:
            materials[name] = len(materials) + 1
            mesh3.SetMaterial(materials[name], name)
    face_index: dict[tuple[str, int], int] = {}

    def face(name: str, domain: int) -> int:
        if (name, domain) not in face_index:
            bc = len(face_index) + 1
            face_index[name, domain] = mesh3.Add(
                nm.FaceDescriptor(surfnr=bc, domin=domain, domout=0, bc=bc))
            mesh3.SetBCName(bc - 1, name)
        return face_index[name, domain]

    for el in base.Elements2D():
        dom = materials[base.GetMaterial(el.index)]
        cols = [column(v) for v in el.vertices]
        # Netgen's prisms/hexes list the bottom face so that its right-hand normal
        # points away from the top face: reverse the (counter-clockwise) base cell
        down = list(reversed(cols))
        for k in range(nl):
            mesh3.Add(nm.Element3D(dom, [c[k] for c in down] + [c[k + 1] for c in down]))
        mesh3.Add(nm.Element2D(face(bottom, dom), [c[0] for c in down]))
        mesh3.Add(nm.Element2D(face(top, dom), [c[nl] for c in cols]))
    for seg in base.Elements1D():
        ed = base.EdgeDescriptor(seg.index)
        if ed.domin > 0 and ed.domout > 0:
            raise ValueError(f"extrude: internal line {ed.name!r} in the base mesh is not "
                             "supported")
        a, b = (column(v) for v in seg.vertices)
        dom = materials[base.GetMaterial(max(ed.domin, ed.domout))]
        for k in range(nl):
            # the body lies left of a->b when it is 'domin': then this quad's
            # right-hand normal points out of it
            quad = [a[k], b[k], b[k + 1], a[k + 1]]
            mesh3.Add(nm.Element2D(face(ed.name, dom), quad if ed.domin > 0 else quad[::-1]))
    return mesh3


def graded_nodes(a: float, b: float, *, h: float, h_a: float | None = None,
                 h_b: float | None = None, growth: float = 1.2) -> np.ndarray:
    """Increasing nodes from ``a`` to ``b`` with spacing ``h`` away from the ends.

    Near ``a`` (``b``) the spacing starts at ``h_a`` (``h_b``) and grows by about the
    factor ``growth`` per cell until it reaches ``h``: nodes are equidistributed for the
    size function ``min(h, h_a + (growth - 1) |x - a|, h_b + (growth - 1) |x - b|)``.
    """
    sizes = [h] + [s for s in (h_a, h_b) if s is not None]
    x = np.linspace(a, b, max(2001, int(20 * (b - a) / min(sizes)) + 1))
    size = np.full_like(x, h)
    if h_a is not None:
        size = np.minimum(size, h_a + (growth - 1.0) * (x - a))
    if h_b is not None:
        size = np.minimum(size, h_b + (growth - 1.0) * (b - x))
    density = 1.0 / size
    phi = np.concatenate([[0.0], np.cumsum(0.5 * (density[1:] + density[:-1]) * np.diff(x))])
    n = max(1, math.ceil(phi[-1] - 1e-9))
    nodes = np.interp(np.linspace(0.0, phi[-1], n + 1), phi, x)
    nodes[0], nodes[-1] = a, b
    return nodes


# Netgen's triangles exceed maxh a little (grading, curved faces); 2 leaves a margin.
ASPECT_FACTOR = 2.0


def aspect_bound(maxh: float, layer_thicknesses: Sequence[float]) -> float:
    """Documented bound on :func:`aspect_ratios` of a layered mesh.

    ``ASPECT_FACTOR * max(maxh, thickest layer cell) / thinnest layer cell``, where a
    layer cell is a layer's thickness divided by its number of element layers.
    """
    return ASPECT_FACTOR * max(maxh, *layer_thicknesses) / min(layer_thicknesses)


def aspect_ratios(mesh: ngsolve.Mesh) -> np.ndarray:
    """Longest over shortest straight edge of every volume element.

    This is the measure the layered builders bound in their docstrings; for a layered
    thin body it is about (in-plane element size) / (layer thickness).
    """
    coords = np.array([v.point for v in mesh.vertices])
    ratios = np.empty(mesh.ne)
    for k, el in enumerate(mesh.Elements(ngsolve.VOL)):
        ends = np.array([[v.nr for v in mesh[e].vertices] for e in el.edges])
        lengths = np.linalg.norm(coords[ends[:, 0]] - coords[ends[:, 1]], axis=1)
        ratios[k] = lengths.max() / lengths.min()
    return ratios


Point2 = tuple[float, float]


def curved_face(pieces: Sequence[tuple[str, Sequence[Point2]]], *, region: str) -> occ.Face:
    """Planar OCC face bounded by consecutive named pieces, in the x-y plane.

    A piece with two points is a segment, with three an arc through the middle point.
    Each boundary edge of the face is named after its piece.
    """
    edges, ends = [], []
    for _, pts in pieces:
        p = [occ.Pnt(x, y, 0.0) for x, y in pts]
        edges.append(occ.Segment(p[0], p[1]) if len(p) == 2 else occ.ArcOfCircle(*p))
        ends.append((np.array(pts[0]), np.array(pts[-1])))
    face = occ.Face(occ.Wire(edges))
    face.name = region
    # OCC rebuilds the edges when it makes the wire, dropping their names: name the
    # face's edges by matching end points instead
    scale = max(np.abs(np.array([p for _, pts in pieces for p in pts])).max(), 1.0)
    for edge in face.edges:
        s = np.array([edge.start.x, edge.start.y])
        e = np.array([edge.end.x, edge.end.y])
        for (name, _), (p, q) in zip(pieces, ends):
            if min(np.linalg.norm(s - p) + np.linalg.norm(e - q),
                   np.linalg.norm(s - q) + np.linalg.norm(e - p)) < 1e-9 * scale:
                edge.name = name
    return face


def revolve(section: occ.Face, angle: float = 360.0) -> occ.TopoDS_Shape:
    """Solid of revolution about the z axis of an r-z section drawn with x = r, y = z, swept
    by ``angle`` degrees from the plane y = 0 towards +y (180: the half y >= 0).

    Each face of the solid carries the name of the section edge that sweeps it.
    """
    upright = section.Rotate(occ.Axis((0, 0, 0), occ.X), 90)
    return upright.Revolve(occ.Axis((0, 0, 0), occ.Z), angle)


def named_face(shape: occ.TopoDS_Shape, name: str) -> occ.Face:
    """The single face of ``shape`` named ``name``."""
    found = [f for f in shape.faces if f.name == name]
    if len(found) != 1:
        raise RuntimeError(f"expected one face named {name!r}, found {len(found)}")
    return found[0]


def identify_layers(shape: occ.TopoDS_Shape, pairs: Sequence[tuple[str, str]], *,
                    name: str, trafo: Any) -> None:
    """Mark face pairs of a thin solid as close surfaces, meshed by prisms.

    ``trafo`` maps the first face of each pair onto the second.  Netgen copies the
    surface mesh of one face to the other and fills the gap with one prism layer;
    :func:`layered_mesh` then splits it into the requested number of layers.
    """
    for first, second in pairs:
        named_face(shape, first).Identify(named_face(shape, second), name,
                                          nm.IdentificationType.CLOSESURFACES, trafo)


def layered_mesh(shape: occ.TopoDS_Shape, *, maxh: float,
                 layers: Mapping[str, int]) -> tuple[occ.OCCGeometry, nm.Mesh]:
    """Mesh a solid whose close-surface identifications are keys of ``layers``.

    Each identification gets ``layers[name]`` equally thick prism layers.
    """
    geometry = occ.OCCGeometry(shape)
    ngmesh = generate(geometry, maxh=maxh)
    for name, n in layers.items():
        if n > 1:
            ngmesh.ZRefine(name, [k / n for k in range(1, n)])
    return geometry, ngmesh
