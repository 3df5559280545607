"""Equilibrium solver against closed-form swelling, inhomogeneous reference solutions and bad input."""

import math

import numpy as np
import ngsolve as ngs
import pytest
from netgen.occ import X, Y, Box, Circle, Glue, OCCGeometry, Pnt, Rectangle, Sphere
from ngsolve.meshes import Make1DMesh, MakeStructured2DMesh, MakeStructured3DMesh

from ngsgel import (Axisymmetric, EquilibriumProblem, FloryRehnerGel, GeneralizedPlaneStrain, NeoHookeanFilm,
                    NewtonError, PlaneStrain, Solid3D, SphericalSymmetric, ramp)
from ngsgel.kinematics import PolarGeneralizedPlaneStrain
from ngsgel.stability import random_field, seed_imperfection


def unit_square():
    # boundaries: left x=0, bottom y=0, right, top
    return MakeStructured2DMesh(nx=2, ny=2)


def unit_cube():
    # MakeStructured3DMesh names: back x=0, left y=0, bottom z=0
    return MakeStructured3DMesh(nx=2, ny=2, nz=2)


SYMMETRY = {"plane": [("left", "x"), ("bottom", "y")], "axisymmetric": [("left", "r"), ("bottom", "z")],
            "solid3d": [("back", "x"), ("left", "y"), ("bottom", "z")]}
KINEMATICS = {"plane": (PlaneStrain, unit_square), "axisymmetric": (Axisymmetric, unit_square),
              "solid3d": (Solid3D, unit_cube)}


def swelling_problem(kind, gel, lam0, mu, *, constrain_sides=False, order=2):
    kin, make_mesh = KINEMATICS[kind]
    mesh = make_mesh()
    prob = EquilibriumProblem(mesh, kinematics=kin(), materials=gel, lam0=lam0, mu=mu, order=order)
    for boundary, comp in SYMMETRY[kind]:
        prob.fix(boundary, comp)
    if constrain_sides:  # rollers on the lateral faces: a layer held at its reference in-plane stretch
        prob.fix("right", "x")
        if kind == "solid3d":
            prob.fix("front", "x")
            prob.fix("right", "y")
    return prob


def corner_stretch(prob, lam0):
    mesh = prob.mesh
    point = mesh(1, 1, 1) if mesh.dim == 3 else mesh(1, 1)
    u = np.array(prob.displacement(point))
    return lam0 * (1 + u)


@pytest.mark.parametrize("kind", ["plane", "axisymmetric", "solid3d"])
@pytest.mark.parametrize("Nv", [1e-3, 1e-2])
@pytest.mark.parametrize("chi", [0.1, 0.5])
@pytest.mark.parametrize("mu0,mu1", [(-0.05, -0.6), (-0.3, -0.01)])  # shrinking, swelling
def test_free_swelling_matches_closed_form(kind, Nv, chi, mu0, mu1):
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    lam0 = gel.lam_free(mu0)
    prob = swelling_problem(kind, gel, lam0, mu0)
    prob.mu.Set(mu1)
    result = prob.solve()
    assert result.converged
    stretch = corner_stretch(prob, lam0)
    if kind == "plane":
        # out-of-plane stretch held at lam0: in-plane stretch from sigma_xx = sigma_yy = 0
        exact = gel.lam_plane_strain(mu1, lam0)
    else:
        exact = gel.lam_free(mu1)
    assert np.allclose(stretch, exact, rtol=1e-9, atol=0), (stretch, exact)


@pytest.mark.parametrize("kind", ["plane", "solid3d"])
@pytest.mark.parametrize("mu1", [-0.5, 0.0])
def test_constrained_layer_matches_closed_form(kind, mu1):
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = gel.lam_free(-0.1)
    prob = swelling_problem(kind, gel, lam0, -0.1, constrain_sides=True)
    ramp(prob, prob.mu, mu1, step=0.05)
    stretch = corner_stretch(prob, lam0)
    thickness = stretch[-1]
    assert thickness == pytest.approx(gel.lam_constrained(mu1, lam0), rel=1e-9)
    assert np.allclose(stretch[:-1], lam0, rtol=1e-12)


@pytest.mark.parametrize("kind", ["plane", "axisymmetric", "solid3d"])
def test_swollen_reference_is_stress_free(kind):
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = 2.0
    prob = swelling_problem(kind, gel, lam0, gel.mu_free(lam0))
    r = prob.state.CreateVector()
    prob.residual(prob.state, r)
    assert np.linalg.norm(r.FV().NumPy()) < 1e-12


