"""Surface energy of the gel-solvent interface (elastocapillarity).

A free surface with surface energy ``gamma`` (per unit *current* area, isotropic, independent
of the strain: a liquid-like surface tension) adds

    E_s = gamma * int |F' t| dS'        (plane strain: deformed length per reference length)
    E_s = gamma * int J' |F'^-T N| dA'  (3D: deformed area per reference area, Nanson)

to the free energy. Its first variation is the Young-Laplace condition: the traction on the
surface is ``sigma n = -gamma kappa n`` (curvature ``kappa``, > 0 for a convex body), i.e. a
pressure ``gamma / R`` on a surface of radius ``R`` in plane strain. It introduces the
elastocapillary length ``gamma / G``: wrinkles and crease tips shorter than it are suppressed
(Kang & Huang, Soft Matter 6, 5736, 2010; Chen, Cai & Suo, Soft Matter 8, 1258, 2012), which
is what makes crease nucleation mesh independent once the surface elements are well below it.

Units: energies per volume are in ``kT/v``, lengths in the scene length ``L``, so ``gamma`` is
in ``kT L / v``; ``gamma / (G L)`` is the dimensionless elastocapillary number.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import ngsolve as ngs

__all__ = ["surface_tension"]


def surface_tension(gamma: float) -> Callable:
    """Density ``u -> gamma * (deformed / reference surface measure)`` for
    ``GelBody.add_surface_energy``, for plane strain (``u`` with 2 components, ``|F' t|``) and
    3D (``J' |F'^-T N|``). Not for axisymmetric problems (the hoop stretch is missing)."""
    if not (isinstance(gamma, (int, float)) and math.isfinite(gamma) and gamma >= 0):
        raise ValueError(f"gamma must be a finite number >= 0, got {gamma!r}")

    def density(u):
        dim = u.dim
        if dim == 2:
            t = ngs.specialcf.tangential(2)
            Ft = t + ngs.Grad(u.Trace()) * t
            return gamma * ngs.sqrt(ngs.InnerProduct(Ft, Ft))
        if dim == 3:
            n = ngs.specialcf.normal(3)
            F = ngs.Id(3) + ngs.Grad(u.Trace())
            cof = ngs.Cof(F)
            m = cof * n
            return gamma * ngs.sqrt(ngs.InnerProduct(m, m))
        raise ValueError(f"surface_tension needs a displacement with 2 or 3 components, got {dim}")

    return density
