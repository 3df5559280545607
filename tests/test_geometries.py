"""Tests of the geometries package: measures, names, layers, aspect ratios, graded
fields and parameter checks.  Coarse meshes only: the whole file runs in seconds."""

from __future__ import annotations

import math

import numpy as np
import ngsolve as ng
import pytest

import geometries as g
from geometries.common import aspect_bound, aspect_ratios

# --- builders with curved geometry: (name, factory taking curve_order) --------------
CURVED = {
    "disk": lambda k: g.disk(radius=1.0, maxh=0.4, curve_order=k),
    "ball_octant": lambda k: g.ball_octant(maxh=0.25, curve_order=k),
    "ball_section": lambda k: g.ball_section(radius=2.0, maxh=0.3, curve_order=k),
    "cap_solid": lambda k: g.cap_solid(H=0.3, t=0.02, maxh=0.15, layers=1, curve_order=k),
    "cap_section": lambda k: g.cap_section(H=0.3, t=0.02, maxh=0.15, curve_order=k),
    "cap_midsurface": lambda k: g.cap_midsurface(H=0.3, t=0.02, maxh=0.15, curve_order=k),
    "plate_solid": lambda k: g.plate_solid(t=0.05, maxh=0.25, layers=1, curve_order=k),
    "plate_midsurface": lambda k: g.plate_midsurface(maxh=0.25, curve_order=k),
    "tube_plane": lambda k: g.tube_plane(Ri=1.0, Ro=2.0, tfi=0.02, tfo=0.02, maxh=0.25,
                                         curve_order=k),
    "tube_solid": lambda k: g.tube_solid(Ri=1.0, Ro=1.2, Hz=0.4, tfo=0.05, maxh=0.3,
                                         film_layers=1, wall_layers=1, curve_order=k),
    "sphere_octant": lambda k: g.sphere_octant(inner=0.5, outer=1.0, maxh=0.2, curve_order=k),
}

# --- every builder with coarse parameters --------------------------------------------
ALL = {
    "rectangle": lambda: g.rectangle(width=2.0, height=1.0, maxh=0.4),
    "rectangle_structured": lambda: g.rectangle(width=2.0, height=1.0, maxh=0.4,
                                                origin=(1.0, -1.0), structured=True),
    "rectangle_quads": lambda: g.rectangle(width=2.0, height=1.0, maxh=0.4,
                                           structured=True, quad=True),
    "block": lambda: g.block(lx=1.0, ly=0.5, lz=0.25, maxh=0.3),
    "block_hexes": lambda: g.block(lx=1.0, ly=0.5, lz=0.25, maxh=0.3, structured=True),
    "block_prisms": lambda: g.block(lx=1.0, ly=0.5, lz=0.25, maxh=0.3, structured=True,
                                    hexes=False),
    "plate_section": lambda: g.plate_section(t=0.05, maxh=0.25, layers=2),
    "tube_section": lambda: g.tube_section(Ri=1.0, Ro=1.5, Hz=1.0, tfi=0.02, tfo=0.02,
                                           maxh=0.25, quad=True),
    "tube_solid_plain": lambda: g.tube_solid(Ri=1.0, Ro=1.1, Hz=0.5, maxh=0.3),
    "layer_plane": lambda: g.layer_plane(width=2.0, thickness=1.0, maxh=0.3, top_maxh=0.1),
    "layer_solid": lambda: g.layer_solid(width=1.0, depth=0.5, thickness=0.5, maxh=0.3),
    # its straight edges' errors on the inner and outer arcs cancel in the area: its curved
    # measures are tested on the arcs (test_sphere_arcs_converge_with_curve_order)
    "sphere_section": lambda: g.sphere_section(inner=0.5, outer=1.0, maxh=0.1),
    "sphere_radial": lambda: g.sphere_radial(inner=0.5, outer=1.5, maxh=0.3),
    "ball_radial": lambda: g.sphere_radial(outer=1.0, maxh=0.3),
    **{name: (lambda f=f: f(2)) for name, f in CURVED.items()},
}


@pytest.fixture(scope="module")
def bundles() -> dict[str, g.MeshBundle]:
    return {name: make() for name, make in ALL.items()}


def measure(b: g.MeshBundle, region: str | None = None) -> float:
    names = [region] if region else b.regions
    return sum(ng.Integrate(1, b.mesh, definedon=b.region(n)) for n in names)


