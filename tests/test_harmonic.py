"""Non-axisymmetric stability of axisymmetric states by angular wave number (ngsgel.harmonic)."""

from __future__ import annotations

import numpy as np
import ngsolve as ngs
import pytest
from netgen.occ import Cylinder, OCCGeometry, Pnt, Z

from geometries.basic import rectangle
from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, PlaneStrain, ramp
from ngsgel.harmonic import HarmonicStability, first_harmonic_instability, stress_rate

X, Y, ZC = ngs.x, ngs.y, ngs.z


def base_displacement(r, z):
    return 0.05 * r + 0.04 * z * z, -0.03 * z + 0.02 * r * z


def amplitudes(r, z):
    return r * z, r * r - z, 0.5 + z * r


def test_second_variation_equals_the_3d_energy_along_a_harmonic_perturbation():
    # A tube: the section's quadratic form for wave number k against the second difference of
    # the 3D energy along u0 + eps (a cos k th, b cos k th, c sin k th), with both fields exact
    # (polynomials in the section space; analytic in 3D). A wrong entry of the perturbed F
    # gives O(1) errors (e.g. dropping the torsion term at k = 0: 10x); measured <= 9e-5,
    # limited by the curved 3D geometry and quadrature.
    gel = FloryRehnerGel(Nv=5e-3, chi=0.4)
    lam0, mu = 1.3, -0.1
    Ri, Ro, L = 0.3, 0.6, 0.5
    section = rectangle(width=Ro - Ri, height=L, origin=(Ri, 0.0), maxh=0.05).mesh
    prob = EquilibriumProblem(section, kinematics=Axisymmetric(), materials=gel, lam0=lam0, mu=mu, order=3)
    prob.displacement.Set(ngs.CF(base_displacement(X, Y)))
    hs = HarmonicStability(prob, axis=None)

    tube = Cylinder(Pnt(0, 0, 0), Z, Ro, L) - Cylinder(Pnt(0, 0, 0), Z, Ri, L)
    mesh3 = ngs.Mesh(OCCGeometry(tube).GenerateMesh(maxh=0.15))
    mesh3.Curve(4)
    r = ngs.sqrt(X * X + Y * Y)
    theta = ngs.atan2(Y, X)

    def energy_3d(eps, k):
        ur, uz = base_displacement(r, ZC)
        a, b, c = amplitudes(r, ZC)
        Ur = ur + eps * a * ngs.cos(k * theta)
        Ut = eps * c * (ngs.sin(k * theta) if k else 1.0)
        Uz = uz + eps * b * ngs.cos(k * theta)
        U = (Ur * X / r - Ut * Y / r, Ur * Y / r + Ut * X / r, Uz)
        F = ngs.Id(3) + ngs.CF(tuple(Ui.Diff(v) for Ui in U for v in (X, Y, ZC)), dims=(3, 3))
        return ngs.Integrate(gel.reference_energy(F, ngs.CF(mu), lam0), mesh3, order=10)

    eps = 1e-3
    for k in (0, 1, 2, 3):
        K, _, free = hs.matrices(k)
        v = hs.vector(k, *amplitudes(X, Y))[free]
        quadratic = v @ (K @ v)
        second_difference = (energy_3d(eps, k) - 2 * energy_3d(0.0, k) + energy_3d(-eps, k)) / eps**2
        assert quadratic == pytest.approx(second_difference, rel=1e-3), k


def free_graded_cylinder():
    # graded (stressed) cylinder resting on a frictionless base: free to translate sideways and
    # to turn about its axis, swollen from -0.2 to -0.05
    gel = FloryRehnerGel(Nv=1e-3 + 4e-3 * X**2, chi=0.5)
    mesh = rectangle(width=0.5, height=1.0, maxh=0.1).mesh
    prob = EquilibriumProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=1.3, mu=-0.2)
    prob.fix("left", "r")
    prob.fix("bottom", "z")
    prob.solve()
    assert ramp(prob, prob.mu, -0.05).converged
    return prob


