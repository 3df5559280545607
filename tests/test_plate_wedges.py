"""Mirror-symmetric wedges of the graded disk (ngsgel/scenes/plate_wedges.py, issue 39 item 2b)."""

import math

import numpy as np
import ngsolve as ngs
import pytest

from geometries.plates import plate_sector_midsurface, sector_copy_map
from ngsgel.scenes.plate_wedges import check_wave, fold, reflect_displacement, wedge_plate


def _equivariant_field(k: int) -> ngs.CoefficientFunction:
    """A displacement invariant under the dihedral group of the k-fold wedge: the in-plane part
    the gradient of an invariant scalar (normal to no mirror), the deflection invariant."""
    x, y = ngs.x, ngs.y
    invariant = sum(math.comb(k, j) * x**(k - j) * y**j * ((1j)**j).real for j in range(k + 1))  # Re (x + iy)^k
    r2 = x * x + y * y
    return ngs.CF((invariant.Diff(x) * r2 + invariant * 2 * x, invariant.Diff(y) * r2 + invariant * 2 * y,
                   invariant + r2 * r2))


def _with_mirror_conditions(u: ngs.GridFunction, mesh: ngs.Mesh, k: int) -> None:
    """Remove the normal part of the coefficients on both mirror edges (the shell's conditions)."""
    space = u.space.components[0]
    ux, uy = (u.components[i].vec.FV().NumPy() for i in range(2))
    for name, angle in (("sym", 0.0), ("sym_end", math.pi / k)):
        dofs = sorted({d for el in mesh.Elements(ngs.BBND) if el.mat == name for d in space.GetDofNrs(el)})
        tangential = ux[dofs] * math.cos(angle) + uy[dofs] * math.sin(angle)
        ux[dofs], uy[dofs] = tangential * math.cos(angle), tangential * math.sin(angle)
    centre = space.GetDofNrs(mesh.vertices[int(np.argmin([np.hypot(*v.point[:2]) for v in mesh.vertices]))])[0]
    ux[centre] = uy[centre] = 0.0  # on both planes


@pytest.mark.parametrize("k", [2, 4, 5])
def test_a_wedge_displacement_reflected_onto_the_disk_is_its_mirror_image_everywhere(k):
    wedge = plate_sector_midsurface(angle=math.pi / 20, copies=20 // k, maxh=0.3, curve_order=3).mesh
    disk = plate_sector_midsurface(angle=math.pi / 20, copies=40, maxh=0.3, curve_order=3).mesh
    u = ngs.GridFunction(ngs.VectorH1(wedge, order=3))
    u.Set(_equivariant_field(k), definedon=wedge.Boundaries(".*"))
    _with_mirror_conditions(u, wedge, k)
    image = ngs.GridFunction(ngs.VectorH1(disk, order=3))
    reflect_displacement(u, wedge, image, disk, k)
    rng = np.random.default_rng(1)
    points = rng.uniform(-1, 1, (600, 2))
    points = np.column_stack([points[np.hypot(*points.T) < 0.99], np.zeros(np.count_nonzero(np.hypot(*points.T) < 0.99))])
    blocks, folded = fold(points, k)
    assert set(blocks) == set(range(2 * k))
    error = max(np.max(np.abs(np.array(image(disk(*p, ngs.BND)))
                              - sector_copy_map(math.pi / k, int(b)) @ np.array(u(wedge(*q, ngs.BND)))))
                for p, q, b in zip(points, folded, blocks))
    scale = max(np.max(np.abs(np.array(u(wedge(*q, ngs.BND))))) for q in folded)
    assert error < 1e-12 * scale


def test_sector_copies_close_the_disk_with_every_normal_up_and_the_exact_area():
    disk = plate_sector_midsurface(angle=math.pi / 20, copies=40, maxh=0.3, curve_order=3)
    mesh = disk.mesh
    assert set(mesh.GetBBoundaries()) == {"rim"}
    assert abs(ngs.Integrate(1, mesh, ngs.BND) - math.pi) < 1e-4  # order-3 rim: ~h^4
    normals = ngs.Integrate(ngs.specialcf.normal(3)[2], mesh, ngs.BND, element_wise=True)
    assert min(normals) > 0
    points = np.array([v.point for v in mesh.vertices])
    for angle in (0.0, math.pi / 4, math.pi / 5):  # mirror lines of the k = 4 and k = 5 wedges
        mirrored = points @ sector_copy_map(angle, 1).T  # the reflection across the line at angle
        distance = np.min(np.linalg.norm(mirrored[:, None, :] - points[None, :, :], axis=2), axis=1)
        assert distance.max() < 1e-12


def test_the_slanted_mirror_holds_the_normal_displacement_of_the_swollen_flat_wedge():
    """Uniform-ish in-plane swelling of the flat graded wedge at mu = -0.5: the in-plane
    displacement is radial by symmetry, so its normal part on the slanted mirror must vanish (the
    penalty's residue ~ strain h / 1e6) while the tangential part does not."""
    shell, mesh = wedge_plate(2.0, 5, maxh=0.3, order=2)
    shell.mu.Set(-0.5)
    shell.solve()
    u = shell.displacement
    normal = ngs.CF((-math.sin(math.pi / 5), math.cos(math.pi / 5), 0))
    edge = mesh.BBoundaries("sym_end")
    normal_part = math.sqrt(ngs.Integrate((u * normal)**2, mesh, ngs.BBND, definedon=edge))
    radial = math.sqrt(ngs.Integrate(u * u, mesh, ngs.BBND, definedon=edge))
    assert radial > 1e-3
    assert normal_part < 1e-6 * radial


def test_wave_numbers_must_divide_the_base_sectors():
    with pytest.raises(ValueError, match="k must be"):
        check_wave(3, 20)
    with pytest.raises(ValueError, match="copies"):
        plate_sector_midsurface(angle=math.pi / 20, copies=41, maxh=0.3)
