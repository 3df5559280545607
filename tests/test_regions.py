"""Per-region and field-valued swollen references (``lam0`` per region or as a field).

The bilayer: a long plane-strain strip of two layers of the same gel family with different
cross-link densities, each referenced at its own free swelling at a common ``mu0``. At ``mu0``
the undeformed strip is an equilibrium with zero stress in both layers; a small step of ``mu``
bends it by Timoshenko's bimetal-strip formula, with the layers' plane-strain drained moduli and
plane-strain free swelling strains at ``mu0``.
"""

import math

import numpy as np
import ngsolve as ngs
import pytest

from geometries.common import tensor_mesh_2d, to_ngsolve
from ngsgel import EquilibriumProblem, FloryRehnerGel, NeoHookeanFilm, PlaneStrain, TransientProblem
from ngsgel.supports import pin_vertex_component

CHI, MU0 = 0.5, -0.005
# at MU0 their free swelling strains per unit mu differ by a factor 1.8 and their moduli by 9
SOFT, STIFF = FloryRehnerGel(Nv=1e-3, chi=CHI), FloryRehnerGel(Nv=1e-2, chi=CHI)
THICKNESS, HALF_LENGTH = 1.0, 10.0  # each layer half the thickness; the strip is 20 thick long


def bilayer_mesh(n: int) -> ngs.Mesh:
    """Half of the strip, ``[0, HALF_LENGTH] x [0, THICKNESS]``, ``10 n x 2 n`` cells split into
    triangles: "bottom" layer (stiff) under "top" (soft), symmetry line "sym" at x = 0."""
    nx, ny = 10 * n, 2 * n
    ngmesh = tensor_mesh_2d(np.linspace(0, HALF_LENGTH, nx + 1), np.linspace(0, THICKNESS, ny + 1),
                            mapping=lambda x, y: (x, y), region=lambda i, j: "bottom" if j < ny // 2 else "top",
                            sides={"s_min": "sym", "s_max": "end", "t_min": "base", "t_max": "surface"}, quad=False)
    return to_ngsolve(ngmesh, 1)


def bilayer(mesh: ngs.Mesh, lam0=None) -> EquilibriumProblem:
    lam0 = {"top": SOFT.lam_free(MU0), "bottom": STIFF.lam_free(MU0)} if lam0 is None else lam0
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials={"top": SOFT, "bottom": STIFF},
                              lam0=lam0, mu=MU0)
    prob.fix("sym", "x")
    pin_vertex_component(prob, point=(0.0, 0.0), component=1)  # the last rigid motion
    return prob


def free_residual(prob) -> float:
    r = prob.state.CreateVector()
    prob.residual(prob.state, r)
    return float(np.linalg.norm(r.FV().NumPy()[prob.free_mask]))


def plane_strain_layer(gel: FloryRehnerGel, lam0: float) -> tuple[float, float]:
    """Drained plane-strain modulus ``E / (1 - nu^2)`` and in-plane free swelling strain per unit
    ``mu`` at fixed out-of-plane stretch, ``(1 + nu) / (3 K)``, about free swelling at ``lam0``."""
    G, K = gel.shear_modulus(lam0), gel.bulk_modulus(lam0)
    E, nu = 9 * K * G / (3 * K + G), (3 * K - 2 * G) / (2 * (3 * K + G))
    return E / (1 - nu**2), (1 + nu) / (3 * K)


def timoshenko_curvature_rate() -> float:
    """``d kappa / d mu`` of the strip (Timoshenko 1925, bimetal strip): layer 1 the stiff bottom,
    2 the soft top; positive: concave towards the stiff, less swelling, layer (u_y falls with x)."""
    E1, e1 = plane_strain_layer(STIFF, STIFF.lam_free(MU0))
    E2, e2 = plane_strain_layer(SOFT, SOFT.lam_free(MU0))
    h1 = h2 = THICKNESS / 2
    m, n, h = h1 / h2, E1 / E2, h1 + h2
    return 6 * (e2 - e1) * (1 + m) ** 2 / (h * (3 * (1 + m) ** 2 + (1 + m * n) * (m**2 + 1 / (m * n))))


def test_layer_moduli_give_the_free_swelling_strain():
    # (1 + nu)/(3K) is the plane-strain free swelling strain per mu: the derivative of the
    # closed-form plane-strain swelling at the reference's out-of-plane stretch
    for gel in (SOFT, STIFF):
        lam0, d = gel.lam_free(MU0), 1e-6
        rate = (gel.lam_plane_strain(MU0 + d, lam0) - gel.lam_plane_strain(MU0 - d, lam0)) / (2 * d * lam0)
        assert plane_strain_layer(gel, lam0)[1] == pytest.approx(rate, rel=1e-7)


def test_bilayer_reference_is_stress_free_in_each_layer():
    mesh = bilayer_mesh(1)
    prob = bilayer(mesh)
    floor = prob.residual_floor
    assert free_residual(prob) < floor  # round-off: the floor is the residual's round-off level
    sigma = prob.stress()
    for point, gel in (((5.0, 0.25), STIFF), ((5.0, 0.75), SOFT)):
        values = np.array(sigma(mesh(*point)))
        assert np.max(np.abs(values)) < 1e-13 * gel.Nv, point
    # a single reference (the soft layer's) leaves the stiff layer prestressed: the test can fail
    single = bilayer(mesh, lam0=SOFT.lam_free(MU0))
    assert free_residual(single) > 1e6 * floor


