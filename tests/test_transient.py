"""Transient swelling (issue 3): linear limit, equilibrium limit, solvent balance, stability,
large swelling, axisymmetric against a spherically symmetric reference, the layer script."""

import math
import time

import numpy as np
import ngsolve as ngs
import pytest
from netgen.occ import Circle, OCCGeometry, Rectangle, X, Y
from ngsolve.meshes import Make1DMesh, MakeStructured2DMesh

from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, PlaneStrain, SphericalSymmetric
from ngsgel.transient import TransientProblem, march, time_ramp

EPS = np.finfo(float).eps


def assert_balanced(prob, result):
    """Every step: the change of solvent content equals the solvent that entered, to 1e-8 of the
    solvent exchanged so far (near steady state a step moves almost nothing and its own change
    is at the Newton residual's round-off), and the running totals agree to 1e-8."""
    for r in result.records:
        floor = 64 * EPS * abs(r.content)  # round-off of the content integrals
        assert abs(r.balance_error) <= 1e-8 * max(abs(r.step_uptake), abs(r.uptake)) + floor, r
        assert abs(r.uptake - r.exchanged) <= 1e-8 * abs(r.uptake) + floor, r
    assert abs(result.records[-1].content - prob.initial_content - result.records[-1].uptake) <= 1e-12


def column(gel, mu0, *, ny, order=2, mu_order=None, lumped=None, grading=1, quads=False, width=0.1):
    """Layer of unit thickness on a rigid impermeable base, laterally constrained (rollers):
    one element across, a 1D problem. ``grading`` > 1 refines towards the wetted top."""
    mesh = MakeStructured2DMesh(nx=1, ny=ny, quads=quads, mapping=lambda x, y: (width * x, 1 - (1 - y) ** grading))
    prob = TransientProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=gel.lam_free(mu0), mu0=mu0,
                            order=order, mu_order=mu_order, lumped=lumped)
    prob.fix("bottom")
    prob.fix("left|right", "x")
    return prob


# ------------------------------------------------------------------------------ linear limit
def terzaghi(T: float) -> float:
    return 1 - sum(8 / ((2 * m + 1) ** 2 * math.pi**2) * math.exp(-((2 * m + 1) ** 2) * math.pi**2 * T / 4)
                   for m in range(200))


def test_terzaghi_linear_limit():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    mu0, dmu = -0.1, 1e-4
    lam0 = gel.lam_free(mu0)
    K, G = gel.bulk_modulus(lam0), gel.shear_modulus(lam0)
    Dc = (1 - lam0**-3) * (K + 4 * G / 3)
    width = 0.1
    final = width * (gel.lam_constrained(mu0 + dmu, lam0) / lam0 - 1)
    Ts = np.geomspace(1e-4, 2.0, 30)
    rows = []
    for ny, ratio in ((8, 0.2), (16, 0.1), (32, 0.05)):
        prob = column(gel, mu0, ny=ny, grading=3, width=width)
        prob.immerse("top", mu0 + dmu)
        # the steps refined here are backward Euler's at dt = ratio * t (no error control)
        result = march(prob, Ts[-1] / Dc, scheme="backward_euler", rtol=None, dt_start=1e-6 / Dc, dt_over_t=ratio,
                       grow=ratio + 1, output_times=Ts / Dc)
        assert_balanced(prob, result)
        T = np.array([r.time * Dc for r in result.outputs])
        U = np.array([r.uptake / final for r in result.outputs])
        late = np.max(np.abs(U - [terzaghi(t) for t in T])[T >= 0.01])
        early_mask = T <= 0.01
        early = np.max(np.abs(U[early_mask] / (2 * np.sqrt(T[early_mask] / np.pi)) - 1))
        rows.append((ny, ratio, result.steps, late, early))
    print("\nTerzaghi: ny  dt/t  steps  max|U-U_T| (T>=0.01)  max rel. err vs 2 sqrt(T/pi) (1e-4<=T<=0.01)")
    for row in rows:
        print("          %3d  %.3f  %4d  %.3e  %.3e" % row)
    late, early = np.array([r[3] for r in rows]), np.array([r[4] for r in rows])
    assert late[-1] < 0.01 and early[-1] < 0.01
    assert np.all(np.diff(late) < 0) and np.all(np.diff(early) < 0)


