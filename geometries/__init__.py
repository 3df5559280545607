"""Netgen/NGSolve geometries for the ngsgel scenes (MODEL.md section 5).

Every builder takes keyword-only, dimensionless parameters, validates them before
meshing (ValueError naming the parameter and its allowed range) and returns a
:class:`MeshBundle` (mesh, geometry, model, exact measure, parameters, and the names of
its regions and boundaries).  Models: ``"solid3d"``, ``"plane"`` (plane strain),
``"axisymmetric"`` (r-z section, x = r >= 0, y = z, symmetry axis ``"axis"``),
``"surface"`` (mid-surface for shells) and ``"spherical"`` (the radial line x = r of a
spherically symmetric body).  This package depends only on netgen, ngsolve
and numpy; ``ngsgel`` uses it, not the other way round.
"""

from .basic import ball_octant, ball_section, block, disk, rectangle
from .caps import cap_midsurface, cap_section, cap_solid
from .common import (AXISYMMETRIC, PLANE, SOLID3D, SPHERICAL, SURFACE, MeshBundle, aspect_bound,
                     aspect_ratios)
from .fields import axial_grading, axial_grading_np, radial_grading, radial_grading_np
from .layers import layer_plane, layer_solid
from .plates import plate_midsurface, plate_section, plate_solid
from .spheres import sphere_octant, sphere_radial, sphere_section
from .tubes import tube_plane, tube_section, tube_solid

__all__ = [
    "MeshBundle", "SOLID3D", "PLANE", "AXISYMMETRIC", "SURFACE", "SPHERICAL",
    "aspect_ratios", "aspect_bound",
    "rectangle", "block", "disk", "ball_octant", "ball_section",
    "cap_solid", "cap_section", "cap_midsurface",
    "tube_plane", "tube_section", "tube_solid",
    "plate_solid", "plate_section", "plate_midsurface",
    "layer_plane", "layer_solid",
    "sphere_octant", "sphere_section", "sphere_radial",
    "radial_grading", "axial_grading", "radial_grading_np", "axial_grading_np",
]