def test_graded_gel_converges_from_unequilibrated_reference():
    # Nv varies along x, so the uniformly scaled reference is not stress-free at mu0.
    Nv = 1e-3 + 9e-3 * ngs.x
    gel = FloryRehnerGel(Nv=Nv, chi=0.5)
    lam0 = FloryRehnerGel(Nv=5e-3, chi=0.5).lam_free(-0.1)
    prob = swelling_problem("plane", gel, lam0, -0.1)
    r = prob.state.CreateVector()
    prob.residual(prob.state, r)
    assert np.linalg.norm(r.FV().NumPy()[prob.free_mask]) > 1e-5
    result = prob.solve()
    assert result.converged
    # the soft side (x = 0) swells more than the stiff side, each between the free swelling of
    # the softest and the stiffest gel
    J = prob.volume_ratio()
    soft, stiff = J(prob.mesh(0.05, 0.5)), J(prob.mesh(0.95, 0.5))
    bounds = [FloryRehnerGel(Nv=n, chi=0.5).lam_free(-0.1) ** 3 for n in (1e-2, 1e-3)]
    assert bounds[0] < stiff < soft < bounds[1]


def test_step_that_would_dry_the_gel_is_cut_back():
    # One Newton solve from a well-swollen state to a nearly dry one: full Newton steps
    # overshoot to J <= 1; the line search must cut them back and still converge exactly.
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = gel.lam_free(-0.01)
    prob = swelling_problem("plane", gel, lam0, -0.01)
    prob.mu.Set(-2.0)
    result = prob.solve(maxit=60)
    assert result.line_search_cuts > 0
    assert np.all(np.isfinite(prob.save_state()))
    assert corner_stretch(prob, lam0)[0] == pytest.approx(gel.lam_plane_strain(-2.0, lam0), rel=1e-9)


def test_newton_failure_raises_and_restores_state():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = gel.lam_free(-0.01)
    prob = swelling_problem("plane", gel, lam0, -0.01)
    before = prob.save_state()
    prob.mu.Set(-2.0)
    with pytest.raises(NewtonError) as info:
        prob.solve(maxit=2)
    assert not info.value.result.converged
    assert np.array_equal(prob.save_state(), before)


def test_ramp_cuts_back_and_regrows():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = gel.lam_free(-0.01)
    prob = swelling_problem("plane", gel, lam0, -0.01)
    result = ramp(prob, prob.mu, -3.0, newton_options={"maxit": 6})
    assert result.converged and result.cutbacks > 0
    assert corner_stretch(prob, lam0)[0] == pytest.approx(gel.lam_plane_strain(-3.0, lam0), rel=1e-9)


def test_prescribed_displacement_and_film():
    # A film bonded on top of a gel strip, stretched by a prescribed end displacement: the
    # prescribed value is met exactly and the film (stiffer) carries most of the force.
    from netgen.occ import Glue, X, Y
    gel_face = Rectangle(2, 0.5).Face()
    film_face = Rectangle(2, 0.05).Face().Move((0, 0.5, 0))
    gel_face.faces.name, film_face.faces.name = "gel", "film"
    shape = Glue([gel_face, film_face])
    shape.edges.Min(X).name = "left"
    shape.edges.Max(X).name = "right"
    shape.edges.Min(Y).name = "bottom"
    mesh = ngs.Mesh(OCCGeometry(shape, dim=2).GenerateMesh(maxh=0.1))
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = gel.lam_free(0.0)
    film = NeoHookeanFilm(E=100 * gel.youngs_modulus(lam0), nu=0.3)
    load = ngs.Parameter(0.0)
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials={"gel": gel, "film": film},
                              lam0=lam0, mu=0.0, order=2)
    prob.fix("left", "x")
    prob.fix("bottom", "y")
    prob.prescribe("right", "x", 0.1 * load)
    result = ramp(prob, load, 1.0, step=0.5)
    assert result.converged
    u_end = prob.displacement(mesh(2.0, 0.25))[0]
    assert u_end == pytest.approx(0.1, abs=1e-12)
    sigma = prob.stress()
    assert sigma[0, 0](mesh(1.0, 0.525)) > 20 * sigma[0, 0](mesh(1.0, 0.25))


# ------------------------------------------------------------ inhomogeneous: shell on a rigid core
RI, RO = 1.0, 1.5
SHELL_GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
MU0, MU1 = -0.1, -0.02