def test_rigid_motions_are_exact_zero_modes_and_are_excluded():
    prob = free_graded_cylinder()
    hs = HarmonicStability(prob, axis="left")
    for k, count in ((0, 1), (1, 1), (2, 0)):
        rigid = hs.rigid_modes(k)
        assert rigid.shape[1] == count
        K, _, _ = hs.matrices(k)
        for v in rigid.T:
            assert np.linalg.norm(K @ v) <= 1e-12 * abs(K).max() * np.linalg.norm(v)
    for k in (0, 1):
        plain = hs.spectrum(k, count=3)
        excluded = hs.spectrum(k, count=2, exclude_rigid=True)
        assert abs(plain.eigenvalues[0]) < 1e-10 * plain.eigenvalues[1]
        assert excluded.eigenvalues == pytest.approx(plain.eigenvalues[1:], rel=1e-8)
        assert excluded.negative == 0


def test_euler_buckling_of_a_gel_rod_is_the_first_harmonic_instability():
    # Clamped base, top pushed down without lateral restraint but kept flat (clamped-guided):
    # Euler's strain pi^2 I / (A L^2) = pi^2 R^2 / (4 L^2), mode k = 1. Measured onset/Euler - 1:
    # 0.64 %, 0.32 %, 0.25 % with 20, 40, 80 cells along the rod (finite strain, shear).
    gel = FloryRehnerGel(Nv=1e-2, chi=0.4)
    lam0 = 1.5
    R, L = 0.05, 1.0
    euler = np.pi**2 * R**2 / (4 * L**2)
    mesh = rectangle(width=R, height=L, maxh=1.0, structured=True, nx=1, ny=20).mesh
    prob = EquilibriumProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=lam0, mu=gel.mu_free(lam0))
    shortening = ngs.Parameter(0.0)
    prob.fix("left", "r")
    prob.fix("bottom")
    prob.prescribe("top", "z", -shortening)
    onset = first_harmonic_instability(prob, shortening, 2 * euler * L, ks=[0, 1, 2], step=0.25 * euler,
                                       tolerance=1e-7, stability=HarmonicStability(prob, axis="left"))
    assert onset.found and onset.k == 1
    assert onset.parameter / L == pytest.approx(euler, rel=0.01)
    # finite strain (a compressed gel rod thickens) stiffens it more than shear softens it (the
    # linearised buckling step below: -2.1 %)
    assert onset.parameter / L > euler
    # the problem is left at the last stable state
    assert shortening.Get() < onset.parameter


def test_bad_input():
    gel = FloryRehnerGel(Nv=1e-2, chi=0.4)
    mesh = rectangle(width=1.0, height=1.0, maxh=0.5).mesh
    plane = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=1.5)
    with pytest.raises(ValueError, match="Axisymmetric"):
        HarmonicStability(plane)
    axi = EquilibriumProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=1.5)
    with pytest.raises(ValueError, match="axis"):
        HarmonicStability(axi, axis="nonexistent")
    hs = HarmonicStability(axi, axis="left")
    with pytest.raises(ValueError, match="k"):
        hs.spectrum(-1)


def _gel_rod(*, clamped: bool, nx: int = 1, ny: int = 20, order: int = 2):
    """The rod of the Euler test with its top shortened by a parameter; the base clamped, or on
    rollers (then the compression is homogeneous)."""
    gel = FloryRehnerGel(Nv=1e-2, chi=0.4)
    lam0 = 1.5
    mesh = rectangle(width=0.05, height=1.0, maxh=1.0, structured=True, nx=nx, ny=ny).mesh
    prob = EquilibriumProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=lam0, mu=gel.mu_free(lam0),
                              order=order)
    shortening = ngs.Parameter(0.0)
    prob.fix("left", "r")
    prob.fix("bottom", *(() if clamped else ("z",)))
    prob.prescribe("top", "z", -shortening)
    prob.solve()
    return prob, shortening, gel, lam0, mesh


def test_stress_rate_of_homogeneous_compression_is_the_drained_uniaxial_modulus():
    prob, shortening, gel, lam0, mesh = _gel_rod(clamped=False)
    state = prob.save_state()
    rate = stress_rate(prob, shortening)
    assert shortening.Get() == 0.0 and np.array_equal(prob.save_state(), state)
    # lateral faces free, solvent free to leave (fixed mu): S_zz per unit shortening is -E / L
    # with the drained Young's modulus of the swollen gel; nothing else is stressed
    E = 2 * gel.shear_modulus(lam0) * (1 + gel.drained_poisson_ratio(lam0))
    for point in ((0.01, 0.1), (0.04, 0.5), (0.025, 0.93)):
        here = mesh(*point)
        assert rate[1, 1](here) == pytest.approx(-E, rel=1e-5)
        for i, j in ((0, 0), (2, 2), (0, 1)):
            assert abs(rate[i, j](here)) < 1e-6 * E
    with pytest.raises(ValueError, match="relative_step"):
        stress_rate(prob, shortening, relative_step=0.0)


