"""A dry reference (``lam0 = 1``): a layer bonded to a rigid substrate in the dry state.

The mesh is the dry layer. Bonded at its base and in plane strain (or with rollers on the
sides in 3D), its lateral stretches stay 1 (the out-of-plane one from the kinematics, not from
``lam0``), and it swells in thickness only, to the constrained-swelling closed form from dry
(Hong et al. 2008; MODEL.md section 2 with ``lamL = 1``):

    Nv (lam - 1/lam) + ln(1 - 1/lam) + 1/lam + chi/lam^2 = mu,   J = lam.

``W`` is finite at ``J = 1`` but its mixing pressure ``ln(1 - 1/J)`` is ``-inf`` there, so the
undeformed dry mesh is outside the admissible set: solves start from a swollen state.
"""

import numpy as np
import ngsolve as ngs
import pytest
from ngsolve.meshes import MakeStructured2DMesh, MakeStructured3DMesh

from ngsgel import EquilibriumProblem, FloryRehnerGel, NewtonError, PlaneStrain, Solid3D, TransientProblem, march

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)


def bonded_layer(kinematics, mu, **options) -> EquilibriumProblem:
    """Unit layer bonded at the bottom, lateral faces on rollers (a cell of an infinite layer)."""
    if kinematics == "plane":
        prob = EquilibriumProblem(MakeStructured2DMesh(nx=1, ny=4), kinematics=PlaneStrain(), materials=GEL,
                                  lam0=1.0, mu=mu, **options)
        prob.fix("bottom")
        prob.fix("left|right", "x")
    else:  # MakeStructured3DMesh: bottom z = 0, back/front x = 0/1, left/right y = 0/1
        prob = EquilibriumProblem(MakeStructured3DMesh(nx=1, ny=1, nz=3), kinematics=Solid3D(), materials=GEL,
                                  lam0=1.0, mu=mu, **options)
        prob.fix("bottom")
        prob.fix("back|front", "x")
        prob.fix("left|right", "y")
    return prob


def swell_from(prob, stretch: float) -> None:
    """Uniform thickness stretch ``stretch`` from the dry mesh: an admissible start."""
    up = ngs.y if prob.mesh.dim == 2 else ngs.z
    prob.displacement.Set(ngs.CF((0, (stretch - 1) * up) if prob.mesh.dim == 2 else (0, 0, (stretch - 1) * up)))


@pytest.mark.parametrize("kinematics", ["plane", "solid3d"])
@pytest.mark.parametrize("mu", [-1.0, -0.1, 0.0])
def test_dry_bonded_layer_swells_to_the_constrained_closed_form(kinematics, mu):
    prob = bonded_layer(kinematics, mu)
    swell_from(prob, 1.5)  # Newton goes from J = 1.5 to J = 1.11 ... 4.53
    prob.solve()
    lam = GEL.lam_constrained(mu, 1.0)
    top = (0.5, 1.0) if kinematics == "plane" else (0.5, 0.5, 1.0)
    # the deformation is homogeneous: the P2 solution is exact
    stretches = np.diag(prob.evaluate(prob.deformation_gradient(prob.displacement), top))
    thickness = 2 if kinematics == "solid3d" else 1
    assert stretches[thickness] == pytest.approx(lam, rel=1e-12)
    assert np.delete(stretches, thickness) == pytest.approx([1.0, 1.0], abs=1e-13)
    # the lateral constraint carries sigma_lateral = Pi(J, mu) = -Nv (lam^2 - 1)/lam
    sigma = np.diag(prob.evaluate(prob.stress(), top))
    lateral = -GEL.Nv * (lam**2 - 1) / lam
    assert np.delete(sigma, thickness) == pytest.approx([lateral, lateral], rel=1e-9)
    assert sigma[thickness] == pytest.approx(0.0, abs=1e-9 * abs(lateral))


def test_energy_is_finite_at_the_dry_state_and_the_mixing_pressure_is_not():
    # J = 1 + s: W -> -chi - Nv/2 ... like s ln s (the mixing term (J-1) ln(1 - 1/J)), while
    # Pi = ln(1 - 1/J) + 1/J + chi/J^2 - mu -> ln s + 1 + chi: the dry state has finite energy
    # and infinite osmotic suction, so lam0 = 1 is a usable reference but no starting state
    mesh = MakeStructured2DMesh(nx=1, ny=1)  # kept: a MeshPoint does not hold its mesh
    point = mesh(0.5, 0.5)
    chi = GEL.chi
    for s in (1e-4, 1e-8, 1e-12):
        F = ngs.CF((1 + s, 0, 0, 0, 1, 0, 0, 0, 1), dims=(3, 3))
        W = GEL.energy(F, 0.0)(point)
        nv_part = GEL.Nv / 2 * ((1 + s) ** 2 - 1 - 2 * np.log1p(s))
        assert W - nv_part + chi / (1 + s) == pytest.approx(s * np.log(s), rel=1e-3)
        # O(s) from the expansion, eps/s from rounding 1 - 1/J (why J - 1 < 2e-12 is out of reach)
        rounding = np.finfo(float).eps / s
        assert GEL.mixing_pressure(ngs.CF(1 + s), 0.0)(point) == pytest.approx(np.log(s) + 1 + chi,
                                                                               abs=10 * (s + rounding))


def test_dry_mesh_itself_is_not_a_starting_state():
    prob = bonded_layer("plane", -0.1)
    with pytest.raises(NewtonError, match="starting state is not admissible"):
        prob.solve()
    transient = TransientProblem(MakeStructured2DMesh(nx=1, ny=4), kinematics=PlaneStrain(), materials=GEL,
                                 lam0=1.0, mu0=-1.0)
    transient.immerse("top", -0.1)
    with pytest.raises(ValueError, match="with a dry reference \\(lam0 = 1\\).*reset\\(equilibrium=...\\)"):
        march(transient, 1.0)


def test_dry_bonded_layer_immersed_reaches_the_closed_form():
    # from its equilibrium at mu0 = -1 (J = 1.11) to the bath's mu = -0.1 (J = 1.80): the
    # equilibrium limit of the transient model with a dry reference, and the solvent taken up
    # is the closed forms' difference (solvent volume per dry volume: J - 1)
    mu0, bath = -1.0, -0.1
    mesh = MakeStructured2DMesh(nx=1, ny=4)
    start = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=GEL, lam0=1.0, mu=mu0, quadrature_order=4)
    start.fix("bottom")
    start.fix("left|right", "x")
    swell_from(start, 1.2)
    start.solve()
    prob = TransientProblem(mesh, kinematics=PlaneStrain(), materials=GEL, lam0=1.0, mu0=mu0)
    prob.fix("bottom")
    prob.fix("left|right", "x")
    prob.immerse("top", bath)
    prob.reset(equilibrium=start)
    march(prob, 1e4, output_times=[1e4])
    lam = 1 + prob.evaluate(prob.displacement, (0.5, 1.0))[1]
    assert lam == pytest.approx(GEL.lam_constrained(bath, 1.0), rel=1e-9)
    assert prob.uptake == pytest.approx(GEL.lam_constrained(bath, 1.0) - GEL.lam_constrained(mu0, 1.0), rel=1e-9)