def _name_by_radius(entities, planes):
    for e in entities:
        c = e.center
        for axis, name in planes:
            if abs(getattr(c, axis)) < 1e-9:
                e.name = name
                break
        else:
            e.name = "inner" if math.sqrt(c.x**2 + c.y**2 + c.z**2) < (RI + RO) / 2 else "outer"


def shell_section_mesh(h, order):
    face = (Circle((0, 0), RO).Face() - Circle((0, 0), RI).Face()) * Rectangle(2, 2).Face()
    _name_by_radius(face.edges, [("x", "axis"), ("y", "equator")])
    face.faces.name = "gel"
    mesh = ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=h))
    mesh.Curve(order)
    return mesh


def shell_octant_mesh(h, order):
    solid = (Sphere(Pnt(0, 0, 0), RO) - Sphere(Pnt(0, 0, 0), RI)) * Box(Pnt(0, 0, 0), Pnt(2, 2, 2))
    _name_by_radius(solid.faces, [("x", "x0"), ("y", "y0"), ("z", "z0")])
    solid.solids.name = "gel"
    mesh = ngs.Mesh(OCCGeometry(solid).GenerateMesh(maxh=h))
    mesh.Curve(order)
    return mesh


def swollen_shell_volume(mesh, kinematics, order, fixes, fraction):
    """Current volume of the whole shell, from a part of it that is ``fraction``."""
    lam0 = SHELL_GEL.lam_free(MU0)
    prob = EquilibriumProblem(mesh, kinematics=kinematics, materials=SHELL_GEL, lam0=lam0, mu=MU0, order=order)
    for boundary, comp in fixes:
        prob.fix(boundary, comp)
    ramp(prob, prob.mu, MU1, step=0.04)
    return prob.integrate(prob.volume_ratio()) / lam0**3 / fraction


@pytest.fixture(scope="module")
def shell_reference():
    mesh = Make1DMesh(64, mapping=lambda t: RI + (RO - RI) * t)
    return swollen_shell_volume(mesh, SphericalSymmetric(), 6, [("left", None)], 1.0)


def test_spherical_reference_is_converged(shell_reference):
    mesh = Make1DMesh(16, mapping=lambda t: RI + (RO - RI) * t)
    coarse = swollen_shell_volume(mesh, SphericalSymmetric(), 4, [("left", None)], 1.0)
    assert coarse == pytest.approx(shell_reference, rel=1e-10)
    # the bonded shell swells, but less than a free one
    reference_volume = 4 * math.pi / 3 * (RO**3 - RI**3)
    free = reference_volume * (SHELL_GEL.lam_free(MU1) / SHELL_GEL.lam_free(MU0)) ** 3
    assert reference_volume < shell_reference < free


AXI_FIXES = [("inner", None), ("axis", "r"), ("equator", "z")]


@pytest.mark.parametrize("order,min_rate", [(1, 1.7), (2, 2.8)])
def test_axisymmetric_shell_converges_under_h_refinement(shell_reference, order, min_rate):
    errors = []
    for h in (0.4, 0.2, 0.1):
        vol = swollen_shell_volume(shell_section_mesh(h, order), Axisymmetric(), order, AXI_FIXES, 0.5)
        errors.append(abs(vol - shell_reference) / shell_reference)
    rates = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    print(f"order {order}: relative volume errors {errors}, rates {rates}")
    assert np.all(rates > min_rate), rates


def test_axisymmetric_shell_converges_under_p_refinement(shell_reference):
    mesh_h = 0.4
    errors = [abs(swollen_shell_volume(shell_section_mesh(mesh_h, p), Axisymmetric(), p, AXI_FIXES, 0.5)
                  - shell_reference) / shell_reference for p in (1, 2, 3)]
    print(f"p-refinement errors {errors}")
    assert errors[1] < errors[0] / 20 and errors[2] < errors[1] / 5


def test_3d_shell_agrees_with_axisymmetric(shell_reference):
    fixes = [("inner", None), ("x0", "x"), ("y0", "y"), ("z0", "z")]
    errors = [abs(swollen_shell_volume(shell_octant_mesh(h, 2), Solid3D(), 2, fixes, 1 / 8)
                  - shell_reference) / shell_reference for h in (0.5, 0.3)]
    axi = abs(swollen_shell_volume(shell_section_mesh(0.4, 2), Axisymmetric(), 2, AXI_FIXES, 0.5)
              - shell_reference) / shell_reference
    print(f"3D errors {errors}, axisymmetric {axi}")
    assert errors[1] < errors[0] and errors[0] < 1e-3
    assert axi < 1e-3


