"""The 3D thin-solid rows of the work-precision study (issue 10, ``scripts/work_precision.py``):
the graded plate's onset on the coarsest prism mesh."""

from __future__ import annotations

import bench_shell  # scripts/ (tests/conftest.py)


def test_graded_plate_thin_solid_buckles_with_two_waves_late_by_its_discretisation_error():
    # Softer-edge graded disk (p = 2, t/R = 0.01) as a 3D thin solid: one prism layer, in-plane
    # h = 0.2 (h/t = 20), order 2: 2826 unknowns, ~10 s on one loaded core. Its onset is late:
    # measured mu_c = -0.277814 against the reference -0.291049 (axisymmetric section + harmonic
    # scan), 4.55 % (docs/benchmarks.md; h = 0.15: 1.35 %, h = 0.1: 0.2 %, so it is the mesh's
    # error: one order-2 layer at h/t = 20 is too stiff in bending). The location tolerance
    # (1e-5 in mu, 3.4e-5 relative) and the Newton floor (4e-6 in mu) are far below it; the pin
    # layout moved this mesh's onset by 0.6 % (see graded_plate_solid). The window 4.0 .. 5.0 %
    # brackets the measured value: it checks that the error is this mesh's known error, so a
    # change of the physics (reference stretch, load, pins) would show.
    row = bench_shell.graded_plate_solid_onset(2.0, maxh=0.2, layers=1, order=2)
    reference = bench_shell.GRADED_REFERENCE[2.0]
    assert row["found"] and row["event"] == "bifurcation"
    assert row["k"] == 2 and row["purity"] > 0.99
    late = 1.0 - row["mu_critical"] / reference
    assert 0.040 < late < 0.050
    # the six pins are statically determinate: no reaction beyond the Newton floor (~1e-9)
    assert max(abs(r) for r in row["pin_reactions"]) < 1e-8