def revolved_volume(b: g.MeshBundle) -> float:
    return 2 * math.pi * ng.Integrate(ng.x, b.mesh)


# ------------------------------------------------------------------ measures --------

@pytest.mark.parametrize("name", CURVED)
def test_measure_converges_with_curve_order(name):
    b = CURVED[name](1)
    errors = []
    for order in (1, 2, 3):
        b.mesh.Curve(order)
        errors.append(abs(measure(b) / b.exact_measure - 1))
    assert errors[0] < 3e-2
    assert errors[1] < 0.1 * errors[0]
    assert errors[2] < errors[1]
    assert errors[2] < 5e-5
    for region, exact in b.region_measures.items():
        assert measure(b, region) == pytest.approx(exact, rel=1e-3)


@pytest.mark.parametrize("name", ["rectangle", "rectangle_structured", "rectangle_quads",
                                  "block", "block_hexes", "block_prisms", "plate_section",
                                  "tube_section", "layer_plane", "layer_solid", "sphere_radial",
                                  "ball_radial"])
def test_straight_measure_exact(bundles, name):
    b = bundles[name]
    assert measure(b) == pytest.approx(b.exact_measure, rel=1e-12)
    for region, exact in b.region_measures.items():
        assert measure(b, region) == pytest.approx(exact, rel=1e-12)


@pytest.mark.parametrize("name", ["cap_section", "plate_section", "tube_section", "ball_section", "sphere_section"])
def test_axisymmetric_volume(bundles, name):
    b = bundles[name]
    assert b.model == g.AXISYMMETRIC
    assert b.exact_volume == pytest.approx(revolved_volume(b), rel=1e-5)
    xs = [v.point[0] for v in b.mesh.vertices]
    assert min(xs) >= 0.0


# ------------------------------------------------------------------ names -----------

@pytest.mark.parametrize("name", ALL)
def test_named_regions_and_boundaries_non_empty(bundles, name):
    b = bundles[name]
    assert b.regions and b.boundaries
    for region in b.regions:
        assert measure(b, region) > 0, region
    for boundary in b.boundaries:
        assert ng.Integrate(1, b.mesh, definedon=b.boundary(boundary)) > 0, boundary
    if b.model != g.SURFACE:
        # no unnamed leftovers: the documented names are all there is
        assert set(b.mesh.GetMaterials()) == set(b.regions)
        assert set(b.mesh.GetBoundaries()) == set(b.boundaries)
    if b.model == g.AXISYMMETRIC and name != "tube_section":
        assert "axis" in b.boundaries
        axis = ng.Integrate(ng.x * ng.x, b.mesh, definedon=b.boundary("axis"))
        assert axis == pytest.approx(0.0, abs=1e-20)


# 1D meshes left out: NGSolve's normal on a point boundary is +1 at either end
@pytest.mark.parametrize("name", [n for n in ALL if not n.endswith(("midsurface", "radial"))])
def test_normals_point_outward(bundles, name):
    """Divergence theorem: int_dOmega x.n = dim |Omega| over the outer boundaries."""
    b = bundles[name]
    dim = b.mesh.dim
    x = ng.CoefficientFunction((ng.x, ng.y, ng.z)[:dim])
    outer = [n for n in b.boundaries if not n.startswith("interface")]
    flux = sum(ng.Integrate(x * ng.specialcf.normal(dim), b.mesh, definedon=b.boundary(n))
               for n in outer)
    # curved elements are integrated, not exact: the theorem holds to quadrature error
    assert flux == pytest.approx(dim * measure(b), rel=1e-4)


def test_tube_interface_normals_point_outward(bundles):
    b = bundles["tube_plane"]
    er = ng.CoefficientFunction((ng.x, ng.y)) / ng.sqrt(ng.x**2 + ng.y**2)
    for name, radius in (("interface_inner", 1.0), ("interface_outer", 2.0),
                         ("outer", 2.02), ("inner", 0.98)):
        flux = ng.Integrate(er * ng.specialcf.normal(2), b.mesh, definedon=b.boundary(name))
        sign = -1 if name == "inner" else 1
        assert flux == pytest.approx(sign * 2 * math.pi * radius, rel=1e-5)


# ------------------------------------------------------------------ thin layers -----

def surface_elements(mesh: ng.Mesh, names: tuple[str, ...]) -> int:
    return sum(1 for el in mesh.Elements(ng.BND) if el.mat in names)


