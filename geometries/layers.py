"""Thick gel layers bonded to a rigid substrate (creasing, MODEL.md scene E).

Geometry
--------
Plane strain: ``[0, width] x [0, thickness]``; 3D: ``[0, width] x [0, depth] x
[0, thickness]``.  The bonded face is at the bottom, the free (immersed) face on top.
An optional surface imperfection ``w`` moves the top to ``thickness + w`` and scales
each vertical line in proportion, so the bottom stays flat:

* ``wavelength`` only: ``w = amplitude cos(2 pi x / wavelength)`` (3D: times
  ``cos(2 pi y / wavelength)``);
* ``wavelength`` and ``seed``: a random sum of Fourier modes that fit the width (and
  depth) a whole number of times, with wavelengths ``>= wavelength``, scaled so that
  ``max |w| = amplitude``; reproducible from ``seed``;
* ``wavelength``, ``seed`` and ``mirror=True``: the same with the modes
  ``cos(pi m x / width)`` (3D: times ``cos(pi n y / depth)``), wavelengths ``2 width / m
  >= wavelength``: zero slope at the sides, so the cell is the half period between two
  mirror planes of a pattern that is symmetric about them.

The imperfection is applied to the mesh nodes, so the mesh carries its piecewise
linear interpolant (error ``~ amplitude (h / wavelength)^2``); the geometry object is
the flat layer and the mesh is detached from it, so do not ``Curve`` or ``Refine`` an
imperfect mesh.  ``exact_measure`` includes the exact integral of ``w``.

Names
-----
region ``"gel"``; boundaries ``"bottom"`` (bonded), ``"top"`` (free/immersed),
``"left"``/``"right"`` (x = 0 / width), and in 3D ``"front"``/``"back"``
(y = 0 / depth).

Mesh size: ``maxh`` in the bulk, ``top_maxh`` on the top boundary, graded between them
by Netgen's ``grading``; unstructured triangles (or quad-dominated) / tetrahedra.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from netgen import occ

from .basic import (BACK, BLOCK_BOUNDARIES, BOTTOM, FRONT, GEL, LEFT, RECTANGLE_BOUNDARIES,
                    RIGHT, TOP, named_box, rectangle_face)
from .common import (PLANE, SOLID3D, MeshBundle, generate, require_below,
                     require_positive, to_ngsolve)

# the boundary names are basic's, re-exported here for scenes
__all__ = ["layer_plane", "layer_solid", "GEL", "BOTTOM", "TOP", "LEFT", "RIGHT", "FRONT",
           "BACK"]

Profile = Callable[..., np.ndarray]


def _imperfection(amplitude: float, wavelength: float | None, seed: int | None,
                  lengths: tuple[float, ...], mirror: bool = False) -> tuple[Profile | None, float]:
    """Surface profile ``w(*coords)`` (None if flat) and its exact integral."""
    if mirror and seed is None:
        raise ValueError("mirror=True needs a seed (it selects the random mirror-symmetric modes)")
    if amplitude == 0.0:
        return None, 0.0
    if wavelength is None:
        raise ValueError("wavelength must be given (> 0) when amplitude != 0")
    wavelength = require_positive("wavelength", wavelength)
    if seed is None:
        k = 2 * math.pi / wavelength

        def cosine(*coords: np.ndarray) -> np.ndarray:
            return amplitude * np.prod([np.cos(k * c) for c in coords], axis=0)

        integral = amplitude * math.prod(math.sin(k * length) / k for length in lengths)
        return cosine, integral
    # a mode m_i along side L_i has wavelength L_i / m_i (periodic) or 2 L_i / m_i (mirror)
    periods = [2 * length if mirror else length for length in lengths]
    require_below("wavelength", wavelength, "twice the smallest side" if mirror else "the smallest side",
                  min(periods), inclusive=True)
    # every mode fits a whole number of (half) periods, so each integrates to zero
    counts = [int(period / wavelength) for period in periods]
    modes = [m for m in np.ndindex(*(c + 1 for c in counts))
             if any(m) and math.hypot(*(mi / pi for mi, pi in zip(m, periods)))
             <= 1 / wavelength + 1e-12]
    rng = np.random.default_rng(seed)
    weights = rng.standard_normal(len(modes))
    phases = np.zeros((len(modes), len(lengths))) if mirror else \
        rng.uniform(0, 2 * math.pi, (len(modes), len(lengths)))

    def raw(*coords: np.ndarray) -> np.ndarray:
        total = 0.0
        for m, a, ph in zip(modes, weights, phases):
            total = total + a * np.prod([np.cos(2 * math.pi * mi * c / pi + p)
                                         for mi, c, pi, p in zip(m, coords, periods, ph)],
                                        axis=0)
        return total

    grid = np.meshgrid(*(np.linspace(0, length, 401) for length in lengths), indexing="ij")
    scale = amplitude / np.abs(raw(*grid)).max()
    return (lambda *coords: scale * raw(*coords)), 0.0


def _top_size(thickness: float, maxh: float, top_maxh: float | None,
              amplitude: float) -> float:
    """Validate the common parameters; the element size wanted on the top."""
    require_positive("thickness", thickness)
    require_positive("maxh", maxh)
    if not (isinstance(amplitude, (int, float)) and math.isfinite(amplitude)):
        raise ValueError(f"amplitude must be a finite number, got {amplitude!r}")
    require_below("|amplitude|", abs(amplitude), "thickness", thickness)
    return maxh if top_maxh is None else min(maxh, require_positive("top_maxh", top_maxh))


def _apply(ngmesh, profile: Profile | None, thickness: float, dim: int) -> None:
    """Move the nodes by the imperfection, each vertical line stretched uniformly."""
    if profile is None:
        return
    ngmesh.SetGeometry(None)  # the flat geometry would pull curved or refined nodes back
    vertical = dim - 1
    for p in ngmesh.Points():
        coords = [np.array(p[i]) for i in range(vertical)]
        p[vertical] = p[vertical] * (1.0 + float(profile(*coords)) / thickness)


def layer_plane(*, width: float, thickness: float, maxh: float,
                top_maxh: float | None = None, grading: float = 0.3,
                amplitude: float = 0.0, wavelength: float | None = None,
                seed: int | None = None, mirror: bool = False, quad: bool = False,
                corner_maxh: float | None = None, corner_length: float | None = None) -> MeshBundle:
    """Plane-strain layer ``[0, width] x [0, thickness]`` on a substrate at y = 0.

    ``|amplitude| < thickness``; ``wavelength > 0`` is needed when ``amplitude != 0``
    (and ``<= width`` with a ``seed``, ``<= 2 width`` with ``mirror``).  Region ``"gel"``; boundaries ``"bottom"``,
    ``"top"``, ``"left"``, ``"right"``.

    ``corner_maxh`` with ``corner_length``: a finer size on the part ``x < corner_length``
    of the top (the top is split there into two edges, both named ``"top"``), graded into
    the bulk: resolves a feature at the top-left corner, e.g. the tip of a crease on the
    mirror line x = 0, without refining the whole surface.
    """
    width = require_positive("width", width)
    top_h = _top_size(thickness, maxh, top_maxh, amplitude)
    profile, integral = _imperfection(amplitude, wavelength, seed, (width,), mirror)
    if (corner_maxh is None) != (corner_length is None):
        raise ValueError("corner_maxh and corner_length go together, got "
                         f"corner_maxh={corner_maxh!r}, corner_length={corner_length!r}")
    if corner_maxh is None:
        face = rectangle_face(0.0, 0.0, width, thickness)
        face.edges.Max(occ.Y).maxh = top_h
    else:
        require_positive("corner_maxh", corner_maxh)
        require_below("corner_length", require_positive("corner_length", corner_length), "width", width)
        face = rectangle_face(0.0, 0.0, width, thickness, top_split=corner_length)
        for edge in face.edges:
            if edge.name == TOP:
                edge.maxh = min(top_h, corner_maxh) if edge.center.x < corner_length else top_h
    geometry = occ.OCCGeometry(face, dim=2)
    ngmesh = generate(geometry, maxh=maxh, grading=grading, quad_dominated=quad)
    _apply(ngmesh, profile, thickness, 2)
    area = width * thickness + integral
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=geometry, model=PLANE,
                      exact_measure=area,
                      params=dict(width=width, thickness=thickness, maxh=maxh,
                                  top_maxh=top_maxh, grading=grading, amplitude=amplitude,
                                  wavelength=wavelength, seed=seed, mirror=mirror, quad=quad,
                                  corner_maxh=corner_maxh, corner_length=corner_length),
                      boundaries=RECTANGLE_BOUNDARIES, regions=(GEL,),
                      region_measures={GEL: area})


def layer_solid(*, width: float, depth: float, thickness: float, maxh: float,
                top_maxh: float | None = None, grading: float = 0.3,
                amplitude: float = 0.0, wavelength: float | None = None,
                seed: int | None = None, mirror: bool = False) -> MeshBundle:
    """3D layer ``[0, width] x [0, depth] x [0, thickness]`` on a substrate at z = 0.

    Parameters as in :func:`layer_plane` (``wavelength <= min(width, depth)`` with a
    ``seed``, ``<= 2 min(width, depth)`` with ``mirror``).  Region ``"gel"``; boundaries ``"bottom"``, ``"top"``, ``"left"``,
    ``"right"``, ``"front"``, ``"back"``.
    """
    width = require_positive("width", width)
    depth = require_positive("depth", depth)
    top_h = _top_size(thickness, maxh, top_maxh, amplitude)
    profile, integral = _imperfection(amplitude, wavelength, seed, (width, depth), mirror)
    box = named_box((0.0, 0.0, 0.0), (width, depth, thickness))
    box.faces.Max(occ.Z).maxh = top_h
    geometry = occ.OCCGeometry(box)
    ngmesh = generate(geometry, maxh=maxh, grading=grading)
    _apply(ngmesh, profile, thickness, 3)
    volume = width * depth * thickness + integral
    return MeshBundle(mesh=to_ngsolve(ngmesh, 1), geometry=geometry, model=SOLID3D,
                      exact_measure=volume, exact_volume=volume,
                      params=dict(width=width, depth=depth, thickness=thickness, maxh=maxh,
                                  top_maxh=top_maxh, grading=grading, amplitude=amplitude,
                                  wavelength=wavelength, seed=seed, mirror=mirror),
                      boundaries=BLOCK_BOUNDARIES, regions=(GEL,),
                      region_measures={GEL: volume})
