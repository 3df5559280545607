"""Graded disk (thesis ch. 5): onset of non-axisymmetric buckling from the harmonic scan."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ngsgel.scenes import graded_plate


def test_softer_edge_buckles_non_axisymmetrically_with_compressive_hoop_stress_at_the_edge(tmp_path):
    # softer edge (n0 = 1e-2, nR = 1e-3, p = 10): the edge swells more, its hoop stress turns
    # compressive and the flat disk loses stability to a wave number k >= 2 before mu = 0
    summary = graded_plate.main(["--out", str(tmp_path), "--quick", "--t", "0.05", "--kmax", "5"])
    assert summary["found"] and summary["k_critical"] >= 2
    assert -1.0 < summary["mu_critical"] < 0.0
    assert 0.5 < summary["hoop_compressive_from_r"] < 1.0
    assert summary["critical_swelling_strain"] > 0
    profile = np.loadtxt(tmp_path / "onset_profile.csv", delimiter=",", skiprows=1)
    r, hoop = profile[:, 0], profile[:, 2]
    assert np.all(hoop[r < 0.4] > 0)  # the stiff centre is stretched by the swelling edge
    for name in ("onset.png", "path.csv", "params.json", "section.pvd", "profile_end.csv"):
        assert (tmp_path / name).stat().st_size > 0
    assert json.loads((tmp_path / "summary.json").read_text())["k_critical"] == summary["k_critical"]


def test_softer_centre_swells_into_an_axisymmetric_bowl(tmp_path):
    # softer centre (n0 = 1e-3, nR = 1e-2): the centre swells more, the flat (mid-plane
    # symmetric) disk reaches an axisymmetric pitchfork, the driver switches onto the bowl
    # branch and follows it to mu = 0 with no non-axisymmetric instability on the way
    summary = graded_plate.main(["--out", str(tmp_path), "--quick", "--n0", "1e-3", "--nR", "1e-2", "--p", "2",
                                 "--t", "0.05", "--kmax", "3"])
    kinds = [e["kind"] for e in summary["axisymmetric_events"]]
    assert kinds[:2] == ["bifurcation", "branch switch"], summary["axisymmetric_events"]
    assert -1.0 < summary["axisymmetric_events"][0]["mu"] < 0.0
    assert not summary["found"] and summary["mu_end"] == pytest.approx(0.0, abs=1e-12)
    assert summary["lowest_nonaxisymmetric_eigenvalue"] > 0
    assert abs(summary["rim_rise_end"]) > 0.1  # a bowl, not a flat disk
    assert 1.0 < summary["profile_exponent_end"] < 3.0
    profile = np.loadtxt(tmp_path / "profile_end.csv", delimiter=",", skiprows=1)
    z = profile[:, 2] * np.sign(summary["rim_rise_end"])
    assert np.all(np.diff(z) > 0)  # the rise grows monotonically from the centre to the rim


def test_graded_plate_rejects_bad_input(tmp_path):
    with pytest.raises(ValueError, match="layers"):
        graded_plate.build(n0=1e-2, nR=1e-3, p=10, t=0.05, maxh=0.1, layers=3)
    with pytest.raises(ValueError, match="t "):
        graded_plate.build(n0=1e-2, nR=1e-3, p=10, t=0.7, maxh=0.1)
    with pytest.raises(ValueError, match="p"):
        graded_plate.build(n0=1e-2, nR=1e-3, p=-1, t=0.05, maxh=0.1)
    with pytest.raises(ValueError, match="kmax"):
        graded_plate.run(str(tmp_path), kmax=1)


def test_graded_tube_rejects_bad_input():
    from ngsgel.scenes import graded_tube

    with pytest.raises(ValueError, match="t "):
        graded_tube.build(n0=1e-2, nL=1e-3, p=5, t=1.5, L=2, maxh=0.1, order=2, mu0=-1.0)
    with pytest.raises(ValueError, match="p"):
        graded_tube.build(n0=1e-2, nL=1e-3, p=0, t=0.02, L=2, maxh=0.1, order=2, mu0=-1.0)
    with pytest.raises(ValueError, match="kmax"):
        graded_tube.run("unused", kmax=1)


def test_onset_curve_minimum_is_the_first_instability_and_each_onset_is_bracketed():
    # mu_c(k) of every k on the flat path (coarse softer-edge disk, t/R = 0.05): its lowest
    # value is the first loss of stability of all ks together (same k, same stretch within the
    # bisection tolerance), and each bisected onset brackets the sign change of its own k's
    # lowest eigenvalue to that tolerance
    from ngsgel import FloryRehnerGel
    from ngsgel.harmonic import HarmonicStability, first_harmonic_instability

    # the state at a given mu does not depend on the path: start at mu0 = -0.1 (onset ~ -0.017)
    prob, stretch = graded_plate.build(n0=1e-2, nR=1e-3, p=10.0, t=0.05, maxh=0.1, order=2, mu0=-0.1)
    start = (stretch.Get(), prob.save_state())
    target = FloryRehnerGel(Nv=1e-3, chi=graded_plate.CHI).lam_free(0.0)
    step, tolerance, ks = (target - stretch.Get()) / 8, 1e-5, [1, 2, 3, 4]
    first = first_harmonic_instability(prob, stretch, target, ks=ks, step=step, max_step=step, tolerance=tolerance)
    prob.restore_state(start[1])
    stretch.Set(start[0])
    onsets = graded_plate.onset_curve(prob, stretch, nv=(1e-2, 1e-3), target=target, step=step, ks=ks,
                                      tolerance=tolerance)
    assert first.found and not onsets[0].found  # k = 1 (beyond its rigid motions) stays stable
    lowest = min((o for o in onsets if o.found), key=lambda o: o.mu)
    assert lowest.k == first.k
    assert abs(lowest.soft_stretch - first.parameter) <= tolerance
    assert graded_plate.local_minima(onsets)[0].k == lowest.k
    hs = HarmonicStability(prob)
    for o in onsets[2:]:
        signs = []
        for s in (o.soft_stretch - tolerance, o.soft_stretch + tolerance):
            stretch.Set(s)
            prob.solve()
            signs.append(hs.spectrum(o.k, count=1).negative)
        assert signs == [0, 1], (o.k, signs)
    # the critical modes of higher k are confined closer to the rim (shorter decay length)
    depths = [o.depth_half for o in onsets[1:]]
    assert all(0 < d < 1 for d in depths) and np.all(np.diff(depths) < 0), depths
    assert all(o.depth_5pct > o.depth_half for o in onsets[1:])


def test_lowest_eigenvalue_is_the_lowest_when_a_wave_number_has_several_negative_ones():
    # flat thin disk (t/R = 0.01) at mu = 0: k = 8 and 16 have two negative eigenvalues each;
    # spectrum(count=1) gives the one nearest zero, lowest_eigenvalue the lowest (dense check)
    import scipy.linalg

    from ngsgel import FloryRehnerGel, ramp
    from ngsgel.harmonic import HarmonicStability

    prob, stretch = graded_plate.build(n0=1e-2, nR=1e-3, p=10.0, t=0.01, maxh=0.05, order=2, mu0=-0.1)
    target = FloryRehnerGel(Nv=1e-3, chi=graded_plate.CHI).lam_free(0.0)
    ramp(prob, stretch, target, step=(target - stretch.Get()) / 8)
    hs = HarmonicStability(prob)
    for k in (8, 16):
        nearest = hs.spectrum(k, count=1)
        assert nearest.negative >= 2
        K, M, _ = hs.matrices(k)
        dense = scipy.linalg.eigh(K.toarray(), M.toarray(), eigvals_only=True)
        assert np.count_nonzero(dense < 0) == nearest.negative
        lowest = graded_plate.lowest_eigenvalue(hs, k)
        assert lowest == pytest.approx(dense[0], rel=1e-8)
        assert lowest < nearest.eigenvalues[0]


def test_local_minima_and_power_law_fit():
    make = lambda k, mu: graded_plate.WaveOnset(k, np.isfinite(mu), 0.0, mu, 0.5, 0.8, 0.0)  # noqa: E731
    curve = [make(1, np.nan), make(2, -0.3), make(3, -0.2), make(4, -0.25), make(5, -0.1), make(6, -0.12)]
    assert [o.k for o in graded_plate.local_minima(curve)] == [2, 4, 6]
    x = np.array([0.005, 0.01, 0.02, 0.05, 0.1])
    exact = graded_plate.power_law_fit(x, 0.8 * x**-0.5)
    assert exact["exponent"] == pytest.approx(-0.5, abs=1e-12) and exact["standard_error"] < 1e-12
    assert exact["prefactor"] == pytest.approx(0.8, rel=1e-12)
    y = np.array([9.0, 8.0, 5.0, 3.0, 3.0])
    fit = graded_plate.power_law_fit(x, y)
    coef, cov = np.polyfit(np.log(x), np.log(y), 1, cov=True)  # the textbook covariance, scaled by s^2 / (n - 2)
    assert fit["exponent"] == pytest.approx(coef[0], rel=1e-12)
    assert fit["standard_error"] == pytest.approx(np.sqrt(cov[0, 0]), rel=1e-9)
    with pytest.raises(ValueError, match="3 points"):
        graded_plate.power_law_fit(x[:2], y[:2])


def test_disk_circle_values_mirror_the_half_disk():
    # a field even in y sampled on the half disk (mirrored) and on the full disk: both equal the
    # closed form r^2 cos 2 theta + r^3 cos 3 theta on the circle, and the wave count finds k = 2;
    # an odd one mirrored with the sign flip (the deflection of a mode odd in y)
    import ngsolve as ngs

    from ngsgel.scenes import shell_cases
    from ngsgel.patterns import wave_number

    field = ngs.x * ngs.x - ngs.y * ngs.y + ngs.x**3 - 3 * ngs.x * ngs.y * ngs.y
    theta = 2 * np.pi * np.arange(48) / 48
    exact = 0.8**2 * np.cos(2 * theta) + 0.8**3 * np.cos(3 * theta)
    for half in (True, False):
        mesh = shell_cases.split_disk(maxh=0.3, curve_order=2, half=half)
        assert ("cut" in mesh.GetBBoundaries()) == half
        values = shell_cases.disk_circle_values(field, mesh, radius=0.8, n=48, half=half)
        assert np.allclose(values, exact, atol=1e-12)
        assert wave_number(values).k == 2
        # a field odd in y: r^2 sin 2 theta + r^3 sin 3 theta, mirrored with the sign flip
        odd_field = 2 * ngs.x * ngs.y + 3 * ngs.x * ngs.x * ngs.y - ngs.y**3
        odd_values = shell_cases.disk_circle_values(odd_field, mesh, radius=0.8, n=48, half=half, odd=True)
        assert np.allclose(odd_values, 0.8**2 * np.sin(2 * theta) + 0.8**3 * np.sin(3 * theta), atol=1e-12)


def test_matching_thresholds_need_every_computed_thesis_case():
    from ngsgel.scenes.graded_plate_growth import matching_thresholds

    thresholds = [1.0, 2.0, 3.0, 4.0]
    table = {0.25: [2, 2, 2, 3], 10.0: [2, 6, 8, 8], 5.0: [1, 1, 1, 1]}  # 5.0: not a thesis case, ignored
    assert matching_thresholds(thresholds, table, {0.25: 2, 10.0: 8, 2.0: 5}) == [3.0]
    assert matching_thresholds(thresholds, {5.0: [1] * 4}, {0.25: 2}) == []


@pytest.mark.slow
def test_quick_growth_selection_starts_at_the_onset_wave_number(tmp_path):
    """At a vanishing threshold the first mode to grow is the first to lose stability (k = 2 for
    the softer edge), and a larger threshold never selects a smaller k on this case."""
    import csv

    from ngsgel.scenes.graded_plate_growth import main

    summary = main(["--quick", "--out", str(tmp_path)])
    assert summary["cases"][0]["k_first_unstable"] == 2
    with open(tmp_path / "selection_mu.csv") as f:
        ks = [int(r["k_p10_t0.01"]) for r in csv.DictReader(f) if r["k_p10_t0.01"] not in ("", "None")]
    assert ks[0] == 2 and ks[-1] > 2
    assert all(b >= a for a, b in zip(ks, ks[1:]))


def test_continuous_critical_wave_number_is_the_vertex_of_the_onset_parabola():
    from ngsgel.scenes.graded_plate import WaveOnset, continuous_critical_wave_number

    def onsets(vertex, ks, missing=()):
        return [WaveOnset(k, k not in missing, math.nan, -0.2 + 0.01 * (k - vertex) ** 2 if k not in missing else math.nan,
                          math.nan, math.nan, -1.0) for k in ks]

    assert continuous_critical_wave_number(onsets(10.3, range(2, 20))) == pytest.approx(10.3, rel=1e-12)
    assert continuous_critical_wave_number(onsets(9.7, range(2, 20))) == pytest.approx(9.7, rel=1e-12)
    assert continuous_critical_wave_number(onsets(10.3, range(2, 20), missing=(11,))) is None  # a neighbour never unstable
    assert continuous_critical_wave_number(onsets(19.2, range(2, 20))) is None  # the minimum at the end of the scan


def test_linear_buckling_from_a_base_near_the_onset_predicts_the_onset(tmp_path):
    # The eigenvalue buckling step (linearised pre-buckling, stress per unit load at the base)
    # is exact only at the onset itself; from a base at a distance d (in the load) below it, the
    # predicted onset is off by O(d^2) (coarse softer-edge disk, t/R = 0.05, onset ~ mu -0.017;
    # measured error / d^2 = 4.2, 2.9, 2.9 from mu = -0.05, -0.025, -0.018)
    from ngsgel import FloryRehnerGel
    from ngsgel.harmonic import HarmonicStability, first_harmonic_instability, stress_rate

    target = FloryRehnerGel(Nv=1e-3, chi=graded_plate.CHI).lam_free(0.0)
    prob, stretch = graded_plate.build(n0=1e-2, nR=1e-3, p=10.0, t=0.05, maxh=0.1, order=2, mu0=-0.1)
    step = (target - stretch.Get()) / 8
    exact = first_harmonic_instability(prob, stretch, target, ks=[2, 3, 4], step=step, max_step=step, tolerance=1e-6)
    assert exact.found
    ratios = []
    for base in (-0.05, -0.025, -0.018):
        prob, stretch = graded_plate.build(n0=1e-2, nR=1e-3, p=10.0, t=0.05, maxh=0.1, order=2, mu0=base)
        hs = HarmonicStability(prob)
        rate = stress_rate(prob, stretch)
        multipliers = {k: hs.linear_buckling(k, rate)[0] for k in (2, 3, 4)}
        k_first = min(multipliers, key=multipliers.get)
        assert k_first == exact.k
        distance = exact.parameter - stretch.Get()
        ratios.append(abs(stretch.Get() + multipliers[k_first] - exact.parameter) / distance**2)
    assert ratios[1] == pytest.approx(ratios[2], rel=0.2)  # second order as the base nears the onset
    assert ratios[0] > ratios[1]

    summary = graded_plate.main(["--quick", "--out", str(tmp_path), "--linear-buckling", "-0.5", "-0.25"])
    bases = summary["linear_buckling"][0]["bases"]
    assert [b["mu_base"] for b in bases] == [-0.5, -0.25]
    assert all(b["k_first"] == 2 and b["multiplier_mu"] > 0 for b in bases)
    assert (tmp_path / "p10" / "linear_buckling.csv").exists()
    with pytest.raises(ValueError, match="bases"):
        graded_plate.linear_buckling_case(str(tmp_path / "bad"), bases=[0.1])


def test_tube_linear_buckling_lists_the_smallest_multiplier_first(tmp_path):
    import csv

    from ngsgel.scenes import graded_tube

    with pytest.raises(ValueError, match="bases"):
        graded_tube.linear_buckling_case(str(tmp_path / "bad"), bases=[-0.5, 0.0])
    rows = graded_tube.main(["--quick", "--out", str(tmp_path), "--linear-buckling", "-0.5", "-0.05", "--p", "10"])
    summary = json.loads((tmp_path / "p10" / "summary.json").read_text())
    with open(tmp_path / "p10" / "linear_buckling.csv") as f:
        table = list(csv.DictReader(f))
    for base in summary["bases"]:  # -0.05 is reached by a ramp from -0.1
        multipliers = {int(r["k"]): float(r["multiplier_mu"]) for r in table if float(r["mu_base"]) == base["mu_base"]}
        assert base["k_first"] == min(multipliers, key=multipliers.get)
        assert base["multiplier_mu"] == pytest.approx(multipliers[base["k_first"]])
    assert rows["sweep"][0]["k_first_base-0.5"] == summary["bases"][0]["k_first"]