@pytest.mark.parametrize("layers", [1, 2])
def test_cap_solid_layers_and_aspect(layers):
    t, maxh = 0.0091, 0.15
    b = g.cap_solid(H=0.3, t=t, maxh=maxh, layers=layers, curve_order=1)
    assert {el.type for el in b.mesh.Elements()} == {ng.ET.PRISM}
    assert b.mesh.ne == layers * surface_elements(b.mesh, ("outer", "apex"))
    assert aspect_ratios(b.mesh).max() <= aspect_bound(maxh, [t / layers])


def test_cap_solid_layers_are_equally_thick_spheres():
    b = g.cap_solid(H=0.3, t=0.02, maxh=0.2, layers=3, curve_order=1)
    r, zc = b.params["r"], b.params["H"] - b.params["r"]
    rho = np.array([math.dist(v.point, (0, 0, zc)) for v in b.mesh.vertices])
    levels = np.unique(np.round((rho - (r - 0.01)) / 0.02 * 3, 6))
    np.testing.assert_allclose(levels, [0, 1, 2, 3], atol=1e-6)


def test_cap_section_layers():
    b = g.cap_section(H=0.3, t=0.02, maxh=0.1, layers=3, quad=True)
    zc = b.params["H"] - b.params["r"]
    rho = np.array([math.hypot(v.point[0], v.point[1] - zc) for v in b.mesh.vertices])
    assert len(np.unique(np.round(rho, 9))) == 4
    assert b.mesh.ne % 3 == 0
    assert aspect_ratios(b.mesh).max() <= aspect_bound(0.1, [0.02 / 3])


def test_plate_solid_layers_and_aspect():
    b = g.plate_solid(t=0.02, maxh=0.2, layers=3, curve_order=1)
    assert {el.type for el in b.mesh.Elements()} == {ng.ET.PRISM}
    assert b.mesh.ne == 3 * surface_elements(b.mesh, ("top",))
    z = np.unique(np.round([v.point[2] for v in b.mesh.vertices], 9))
    np.testing.assert_allclose(z, np.linspace(-0.01, 0.01, 4), atol=1e-9)
    assert aspect_ratios(b.mesh).max() <= aspect_bound(0.2, [0.02 / 3])


def test_tube_films_have_requested_layers():
    b = g.tube_plane(Ri=1.0, Ro=2.0, tfi=0.02, tfo=0.02, maxh=0.2, film_layers=3)
    r = np.unique(np.round([math.hypot(*v.point) for v in b.mesh.vertices], 9))
    assert np.sum((r >= 0.98 - 1e-9) & (r <= 1.0 + 1e-9)) == 4
    assert np.sum((r >= 2.0 - 1e-9) & (r <= 2.02 + 1e-9)) == 4
    cells = [0.02 / 3, 0.02 / 3] + list(np.diff(r))
    assert aspect_ratios(b.mesh).max() <= aspect_bound(0.2, cells)


def test_tube_solid_layers():
    b = g.tube_solid(Ri=1.0, Ro=1.2, Hz=0.4, tfi=0.04, tfo=0.05, maxh=0.3, film_layers=2,
                     wall_layers=3, curve_order=1)
    assert {el.type for el in b.mesh.Elements()} == {ng.ET.PRISM}
    assert b.mesh.ne == (3 + 2 + 2) * surface_elements(b.mesh, ("outer",))
    assert aspect_ratios(b.mesh).max() <= aspect_bound(0.3, [0.02, 0.025, 0.2 / 3])


def test_cap_apex_refinement():
    coarse = g.cap_solid(H=0.3, t=0.02, maxh=0.15, apex_radius=0.1, curve_order=1)
    fine = g.cap_solid(H=0.3, t=0.02, maxh=0.15, apex_radius=0.1, apex_maxh=0.02,
                       curve_order=1)
    assert surface_elements(fine.mesh, ("apex",)) > 4 * surface_elements(coarse.mesh,
                                                                         ("apex",))
    section = g.cap_section(H=0.3, t=0.02, maxh=0.15, apex_radius=0.1, apex_maxh=0.02)
    xs = sorted(v.point[0] for v in section.mesh.vertices if v.point[0] < 0.1)
    assert np.diff(np.unique(np.round(xs, 9))).max() <= 0.02 + 1e-9


