"""Model dimensions: how a displacement field on a mesh becomes a 3x3 deformation gradient.

Every kinematics gives the full 3x3 ``F' = dx/dX`` from the reference (the mesh) and the volume
weight of the mesh measure, so one energy formula serves a 3D solid, a plane-strain section, an
axisymmetric r–z section and a spherically symmetric radial line.

Generalized plane strain (a long body with free ends: uniform axial stretch, zero axial force)
has one global unknown besides the displacement, the axial strain ``e`` (``F_zz = 1 + e``
relative to the reference). Kinematics with ``axial_unknown = True`` take it as
``deformation_gradient(u, axial=e)``; the problem adds it to its space (``ngs.NumberSpace``) and
minimising the energy per unit reference length over it makes the net axial force vanish.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import ngsolve as ngs

__all__ = ["Kinematics", "Solid3D", "PlaneStrain", "GeneralizedPlaneStrain", "Axisymmetric", "SphericalSymmetric",
           "PolarPlaneStrain", "PolarGeneralizedPlaneStrain", "kinematics_by_name"]


@dataclass(frozen=True)
class Kinematics:
    """Base: ``mesh_dim`` is the dimension of the mesh it runs on, ``components`` names the
    displacement components in order."""

    name = "base"
    mesh_dim = 0
    components: tuple[str, ...] = ()
    axial_unknown = False  # True: deformation_gradient(u, axial=e) with one global axial strain e

    def deformation_gradient(self, u) -> ngs.CoefficientFunction:  # pragma: no cover - interface
        raise NotImplementedError

    def volume_weight(self) -> ngs.CoefficientFunction:
        """Factor turning the mesh measure into reference volume."""
        return ngs.CF(1.0)

    def check_mesh(self, mesh: ngs.Mesh) -> None:
        if mesh.dim != self.mesh_dim:
            raise ValueError(f"kinematics {self.name!r} needs a mesh of dimension {self.mesh_dim}, "
                             f"got mesh.dim = {mesh.dim}")

    def component_index(self, component: str) -> int:
        try:
            return self.components.index(component)
        except ValueError:
            raise ValueError(f"component must be one of {self.components} for {self.name!r}, "
                             f"got {component!r}") from None


def _embed(entries) -> ngs.CoefficientFunction:
    return ngs.CF(tuple(entries), dims=(3, 3))


@dataclass(frozen=True)
class Solid3D(Kinematics):
    name = "solid3d"
    mesh_dim = 3
    components: tuple[str, ...] = ("x", "y", "z")

    def deformation_gradient(self, u):
        return ngs.Id(3) + ngs.Grad(u)


@dataclass(frozen=True)
class PlaneStrain(Kinematics):
    """Section in the x–y plane; the out-of-plane stretch stays at its reference value: each
    region's ``lam0`` from the dry state (1 with a dry reference, e.g. a layer bonded dry)."""

    name = "plane"
    mesh_dim = 2
    components: tuple[str, ...] = ("x", "y")

    def deformation_gradient(self, u):
        G = ngs.Grad(u)
        return _embed((1 + G[0, 0], G[0, 1], 0, G[1, 0], 1 + G[1, 1], 0, 0, 0, 1))


@dataclass(frozen=True)
class Axisymmetric(Kinematics):
    """r–z section with ``x = r >= 0``, ``y = z``; torsionless. The hoop stretch is
    ``1 + u_r / r``; the axis (r = 0) needs ``u_r = 0`` there as a boundary condition."""

    name = "axisymmetric"
    mesh_dim = 2
    components: tuple[str, ...] = ("r", "z")

    def deformation_gradient(self, u):
        G = ngs.Grad(u)
        return _embed((1 + G[0, 0], G[0, 1], 0, G[1, 0], 1 + G[1, 1], 0, 0, 0, 1 + u[0] / ngs.x))

    def volume_weight(self):
        return 2 * math.pi * ngs.x


@dataclass(frozen=True)
class SphericalSymmetric(Kinematics):
    """Radial line ``x = r > 0`` of a spherically symmetric body: a 1D reference model for
    shells and spheres (``F = diag(1 + u', 1 + u/r, 1 + u/r)``)."""

    name = "spherical"
    mesh_dim = 1
    components: tuple[str, ...] = ("r",)

    def deformation_gradient(self, u):
        # a scalar space carries the one radial component
        hoop = 1 + u / ngs.x
        return _embed((1 + ngs.Grad(u)[0], 0, 0, 0, hoop, 0, 0, 0, hoop))

    def volume_weight(self):
        return 4 * math.pi * ngs.x**2


@dataclass(frozen=True)
class PolarPlaneStrain(Kinematics):
    """Radial line ``x = r > 0`` of an axisymmetric plane-strain body (a long tube whose axial
    stretch stays at its reference value): ``F = diag(1 + u', 1 + u/r, 1)``. The 1D reference
    model for the pre-buckling state of tubes and annuli in plane strain."""

    name = "polar_plane"
    mesh_dim = 1
    components: tuple[str, ...] = ("r",)

    def deformation_gradient(self, u):
        return _embed((1 + ngs.Grad(u)[0], 0, 0, 0, 1 + u / ngs.x, 0, 0, 0, 1))

    def volume_weight(self):
        return 2 * math.pi * ngs.x


def _axial_stretch(axial, kinematics: Kinematics) -> ngs.CoefficientFunction:
    if axial is None:
        raise ValueError(f"kinematics {kinematics.name!r} needs the axial strain: deformation_gradient(u, axial=e)")
    return 1 + axial


@dataclass(frozen=True)
class GeneralizedPlaneStrain(PlaneStrain):
    """Section in the x–y plane of a long body with free ends: the out-of-plane stretch
    ``1 + e`` is uniform and one global unknown, fixed by zero net axial force (the energy per
    unit reference length is minimal over it)."""

    name = "generalized_plane"
    axial_unknown = True

    def deformation_gradient(self, u, axial=None):
        G = ngs.Grad(u)
        return _embed((1 + G[0, 0], G[0, 1], 0, G[1, 0], 1 + G[1, 1], 0, 0, 0, _axial_stretch(axial, self)))


@dataclass(frozen=True)
class PolarGeneralizedPlaneStrain(PolarPlaneStrain):
    """Radial line of an axisymmetric tube with free ends: ``F = diag(1 + u', 1 + u/r, 1 + e)``
    with one global axial strain ``e`` (zero net axial force), the 1D reference model of
    :class:`GeneralizedPlaneStrain` for axisymmetric states."""

    name = "polar_generalized_plane"
    axial_unknown = True

    def deformation_gradient(self, u, axial=None):
        return _embed((1 + ngs.Grad(u)[0], 0, 0, 0, 1 + u / ngs.x, 0, 0, 0, _axial_stretch(axial, self)))


_BY_NAME = {k.name: k for k in (Solid3D, PlaneStrain, GeneralizedPlaneStrain, Axisymmetric, SphericalSymmetric,
                                PolarPlaneStrain, PolarGeneralizedPlaneStrain)}


def kinematics_by_name(name: str) -> Kinematics:
    try:
        return _BY_NAME[name]()
    except KeyError:
        raise ValueError(f"kinematics must be one of {sorted(_BY_NAME)}, got {name!r}") from None
