"""Mirror-symmetric wedges of the graded disk (ngsgel/scenes/plate_wedges.py, issue 39 item 2b)."""

import csv
import math
import xml.etree.ElementTree as ET

import numpy as np
import ngsolve as ngs
import pytest

from geometries.plates import plate_sector_midsurface, sector_copy_map
from ngsgel import FloryRehnerGel
from ngsgel.output import RunDirectory
from ngsgel.scenes.plate_wedges import (check_wave, fold, full_plate, reflect_displacement, relax_wedge, run,
                                        wedge_plate)
from ngsgel.scenes.shell_cases import GEL, GRADED_MU0
from ngsgel.stability import free_matrix, negative_count


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


@pytest.mark.parametrize("k", [1, 2, 4, 5])
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


def test_the_stretch_load_gives_the_states_of_mu_at_the_softer_gels_free_swelling_stretch():
    """The wedge loaded by the softer gel's free-swelling stretch s is the wedge at mu(s): at the
    stretch of mu = -0.6 both shells reach the same equilibrium (energy, deflection-free swelling)."""
    by_mu, _ = wedge_plate(2.0, 5, maxh=0.3, order=2, load="mu")
    by_stretch, _ = wedge_plate(2.0, 5, maxh=0.3, order=2, load="stretch")
    assert by_stretch.load is not by_stretch.mu and by_mu.load is by_mu.mu
    by_mu.mu.Set(-0.6)
    by_stretch.load.Set(by_stretch.load_at(-0.6))
    assert by_stretch.load.Get() > 1.0  # a stretch, not mu
    assert abs(by_stretch.mu_value() + 0.6) < 1e-12
    by_mu.solve()
    by_stretch.solve()
    assert abs(by_stretch.energy() - by_mu.energy()) < 1e-10 * abs(by_mu.energy())
    difference = by_stretch.state.FV().NumPy() - by_mu.state.FV().NumPy()
    assert np.max(np.abs(difference)) < 1e-9 * np.max(np.abs(by_mu.state.FV().NumPy()))


def test_the_half_disk_wedge_holds_its_rigid_motions_and_swells_flat():
    """k = 1 is the half disk mirrored about y = 0 with two more pins: its flat swelling is a
    regular equilibrium (no free rigid motion) that stays flat (the pins take no load)."""
    shell, mesh = wedge_plate(0.75, 1, maxh=0.3, order=2)
    assert set(mesh.GetBBoundaries()) >= {"sym", "sym_end"}
    shell.mu.Set(-0.8)
    shell.solve()
    w = shell.displacement.components[0].vec.FV().NumPy()
    z = shell.displacement[2]
    assert max(abs(z(mesh(x, y, 0.0, ngs.BND))) for x, y in ((0.5, 0.3), (-0.7, 0.2), (0.9, 0.1))) < 1e-10
    assert np.max(np.abs(w)) > 1e-3  # it swelled in plane


def test_a_load_that_is_not_mu_or_the_stretch_is_rejected():
    with pytest.raises(ValueError, match="load must be one of"):
        wedge_plate(2.0, 5, maxh=0.3, order=2, load="mismatch")


@pytest.mark.slow  # 16 min on the shared machine (one thread)
def test_the_relaxation_path_leaves_the_flat_wedge_where_it_buckles_and_ends_on_a_stable_k_fold_state(tmp_path):
    """Load steps in mu (0.1 kT) from the flat k = 5 wedge at mu = -0.3: the flat state is stable
    below its onset, so the first steps are Newton's; past the onset (mu ~ -0.29 on the full
    disk at h = 0.2) Newton's equilibrium is the unstable flat one or none, and the flow relaxes to
    a buckled state. At mu = 0 the end state must be stable on the wedge, carry the wedge's wave
    number on the rim, and lie below the flat wedge's energy there."""
    shell, mesh = wedge_plate(2.0, 5, maxh=0.3, order=2, load="mu")
    run_dir = RunDirectory(tmp_path / "relax")
    path = relax_wedge(shell, mesh, 5, run_dir=run_dir, mu_start=-0.35, step=0.1)
    assert shell.mu_value() == 0.0
    assert path["snaps"], "the flat wedge must lose stability before mu = 0"
    with ngs.TaskManager():
        assert negative_count(free_matrix(shell.tangent(shell.state), shell.free_mask)) == 0
    assert path["rim_end"]["rim_k"] % 5 == 0
    assert path["rim_end"]["rim_amplitude"] > shell.thickness
    flat, _ = wedge_plate(2.0, 5, maxh=0.3, order=2, load="mu")
    for mu in (-0.35, -0.2, -0.1, -0.03, -0.01, 0.0):
        flat.mu.Set(mu)
        flat.solve()
    assert path["energy_wedge"] < flat.energy()