def test_layer_top_refinement():
    b = g.layer_plane(width=2.0, thickness=1.0, maxh=0.4, top_maxh=0.05)
    plain = g.layer_plane(width=2.0, thickness=1.0, maxh=0.4)
    assert surface_elements(b.mesh, ("top",)) >= 0.8 * 2.0 / 0.05
    assert surface_elements(plain.mesh, ("top",)) <= 2.0 / 0.4 + 1
    assert surface_elements(b.mesh, ("bottom",)) < surface_elements(b.mesh, ("top",)) / 2


# ------------------------------------------------------------------ imperfections ---

def top_heights(b: g.MeshBundle) -> np.ndarray:
    dim = b.mesh.dim
    heights = {v.nr: v.point for el in b.mesh.Elements(ng.BND) if el.mat == "top"
               for v in (b.mesh[u] for u in el.vertices)}
    return np.array([p[dim - 1] for p in heights.values()])


def test_cosine_imperfection():
    b = g.layer_plane(width=2.0, thickness=1.0, maxh=0.2, top_maxh=0.05, amplitude=0.02,
                      wavelength=0.5)
    z = top_heights(b)
    assert z.max() == pytest.approx(1.02, abs=1e-12)  # x = 0 is a crest and a node
    assert 0.98 <= z.min() < 0.981
    assert measure(b) == pytest.approx(b.exact_measure, rel=1e-5)
    bottom = ng.Integrate(ng.y * ng.y, b.mesh, definedon=b.boundary("bottom"))
    assert bottom == pytest.approx(0.0, abs=1e-24)


def test_random_imperfection_reproducible():
    kw = dict(width=1.0, depth=0.5, thickness=0.5, maxh=0.25, top_maxh=0.08,
              amplitude=0.01, wavelength=0.25)
    a, b = g.layer_solid(seed=7, **kw), g.layer_solid(seed=7, **kw)
    c = g.layer_solid(seed=8, **kw)
    za, zb, zc = top_heights(a), top_heights(b), top_heights(c)
    np.testing.assert_array_equal(za, zb)
    assert not np.allclose(za, zc)
    assert np.abs(za - 0.5).max() <= 0.01 + 1e-12
    assert np.abs(za - 0.5).max() > 0.003
    # nodal interpolation of w: error ~ amplitude (h / wavelength)^2
    assert measure(a) == pytest.approx(a.exact_measure, rel=2e-3)


def test_mirror_random_imperfection_is_symmetric_about_the_sides():
    # mirror=True: a half period between mirror planes, so w(-x) = w(x) and w(W + x) = w(W - x)
    from geometries.layers import _imperfection
    W = 0.6
    profile, integral = _imperfection(0.01, 0.1, 3, (W,), mirror=True)
    x = np.linspace(0.0, 0.05, 11)
    np.testing.assert_allclose(profile(-x), profile(x), atol=1e-15)
    np.testing.assert_allclose(profile(W + x), profile(W - x), atol=1e-15)
    assert np.abs(profile(np.linspace(0, W, 2001))).max() == pytest.approx(0.01, rel=1e-4)
    b = g.layer_plane(width=W, thickness=1.0, maxh=0.2, top_maxh=0.02, amplitude=0.01, wavelength=0.1,
                      seed=3, mirror=True)
    assert integral == 0.0 and measure(b) == pytest.approx(W, rel=1e-4)
    periodic, _ = _imperfection(0.01, 0.1, 3, (W,))
    assert abs(periodic(-x[-1:]) - periodic(x[-1:]))[0] > 1e-4  # random phases: not mirror-symmetric
    with pytest.raises(ValueError, match="mirror=True needs a seed"):
        g.layer_plane(width=W, thickness=1.0, maxh=0.2, amplitude=0.01, wavelength=0.1, mirror=True)


# ------------------------------------------------------------------ shell vs section -

def test_cap_midsurface_and_section_describe_same_shell():
    t = 0.0091
    mid = g.cap_midsurface(H=0.3, t=t, maxh=0.1, curve_order=3)
    section = g.cap_section(H=0.3, t=t, maxh=0.1, curve_order=3)
    solid = g.cap_solid(H=0.3, t=t, maxh=0.15, curve_order=3)
    shell_volume = measure(mid) * t
    assert shell_volume == pytest.approx(mid.exact_volume, rel=1e-5)
    assert revolved_volume(section) == pytest.approx(shell_volume, rel=1e-4)
    assert measure(solid) == pytest.approx(shell_volume, rel=1e-4)
    assert section.exact_volume == pytest.approx(mid.exact_volume, rel=1e-4)


