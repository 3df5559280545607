"""Creases on a bonded gel layer (scene E): homogeneous state, linear threshold, contact, script."""

import json

import numpy as np
import ngsolve as ngs
import pytest


from ngsgel.scenes import creases
from geometries.layers import layer_plane
from ngsgel import EquilibriumProblem, FloryRehnerGel, PlaneStrain, ramp
from ngsgel.contact import SelfContact, crossing_loops, plane_contact, self_intersections, surface_line
from ngsgel.surface import surface_tension
from ngsgel.transient import march
from netgen import occ
from ngsolve.meshes import Make1DMesh
from scipy.optimize import brentq


def coarse(**change):
    """Coarse cell; without surface energy unless asked (the sharp-interface model)."""
    return creases.Setup(**{"top_h": 0.02, "maxh": 0.05, "surface_tension": 0.0, **change})


def test_homogeneous_layer_matches_constrained_closed_form():
    """Flat cell, mu raised by Newton: the top moves as the laterally constrained layer
    (lam_constrained), which P2 displacements represent exactly (linear in y)."""
    setup = coarse()
    prob = creases.build_equilibrium(setup, imperfect=False, contact=False)
    for mu in (-0.3, -0.1, -0.02):
        prob.mu.Set(mu)
        prob.solve()
        top = prob.displacement(prob.mesh(0.1, 1.0))[1]
        exact = setup.gel.lam_constrained(mu, setup.lam0) / setup.lam0 - 1.0
        assert top == pytest.approx(exact, rel=1e-9)


def test_linear_threshold_converges_between_crease_and_biot():
    """The flat layer loses stability (exact inertia) at a thickness/lateral stretch ratio that
    changes by < 1 % between two meshes and lies below Biot's incompressible half-space value
    (the drained gel is compressible, which lowers the threshold) and above the energetic crease
    threshold 2.4 (creases are subcritical: they precede wrinkling)."""
    a = creases.linear_threshold(coarse(top_h=0.01))
    b = creases.linear_threshold(coarse(top_h=0.005))
    assert a["residual_homogeneous"] < 1e-12 and b["residual_homogeneous"] < 1e-12
    assert abs(a["ratio"] - b["ratio"]) / b["ratio"] < 0.01
    assert creases.CREASE_RATIO < b["ratio"] < creases.BIOT_RATIO


def _quarter_disk(radius: float, maxh: float) -> ngs.Mesh:
    face = occ.WorkPlane().Circle(0, 0, radius).Face() * occ.WorkPlane().Rectangle(2 * radius, 2 * radius).Face()
    face.name = "gel"
    face.edges.name = "outer"
    face.edges.Min(occ.X).name = "xsym"
    face.edges.Min(occ.Y).name = "ysym"
    mesh = ngs.Mesh(occ.OCCGeometry(face, dim=2).GenerateMesh(maxh=maxh))
    mesh.Curve(2)  # isoparametric P2: homogeneous states are in the space
    return mesh


def test_surface_tension_gives_the_laplace_pressure():
    """A plane-strain gel disk (radius R, quarter with mirror sides) with surface energy gamma
    on its rim, at the reference mu0: the surface energy compresses it homogeneously; the
    Young-Laplace law gives the pressure gamma / (s R) and the closed-form in-plane stretch s from
    sigma_rr(s) = -gamma / (s R) (Flory-Rehner stress, out-of-plane stretch held). Measured: the
    mean pressure and the area ratio agree to 1.5e-5 at maxh = R/4 (7e-7 at R/8: geometry error
    of the P2 rim)."""
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    mu0, radius = -0.1, 1.0
    lam0 = gel.lam_free(mu0)
    gamma = 0.5 * gel.shear_modulus(lam0) * radius
    mesh = _quarter_disk(radius, 0.25)
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=lam0, mu=mu0, quadrature_order=6)
    prob.fix("xsym", "x")
    prob.fix("ysym", "y")
    prob.add_surface_energy("outer", surface_tension(gamma))
    prob.solve()
    s = brentq(lambda s: gel.mu_traction_free(lam0 * s, lam0**3 * s * s) - mu0 + gamma / (s * radius), 0.9, 1.0,
               xtol=1e-15)
    area = prob.integrate(ngs.CF(1.0))
    sigma = prob.stress()
    pressure = -prob.integrate(0.5 * (sigma[0, 0] + sigma[1, 1])) / area
    area_ratio = prob.integrate(ngs.Det(prob.deformation_gradient(prob.displacement))) / area
    assert pressure == pytest.approx(gamma / (s * radius), rel=1e-4)
    assert (area_ratio - 1) == pytest.approx(s * s - 1, rel=1e-4)
    assert s * s < 1 - 1e-4  # the effect measured is not round-off


