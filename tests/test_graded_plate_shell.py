"""The graded disk shell script's pattern measures on a synthetic deflection (no solve)."""

import math

import numpy as np
import ngsolve as ngs
import pytest

from ngsgel.scenes import shell_cases
from ngsgel.scenes import graded_plate_shell
from ngsgel.stability import spectrum


@pytest.mark.parametrize("half", [True, False])
def test_pattern_depth_of_an_exponentially_decaying_edge_wave(half):
    shell, mesh, _ = shell_cases.graded_plate_shell(10.0, maxh=0.15, order=3, half=half)
    k, decay = 5, 0.12  # w = exp(-(1 - r) / decay) cos(k theta): l_5% = decay ln 20, l_1/2 = decay ln 2
    r = ngs.sqrt(ngs.x**2 + ngs.y**2)
    theta = ngs.atan2(ngs.y, ngs.x)
    shell.displacement.Set(ngs.CF((0, 0, ngs.exp(-(1 - r) / decay) * ngs.cos(k * theta))),
                           definedon=mesh.Boundaries(".*"))
    depth = graded_plate_shell.pattern_depth(shell, mesh, k, half=half)
    assert depth["k"] == k
    # measured from the sampling circle r = 0.97 inward; linear interpolation between 24 radii
    assert depth["l_5%"] == pytest.approx(decay * math.log(20), rel=0.03)
    assert depth["l_half"] == pytest.approx(decay * math.log(2), rel=0.03)
    rim = np.array(depth["amplitude"])[-1]
    assert rim == pytest.approx(math.exp(-0.03 / decay), rel=1e-3)


@pytest.mark.parametrize("half", [True, False])
def test_rim_crests_count_a_modulated_tilted_edge_wave(half):
    # 8 waves whose amplitude varies around the rim (|1 + 0.6 cos 2 theta| between 0.4 and 1.6)
    # on a global tilt: the dominant harmonic holds well under all of it, the crests are 8
    shell, mesh, _ = shell_cases.graded_plate_shell(10.0, maxh=0.15, order=3, half=half)
    r = ngs.sqrt(ngs.x**2 + ngs.y**2)
    theta = ngs.atan2(ngs.y, ngs.x)
    w = r**8 * (1 + 0.6 * ngs.cos(2 * theta)) * ngs.cos(8 * theta) + 0.3 * r * ngs.cos(theta)
    shell.displacement.Set(ngs.CF((0, 0, w)), definedon=mesh.Boundaries(".*"))
    values = graded_plate_shell.RimWaves(shell, mesh, half=half).values()
    assert values["rim_k"] == 8 and values["rim_purity"] < 0.8
    assert values["rim_crests"] == 8


@pytest.mark.slow
def test_quick_run_switches_onto_the_saddle_at_the_converged_onset(tmp_path):
    # --quick (half disk, h = 0.2, about 2 min): the flat disk loses stability at the onset of the
    # converged reference (100 x 4 section cells, shell_cases.GRADED_REFERENCE) and the switch
    # lands on a stable, nearly pure k = 2 saddle
    summary = graded_plate_shell.main(["--quick", "--out", str(tmp_path)])
    kinds = [e["kind"] for e in summary["events"]]
    assert kinds[:2] == ["bifurcation", "branch switch"]
    onset = summary["events"][0]
    assert onset["mu"] == pytest.approx(shell_cases.GRADED_REFERENCE[10.0], rel=1e-3)
    assert onset["mode_k"] == 2
    assert summary["negative_end"] == 0 and summary["mu_end"] > onset["mu"]
    assert summary["rim_end"]["rim_k"] == 2 and summary["rim_end"]["rim_purity"] > 0.9
    assert summary["rim_end"]["rim_crests"] == 2
    assert summary["rim_end"]["rim_amplitude"] > 0.1 * 0.01


@pytest.mark.parametrize("options, match", [({"k": 1}, "k must be"), ({"k": 8, "load": 0.0}, "load must be"),
                                            ({"k": 8, "mu_start": 0.0}, "mu_start must be")])
def test_seeded_pattern_rejects_bad_input_before_work(tmp_path, options, match):
    with pytest.raises(ValueError, match=match):
        graded_plate_shell.seeded_pattern(str(tmp_path), p=10.0, **options)


@pytest.mark.parametrize("overshoot", [0.0, 2.5e-4, 2 * 0.05 / graded_plate_shell.MIN_STEP_DIVISOR])
def test_a_snap_overshoot_inside_the_stall_resolution_is_rejected_before_work(tmp_path, overshoot):
    with pytest.raises(ValueError, match="snap_overshoot must"):
        graded_plate_shell.run(str(tmp_path), step=0.05, snap_overshoot=overshoot)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("ratio", [0.0, -1.0])
def test_a_non_positive_jump_ratio_is_rejected_before_work(tmp_path, ratio):
    with pytest.raises(ValueError, match="jump_ratio must"):
        graded_plate_shell.run(str(tmp_path), jump_ratio=ratio)
    assert not any(tmp_path.iterdir())


@pytest.mark.parametrize("grading, match", [({"n0": 0.0}, "n0 \\(Nv\\) must be"), ({"nR": -1e-3}, "nR \\(Nv\\) must be"),
                                            ({"nR": 0.5}, "nR \\(Nv\\) must be")])
def test_a_bad_cross_link_grading_is_rejected_before_work(tmp_path, grading, match):
    with pytest.raises(ValueError, match=match):
        graded_plate_shell.run(str(tmp_path / "run"), **grading)
    with pytest.raises(ValueError, match=match):
        graded_plate_shell.seeded_pattern(str(tmp_path / "seeded"), p=10.0, k=8, **grading)
    assert not any(tmp_path.iterdir())


def test_the_flat_half_disk_has_the_same_sin_and_cos_spectrum_at_k_3():
    # The flat disk at mu0 is axisymmetric: every wave number k >= 1 has a pair of equal
    # eigenvalues, cos k theta (the half disk's even modes) and sin k theta (the odd modes that
    # odd_free_mask adds back). k = 3 is checked: the pins (w at r = 0.25 on the x axis for even,
    # on the y axis for odd modes) touch the k <= 2 modes differently, k = 3 hardly (r^3).
    shell, mesh, _ = shell_cases.graded_plate_shell(10.0, maxh=0.2, order=3, half=True)
    shell.solve()
    even = spectrum(shell, count=4)
    assert even.negative == 0
    mode = ngs.GridFunction(shell.space)
    even_k3 = []
    for value, vector in zip(even.eigenvalues, even.modes.T):
        mode.vec.FV().NumPy()[:] = 0.0
        mode.vec.FV().NumPy()[shell.free_mask] = vector
        if shell_cases.plate_mode_wave(mode.components[0], mesh, half=True)["k"] == 3:
            even_k3.append(value)
    odd = graded_plate_shell.odd_modes(shell, mesh, count=4)
    assert odd["negative"] == 0
    odd_k3 = [m["eigenvalue"] for m in odd["modes"] if m["k"] == 3 and m["purity"] > 0.99]
    assert len(even_k3) == 1 and len(odd_k3) == 1  # measured 2.9617e-5 and 2.9631e-5
    assert odd_k3[0] == pytest.approx(even_k3[0], rel=2e-3)