def test_half_cap_midsurface_is_cut_by_the_mirror_plane():
    H, maxh = 0.3, 0.1
    full = g.cap_midsurface(H=H, maxh=maxh, apex_radius=0.05, curve_order=3)
    half = g.cap_midsurface(H=H, maxh=maxh, apex_radius=0.05, curve_order=3, half=True)
    assert measure(half) == pytest.approx(0.5 * measure(full), rel=1e-5)
    assert half.exact_measure == pytest.approx(0.5 * full.exact_measure)
    mesh = half.mesh
    sym = mesh.BBoundaries("sym")
    r = (1 + H * H) / (2 * H)
    # two meridians from the base to the apex, in the plane y = 0
    assert ng.Integrate(ng.CF(1), mesh, ng.BBND, definedon=sym) == pytest.approx(2 * r * math.asin(1 / r), rel=1e-6)
    assert ng.Integrate(ng.y * ng.y, mesh, ng.BBND, definedon=sym) < 1e-20
    assert ng.Integrate(ng.CF(1), mesh, ng.BBND, definedon=mesh.BBoundaries("base")) == pytest.approx(math.pi, rel=1e-6)
    with pytest.raises(ValueError, match="half"):
        g.cap_midsurface(H=H, maxh=maxh, half=1)


# ------------------------------------------------------------------ graded fields ---

P_VALUES = [0.25, 0.75, 2, 10]


@pytest.mark.parametrize("p", P_VALUES)
@pytest.mark.parametrize("n0, n1", [(1e-3, 1e-2), (1e-2, 1e-3)])
def test_graded_fields_endpoints_and_monotone(p, n0, n1):
    s = np.linspace(0.0, 1.0, 1001)
    radial = g.radial_grading_np(n0, n1, p, 1.0, s)
    axial = g.axial_grading_np(n0, n1, p, 2.0, 2 * s + 0.5, z0=0.5)
    for values in (radial, axial):
        assert values[0] == n0 and values[-1] == n1
        steps = np.diff(values) * np.sign(n1 - n0)
        assert steps.min() >= -1e-18 and steps.sum() > 0


def vertex_values(mesh: ng.Mesh, cf: ng.CoefficientFunction) -> list[tuple[tuple, float]]:
    """(point, value) at the element corners, mapped from exact reference points.

    ``mesh(x, y, z)`` inverts the element map only approximately, and ``r^p`` with
    ``p < 1`` magnifies a round-off radius; the corners themselves are exact.
    """
    dim = mesh.dim
    corners = [(0.0,) * dim] + [tuple(float(i == k) for i in range(dim)) for k in range(dim)]
    out = []
    for el in mesh.Elements(ng.VOL):
        trafo = mesh.GetTrafo(el)
        for c in corners:
            mip = trafo(*c)
            out.append((tuple(mip.point), cf(mip)))
    return out


@pytest.mark.parametrize("p", P_VALUES)
def test_graded_coefficient_functions(p):
    n0, nR = 1e-2, 1e-3
    plate = g.plate_section(R=2.0, t=0.1, maxh=0.5, quad=False)
    solid = g.block(lx=1.0, ly=1.0, lz=2.0, maxh=0.5, origin=(-0.5, -0.5, 0.0),
                    structured=True, hexes=False)
    cases = [
        (plate.mesh, g.radial_grading(n0, nR, p, 2.0, model=g.AXISYMMETRIC),
         lambda q: abs(q[0]) / 2.0),
        (plate.mesh, g.axial_grading(n0, nR, p, 0.1, z0=-0.05, model=g.AXISYMMETRIC),
         lambda q: (q[1] + 0.05) / 0.1),
        (solid.mesh, g.radial_grading(n0, nR, p, 0.5), lambda q: math.hypot(q[0], q[1]) / 0.5),
        (solid.mesh, g.axial_grading(n0, nR, p, 2.0), lambda q: q[2] / 2.0),
    ]
    for mesh, cf, scaled in cases:
        values = vertex_values(mesh, cf)
        ends = {0.0: n0, 1.0: nR}
        hits = [(ends[scaled(q)], v) for q, v in values if scaled(q) in ends]
        assert {e for e, _ in hits} == {n0, nR}
        for expected, value in hits:
            assert value == expected
        s = np.array([scaled(q) for q, _ in values])
        v = np.array([val for _, val in values])
        np.testing.assert_allclose(v, g.radial_grading_np(n0, nR, p, 1.0, s), rtol=1e-13)
        order = np.argsort(s)
        assert np.all(np.diff(v[order]) <= 1e-15)