# -------------------------------------------------------------------------- equilibrium limit
def equilibrium_limit(mesh, kinematics, gel, fixes, wetted, *, mu0, mu1, graded):
    lam0 = FloryRehnerGel(Nv=5e-3, chi=gel.chi).lam_free(mu0) if graded else gel.lam_free(mu0)

    def equilibrium():
        # the transient problem pins the quadrature at 2 order: the same discrete energy
        eq = EquilibriumProblem(mesh, kinematics=kinematics, materials=gel, lam0=lam0, mu=mu0, quadrature_order=4)
        for boundary, comp in fixes:
            eq.fix(boundary, comp)
        eq.solve()
        return eq

    start = equilibrium()
    if graded:  # the uniformly swollen reference is not stress-free: start from equilibrium
        assert np.max(np.abs(start.state.FV().NumPy())) > 1e-5
    prob = TransientProblem(mesh, kinematics=kinematics, materials=gel, lam0=lam0, mu0=mu0)
    for boundary, comp in fixes:
        prob.fix(boundary, comp)
    prob.immerse(wetted, mu1)
    prob.reset(equilibrium=start)
    result = march(prob, 1e6, dt_start=1e-6, output_times=[1.0, 100.0])
    assert_balanced(prob, result)
    final = equilibrium()
    final.mu.Set(mu1)
    final.solve(maxit=60)
    u_eq = final.state.FV().NumPy()
    u_tr = prob.displacement.vec.FV().NumPy()
    mu_tr = prob.chemical_potential.vec.FV().NumPy()
    ones = np.zeros_like(mu_tr)
    ones[: mesh.nv] = 1.0  # vertex dofs of the mu space: the constant has 1 there, 0 elsewhere
    du = np.max(np.abs(u_tr - u_eq)) / np.max(np.abs(u_eq))
    dmu = np.max(np.abs(mu_tr - mu1 * ones))
    print(f"\n{kinematics.name}: {result.steps} steps, {result.cutbacks} cut-backs; "
          f"max|u - u_eq| / max|u_eq| = {du:.2e}, max|mu - mu_ext| = {dmu:.2e}")
    assert du < 1e-8 and dmu < 1e-8
    return result


def test_equilibrium_limit_bonded_plane_strain():
    # a block bonded to a rigid base (bottom), immersed on top and on its free side
    mesh = MakeStructured2DMesh(nx=4, ny=2, quads=False, mapping=lambda x, y: (2 * x, 0.5 * y))
    equilibrium_limit(mesh, PlaneStrain(), FloryRehnerGel(Nv=1e-3, chi=0.5), [("bottom", None), ("left", "x")],
                      "top|right", mu0=-0.3, mu1=-0.05, graded=False)


def test_equilibrium_limit_graded_axisymmetric():
    # disk, half thickness (mid-plane z = 0 symmetric), Nv rising from centre to rim
    mesh = MakeStructured2DMesh(nx=4, ny=2, quads=False, mapping=lambda x, y: (x, 0.2 * y))
    gel = FloryRehnerGel(Nv=1e-3 + 9e-3 * ngs.x**2, chi=0.5)
    equilibrium_limit(mesh, Axisymmetric(), gel, [("left", "r"), ("bottom", "z")], "top|right",
                      mu0=-0.3, mu1=-0.05, graded=True)


# ----------------------------------------------------------------------------------- stability
def immersion_overshoot(dt, *, mu0=-0.2, mu_ext=-0.1, steps=3, **options):
    """Largest excursion of mu outside [mu0, mu_ext] over the first steps after an immersion
    step, sampled densely through the layer."""
    prob = column(FloryRehnerGel(Nv=1e-3, chi=0.5), mu0, ny=16, **options)
    prob.immerse("top", mu_ext)
    y = np.linspace(0, 1, 321)
    points = prob.mesh(np.full_like(y, 0.05), y)
    worst = 0.0
    for _ in range(steps):
        prob.step_to(prob.time + dt)
        mu = prob.chemical_potential(points).ravel()
        worst = max(worst, min(mu0, mu_ext) - mu.min(), mu.max() - max(mu0, mu_ext))
    return worst


DTS = 10.0 ** np.arange(-8, 3)


def test_immersion_step_does_not_oscillate_with_default_pair():
    over = np.array([immersion_overshoot(dt) for dt in DTS])
    print("\ndt", DTS, "\novershoot, default pair (P2-P1, lumped mass)", over)
    assert over.max() < 1e-3  # the step in mu is 0.1


def test_equal_order_and_consistent_mass_oscillate():
    # P1-P1: the unstable pair; P2-P1 with consistent mass: stable, but the consistent mass
    # breaks the maximum principle for dt << h^2 / Dc (the lumped default does not)
    small = DTS[:4]
    equal = np.array([immersion_overshoot(dt, order=1, mu_order=1, steps=1) for dt in small])
    consistent = np.array([immersion_overshoot(dt, lumped=False, steps=1) for dt in small])
    print("\ndt", small, "\novershoot P1-P1", equal, "\novershoot P2-P1 consistent mass", consistent)
    assert equal.min() > 0.02 and consistent.min() > 0.02  # 20 times the default pair's bound