# ------------------------------------------------------------------------------ bad input
def test_bad_problem_input():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    mesh = unit_square()
    with pytest.raises(ValueError, match="lam0"):  # drier than dry (1: the dry reference, tests/test_dry_reference.py)
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=0.99)
    with pytest.raises(ValueError, match="mu"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=2.0, mu=0.05)
    with pytest.raises(ValueError, match="dimension"):
        EquilibriumProblem(mesh, kinematics=Solid3D(), materials=gel, lam0=2.0)
    with pytest.raises(ValueError, match="region"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials={"nope": gel}, lam0=2.0)
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=2.0)
    with pytest.raises(ValueError, match="boundary"):
        prob.fix("nowhere")
    with pytest.raises(ValueError, match="component"):
        prob.fix("left", "z")
    with pytest.raises(ValueError, match="order"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=2.0, order=0)


def test_fix_dof_after_solve_fixes_it_at_zero_and_rejects_bad_dofs():
    from ngsolve.meshes import MakeStructured2DMesh

    from ngsgel.supports import vertex_dof

    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    prob = EquilibriumProblem(MakeStructured2DMesh(nx=2, ny=2), kinematics=PlaneStrain(), materials=gel,
                              lam0=gel.lam_free(-0.1), mu=-0.1)
    prob.fix("bottom")
    prob.mu.Set(-0.05)
    prob.solve()
    dof = vertex_dof(prob, point=(0.0, 1.0), component=0)
    assert prob.state.FV().NumPy()[dof] < -1e-3  # the swelling top corner moves outwards
    prob.fix_dof(dof)
    assert not prob.free_mask[dof]
    prob.mu.Set(-0.02)
    prob.solve()
    assert prob.state.FV().NumPy()[dof] == 0.0
    with pytest.raises(ValueError, match="already fixed"):
        prob.fix_dof(dof)
    with pytest.raises(ValueError, match="dof must be in"):
        prob.fix_dof(-1)
    with pytest.raises(ValueError, match="no mesh vertex"):
        vertex_dof(prob, point=(0.3, 0.3), component=0)


# ----------------------------------------------------------------------------- generalized plane strain
def _gps_problem(kind, gel, lam0, mu, materials=None):
    """A quarter section (rollers on the symmetry lines) or a radial line of an annulus."""
    if kind == "plane":
        mesh = unit_square()
        prob = EquilibriumProblem(mesh, kinematics=GeneralizedPlaneStrain(), materials=materials or gel, lam0=lam0,
                                  mu=mu, order=2)
        prob.fix("left", "x")
        prob.fix("bottom", "y")
    else:
        mesh = Make1DMesh(8, mapping=lambda t: 1.0 + t)
        prob = EquilibriumProblem(mesh, kinematics=PolarGeneralizedPlaneStrain(), materials=materials or gel,
                                  lam0=lam0, mu=mu, order=2)
    return mesh, prob


@pytest.mark.parametrize("kind", ["plane", "polar"])
@pytest.mark.parametrize("Nv, chi, mu0, mu1", [(1e-3, 0.5, 0.0, -5e-4), (1e-2, 0.2, -0.01, 0.0)])
def test_generalized_plane_strain_free_swelling_is_isotropic(kind, Nv, chi, mu0, mu1):
    """A free section of a long gel body with free ends swells or shrinks isotropically: the
    axial stretch (the global unknown) equals the in-plane stretches, both ``lam_free(mu1) /
    lam_free(mu0)``, the stress and the net axial force vanish."""
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    lam0 = gel.lam_free(mu0)
    mesh, prob = _gps_problem(kind, gel, lam0, mu0)
    ramp(prob, prob.mu, mu1)
    ratio = gel.lam_free(mu1) / lam0
    assert prob.axial_stretch() == pytest.approx(ratio, rel=1e-10)
    u = prob.displacement
    points = [(0.3, 0.7), (1.0, 1.0)] if kind == "plane" else [(1.2,), (2.0,)]
    for x in points:
        value = np.atleast_1d(u(mesh(*x)))
        assert value == pytest.approx((ratio - 1.0) * np.array(x), rel=1e-8)
    sigma = prob.stress()
    for i in range(3):
        assert abs(prob.integrate(sigma[i, i])) < 1e-10 * Nv
    assert abs(prob.axial_force()) < 1e-10 * Nv