# ------------------------------------------------------------------ bad parameters --

BAD = [
    (g.cap_solid, dict(H=1.2, t=0.01, maxh=0.1), "H"),
    (g.cap_solid, dict(H=0.3, t=0.0, maxh=0.1), "t"),
    (g.cap_solid, dict(H=0.3, t=-0.01, maxh=0.1), "t"),
    (g.cap_section, dict(H=0.3, t=2.0, maxh=0.1), "t"),
    (g.cap_solid, dict(H=0.3, t=0.01, maxh=0.1, layers=0), "layers"),
    (g.cap_section, dict(H=0.3, t=0.01, maxh=0.0), "maxh"),
    (g.cap_midsurface, dict(H=0.3, maxh=0.1, apex_radius=1.5), "apex_radius"),
    (g.cap_midsurface, dict(H=0.3, maxh=0.1, curve_order=0), "curve_order"),
    (g.tube_plane, dict(Ri=1.0, Ro=2.0, tfi=0.6, tfo=0.5, maxh=0.1), "tfi + tfo"),
    (g.tube_plane, dict(Ri=0.5, Ro=2.0, tfi=0.5, maxh=0.1), "tfi"),
    (g.tube_plane, dict(Ri=2.0, Ro=1.0, maxh=0.1), "Ri"),
    (g.tube_plane, dict(Ri=1.0, Ro=2.0, tfo=-0.1, maxh=0.1), "tfo"),
    (g.tube_plane, dict(Ri=1.0, Ro=2.0, tfi=0.02, maxh=0.1, n_theta=10), "n_theta"),
    (g.tube_section, dict(Ri=1.0, Ro=2.0, Hz=0.0, maxh=0.1), "Hz"),
    (g.tube_solid, dict(Ri=1.0, Ro=2.0, Hz=1.0, maxh=0.1, film_layers=0, tfi=0.01),
     "film_layers"),
    (g.tube_solid, dict(Ri=1.0, Ro=2.0, Hz=1.0, maxh=0.1, wall_layers=0), "wall_layers"),
    (g.plate_solid, dict(t=1.5, maxh=0.1), "t"),
    (g.plate_section, dict(t=0.01, maxh=0.1, layers=0), "layers"),
    (g.plate_midsurface, dict(R=-1.0, maxh=0.1), "R"),
    (g.layer_plane, dict(width=1.0, thickness=1.0, maxh=0.1, amplitude=1.0,
                         wavelength=0.1), "|amplitude|"),
    (g.layer_plane, dict(width=1.0, thickness=1.0, maxh=0.1, amplitude=0.01),
     "wavelength"),
    (g.layer_solid, dict(width=1.0, depth=0.5, thickness=1.0, maxh=0.1, amplitude=0.01,
                         wavelength=0.8, seed=1), "wavelength"),
    (g.layer_plane, dict(width=1.0, thickness=1.0, maxh=0.1, top_maxh=0.0), "top_maxh"),
    (g.rectangle, dict(width=0.0, height=1.0, maxh=0.1), "width"),
    (g.rectangle, dict(width=1.0, height=1.0, maxh=0.1, structured=True, nx=0), "nx"),
    (g.block, dict(lx=1.0, ly=1.0, lz=1.0, maxh=-1.0), "maxh"),
    (g.disk, dict(radius=1.0, maxh=float("nan")), "maxh"),
    (g.ball_octant, dict(radius=-1.0, maxh=0.3), "radius"),
    (g.ball_section, dict(maxh=0.0), "maxh"),
    (g.sphere_octant, dict(inner=0.0, outer=1.0, maxh=0.3), "inner"),
    (g.sphere_section, dict(inner=1.0, outer=1.0, maxh=0.3), "inner"),
    (g.sphere_section, dict(inner=0.5, outer=-1.0, maxh=0.3), "outer"),
    (g.sphere_radial, dict(inner=-0.5, outer=1.0, maxh=0.3), "inner"),
    (g.sphere_radial, dict(outer=1.0, maxh=0.3, cells=0), "cells"),
    (g.radial_grading, dict(n0=1e-3, nR=1e-2, p=0.0, R=1.0), "p"),
    (g.axial_grading, dict(n0=1e-3, nL=1e-2, p=1.0, L=0.0), "L"),
]


@pytest.mark.parametrize("builder, kwargs, param", BAD,
                         ids=[f"{b.__name__}-{p}-{i}" for i, (b, _, p) in enumerate(BAD)])