@pytest.mark.parametrize("n", [1, 2])
def test_bilayer_curves_by_timoshenko(n):
    # Linear response from a symmetric difference of two small mu steps (the O(dmu) geometric
    # nonlinearity cancels; the O(dmu^2) rest measured 2.9e-4 at dmu = 1e-4, 3e-6 at 1e-5). The far
    # field of the linear strip, strain linear in y in each layer, lies in the P2 space, so the
    # mesh only enters through the end zone 5 thicknesses away: meshes n = 1, 2, 4 agree to 1e-7
    # of the curvature. The curvature is the second difference of u_y along the mid-line,
    # u_y = -kappa x^2 / 2 + g(y), between the symmetry line and x = 5.
    mesh = bilayer_mesh(n)
    prob = bilayer(mesh)
    dmu, c = 1e-6, 5.0
    curvature = []
    for sign in (1, -1):
        prob.state[:] = 0.0
        prob.mu.Set(MU0 + sign * dmu)
        prob.solve()
        u = prob.displacement
        curvature.append(-2 * (u(mesh(c, 0.5))[1] - u(mesh(0.0, 0.5))[1]) / c**2)
    rate = (curvature[0] - curvature[1]) / (2 * dmu)
    assert rate == pytest.approx(timoshenko_curvature_rate(), rel=1e-6)


def test_field_reference_of_a_graded_gel_is_stress_free():
    # Nv graded through the thickness, lam0(y) its free swelling at MU0 pointwise: Nv follows
    # from the free-swelling equation solved for Nv at the chosen lam0(y)
    mesh = bilayer_mesh(1)
    lam0 = 1.55 + 0.05 * ngs.y
    J = lam0**3
    Nv = (MU0 - (ngs.log(1 - 1 / J) + 1 / J + CHI / J**2)) / (1 / lam0 - 1 / J)
    gel = FloryRehnerGel(Nv=Nv, chi=CHI)
    assert 1e-3 < Nv(mesh(0.0, 1.0)) < Nv(mesh(0.0, 0.0)) < 1e-2
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=lam0, mu=MU0)
    prob.fix("sym", "x")
    pin_vertex_component(prob, point=(0.0, 0.0), component=1)
    assert free_residual(prob) < prob.residual_floor
    assert np.max(np.abs(prob.stress()(mesh(5.0, 0.4)))) < 1e-15
    uniform = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=1.575, mu=MU0)
    assert free_residual(uniform) > 1e6 * prob.residual_floor
    with pytest.raises(ValueError, match="lam0 differs between the gel regions or is a field"):
        prob.lam0


def test_transient_bilayer_rests_at_its_reference():
    # each layer's solvent content (J' - lam0^-3 per reference volume) and the kinetics use its
    # own reference: immersed at MU0, nothing moves and the content is the layers' sum
    mesh = bilayer_mesh(1)
    lam0 = {"top": SOFT.lam_free(MU0), "bottom": STIFF.lam_free(MU0)}
    prob = TransientProblem(mesh, kinematics=PlaneStrain(), materials={"top": SOFT, "bottom": STIFF},
                            lam0=lam0, mu0=MU0)
    prob.fix("sym", "x")
    prob.fix("base", "y")
    prob.immerse("surface", MU0)
    prob.form  # built: the state and its content
    area = HALF_LENGTH * THICKNESS / 2
    assert prob.initial_content == pytest.approx(sum(area * (1 - lam**-3) for lam in lam0.values()), rel=1e-13)
    record = prob.step_to(1.0)
    assert np.max(np.abs(prob.displacement.vec.FV().NumPy())) < 1e-12
    assert abs(record.step_uptake) < 1e-12 * prob.initial_content


def test_lam0_forms_and_errors():
    mesh = bilayer_mesh(1)
    materials = {"top": SOFT, "bottom": STIFF}
    prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials, lam0=1.6)
    assert prob.lam0 == 1.6 and prob.lam0_of("top") == 1.6 and prob.lam0_field == 1.6
    with pytest.raises(ValueError, match="lam0 is required: regions \\['bottom', 'top'\\] hold gels"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials)
    with pytest.raises(ValueError, match="lam0 has no value for the gel regions \\['bottom'\\]"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials, lam0={"top": 1.6})
    with pytest.raises(ValueError, match="unknown region 'middle'"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials,
                           lam0={"top": 1.6, "bottom": 1.5, "middle": 1.2})
    with pytest.raises(ValueError, match="lam0 of region 'top' must be a number >= 1"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials, lam0={"top": 0.9, "bottom": 1.5})
    with pytest.raises(ValueError, match="lam0 of region 'top' is a field below 1"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials, lam0=1.5 - ngs.y)
    with pytest.raises(ValueError, match="scalar CoefficientFunction"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=materials, lam0=ngs.CF((1.5, 1.5)))
    # films are stress-free in the mesh: no lam0 needed, and none accepted for them
    film = NeoHookeanFilm(E=1.0, nu=0.3)
    with_film = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials={"top": film, "bottom": STIFF},
                                   lam0={"bottom": 1.5})
    assert with_film.lam0 == 1.5 and with_film.lam0_of("top") == 1.0
    assert EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=film).lam0 == 1.0
    with pytest.raises(ValueError, match="lam0 is given for region 'top', whose NeoHookeanFilm is stress-free"):
        EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials={"top": film, "bottom": STIFF},
                           lam0={"top": 1.5, "bottom": 1.5})
    mixed = bilayer(mesh)
    with pytest.raises(ValueError, match="use lam0_of\\(region\\) or lam0_field"):
        mixed.lam0
    assert mixed.lam0_of("top") == SOFT.lam_free(MU0)
    assert math.isclose(mixed.volume_ratio()(mesh(1.0, 0.75)), SOFT.lam_free(MU0) ** 3, rel_tol=1e-14)