# ------------------------------------------------------------------- large swelling, sphere
def sphere_1d(gel, mu0, *, n, mu_ext=0.0, order=2):
    mesh = Make1DMesh(n, mapping=lambda t: t)  # radius 1, "left" is the centre
    prob = TransientProblem(mesh, kinematics=SphericalSymmetric(), materials=gel, lam0=gel.lam_free(mu0), mu0=mu0,
                            order=order)
    prob.fix("left")
    prob.immerse("right", mu_ext)
    return prob


def test_large_swelling_completes_with_adaptive_steps():
    # dry-ish (J = 1.11) to mu = 0 (J = 9.97): a ninefold volume, the skin swells first
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    prob = sphere_1d(gel, -1.0, n=16)
    result = march(prob, 1e5, dt_start=1e-6)
    assert_balanced(prob, result)
    assert np.all(np.isfinite(prob.save_state()))
    J_final = gel.lam_free(0.0) ** 3
    J = prob.volume_ratio()
    J_points = np.array([J(prob.mesh(r)) for r in np.linspace(0.05, 0.95, 7)])
    spread = J_points / J_final - 1
    print(f"\nlarge swelling: {result.steps} steps, {result.cutbacks} cut-backs, max Newton iterations "
          f"{result.column('iterations').max()}, dt {result.records[0].dt:.1e} ... {result.column('dt').max():.1e}; "
          f"volume ratio {J_final / gel.lam_free(-1.0) ** 3:.2f}, J / J_free - 1 in [{spread.min():.1e}, {spread.max():.1e}]")
    assert J_final / gel.lam_free(-1.0) ** 3 > 5
    assert np.allclose(J_points, J_final, rtol=1e-8)
    assert result.column("dt").max() > 1e3 * result.records[0].dt  # the steps did adapt


# -------------------------------------------------- nonlinear: axisymmetric against spherical
def quarter_disk(h, order):
    face = Circle((0, 0), 1.0).Face() * Rectangle(1, 1).Face()
    face.edges.Min(X).name = "axis"
    face.edges.Min(Y).name = "equator"
    for edge in face.edges:
        if edge.name not in ("axis", "equator"):
            edge.name = "surface"
    mesh = ngs.Mesh(OCCGeometry(face, dim=2).GenerateMesh(maxh=h))
    mesh.Curve(order)
    return mesh


SPHERE_TIMES = np.concatenate([[0.0], np.geomspace(1e-4, 3.0, 25)])


def sphere_history(prob):
    return np.array([prob.step_to(t).uptake for t in SPHERE_TIMES[1:]])


def test_axisymmetric_sphere_matches_spherical_symmetry():
    # swelling of a sphere from mu = -0.5 to -0.1, uptake histories of an axisymmetric section
    # and of the spherically symmetric line: their difference is below the discretisation
    # error of the line model at the same mesh size and shrinks with it
    gel = FloryRehnerGel(Nv=1e-2, chi=0.5)
    mu0, mu1 = -0.5, -0.1

    def line(n):
        return sphere_history(sphere_1d(gel, mu0, n=n, mu_ext=mu1))

    fine = line(128)
    rows = []
    for h in (0.5, 0.25, 0.125):
        mesh = quarter_disk(h, 2)
        prob = TransientProblem(mesh, kinematics=Axisymmetric(), materials=gel, lam0=gel.lam_free(mu0), mu0=mu0)
        prob.fix("axis", "r")
        prob.fix("equator", "z")
        prob.immerse("surface", mu1)
        axi = 2 * sphere_history(prob)  # the section is the upper half
        coarse = line(round(1 / h))
        scale = fine[-1]
        rows.append((h, np.max(np.abs(axi - fine)) / scale, np.max(np.abs(coarse - fine)) / scale,
                     np.max(np.abs(axi - coarse)) / scale))
    print("\nsphere: h, |axi - line_fine|, |line_h - line_fine|, |axi - line_h| (max over history / final uptake)")
    for row in rows:
        print("        %.3f  %.2e  %.2e  %.2e" % row)
    h, to_fine, line_error, difference = np.array(rows).T
    assert np.all(difference < 0.2 * line_error)
    assert np.all(np.log2(difference[:-1] / difference[1:]) > 1.5)