def test_linear_buckling_of_the_unloaded_gel_rod_is_timoshenkos_column():
    # The eigenvalue buckling step from the unloaded, clamped rod (stress per unit shortening,
    # linearised pre-buckling, no change of the cross-section): Euler's shortening lowered by
    # shear, Timoshenko's P_E / (1 + P_E / (kappa G A)) with Cowper's kappa = 6 (1 + nu) / (7 + 6 nu)
    # for a circular section: -1.95 % against Euler. Measured -1.68 % (1 x 20 cells, order 2),
    # -1.99 % (2 x 40), -2.08 % (2 x 40, order 3), -2.11 % (4 x 80, order 3). Ovalisation
    # (k = 2, 3) comes far later.
    prob, shortening, gel, lam0, _ = _gel_rod(clamped=True, nx=2, ny=40, order=3)
    R, L = 0.05, 1.0
    euler = np.pi**2 * R**2 / (4 * L**2)
    nu = gel.drained_poisson_ratio(lam0)
    kappa = 6 * (1 + nu) / (7 + 6 * nu)
    timoshenko = euler / (1 + euler * 2 * (1 + nu) / kappa)  # E / G = 2 (1 + nu)
    hs = HarmonicStability(prob, axis="left")
    rate = stress_rate(prob, shortening)
    lam1 = hs.linear_buckling(1, rate)[0]
    assert lam1 / L == pytest.approx(timoshenko, rel=3e-3)
    for k in (2, 3):
        assert hs.linear_buckling(k, rate)[0] > 20 * lam1


def test_a_pinned_vertex_removes_the_rigid_modes_of_its_ring():
    # the free cylinder's rigid turn (k = 0) and sideways shift (k = 1) are zero modes; a ring
    # held at the base's outer edge (every component of the perturbation zero there) removes both
    prob = free_graded_cylinder()
    plain = HarmonicStability(prob, axis="left")
    pinned = HarmonicStability(prob, axis="left", pins=[(0.5, 0.0)])
    for k in (0, 1):
        assert pinned.rigid_modes(k).shape[1] == 0
        free_plain, free_pinned = plain.matrices(k)[2], pinned.matrices(k)[2]
        assert free_plain.sum() - free_pinned.sum() == 2  # r and theta of the vertex (z is held on the base)
        without, held = plain.spectrum(k, count=5), pinned.spectrum(k, count=2)
        assert abs(without.eigenvalues[0]) < 1e-10 * without.eigenvalues[1]
        # three constraints: the lowest eigenvalue rises from the rigid zero to at most the fourth
        assert held.negative == 0 and 1e-3 * without.eigenvalues[1] < held.eigenvalues[0] <= without.eigenvalues[3]
    with pytest.raises(ValueError, match="no mesh vertex"):
        HarmonicStability(prob, axis="left", pins=[(0.25, 0.013)])


def test_scan_reports_the_lowest_eigenvalue_of_a_wave_number_with_two_negative_ones():
    # The straight clamped-guided rod past 4x Euler's strain has two unstable k = 1 modes (one and
    # two half-waves of sway); shift-invert about zero finds the one nearest zero first.
    prob, shortening, *_ = _gel_rod(clamped=True)
    euler = np.pi**2 * 0.05**2 / 4
    ramp(prob, shortening, 4.6 * euler, step=euler)
    hs = HarmonicStability(prob, axis="left")
    all_three = hs.spectrum(1, count=3, exclude_rigid=True)
    assert all_three.negative == 2 and all_three.eigenvalues[0] < all_three.eigenvalues[1] < 0
    nearest_zero = hs.spectrum(1, count=1, exclude_rigid=True).eigenvalues[0]
    assert nearest_zero == pytest.approx(all_three.eigenvalues[1], rel=1e-8)
    scan = hs.scan([1], exclude_rigid=True)
    assert scan.lowest[1] == pytest.approx(all_three.eigenvalues[0], rel=1e-8) and scan.unstable == [1]