def test_bad_parameters_raise_value_error_naming_them(builder, kwargs, param):
    with pytest.raises(ValueError) as info:
        builder(**kwargs)
    message = str(info.value)
    assert message.startswith((f"{param} ", f"|{param}| ")), message


def test_mesh_bundle_rejects_unknown_model():
    with pytest.raises(ValueError, match="model"):
        g.MeshBundle(mesh=None, geometry=None, model="shell", exact_measure=1.0, params={})


def test_mesh_timing_script(tmp_path):
    import mesh_timing  # scripts/ is on sys.path (tests/conftest.py)

    rows = mesh_timing.main(["--quick", "--out", str(tmp_path)])
    assert {r["mesh"] for r in rows} >= {"cap_solid", "gear_annulus", "plate_solid",
                                         "crease_layer"}
    assert all(r["elements"] > 0 and r["seconds"] > 0 for r in rows)
    assert (tmp_path / "mesh_timing.csv").read_text().count("\n") == len(rows) + 1


# ------------------------------------------- spheres with the kinematics they are for ----

@pytest.mark.parametrize("build, surfaces", [
    (lambda k: g.sphere_section(inner=0.5, outer=1.0, maxh=0.2, curve_order=k), {"inner": 0.5, "outer": 1.0}),
    (lambda k: g.sphere_octant(inner=0.5, outer=1.0, maxh=0.2, curve_order=k), {"inner": 0.5, "outer": 1.0})])
def test_sphere_arcs_converge_with_curve_order(build, surfaces):
    # the section's arcs have length pi r / 2, the octant's spherical faces area pi r^2 / 2
    b = build(1)
    for name, r in surfaces.items():
        exact = math.pi * r / 2 if b.mesh.dim == 2 else math.pi * r**2 / 2
        errors = []
        for order in (1, 2, 3):
            b.mesh.Curve(order)
            errors.append(abs(ng.Integrate(1, b.mesh, definedon=b.boundary(name), order=8) / exact - 1))
        assert errors[1] < 0.1 * errors[0] and errors[2] < errors[1] and errors[2] < 1e-3, (name, errors)


def test_radial_line_volume_and_centre():
    for b in (g.sphere_radial(inner=0.5, outer=1.5, maxh=0.3), g.sphere_radial(outer=1.0, maxh=0.3)):
        assert b.model == g.SPHERICAL
        assert 4 * math.pi * ng.Integrate(ng.x**2, b.mesh, order=2) == pytest.approx(b.exact_volume, rel=1e-13)
        inner = [v.point[0] for v in b.mesh.vertices if v.point[0] == b.params["inner"]]
        assert len(inner) == 1  # the "inner" end (a ball's centre) is a vertex
    assert g.sphere_radial(outer=1.0, maxh=1 / 64).mesh.ne == 64  # segments of at most maxh, no more


SPHERE_MODELS = ["radial", "section", "octant"]