def test_surface_tension_keeps_flat_state_and_raises_linear_threshold():
    """A flat surface stays flat: the closed-form laterally constrained state is still an exact
    equilibrium with surface energy (no curvature, no normal traction). Surface energy penalises
    short wrinkles, so the linear threshold rises with gamma / (G H): measured at h = 0.01 3.126,
    3.252, 3.372 for 0, 0.01, 0.02 (mesh change to h = 0.005 < 0.1 %)."""
    ratios = []
    for st in (0.0, 0.01, 0.02):
        res = creases.linear_threshold(coarse(top_h=0.01, surface_tension=st))
        assert res["residual_homogeneous"] < 1e-12
        ratios.append(res["ratio"])
    assert ratios[0] < ratios[1] - 0.05 < ratios[2] - 0.1
    assert ratios[2] == pytest.approx(3.372, rel=2e-3)


def _forced_fold(with_contact: bool):
    """A block bonded at the bottom, its right side pushed left by 0.03: the top surface is carried
    across the plane x = 0 unless contact holds it."""
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    mesh = layer_plane(width=0.2, thickness=0.1, maxh=0.02).mesh
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=gel.lam_free(-0.1), mu=-0.1)
    load = ngs.Parameter(0.0)
    prob.fix("bottom", "y")
    prob.prescribe("right", "x", -0.03 * load)
    if with_contact:
        prob.add_surface_energy("top", plane_contact(component=0, position=0.0, side=1,
                                                     penalty=1e3 * gel.shear_modulus(prob.lam0) / 0.02))
    prob.solve()
    assert ramp(prob, load, 1.0, step=0.25).converged
    return surface_line(prob.displacement, mesh, "top")


def test_contact_prevents_interpenetration():
    free = _forced_fold(False)
    held = _forced_fold(True)
    assert free.current[:, 0].min() < -0.02  # without contact the surface crosses the plane
    assert -held.current[:, 0].min() < 0.05 * held.edge_length  # with it, penetration < 5 % of h (penalty 1e3 G/h)
    assert self_intersections(held.current) == 0


def test_self_intersections_counts_a_crossing_fold():
    folded = np.array([[0, 0], [1, 0], [1, 1], [0.5, -0.5], [2, -1.0]])
    assert self_intersections(folded) == 1
    assert self_intersections(np.array([[0, 0], [1, 0], [2, 0.1], [3, 0]])) == 0


def test_crossing_loops_tell_a_penalty_sliver_from_a_crossing():
    # faces overlapping by d over a length L (a rectangle L x d between the crossing and the tip):
    # width 2 A / P = 2 L d / (2 L + 2 d); a crossing fold cuts off a lobe as wide as the fold
    d, L = 1e-3, 0.9
    sliver = np.array([[-1, 1.0], [0, 1], [0, 0.5], [0, 0], [-d, 0], [-d, 0.5], [-d, L], [1, L]])
    (loop,) = crossing_loops(sliver)
    assert loop.width == pytest.approx(2 * L * d / (2 * L + 2 * d), rel=1e-12)
    assert loop.area == pytest.approx(L * d, rel=1e-12) and loop.innermost
    folded = np.array([[0, 0], [1, 0], [1, 1], [0.5, -0.5], [2, -1.0]])
    (lobe,) = crossing_loops(folded)
    assert lobe.width > 0.1  # the triangle cut off at (5/6, 0)
    assert crossing_loops(np.array([[0, 0], [1, 0], [2, 0.1], [3, 0]])) == []


def test_crossing_loops_cut_a_crossed_tip_out_of_its_sliver():
    # a sliver (faces x = 0 and x = -d overlapping from y = 0.3 to 0.9) ending in a crossed lobe
    # (the bottom folded through itself): the sliver's width is the overlap, the lobe is apart
    d = 1e-3
    line = np.array([[-1, 1.0], [0, 1], [0, 0.3], [-0.1, 0], [0.1, 0], [-d, 0.3], [-d, 0.9], [1, 0.9]])
    sliver, lobe = crossing_loops(line)
    assert (sliver.first, sliver.last, lobe.first, lobe.last) == (1, 6, 2, 4)
    assert not sliver.innermost and lobe.innermost
    assert sliver.width == pytest.approx(d, rel=0.02)
    assert lobe.width > 50 * d