# ------------------------------------------------------------------ flux, time-dependent BCs
def test_prescribed_flux_and_ramped_immersion():
    gel = FloryRehnerGel(Nv=1e-2, chi=0.5)
    # a constant inflow through the top of a sealed layer: uptake = inflow x area x time
    prob = column(gel, -0.5, ny=8)
    prob.add_flux("top", 0.02)
    result = march(prob, 2.0, dt_start=1e-3)
    assert_balanced(prob, result)
    assert result.records[-1].uptake == pytest.approx(0.02 * 0.1 * 2.0, rel=1e-10)
    assert all(r.wetted_inflow == 0.0 for r in result.records)
    # immersion ramped in time: the top follows the ramp, then holds
    prob = column(gel, -0.5, ny=8)
    prob.immerse("top", time_ramp(prob.t, start=-0.5, end=-0.1, duration=1.0))
    top = prob.mesh(0.05, 1.0)
    seen = []
    result = march(prob, 3.0, dt_start=1e-3, output_times=[0.25, 0.5],
                   on_step=lambda p, r: seen.append((r.time, p.chemical_potential(top))) if r.output else None)
    assert_balanced(prob, result)
    assert [t for t, _ in seen] == [0.25, 0.5, 3.0]
    assert [mu for _, mu in seen] == pytest.approx([-0.4, -0.3, -0.1], abs=1e-12)


def test_bad_transient_input():
    gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
    mesh = MakeStructured2DMesh(nx=1, ny=1)
    with pytest.raises(ValueError, match="mu_order"):
        TransientProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=2.0, mu0=-0.1, order=1)
    with pytest.raises(ValueError, match="FloryRehnerGel"):
        from ngsgel import NeoHookeanFilm
        TransientProblem(mesh, kinematics=PlaneStrain(), materials=NeoHookeanFilm(E=1.0, nu=0.3), lam0=2.0, mu0=0.0)
    with pytest.raises(ValueError, match="duration"):
        time_ramp(ngs.Parameter(0.0), start=0.0, end=1.0, duration=0.0)
    prob = TransientProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=gel.lam_free(-0.1), mu0=-0.1)
    prob.immerse("top", 0.0)
    with pytest.raises(ValueError, match="t_end"):
        march(prob, 0.0, dt_start=1e-3)
    with pytest.raises(ValueError, match="dt_min"):
        march(prob, 1.0, dt_start=2.0)
    with pytest.raises(ValueError, match="after the current time"):
        prob.step_to(0.0)


# ------------------------------------------------------------------------------------ script
def test_transient_layer_script_quick(tmp_path):
    import json

    from ngsgel.scenes import transient_layer

    start = time.perf_counter()
    transient_layer.main(["--out", str(tmp_path), "--quick"])
    print(f"\ntransient_layer --quick: {time.perf_counter() - start:.1f} s")  # reported, not asserted
    for name in ("params.json", "summary.json", "history.csv", "profiles.csv", "layer.pvd", "transient_layer.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["max_relative_balance_error"] < 1e-8
    assert summary["uptake"] == pytest.approx(summary["uptake_equilibrium"], rel=0.1)  # t_end = 10 H^2 / Dc


def test_ball_3d_agrees_with_axisymmetric_within_discretisation_error(tmp_path):
    # the nonlinear check: a dry-ish ball (J0 = 1.11) swelling 1.6x, 3D octant against the
    # axisymmetric section on meshes of the same size, both against a fine spherical line
    import json

    from ngsgel.scenes import transient_sphere

    transient_sphere.main(["--out", str(tmp_path), "--quick"])
    for name in ("params.json", "summary.json", "errors.csv", "histories.csv", "ball_3d.pvd", "transient_sphere.png"):
        assert (tmp_path / name).stat().st_size > 0, name
    rows = json.loads((tmp_path / "summary.json").read_text())["rows"]
    by = {(r["model"], r["h"]): r for r in rows}
    sizes = sorted({r["h"] for r in rows}, reverse=True)
    for r in rows:
        assert r["cutbacks"] == 0 and r["max_balance_error"] < 1e-8, r
    for model in ("axisymmetric", "3d"):
        errors = [by[(model, h)]["error"] for h in sizes]
        assert all(fine < 0.8 * coarse for coarse, fine in zip(errors, errors[1:])), (model, errors)
    for h in sizes:
        three_d, axi = by[("3d", h)], by[("axisymmetric", h)]
        assert three_d["difference_3d_axisymmetric"] < 0.5 * min(three_d["error"], axi["error"]), (h, three_d, axi)