@pytest.mark.parametrize("model", SPHERE_MODELS)
def test_hollow_sphere_swells_homogeneously_and_evaluates_alike(model):
    # A free hollow sphere taken from free swelling at mu0 to mu1 swells homogeneously,
    # F' = (lam(mu1)/lam(mu0)) I, in each model; its fields at a point come back as the same
    # types (float or numpy array of the field's shape) whatever the mesh dimension.
    from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, Solid3D, SphericalSymmetric

    gel = FloryRehnerGel(Nv=1e-2, chi=0.5)
    mu0, mu1 = -0.5, -0.1
    lam0 = gel.lam_free(mu0)
    if model == "radial":
        bundle, kinematics, fixes = g.sphere_radial(inner=0.5, outer=1.0, maxh=0.25), SphericalSymmetric(), []
    elif model == "section":
        bundle, kinematics = g.sphere_section(inner=0.5, outer=1.0, maxh=0.3), Axisymmetric()
        fixes = [("axis", "r"), ("equator", "z")]
    else:
        bundle, kinematics = g.sphere_octant(inner=0.5, outer=1.0, maxh=0.4), Solid3D()
        fixes = [("xsym", "x"), ("ysym", "y"), ("zsym", "z")]
    prob = EquilibriumProblem(bundle.mesh, kinematics=kinematics, materials=gel, lam0=lam0, mu=mu0)
    for boundary, component in fixes:
        prob.fix(boundary, component)
    prob.mu.Set(mu1)
    prob.solve()
    stretch = gel.lam_free(mu1) / lam0
    point = {"radial": (0.8,), "section": (0.5, 0.6), "octant": (0.4, 0.4, 0.4)}[model]
    F = prob.evaluate(prob.deformation_gradient(prob.displacement), point)
    assert isinstance(F, np.ndarray) and F.shape == (3, 3)
    assert F == pytest.approx(stretch * np.eye(3), abs=1e-9)
    sigma = prob.evaluate(prob.stress(), point)
    assert isinstance(sigma, np.ndarray) and sigma.shape == (3, 3)
    assert np.max(np.abs(sigma)) < 1e-9 * gel.Nv
    J = prob.evaluate(prob.volume_ratio(), point)
    assert isinstance(J, float) and J == pytest.approx(gel.lam_free(mu1) ** 3, rel=1e-9)
    u = prob.evaluate(prob.displacement, point)
    grad = prob.evaluate(ng.Grad(prob.displacement), point)
    if model == "radial":  # one radial component: scalars
        assert isinstance(u, float) and isinstance(grad, float)
        assert u == pytest.approx((stretch - 1) * point[0], rel=1e-9)
    else:
        assert isinstance(u, np.ndarray) and u.shape == (len(point),)
        assert grad.shape == (len(point), len(point))
        assert u == pytest.approx((stretch - 1) * np.array(point), rel=1e-9)
    with pytest.raises(ValueError, match=f"point must be {len(point)} finite coordinates"):
        prob.evaluate(prob.displacement, point + (0.0,))
    with pytest.raises(ValueError, match="outside the mesh"):
        prob.evaluate(prob.displacement, tuple(0.1 for _ in point))


@pytest.mark.parametrize("copies", [1, 6])
def test_cap_sector_midsurface_lies_on_the_sphere_and_its_copies_close_the_cap(copies):
    from geometries.caps import cap_sector_midsurface

    H = 0.3
    r, zc = (1 + H * H) / (2 * H), H - (1 + H * H) / (2 * H)
    bundle = cap_sector_midsurface(H=H, angle=math.pi / 3, copies=copies, maxh=0.15, apex_radius=0.05,
                                   curve_order=3)
    mesh = bundle.mesh
    assert measure(bundle) == pytest.approx(bundle.exact_measure, rel=1e-5)
    apex = ng.Integrate(ng.CF(1), mesh, ng.BND, definedon=mesh.Boundaries("apex"))
    assert apex == pytest.approx(bundle.region_measures["apex"], rel=1e-2)
    distance = ng.sqrt(ng.x**2 + ng.y**2 + (ng.z - zc)**2) - r
    assert math.sqrt(ng.Integrate(distance**2, mesh, ng.BND) / bundle.exact_measure) < 1e-5
    base = ng.Integrate(ng.CF(1), mesh, ng.BBND, definedon=mesh.BBoundaries("base"))
    assert base == pytest.approx(copies * math.pi / 3, rel=1e-5)
    assert ("sym" in mesh.GetBBoundaries()) == (copies == 1)


def test_plate_sector_midsurface_area_rim_and_mirror_edges():
    from geometries.plates import plate_sector_midsurface

    bundle = plate_sector_midsurface(angle=math.pi / 5, copies=2, maxh=0.3, curve_order=3)
    mesh = bundle.mesh
    assert set(mesh.GetBoundaries()) == {"gel"}

    def area_error(b):
        return abs(measure(b) / b.exact_measure - 1)

    def rim_error(b):
        return abs(ng.Integrate(ng.CF(1), b.mesh, ng.BBND, definedon=b.mesh.BBoundaries("rim")) / (2 * math.pi / 5) - 1)

    chords = plate_sector_midsurface(angle=math.pi / 5, copies=2, maxh=0.3, curve_order=1)
    assert rim_error(bundle) < rim_error(chords) / 20  # the rim moved onto the circle (chords: 4e-3)
    assert area_error(bundle) < area_error(chords) / 20
    end = mesh.BBoundaries("sym_end")  # the line at 2 pi / 5
    assert ng.Integrate((-math.sin(2 * math.pi / 5) * ng.x + math.cos(2 * math.pi / 5) * ng.y)**2, mesh, ng.BBND,
                        definedon=end) < 1e-24
    assert ng.Integrate(ng.CF(1), mesh, ng.BBND, definedon=end) == pytest.approx(1.0, rel=1e-9)