def test_fold_estimate_extrapolates_the_vanishing_eigenvalue():
    """Near a fold lambda ~ sqrt(mu_c - mu): two states on lambda = sqrt(mu_c - mu) give mu_c."""
    mu_c = -0.004
    path = [{"mu": m, "lowest_eigenvalue": np.sqrt(mu_c - m)} for m in (-0.01, -0.006)]
    assert creases.fold_estimate(path) == pytest.approx(mu_c, rel=1e-12)
    assert creases.fold_estimate(path[::-1]) is None  # eigenvalue growing: no fold ahead


def test_tip_refinement_puts_small_elements_only_near_the_crease_line():
    """``tip_h`` refines the top on x < tip_length only (the crease tip on the mirror line x = 0
    sets the onset; docs/creases.md), keeps the imperfect area and the boundary names."""
    setup = coarse(top_h=0.01, tip_h=0.0025, tip_length=0.04, amplitude=0.1)
    mesh = setup.mesh()
    sizes = []
    for el in mesh.Elements(ngs.BND):
        if el.mat == "top":
            xs = sorted(mesh[v].point[0] for v in el.vertices)
            sizes.append((xs[0], xs[1] - xs[0]))
    near = [h for x0, h in sizes if x0 < 0.04 - 1e-12]
    far = [h for x0, h in sizes if x0 > 0.06]
    assert max(near) <= 1.2 * 0.0025 and len(near) >= 0.04 / (1.2 * 0.0025)
    assert min(far) >= 0.8 * 0.01
    plain = coarse(top_h=0.01, amplitude=0.1).mesh()
    # the nodes carry the piecewise linear interpolant of the trough a cos(k x): area error
    # <= W h^2 a k^2 / 8 (h = top_h); the exact area is W H (the cosine integrates to 0 over W)
    a, k = 0.1 * setup.width, np.pi / setup.width
    assert abs(ngs.Integrate(1, mesh) - setup.width) <= setup.width * 0.01**2 * a * k**2 / 8
    assert set(mesh.GetBoundaries()) == set(plain.GetBoundaries())
    assert setup.surface_h == 0.0025 and coarse().surface_h == 0.02  # the contact penalty's h


def test_tip_geometry_of_a_parabolic_edge():
    """The first P2 edge is a parabola in its parameter: y = x^2 / (2 R) sampled at 5 points has
    the radius R and a horizontal tangent at the corner; tilted by 10 deg, the angle is 10 deg."""
    s = np.linspace(0.0, 1.0, 5)
    x, y = 0.003 * s, (0.003 * s) ** 2 / (2 * 0.005)
    angle, radius = creases.tip_geometry(np.r_[x, 1.0], np.r_[y, 1.0])  # later points are ignored
    assert angle == pytest.approx(0.0, abs=1e-9) and radius == pytest.approx(0.005, rel=1e-9)
    c, si = np.cos(np.radians(10)), np.sin(np.radians(10))
    angle, radius = creases.tip_geometry(c * x - si * y, si * x + c * y)
    assert angle == pytest.approx(10.0, rel=1e-9) and radius == pytest.approx(0.005, rel=1e-9)


def test_trough_lies_where_the_setup_says():
    for trough, x_low in (("mirror", 0.0), ("centre", 0.1)):
        setup = creases.Setup(width=0.2, amplitude=0.1, trough=trough, top_h=0.02, maxh=0.05)
        mesh = setup.mesh()
        top = [mesh[v].point for el in mesh.Elements(ngs.BND) if el.mat == "top" for v in el.vertices]
        x, y = min(top, key=lambda p: p[1])
        assert x == pytest.approx(x_low, abs=setup.top_h) and y < 1 - 0.9 * 0.02  # a = 0.02 deep