def _vtu_point_arrays(path) -> dict[str, np.ndarray]:
    """The points ("Points") and point fields of an NGSolve ``.vtu`` (raw appended data, each
    array preceded by its byte count as UInt32), one row per point."""
    raw = path.read_bytes()
    head, marker, appended = raw.partition(b"<AppendedData")
    assert marker, f"{path} has no appended data"
    data = appended[appended.index(b"_") + 1:]
    root = ET.fromstring(head + b"</VTKFile>")
    assert root.get("header_type", "UInt32") == "UInt32"
    arrays = {}
    for array in root.iter("DataArray"):
        if array.get("type") != "Float64":
            continue
        offset = int(array.get("offset"))
        size = int(np.frombuffer(data, dtype="<u4", count=1, offset=offset)[0])
        values = np.frombuffer(data, dtype="<f8", count=size // 8, offset=offset + 4)
        arrays[array.get("Name")] = values.reshape(-1, int(array.get("NumberOfComponents", "1")))
    return arrays


def test_the_scene_writes_a_vtk_step_per_path_row_and_the_end_state_swollen_freely_on_the_full_disk(tmp_path):
    """The scene on a uniform gel (n0 = nR: no mismatch, so the wedge swells flat to mu = 0 without a
    snap; k = 4 on base sectors of pi/4, h = 0.5, order 2): the wedge's series has one step per
    row of the path's CSV; the end state on the full disk (the .vtu) covers all 2k images of the
    wedge, is the saved state_k4.npz, and is the free swelling of the uniform gel from the
    reference (the stiff gel at GRADED_MU0) to mu = 0: u = (lam_free(0) / lam0 - 1) x, flat."""
    out = tmp_path
    summary = run(str(out), p=1.0, ks=(4,), maxh=0.5, order=2, n0=1e-3, nR=1e-3, base_sectors=4, load="mu",
                  step=0.3)
    with open(out / "path_k4.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    steps = ET.parse(out / "wedge_k4.pvd").getroot().findall("Collection/DataSet")
    assert len(steps) == len(rows) > 2
    assert all((out / step.get("file")).is_file() for step in steps)
    assert float(rows[-1]["mu"]) == 0.0
    gel = FloryRehnerGel(Nv=1e-3, chi=GEL.chi)
    swelling = gel.lam_free(0.0) / gel.lam_free(GRADED_MU0) - 1.0
    assert swelling > 0.1

    end = _vtu_point_arrays(out / steps[-1].get("file"))
    full = _vtu_point_arrays(out / "full_k4.vtu")
    assert {"displacement", "thickness_stretch", "Nv", "lowest_mode"} <= set(full)
    assert np.allclose(full["Nv"], 1e-3, rtol=1e-12)
    points = full["Points"]
    blocks, _ = fold(points, 4)
    assert set(blocks) == set(range(8))
    # radial, linear in r (exact in the elements), no deflection; Newton's displacement tolerance: 1e-8 t
    for arrays in (end, full):
        u, x = arrays["displacement"], arrays["Points"]
        assert np.max(np.abs(u[:, :2] - swelling * x[:, :2])) < 1e-10 * swelling
        assert np.max(np.abs(u[:, 2])) < 1e-10 * swelling

    saved = np.load(out / "state_k4.npz")
    assert float(saved["mu"]) == 0.0
    shell, mesh, _ = full_plate(1.0, maxh=0.5, order=2, n0=1e-3, nR=1e-3, base_sectors=4)
    shell.restore_state(saved["state"])
    rim = np.flatnonzero(np.abs(np.hypot(points[:, 0], points[:, 1]) - 1.0) < 1e-12)
    assert rim.size >= 8
    written = full["displacement"][rim]
    state = np.array([shell.displacement(mesh(*x, ngs.BND)) for x in points[rim]])
    assert np.max(np.abs(written - state)) < 1e-12 * swelling
    assert summary["table"][0]["negative_full"] == 0
    assert (out / "plate_wedges.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