def test_generalized_plane_strain_with_axial_dof_fixed_is_plane_strain():
    """Holding the axial unknown (``fix_dof(axial_dof)``) recovers plane strain: the same state
    as ``PlaneStrain`` to round-off, and the axial force is the constraint's reaction, the
    closed form ``sigma_zz`` times the current area of a plane-strain shrunk gel."""
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0, mu = gel.lam_free(0.0), -5e-4
    mesh, gps = _gps_problem("plane", gel, lam0, 0.0)
    gps.fix_dof(gps.axial_dof)
    plane = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=lam0, mu=0.0, order=2)
    plane.fix("left", "x")
    plane.fix("bottom", "y")
    for prob in (gps, plane):
        ramp(prob, prob.mu, mu)
    assert gps.axial_stretch() == 1.0
    ndof = plane.space.ndof
    assert np.max(np.abs(gps.save_state()[:ndof] - plane.save_state())) < 1e-12
    lam = gel.lam_plane_strain(mu, lam0)
    J = lam**2 * lam0
    sigma_zz = gel.Nv / J * (lam0**2 - 1) + gel._mix(J) - mu
    assert gps.axial_force() == pytest.approx(sigma_zz * (lam / lam0) ** 2, rel=1e-8)
    assert plane.axial_force() == pytest.approx(gps.axial_force(), rel=1e-12)
    assert sigma_zz > 0  # the shrinking gel pulls on its axial constraint


def test_generalized_plane_strain_bilayer_has_zero_net_axial_force():
    """A gel bonded to a film (left and right halves of a square section) under generalized plane
    strain: the film is squeezed axially and the gel pulled, and the two axial forces (computed
    from the Cauchy stress, not from the residual) cancel to round-off; the energy per unit
    length is below plane strain's (a minimum over a larger set)."""
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    lam0 = gel.lam_free(0.0)
    body = Rectangle(1, 1).Face()
    body.faces.name = "gel"
    film = Rectangle(1, 1).Face().Move((1, 0, 0))
    film.faces.name = "film"
    body.edges.Min(X).name = "left"
    for face in (body, film):
        face.edges.Min(Y).name = "bottom"
    shape = OCCGeometry(Glue([body, film]), dim=2)
    mesh = ngs.Mesh(shape.GenerateMesh(maxh=0.25))
    materials = {"gel": gel, "film": NeoHookeanFilm(E=3e-3, nu=0.3)}
    energies = {}
    for kin in (GeneralizedPlaneStrain(), PlaneStrain()):
        # the energy's quadrature rule is the one of ``integrate`` (order 2 p + 2): the residual's
        # axial entry is then the axial force integral on the same points
        prob = EquilibriumProblem(mesh, kinematics=kin, materials=materials, lam0=lam0, mu=0.0, order=2,
                                  quadrature_order=6)
        prob.fix("left", "x")
        prob.fix("bottom", "y")
        ramp(prob, prob.mu, -5e-4)
        energies[kin.name] = prob.energy()
        if kin.axial_unknown:
            gps = prob
    gel_force, film_force = gps.axial_force(region="gel"), gps.axial_force(region="film")
    assert gel_force > 0 > film_force
    assert abs(gel_force + film_force) < 1e-10 * gel_force
    assert 1.0 > gps.axial_stretch() > gel.lam_free(-5e-4) / lam0
    assert energies["generalized_plane"] < energies["plane"]


def test_imperfection_tools_leave_the_axial_unknown_alone():
    """``random_field`` perturbs only the displacement (unit RMS, zero on constrained dofs) and
    ``seed_imperfection`` moves the mesh by it; the global axial strain is not a displacement."""
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    mesh, prob = _gps_problem("plane", gel, gel.lam_free(0.0), 0.0)
    prob.solve()
    field = random_field(prob, correlation_length=0.5, seed=3)
    u, axial = prob.parts(field)
    assert field.vec.FV().NumPy()[prob.axial_dof] == 0.0
    assert np.all(field.vec.FV().NumPy()[~prob.free_mask] == 0.0)
    assert math.sqrt(prob.integrate(ngs.InnerProduct(u, u)) / prob.integrate(ngs.CF(1.0))) == pytest.approx(1.0, rel=1e-10)
    area = ngs.Integrate(ngs.CF(1.0), mesh, order=8)
    a = 1e-3
    grad = ngs.Grad(u)
    # in 2D the moved area is exactly area + a div u + a^2 det grad u, integrated
    expected = area + ngs.Integrate(a * ngs.Trace(grad) + a * a * ngs.Det(grad), mesh, order=8)
    seed_imperfection(prob, [field], [a])
    moved = ngs.Integrate(ngs.CF(1.0), mesh, order=8)
    mesh.UnsetDeformation()
    assert moved == pytest.approx(expected, rel=1e-12)
    assert abs(moved - area) > 1e-6  # the mesh did move