def test_bad_input_raises_before_work():
    with pytest.raises(ValueError, match="amplitude"):
        creases.Setup(amplitude=0.7).check()
    with pytest.raises(ValueError, match="mu0"):
        creases.Setup(mu0=0.1).check()
    with pytest.raises(ValueError, match="top_h"):
        creases.Setup(top_h=0.1).check()
    with pytest.raises(ValueError, match="surface_tension"):
        creases.Setup(surface_tension=-0.01).check()
    with pytest.raises(ValueError, match="tip_h"):
        creases.Setup(tip_h=0.02).check()  # coarser than top_h
    with pytest.raises(ValueError, match="trough"):
        creases.Setup(trough="left").check()
    with pytest.raises(ValueError, match="wavelength"):
        creases.Setup(seed=1, wavelength=0.5).check()  # > 2 W
    with pytest.raises(ValueError, match="seed"):
        creases.Setup(seed=-1).check()
    with pytest.raises(ValueError, match="overlap_limit"):
        creases.Setup(overlap_limit=0.0).check()
    with pytest.raises(ValueError, match="corner_maxh and corner_length"):
        layer_plane(width=0.2, thickness=1.0, maxh=0.05, corner_maxh=0.01)
    with pytest.raises(ValueError, match="gamma"):
        surface_tension(float("nan"))
    with pytest.raises(ValueError, match="penalty"):
        plane_contact(component=0, position=0.0, side=1, penalty=-1.0)


def test_quick_script_reports_onset(tmp_path):
    summary = creases.main(["--quick", "--out", str(tmp_path)])
    assert summary["onset"] is not None, summary["message"]
    assert summary["max_self_crossings"] == 0
    assert summary["max_penetration_over_h"] < 0.05
    assert summary["max_overlap_over_h"] <= creases.Setup.overlap_limit  # faces held by the self-contact, if any
    assert summary["max_relative_balance_error"] < 1e-6
    # the skin's grooves coarsen as the swollen zone deepens, to one per period at the onset
    assert summary["spacing_against_depth"]["rank_correlation"] > 0
    assert summary["spacing_against_depth"]["bins"][-1]["grooves"] == 1
    saved = json.loads((tmp_path / "summary.json").read_text())
    assert saved["onset"]["time"] == pytest.approx(summary["onset"]["time"])
    sharp = saved["tip_sharpening"]  # the converging onset measure (needs tip_h <= l/16 to mean anything)
    assert sharp is None or sharp["previous_time"] <= sharp["time"] <= sharp["step_time"]
    assert (tmp_path / "creases.png").stat().st_size > 0


def test_spacing_against_depth_recovers_a_power_law_and_ignores_the_cell_bound():
    depth = np.geomspace(1e-3, 1.0, 400)
    period = 0.4
    grooves = np.maximum(1, np.round(period / (0.5 * depth**0.5)))  # spacing 0.5 sqrt(depth), capped at the period
    result = creases.spacing_against_depth(depth, grooves, period)
    several = [b for b in result["bins"] if b["grooves"] >= 2]
    assert result["fit"]["points"] == len(several) >= 3
    assert result["fit"]["exponent"] == pytest.approx(0.5, abs=0.05)  # up to rounding the groove counts
    assert result["rank_correlation"] > 0.95
    assert result["bins"][-1]["spacing"] == period
    assert result["coarsening"] and all(c["to"] < c["from"] for c in result["coarsening"])
    assert creases.spacing_against_depth([0.1, 0.2], [3, 2], period) is None


def test_self_contact_closes_an_interior_crease_as_the_mirror_plane_does():
    # The period [0, 2W] with its trough in the middle, where the crease is an interior one held by
    # general self-contact (penalty k/4 per face, both faces masters), against the half cell
    # [0, W] whose crease closes on the mirror plane x = 0 (penalty k): at a ratio past the
    # groove's closing (2.8; 2.53 is still open) both must be the same state - energy twice the
    # half cell's, overlap of the faces twice the half cell's penetration of the plane. Without
    # the self-contact that closed state does not exist (Newton fails: the faces would cross).
    setup = creases.Setup(amplitude=0.1, top_h=0.01, maxh=0.05, surface_tension=0.02)
    W = setup.width
    half = creases.build_equilibrium(setup, imperfect=True, contact=True)
    # the same trough (depth a W) in the middle of the period [0, 2 W]; its mirror planes at the
    # crests carry no contact, the crease closes on the self-contact (penalty k/4 per face)
    period = creases.Setup(**{**setup.__dict__, "width": 2 * W, "amplitude": setup.amplitude / 2, "trough": "centre"})
    full = creases.build_equilibrium(period, imperfect=True, contact=True)

    def mu_at(ratio):
        return brentq(lambda m: setup.ratio(m) - ratio, setup.mu0, 0.0, xtol=1e-12)

    for prob in (half, full):
        ramp(prob, prob.mu, mu_at(2.53), step=0.05)
        prob.mu.Set(mu_at(2.8))
        prob.solve(maxit=80)
    assert full.energy() == pytest.approx(2 * half.energy(), rel=5e-6)

    penetration = -surface_line(half.displacement, half.mesh, "top").current[:, 0].min()
    line = surface_line(full.displacement, full.mesh, "top")
    ref, cur = line.reference, line.current
    bottom = cur[:, 1].min()
    heights = np.linspace(bottom + 0.005, bottom + 0.05, 20)

    def x_of_face(face, y):
        points = cur[face & (np.abs(ref[:, 0] - W) < 0.06)]
        order = np.argsort(points[:, 1])
        return np.interp(y, points[order, 1], points[order, 0])

    left = ref[:, 0] < W
    overlap = max(x_of_face(left, y) - x_of_face(~left, y) for y in heights)
    assert penetration > 0 and overlap == pytest.approx(2 * penetration, rel=0.1)
    # the scene's stop rule: this closed crease is one sliver, thinner than its widest overlap and
    # far below the limit (in surface elements) past which a loop counts as a crossing
    sliver, tip = crossing_loops(cur)
    assert 0.3 * overlap < sliver.width <= overlap
    assert sliver.width / line.edge_length < 0.1 * setup.overlap_limit
    # the crease's bottom, folded through itself within 3 elements (P2 edges cannot make the hairpin)
    assert tip.innermost and tip.last - tip.first <= 4 * creases.TIP_LOBE_EDGES
    assert 0.1 < tip.width / line.edge_length < 0.5
    surf = creases.surface_state(full, period)
    assert (surf["self_contacts"], surf["tip_lobes"], surf["self_crossings"]) == (1, 1, 0)
    assert surf["contact_X"] < W < surf["contact_X"] + 0.1


def test_self_contact_leaves_an_open_groove_with_a_sharp_bottom_alone():
    # The half cell's groove bends by ~100 degrees within one element at its bottom before it
    # closes on the mirror plane (ratio 2.53, a/W = 0.1): the closest-point search pairs the two
    # elements across that bend obliquely with a positive "gap" and switches them on and off
    # between Newton iterates; unweighted, the ramp stalled there (residual 2e-8, mu -0.01209).
    # Weighted by how squarely the pairs face each other, nothing acts: the same states as
    # without self-contact.
    setup = creases.Setup(amplitude=0.1, top_h=0.01, maxh=0.05, surface_tension=0.02)
    mu = brentq(lambda m: setup.ratio(m) - 2.53, setup.mu0, 0.0, xtol=1e-12)
    energies = []
    for self_contact in (False, True):
        prob = creases.build_equilibrium(creases.Setup(**{**setup.__dict__, "self_contact": self_contact}),
                                         imperfect=True, contact=True)
        ramp(prob, prob.mu, mu, step=0.05)
        energies.append(prob.energy())
    # round-off apart: the self-contact's pair elements change the matrix graph, hence the
    # factorisation (CI with two threads: 1 ulp)
    assert energies[1] == pytest.approx(energies[0], rel=1e-12)


def test_self_contact_input_is_checked_before_any_solve():
    setup = coarse()
    prob = creases.build_equilibrium(setup, imperfect=True, contact=False)
    for kwargs, name in (({"penalty": 0.0}, "penalty"), ({"penalty": 1.0, "maxdist": -1.0}, "maxdist"),
                         ({"penalty": 1.0, "intorder": 0}, "intorder")):
        with pytest.raises(ValueError, match=name):
            prob.add_self_contact("top", **kwargs)
    with pytest.raises(ValueError, match="unknown boundary"):
        prob.add_self_contact("roof", penalty=1.0)
    with pytest.raises(ValueError, match="2D meshes only"):
        SelfContact(Make1DMesh(4), "right", penalty=1.0)
    prob.solve()
    with pytest.raises(RuntimeError, match="before the first solve"):
        prob.add_self_contact("top", penalty=1.0)


def test_self_contact_of_the_transient_problem_leaves_an_open_surface_alone():
    # The transient (u, mu) problem with the top's self-contact declared: while no faces meet (the
    # first steps of immersion of the coarse cell), every step is the one without it, to round-off.
    setup = coarse()
    states = []
    for self_contact in (False, True):
        prob = creases.build_transient(setup)
        if self_contact:
            prob.add_self_contact("top", penalty=1e3 * setup.gel.shear_modulus(setup.lam0) / setup.top_h)
        march(prob, 20 * setup.ramp, dt_start=setup.ramp / 10)
        states.append(prob.save_state())
    assert np.max(np.abs(states[1] - states[0])) <= 1e-12 * np.max(np.abs(states[0]))
