"""Reference cases of the gel shell against solids (used by the shell benchmark, the graded-plate
shell scene, the work-precision study and the tests).

Cap (MODEL.md scene A geometry): base radius R = 1, apex height H = 0.3, mid-surface radius
r = 1.817, thickness ``t``, Nv = 1e-3, chi = 0.5, base clamped, swelling step mu = -0.05 -> -0.049
from the free-swollen reference at -0.05; quantity: the apex rise (shell, 3D thin solid,
axisymmetric section). Point load: apex stiffness of the microlens cap (t/r = 0.005) against
Reissner's shallow-shell value; the cap shell's first non-axisymmetric onset. Large rotation: a
strip rolled into a quarter circle by an end moment. Thin plate: clamped disk R = 1 under uniform
pressure, centre deflection against Kirchhoff's p R^4 / (64 D) with the drained D. Graded disks
(MODEL.md scene C) as shell and as 3D solid: builders, onsets and the rim's wave content.
"""

from __future__ import annotations

import math
import time

import numpy as np
import ngsolve as ngs
from netgen import occ

from geometries import cap_midsurface, cap_section, cap_solid, plate_midsurface, plate_solid
from geometries.fields import radial_grading
from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, Solid3D, follow_path, ramp
from ngsgel.continuation import ContinuationError, StabilityOptions
from ngsgel.patterns import sample_on_circle, wave_number
from ngsgel.shell import GelShell, plate_bending_stiffness
from ngsgel.stability import conjugate_force, free_matrix, load_rate, mode_function, negative_count, spectrum

from ngsgel.scenes.microlens import cap_waves

GEL = FloryRehnerGel(Nv=1e-3, chi=0.5)
MU0, MU1 = -0.05, -0.049
H = 0.3


def cap_section_rise(t: float, *, maxh: float, layers: int) -> tuple[float, int]:
    lam0 = GEL.lam_free(MU0)
    bundle = cap_section(H=H, t=t, maxh=maxh, layers=layers)
    prob = EquilibriumProblem(bundle.mesh, kinematics=Axisymmetric(), materials=GEL, lam0=lam0, mu=MU0)
    prob.fix("base")
    prob.fix("axis", "r")
    ramp(prob, prob.mu, MU1)
    return prob.displacement(bundle.mesh(0.0, H))[1], prob.space.ndof


def cap_solid_rise(t: float, *, maxh: float, layers: int) -> tuple[float, int]:
    lam0 = GEL.lam_free(MU0)
    bundle = cap_solid(H=H, t=t, maxh=maxh, layers=layers)
    prob = EquilibriumProblem(bundle.mesh, kinematics=Solid3D(), materials=GEL, lam0=lam0, mu=MU0)
    prob.fix("base")
    ramp(prob, prob.mu, MU1)
    return prob.displacement(bundle.mesh(0.0, 0.0, H))[2], prob.space.ndof


def cap_shell_rise(t: float, *, maxh: float, order: int = 3) -> tuple[float, int]:
    # a wide apex patch keeps the surface mesh uniform (the patch exists for point loads)
    lam0 = GEL.lam_free(MU0)
    bundle = cap_midsurface(H=H, maxh=maxh, curve_order=order, apex_radius=0.4)
    shell = GelShell(bundle.mesh, material=GEL, lam0=lam0, thickness=t, mu=MU0, order=order)
    shell.clamp("base")
    ramp(shell, shell.mu, MU1)
    return shell.displacement(bundle.mesh(0.0, 0.0, H, ngs.BND))[2], shell.space.ndof


def thin_plate_deflection(*, t: float, maxh: float, order: int = 3, depth: float = 1e-2) -> tuple[float, int]:
    """Centre deflection over Kirchhoff's value, clamped disk, load for w = ``depth`` t. The
    shell is nonlinear: membrane stiffening lowers w by ~0.49 (w/t)^2 (von Karman, Timoshenko),
    ~5e-5 at the default depth, which is the floor of the comparison; a much smaller load would
    sink below the residual's round-off floor at t = 1e-3 (gel stresses ~ eps t, bending ~ t^3)."""
    lam0 = GEL.lam_free(0.0)
    bundle = plate_midsurface(R=1.0, maxh=maxh, curve_order=order)
    shell = GelShell(bundle.mesh, material=GEL, lam0=lam0, thickness=t, mu=0.0, order=order)
    shell.clamp("rim")
    D = plate_bending_stiffness(GEL, lam0=lam0, thickness=t)
    p = 64 * depth * D * t
    shell.add_surface_load("gel", (0.0, 0.0, p))
    shell.solve()
    return shell.displacement(bundle.mesh(0.0, 0.0, 0.0, ngs.BND))[2] / (p / (64 * D)), shell.space.ndof


def apex_stiffness_over_reissner(*, maxh: float, apex_maxh: float, order: int = 3) -> tuple[float, int]:
    """Microlens cap (H = 0.3, t = 0.005 r, Nv = 1e-3, mu = 0, base clamped) under a small
    inward point force at the apex: stiffness F/w over Reissner's deep-shell value
    ``4 E t^2 / (r sqrt(3 (1 - nu^2)))`` (drained E, nu). The bending length
    ``sqrt(r t) / (3 (1 - nu^2))^(1/4) = 0.1`` is far below the cap's size, so the clamp does not
    matter; the force gives w = 1e-4 t (linear)."""
    lam0 = GEL.lam_free(0.0)
    r = (1 + H**2) / (2 * H)
    t = 0.005 * r
    G, nu = GEL.shear_modulus(lam0), GEL.drained_poisson_ratio(lam0)
    stiffness = 4 * 2 * G * (1 + nu) * t**2 / (r * math.sqrt(3 * (1 - nu**2)))
    bundle = cap_midsurface(H=H, maxh=maxh, apex_radius=0.2, apex_maxh=apex_maxh, curve_order=order)
    shell = GelShell(bundle.mesh, material=GEL, lam0=lam0, thickness=t, mu=0.0, order=order)
    shell.clamp("base")
    force = 1e-4 * stiffness * t
    shell.add_point_load((0.0, 0.0, H), (0.0, 0.0, -force))
    shell.solve()
    w = -shell.displacement(bundle.mesh(0.0, 0.0, H, ngs.BND))[2]
    return force / w / stiffness, shell.space.ndof


def rolled_strip_tip_error(*, maxh: float = 0.1, steps: int = 4) -> tuple[float, int, int]:
    """Large rotation: a gel strip (L = 1, width 0.1, t = 0.01, mu = 0) clamped at x = 0, in
    cylindrical bending (symmetry edges along it), under an end moment m = D pi / 2 rolls into a
    quarter circle of radius 2/pi (D = E t^3 / (12 (1 - nu^2)), drained E, nu; bending strains
    ~ t kappa / 2 = 0.8 % stay linear). Returns the tip position error over L, unknowns and
    load steps; the edge normals follow the rotation after every step."""
    lam0 = GEL.lam_free(0.0)
    length, width, t = 1.0, 0.1, 0.01
    face = occ.WorkPlane().Rectangle(length, width).Face()
    for edge in face.edges:
        x = edge.center.x
        edge.name = "clamped" if abs(x) < 1e-9 else "end" if abs(x - length) < 1e-9 else "side"
    mesh = ngs.Mesh(occ.OCCGeometry(face).GenerateMesh(maxh=maxh))
    mesh.Curve(3)
    G, nu = GEL.shear_modulus(lam0), GEL.drained_poisson_ratio(lam0)
    D = 2 * G * (1 + nu) * t**3 / (12 * (1 - nu**2))
    kappa = math.pi / 2 / length
    load = ngs.Parameter(0.0)
    shell = GelShell(mesh, material=GEL, lam0=lam0, thickness=t, mu=0.0)
    shell.clamp("clamped")
    shell.symmetry("side", normal="y")
    shell.add_edge_moment("end", load * D * kappa)
    result = ramp(shell, load, 1.0, step=1.0 / steps, max_step=1.0 / steps,
                  on_step=lambda *_: shell.update_edge_normals())
    ux, _, uz = shell.displacement(mesh(length, width / 2, 0.0, ngs.BND))
    exact = (math.sin(kappa * length) / kappa - length, (1 - math.cos(kappa * length)) / kappa)
    # the rolling direction follows the moment's sign convention; compare magnitudes in z
    error = math.hypot(ux - exact[0], abs(uz) - exact[1]) / length
    return error, shell.space.ndof, result.steps


# ----------------------------------------------------------------------------- microlens onset
# The inward-indented clamped cap of ngsgel/scenes/microlens_onset.py (H = 0.3, t = 0.005 r, mu = 0):
# the apex patch (polar angle below asin(APEX / r)) is moved down rigidly by ``depth`` (its z
# displacement is prescribed, x and y free), on the outer face of the solid and on the
# mid-surface of the shell.
APEX = 0.05
MICROLENS_T = 0.005 * (1 + H**2) / (2 * H)
STIFFNESS_DEPTH = 1e-3 * MICROLENS_T  # linear range: the stiffness changes by ~1e-4 over it


def cap_section_stiffness(*, maxh: float, layers: int = 2, order: int = 3) -> tuple[float, int]:
    """Apex-patch stiffness ``F/d`` of the axisymmetric solid (the 3D force: the section's energy
    carries the 2 pi r weight) at ``d = STIFFNESS_DEPTH``, and the section's unknowns."""
    bundle = cap_section(H=H, t=MICROLENS_T, maxh=maxh, layers=layers, apex_radius=APEX,
                         apex_maxh=min(maxh, APEX / 4))
    prob = EquilibriumProblem(bundle.mesh, kinematics=Axisymmetric(), materials=GEL, lam0=GEL.lam_free(0.0),
                              mu=0.0, order=order)
    depth = ngs.Parameter(0.0)
    prob.fix("base")
    prob.fix("axis", "r")
    prob.prescribe("apex", "z", -depth)
    return patch_stiffness(prob, depth), prob.space.ndof


def patch_stiffness(problem, depth: ngs.Parameter) -> float:
    """``F/d`` of a problem whose apex patch follows ``-depth`` in z, at ``d = STIFFNESS_DEPTH`` from
    its current (unloaded) state (``conjugate_force``: ``dE/d(depth)``); the problem is left at
    that state and ``depth`` at ``STIFFNESS_DEPTH``."""
    depth.Set(STIFFNESS_DEPTH)
    problem.solve()
    return conjugate_force(problem, depth) / STIFFNESS_DEPTH


def _apex_areas() -> tuple[float, float]:
    """Areas of the apex patch on the solid's outer face and on the mid-surface."""
    r = (1 + H**2) / (2 * H)
    one_minus_cos = 1 - math.sqrt(1 - (APEX / r) ** 2)
    return 2 * math.pi * (r + MICROLENS_T / 2) ** 2 * one_minus_cos, 2 * math.pi * r**2 * one_minus_cos


def cap_section_pressure_stiffness(*, maxh: float, layers: int = 2, order: int = 3) -> tuple[float, int]:
    """Force over mid-surface apex deflection of the axisymmetric solid under a small uniform
    vertical dead load on the apex patch of its outer face (a load both the solid and the
    shell represent, unlike the rigid patch, whose edge the shell clamps), and the unknowns."""
    bundle = cap_section(H=H, t=MICROLENS_T, maxh=maxh, layers=layers, apex_radius=APEX,
                         apex_maxh=min(maxh, APEX / 4))
    prob = EquilibriumProblem(bundle.mesh, kinematics=Axisymmetric(), materials=GEL, lam0=GEL.lam_free(0.0),
                              mu=0.0, order=order)
    prob.fix("base")
    prob.fix("axis", "r")
    force = 2e-12  # w ~ 1e-3 t: linear (stiffness ~2e-7)
    prob.add_traction("apex", (0.0, -force / _apex_areas()[0]))
    prob.solve()
    return force / -prob.displacement(bundle.mesh(0.0, H))[1], prob.space.ndof


def cap_shell_pressure_stiffness(*, maxh: float, apex_maxh: float, order: int) -> tuple[float, int]:
    """The same load on the shell's mid-surface apex patch; force over apex deflection."""
    bundle = cap_midsurface(H=H, maxh=maxh, apex_radius=APEX, apex_maxh=apex_maxh, curve_order=order)
    shell = GelShell(bundle.mesh, material=GEL, lam0=GEL.lam_free(0.0), thickness=MICROLENS_T, mu=0.0,
                     order=order)
    shell.clamp("base")
    force = 2e-12
    shell.add_surface_load("apex", (0.0, 0.0, -force / _apex_areas()[1]))
    shell.solve()
    return force / -shell.displacement(bundle.mesh(0.0, 0.0, H, ngs.BND))[2], shell.space.ndof


def _mode_wave(mode_u: ngs.CoefficientFunction, mesh: ngs.Mesh, *, r: float, zc: float,
               radii: np.ndarray, half: bool = False) -> dict:
    """Wave number of a critical mode of the cap, whole or ``half`` (``microlens.cap_waves``: its
    normal displacement on circles of the mid-surface, the circle of the largest
    non-axisymmetric part)."""
    waves = cap_waves(mode_u, mesh, r=r, zc=zc, half=half, radii=radii)
    return {"k": waves.analysis.k, "purity": waves.analysis.purity, "mode_radius": waves.radius,
            "k_second": waves.analysis.second}


def newton_floor_options(problem, parameter: ngs.Parameter, *, floor: float, step: float) -> dict:
    """``newton_options`` for ``follow_path`` with the absolute Newton floor ``floor * step *
    |dR/dparameter|`` (the driver's default factor is 1e-10; the 3D thin solids' residuals stall
    above it, see ``graded_plate_solid_onset`` and ``cap_solid_onset``)."""
    return {"atol": floor * step * float(np.linalg.norm(load_rate(problem, parameter).residual))}


def _indented_cap_onset(problem, depth: ngs.Parameter, *, mesh: ngs.Mesh, displacement, wave_r: float,
                        depth_max: float, step: float, tol: float, eigenvalues: int, progress, history,
                        newton_floor: float | None = None, half: bool = False) -> dict:
    """What the shell and the 3D thin cap onsets share, from the unloaded problem whose apex patch
    follows ``-depth`` in z: the linear-range patch stiffness ``F/d`` at ``d = STIFFNESS_DEPTH``
    (``conjugate_force``), then the depth stepped from 0 by the continuation driver (natural
    parameter; under displacement control the axisymmetric path has no limit point before the
    bifurcation) with the exact negative count of the tangent at every state (``eigenvalues``
    lowest eigenvalues recorded too; 0: the count alone), stopping at the first unstable state,
    the first change located to ``tol H`` in depth; the critical mode's wave number from
    ``_mode_wave`` of ``displacement(mode)`` on the sphere of radius ``wave_r`` about the
    centre. ``half``: the half cap with its mirror plane (stiffness of the whole cap: twice the
    half's). ``newton_floor``: see ``newton_floor_options`` (None: the driver's default). Returns
    the model-independent part of the row (no timing). A change of the count that the driver
    could not locate (``event`` "stability change", its reason in ``event_details``) gives no
    ``depth_over_H``: the row has the step that holds it (``stable_to_over_H``,
    ``unstable_at_over_H``) and the wave number of the lowest mode at its unstable end. A path whose
    steps stall before the count changes (``ContinuationError``) gives a row without onset, the
    reason in ``stalled`` (measured: the full shell cap at h = 0.1, a line search at 5.5e-15 at
    d/H 0.669), so that a study goes on with its other rows."""
    r = (1 + H**2) / (2 * H)
    unloaded = problem.save_state()
    stiffness = patch_stiffness(problem, depth) * (2.0 if half else 1.0)
    depth.Set(0.0)
    problem.restore_state(unloaded)
    newton_options = None if newton_floor is None else newton_floor_options(problem, depth, floor=newton_floor,
                                                                            step=step * H)
    stalled = None
    try:
        path = follow_path(problem, depth, method="natural", step=step * H, max_step=step * H, target=depth_max * H,
                           stability=StabilityOptions(eigenvalues=eigenvalues, tol=tol * H), progress=progress,
                           history=history, stop=lambda point: bool(point.negative), newton_options=newton_options)
    except ContinuationError as error:  # steps that stalled while the count was 0: a row without onset
        path, stalled = error.result, str(error)
    row = {"ndof": problem.space.ndof, "stiffness": stiffness, "steps": len(path.points), "found": bool(path.events),
           "stalled": stalled,
           "newton_iterations": sum(p.iterations for p in path.points),
           "lowest_eigenvalue": [(p.parameter / H, p.eigenvalues[0]) for p in path.points if p.eigenvalues]}
    if not path.events:
        return row
    event = path.events[0]
    row.update(event=event.kind, negative_after=event.negative_after, event_details=dict(event.details))
    radii = np.linspace(0.05, 0.7, 14)
    if event.mode is not None:
        row.update(depth_over_H=event.parameter / H, depth_error_over_H=(event.parameter_error or 0.0) / H,
                   **_mode_wave(displacement(event.mode), mesh, r=wave_r, zc=H - r, radii=radii, half=half))
        return row
    # not located (its solves failed, event_details says why): no critical depth, only the step that
    # holds it, and the wave number of the lowest mode at the first unstable state (the problem's)
    lowest = spectrum(problem, count=1, past_negative=True)
    mode = mode_function(problem, lowest.modes[:, 0])
    row.update(stable_to_over_H=path.points[-2].parameter / H, unstable_at_over_H=path.points[-1].parameter / H,
               **_mode_wave(displacement(mode), mesh, r=wave_r, zc=H - r, radii=radii, half=half))
    return row


def cap_shell_onset(*, maxh: float, apex_maxh: float, order: int, depth_max: float = 0.8,
                    step: float = 0.1, tol: float = 1e-3, apex_radius: float = APEX, half: bool = False,
                    progress=None, history=None) -> dict:
    """First bifurcation of the inward-indented full cap (no symmetry imposed, so any wave number
    can appear; ``half``: the half cap with its mirror plane, which keeps one of each pair of
    ``cos k theta`` / ``sin k theta`` modes, so a critical pair becomes a simple eigenvalue) with ``GelShell`` (``_indented_cap_onset``: the exact negative count of the
    shell's tangent at every state and its two lowest eigenvalues, the first change located to
    ``tol H`` in depth). Returns the critical ``d/H``, the critical mode's wave number
    (``_mode_wave``, mid-surface), the linear-range patch stiffness, unknowns and wall time
    (mesh excluded); also when no bifurcation occurs up to ``depth_max H`` (``found`` False; the
    lowest eigenvalue along the path is in the row). ``apex_radius``: radius of the shell's
    rigid patch (the solid's is ``APEX``)."""
    start = time.perf_counter()
    bundle = cap_midsurface(H=H, maxh=maxh, apex_radius=apex_radius, apex_maxh=apex_maxh, curve_order=order,
                            half=half)
    mesh_seconds = time.perf_counter() - start
    shell = GelShell(bundle.mesh, material=GEL, lam0=GEL.lam_free(0.0), thickness=MICROLENS_T, mu=0.0,
                     order=order)
    shell.clamp("base")
    if half:
        shell.symmetry("sym", normal="y")
    depth = ngs.Parameter(0.0)
    shell.prescribe_region("apex", "z", -depth)
    onset = _indented_cap_onset(shell, depth, mesh=bundle.mesh, displacement=lambda mode: mode.components[0],
                                wave_r=(1 + H**2) / (2 * H), depth_max=depth_max, step=step, tol=tol,
                                eigenvalues=2, progress=progress, history=history, half=half)
    row = {"model": "shell", "order": order, "maxh": maxh, "apex_maxh": apex_maxh, "apex_radius": apex_radius,
           "half": half, "elements": bundle.mesh.GetNE(ngs.BND), **onset}
    row["seconds"] = time.perf_counter() - start - mesh_seconds
    return row


def indented_cap_solid(*, maxh: float, apex_maxh: float, layers: int, order: int,
                       half: bool = False) -> tuple[EquilibriumProblem, ngs.Parameter, ngs.Mesh]:
    """The microlens cap (t = 0.005 r, mu = 0) as a 3D thin solid (``cap_solid``: ``layers`` prism
    layers through t under triangles of size ``maxh``, ``apex_maxh`` on the patch of radius
    ``APEX``; elements and geometry of ``order``), loaded as the axisymmetric solid
    (``cap_section_stiffness``, ``microlens.AxisymmetricCap``): base face clamped, the z
    displacement of the apex patch of the outer face prescribed to ``-depth`` (x, y and the inner
    face free). ``half``: the half cap ``y >= 0``, ``u_y = 0`` on its mirror plane. Not yet
    solved; returns the problem, ``depth`` (0) and the mesh."""
    mesh = cap_solid(H=H, t=MICROLENS_T, maxh=maxh, layers=layers, apex_radius=APEX, apex_maxh=apex_maxh,
                     curve_order=order, half=half).mesh
    problem = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=GEL, lam0=GEL.lam_free(0.0), mu=0.0,
                                 order=order)
    problem.fix("base")
    if half:
        problem.prescribe("sym", "y", 0.0)
    depth = ngs.Parameter(0.0)
    problem.prescribe("apex", "z", -depth)
    return problem, depth, mesh


def cap_solid_onset(*, maxh: float, apex_maxh: float, layers: int, order: int, depth_max: float = 0.8,
                    step: float = 0.1, tol: float = 1e-3, newton_floor: float = 1e-7, eigenvalues: int = 0,
                    half: bool = False, progress=None, history=None) -> dict:
    """The onset of ``cap_shell_onset`` (``_indented_cap_onset``: same path, tolerance, wave
    analysis) of the full cap (or the ``half`` cap, as ``cap_shell_onset``) as a 3D thin solid (``indented_cap_solid``; its patch stiffness has
    the axisymmetric solid's definition, ``cap_section_stiffness``). The stability check is the
    exact negative count alone (``StabilityOptions()``: with PARDISO the count of the
    factorisation the next Newton solve starts from; eigenpairs only where the count changes):
    one 3D shift-invert eigen solve costs ~10 Newton iterations (docs/benchmarks.md). The wave
    number is read from the critical mode's normal displacement on the outer face (the sphere of
    radius r + t/2, a boundary of the mesh where ``cap_waves`` can sample; a bending mode's
    normal displacement is the same through t to O(t/r)). Returns the row of
    ``cap_shell_onset`` (``lowest_eigenvalue`` empty unless ``eigenvalues`` > 0 asks for that
    many lowest eigenvalues at every state, as the shell's: a diagnosis of a path that stays
    stable, at the cost of an eigen solve per state).

    ``newton_floor`` (``newton_floor_options``): with the driver's 1e-10 (1.5e-15 here) the
    h = 0.2 / 0.025, one-layer, order-3 path stopped at d/H = 0.71: the line search found no
    decrease from a residual of 9.5e-13 (6e-8 of a step's load residual, round-off), as on the
    3D thin plate, whose floor of 1e-7 this takes. Not looser: at h = 0.05 / 0.0125 (order 3, one
    layer) the state at d/H = 0.5 has two negative eigenvalues (the lowest -1.1e-6, 3.8e-4
    unloaded) with 1e-7 and none with 1e-4 (5 Newton iterations instead of 12). With 1e-7 the
    location of that change failed there in two runs (steps 0.1 H and 0.05 H: a solve next to the
    double critical point, the k = 3 pair, stalled 180-240 times above the floor after 30
    iterations): the row then has the bracketing step instead, and the lowest mode's eigen solve
    (~6 min at 192684 unknowns, one core) gives its wave number. The ``half`` cap at the same mesh
    size has a simple critical eigenvalue; its location failed with 1e-7 (a line search next to
    the critical state found no decrease from 9.1e-12) and succeeded with 1e-6 (d/H 0.49110)."""
    start = time.perf_counter()
    problem, depth, mesh = indented_cap_solid(maxh=maxh, apex_maxh=apex_maxh, layers=layers, order=order, half=half)
    mesh_seconds = time.perf_counter() - start
    onset = _indented_cap_onset(problem, depth, mesh=mesh, displacement=lambda mode: problem.parts(mode)[0],
                                wave_r=(1 + H**2) / (2 * H) + MICROLENS_T / 2, depth_max=depth_max, step=step,
                                tol=tol, eigenvalues=eigenvalues, progress=progress, history=history,
                                newton_floor=newton_floor, half=half)
    row = {"model": "solid3d", "order": order, "maxh": maxh, "apex_maxh": apex_maxh, "apex_radius": APEX,
           "layers": layers, "half": half, "elements": mesh.ne, **onset}
    row["seconds"] = time.perf_counter() - start - mesh_seconds
    return row


# ----------------------------------------------------------------------------- cost per Newton iteration
NEWTON_PARTS = ("tangent", "residual", "factorisation", "solve", "stability")


def indented_half_cap_shell(*, maxh: float, apex_maxh: float, order: int = 3, depth: float = 0.01,
                            **shell_options) -> GelShell:
    """The microlens half cap (``cap_midsurface(half=True)``, t = 0.005 r, mu = 0, base clamped,
    mirror plane ``sym``) with its apex patch pushed down by ``depth H`` (z prescribed, the
    microlens path's load), not yet solved; ``shell_options`` go to ``GelShell``."""
    bundle = cap_midsurface(H=H, maxh=maxh, apex_radius=APEX, apex_maxh=apex_maxh, curve_order=order, half=True)
    shell = GelShell(bundle.mesh, material=GEL, lam0=GEL.lam_free(0.0), thickness=MICROLENS_T, mu=0.0,
                     order=order, **shell_options)
    shell.clamp("base")
    shell.symmetry("sym", normal="y")
    shell.prescribe_region("apex", "z", -depth * H)
    return shell


def newton_iteration_costs(problem, *, repeats: int = 3) -> dict:
    """Wall time (s, median of ``repeats``) of each part of one Newton iteration with a stability
    check at the problem's current state: ``tangent`` (assembly), ``residual`` (one evaluation),
    ``factorisation`` (numeric, symbolic factorisation reused as in a path), ``solve`` (one
    triangular solve), ``stability`` (exact negative count of the free tangent, as
    ``follow_path`` does at every state: the factorisation's inertia where the solver has it,
    else SuperLU's); ``iteration``: their sum. Also the negative count and
    the free unknowns. Run with one thread to compare variants."""
    if not isinstance(repeats, int) or repeats < 1:
        raise ValueError(f"repeats must be an integer >= 1, got {repeats!r}")
    x = problem.state
    r = x.CreateVector()
    dx = x.CreateVector()
    problem.residual(x, r)
    solver = problem._solver
    solver.factor(problem.tangent(x))  # symbolic factorisation outside the timing
    samples = {part: [] for part in NEWTON_PARTS}
    negative = None
    for _ in range(repeats):
        start = time.perf_counter()
        K = problem.tangent(x)
        samples["tangent"].append(time.perf_counter() - start)
        start = time.perf_counter()
        problem.residual(x, r)
        samples["residual"].append(time.perf_counter() - start)
        start = time.perf_counter()
        inverse = solver.factor(K)
        samples["factorisation"].append(time.perf_counter() - start)
        start = time.perf_counter()
        dx.data = inverse * r
        samples["solve"].append(time.perf_counter() - start)
        start = time.perf_counter()
        # a solver with the inertia (PARDISO) has the count already: follow_path reads it there
        negative = solver.inertia[1] if solver.inertia is not None else negative_count(free_matrix(K, problem.free_mask))
        samples["stability"].append(time.perf_counter() - start)
    row = {part: float(np.median(values)) for part, values in samples.items()}
    row["iteration"] = sum(row[part] for part in NEWTON_PARTS)
    row.update(negative=negative, free_dofs=int(problem.free_mask.sum()))
    return row


# ----------------------------------------------------------------------------- graded plate
# Softer-edge disk of ngsgel/scenes/graded_plate.py (MODEL.md 5 C): R = 1, t = 0.01, chi = 0.5,
# Nv(r) = n0 + (nR - n0) (r/R)^p, reference stretched by the stiff gel's lam_free(mu0), mu0 = -1,
# mu raised towards 0; axisymmetric + harmonic onsets k = 2 and mu_c below (docs/graded.md).
GRADED_N0, GRADED_NR, GRADED_T, GRADED_MU0 = 1e-2, 1e-3, 0.01, -1.0
# p = 2 and 10 at 100 x 4 cells, order 3 (7826 dofs); 0.25 and 0.75 at 50 x 2 (docs/graded.md)
GRADED_REFERENCE = {0.25: -0.1706, 0.75: -0.2507, 2.0: -0.29104928, 10.0: -0.22366575}
PIN_RADIUS = 0.25  # inside the hoop-compressed rim where the critical modes live (r/R > 0.68)


def split_disk(*, maxh: float, curve_order: int, half: bool = False) -> ngs.Mesh:
    """Unit disk in z = 0 as four quadrant faces (region "gel", rim "rim"): the straight edges
    along the x and y axes put mesh vertices exactly on the axes for the rigid-motion pins.
    ``half``: only the quadrants with y >= 0, the straight edge on y = 0 named "cut"."""
    disk = occ.WorkPlane().Circle(0, 0, 1.0).Face()
    quadrants = [disk * occ.Box(occ.Pnt(0 if sx > 0 else -2, 0 if sy > 0 else -2, -1),
                                occ.Pnt(2 if sx > 0 else 0, 2 if sy > 0 else 0, 1))
                 for sx in (1, -1) for sy in ((1,) if half else (1, -1))]
    shape = occ.Glue(quadrants)
    shape.faces.name = "gel"
    for edge in shape.edges:
        c = edge.center
        if abs(math.hypot(c.x, c.y) - 1.0) < 0.1:
            edge.name = "rim"
        elif half and abs(c.y) < 1e-12:
            edge.name = "cut"
    mesh = ngs.Mesh(occ.OCCGeometry(shape).GenerateMesh(maxh=maxh))
    mesh.Curve(curve_order)
    return mesh


def _axis_vertex(mesh: ngs.Mesh, axis: int, radius: float) -> tuple[float, float, float]:
    """The mesh vertex on coordinate axis ``axis`` nearest to ``radius`` from the centre."""
    points = np.array([v.point for v in mesh.vertices])
    on_axis = np.flatnonzero(np.abs(points[:, 1 - axis]) < 1e-12)
    best = on_axis[np.argmin(np.abs(points[on_axis, axis] - radius))]
    return tuple(points[best])


def graded_gel(p: float, *, n0: float = GRADED_N0, nR: float = GRADED_NR) -> tuple[FloryRehnerGel, float]:
    """The graded gel of exponent ``p`` (``Nv`` a field of x, y) and the reference stretch: the
    stiff gel's free swelling at ``GRADED_MU0`` (as ``graded_plate.build``, MODEL.md 2)."""
    stiff = FloryRehnerGel(Nv=max(n0, nR), chi=GEL.chi)
    gel = FloryRehnerGel(Nv=radial_grading(n0, nR, p, 1.0), chi=GEL.chi)
    return gel, stiff.lam_free(GRADED_MU0)


def graded_plate_shell(p: float, *, maxh: float, order: int, t: float = GRADED_T, realcompile: bool = False,
                       half: bool = False, n0: float = GRADED_N0, nR: float = GRADED_NR,
                       **shell_options) -> tuple[GelShell, ngs.Mesh, list]:
    """The graded disk (thickness ``t``) as a ``GelShell`` on the full disk at ``mu0`` (not yet solved): graded
    ``Nv`` as a field, the stiff gel's free-swelling reference (as the axisymmetric section of
    ``graded_plate.build``). Rigid motions are removed by six statically determinate pins
    (centre: x, y, z; a vertex on the x axis at ``PIN_RADIUS``: y, z; one on the y axis: z): the
    flat state loads none of them, and the critical modes (outer third) hardly move there.
    ``half``: the half disk y >= 0 with mirror symmetry about y = 0 (only cos k theta modes of w:
    the sin k theta partner of every wave number, which shares its eigenvalue on the full disk,
    is excluded); three pins (centre: x, z; the x-axis vertex: z). ``shell_options`` go to
    ``GelShell`` (e.g. ``inverse``). Returns the shell, the mesh and the off-centre pin points."""
    mesh = split_disk(maxh=maxh, curve_order=order, half=half)
    gel, lam0 = graded_gel(p, n0=n0, nR=nR)
    shell = GelShell(mesh, material=gel, lam0=lam0, thickness=t, mu=GRADED_MU0, order=order,
                     realcompile=realcompile, **shell_options)
    if half:
        shell.symmetry("cut", normal="y")
        on_x = _axis_vertex(mesh, 0, PIN_RADIUS)
        shell.prescribe_point((0.0, 0.0, 0.0), "x", 0.0)
        shell.prescribe_point((0.0, 0.0, 0.0), "z", 0.0)
        shell.prescribe_point(on_x, "z", 0.0)
        return shell, mesh, [on_x]
    for component in ("x", "y", "z"):
        shell.prescribe_point((0.0, 0.0, 0.0), component, 0.0)
    on_x, on_y = _axis_vertex(mesh, 0, PIN_RADIUS), _axis_vertex(mesh, 1, PIN_RADIUS)
    shell.prescribe_point(on_x, "y", 0.0)
    shell.prescribe_point(on_x, "z", 0.0)
    shell.prescribe_point(on_y, "z", 0.0)
    return shell, mesh, [on_x, on_y]


def odd_free_mask(shell: GelShell, mesh: ngs.Mesh) -> np.ndarray:
    """Free dofs of the half disk's perturbations odd in y (``graded_plate_shell(half=True)``): on
    the cut ``u_x = w = 0`` and the rotation about it free (the mirror images of the symmetry
    conditions), and the odd rigid motions (translation along y, rotation about z and about x)
    held by ``u_y`` at the centre and at the x-axis pin and ``w`` at the y-axis vertex at
    ``PIN_RADIUS``. The tangent of a state even in y restricted to these dofs is the full disk's
    tangent for the modes the half disk excludes (``sin k theta`` deflections)."""
    V = ngs.VectorH1(mesh, order=shell.order, dirichletx_bbnd="cut", dirichletz_bbnd="cut")
    others = [ngs.NormalFacetSurface(mesh, order=shell.order - 1)]
    others += [ngs.SurfaceL2(mesh, order=shell.order - 1)] * (len(shell.space.components) - 2)
    odd_space = ngs.FESpace([V] + others)
    if odd_space.ndof != shell.space.ndof:
        raise ValueError("the shell's space is not the half disk's (VectorH1, NormalFacetSurface, SurfaceL2 ...)")
    mask = np.array(list(odd_space.FreeDofs()), dtype=bool)
    pins = [((0.0, 0.0, 0.0), 1), (_axis_vertex(mesh, 0, PIN_RADIUS), 1), (_axis_vertex(mesh, 1, PIN_RADIUS), 2)]
    for point, component in pins:
        mask[shell._vertex_dofs(shell._vertex(point))[component]] = False
    return mask


def disk_circle_values(field: ngs.CoefficientFunction, mesh: ngs.Mesh, *, radius: float, n: int,
                       half: bool = False, odd: bool = False) -> np.ndarray:
    """``field`` at ``theta_i = 2 pi i / n`` on a circle about the centre of a disk mid-surface;
    ``half``: the mesh is the half y >= 0 of a mirror-symmetric disk, ``field(theta) = field(-theta)``
    (a scalar even in y, e.g. the deflection), or with ``odd`` ``-field(-theta)`` (the deflection
    of a mode odd in y)."""
    if not half:
        return sample_on_circle(field, mesh, center=(0.0, 0.0, 0.0), radius=radius, n=n).values
    theta = 2.0 * np.pi * np.arange(n) / n
    sign = [-1.0 if odd and math.sin(a) < 0 else 1.0 for a in theta]
    return np.array([s * field(mesh(radius * math.cos(a), abs(radius * math.sin(a)), 0.0, ngs.BND))
                     for s, a in zip(sign, theta)])


def plate_mode_wave(mode_u, mesh: ngs.Mesh, *, half: bool = False, odd: bool = False) -> dict:
    """Wave number of a plate mode's deflection on the circle (r/R = 0.3 ... 0.95) where it is
    largest (``half``, ``odd``: see ``disk_circle_values``)."""
    best = None
    for rho in np.linspace(0.3, 0.95, 14):
        values = disk_circle_values(mode_u[2], mesh, radius=float(rho), n=64, half=half, odd=odd)
        analysis = wave_number(values, max_mode=12)
        if best is None or analysis.amplitude > best[1].amplitude:
            best = (float(rho), analysis)
    return {"k": best[1].k, "purity": best[1].purity, "k_second": best[1].second, "mode_radius": best[0]}


def _graded_onset_path(problem, *, mu_max: float, step: float, tol: float, progress, history,
                       newton_options: dict | None = None) -> tuple:
    """``problem.mu`` stepped from ``mu0`` to ``mu_max`` by the continuation driver (natural) with
    the exact negative count of the tangent, stopping at the first unstable state; the first
    change located to ``tol`` in ``mu``. Returns the path and its part of an onset row."""
    path = follow_path(problem, problem.mu, method="natural", step=step, max_step=step, target=mu_max,
                       stability=StabilityOptions(eigenvalues=2, tol=tol), progress=progress,
                       history=history, stop=lambda point: bool(point.negative), newton_options=newton_options)
    row = {"ndof": problem.space.ndof, "steps": len(path.points), "found": bool(path.events),
           "lowest_eigenvalue": [(pt.parameter, pt.eigenvalues[0]) for pt in path.points]}
    if path.events:
        event = path.events[0]
        row.update(mu_critical=event.parameter, mu_error=event.parameter_error, event=event.kind,
                   negative_after=event.negative_after)
    return path, row


def graded_plate_shell_onset(p: float, *, maxh: float, order: int, mu_max: float = -0.05, step: float = 0.05,
                             tol: float = 1e-5, progress=None, history=None) -> dict:
    """Onset of buckling of the free-swelling graded disk (``graded_plate_shell``): ``mu`` stepped
    from ``mu0`` by the continuation driver with the exact negative count of the tangent, the
    first change located to ``tol`` in ``mu``; the wave number from ``plate_mode_wave``."""
    start = time.perf_counter()
    shell, mesh, (on_x, on_y) = graded_plate_shell(p, maxh=maxh, order=order)
    mesh_seconds = time.perf_counter() - start
    path, onset = _graded_onset_path(shell, mu_max=mu_max, step=step, tol=tol, progress=progress,
                                     history=history)
    row = {"model": "shell", "order": order, "maxh": maxh, "p": p, "elements": mesh.GetNE(ngs.BND), **onset}
    if path.events:
        row.update(**plate_mode_wave(path.events[0].mode.components[0], mesh),
                   pin_reactions=[shell.reaction(on_x, "z"), shell.reaction(on_y, "z")])
    row["seconds"] = time.perf_counter() - start - mesh_seconds
    return row


def graded_plate_solid(p: float, *, maxh: float, layers: int, order: int,
                       t: float = GRADED_T) -> tuple[EquilibriumProblem, ngs.Mesh, list[int]]:
    """The graded disk as a 3D thin solid (``plate_solid``: ``layers`` prism layers under
    triangles of size ``maxh``, elements and geometry of ``order``) at ``mu0``, not yet solved;
    gel and reference as ``graded_plate_shell``. Use one layer: two curved layers lock (onset 20 %
    late at h = 0.2, order 2, where one layer is 4.5 % late; docs/benchmarks.md).

    Rigid motions are removed by six statically determinate pins on the vertex level nearest
    the mid-plane (the mid-plane for an even ``layers``, the bottom face for one layer): z at the
    three rim vertices nearest the polar angles 0, 2 pi/3, 4 pi/3, x and y at the vertex nearest
    the centre, y at the rim vertex on the x axis (the mesh has no vertices on the axes inside the
    rim). Every free equilibrium meets them after a rigid motion, and their reactions vanish (see
    the onset row). For the flat state that motion is a z translation and a rotation about z of
    ~0.01 (the centre vertex lies off the axis), no tilt: the z pins lie at one radius, where the
    flat state's bottom face is level. The layout is not immaterial on coarse meshes
    (statically determinate pins change no onset when rigid rotations are exact discrete
    motions; on this curved mesh they are not: the identity is not in the space of the same
    order, docs/benchmarks.md): the shell's layout (z
    at the vertices nearest r = 0 and (0.25, 0), (0, 0.25), where the modes hardly move; the
    flat state then tilts by the thickness change between those radii) moved the onsets by
    -1.6 % (h = 0.2, order 2), +0.5 % (h = 0.15, order 2), -0.9 % (h = 0.3, order 3) and -0.02 %
    (h = 0.2, order 3) (negative: earlier), and its location solves crawled above the Newton
    floor of ``graded_plate_solid_onset`` at h = 0.1, order 2. Returns the problem, the mesh and
    the pinned dofs."""
    mesh = plate_solid(t=t, maxh=maxh, layers=layers, curve_order=order).mesh
    gel, lam0 = graded_gel(p)
    problem = EquilibriumProblem(mesh, kinematics=Solid3D(), materials=gel, lam0=lam0, mu=GRADED_MU0, order=order)
    levels = np.unique(np.round([v.point[2] for v in mesh.vertices], 12))
    z = float(levels[np.argmin(np.abs(levels))])
    points = np.array([v.point for v in mesh.vertices])
    on_level = np.flatnonzero(np.abs(points[:, 2] - z) < 1e-9)
    on_rim = on_level[np.abs(np.hypot(points[on_level, 0], points[on_level, 1]) - 1.0) < 1e-9]
    rim = [(math.cos(a), math.sin(a)) for a in (0.0, 2 * math.pi / 3, 4 * math.pi / 3)]
    dofs = []
    for target, components, among in [((0.0, 0.0), (0, 1), on_level), (rim[0], (1, 2), on_rim),
                                      (rim[1], (2,), on_rim), (rim[2], (2,), on_rim)]:
        vertex = among[np.argmin(np.sum((points[among] - (*target, z)) ** 2, axis=1))]
        node = problem.space.GetDofNrs(ngs.NodeId(ngs.VERTEX, int(vertex)))
        for component in components:
            problem.fix_dof(node[component])
            dofs.append(node[component])
    return problem, mesh, dofs


def without_rigid_deflection(w: ngs.CoefficientFunction, mesh: ngs.Mesh) -> ngs.CoefficientFunction:
    """``w - (a + b x + c y)``: a deflection field without its L2 projection on the rigid
    deflections (a translation and two tilts) over the body. A critical mode of a pinned free body
    holds the rigid motion that zeroes it at the pins; this removes it, whatever the pins."""
    basis = [ngs.CF(1.0), ngs.x, ngs.y]
    gram = np.array([[ngs.Integrate(a * b, mesh) for b in basis] for a in basis])
    coefficients = np.linalg.solve(gram, [ngs.Integrate(w * b, mesh) for b in basis])
    return w - sum(float(c) * b for c, b in zip(coefficients, basis))


def graded_plate_solid_onset(p: float, *, maxh: float, layers: int, order: int, mu_max: float = -0.05,
                             step: float = 0.05, tol: float = 1e-5, newton_floor: float = 1e-7, progress=None,
                             history=None) -> dict:
    """Onset of buckling of the graded disk as a 3D thin solid (``graded_plate_solid``), located
    as ``graded_plate_shell_onset`` (same path, stability check and tolerance); the wave number
    from the critical mode's vertical displacement, without its rigid part
    (``without_rigid_deflection``), on circles of the mid-plane (``plate_mode_wave``);
    ``pin_reactions``: the residual at the six pinned dofs at the end.

    Newton's absolute floor is ``newton_floor * step * |dR/dmu|`` (the driver's default: 1e-10):
    next to the critical point Newton crawls at ~1e-8 of a step's load residual (likely: one
    layer has no mid-plane vertices, the z pins lie on a face, and the tilts that Newton's steps
    pick up through them, which a flat state's mirror symmetry does not contain, feed the nearly
    singular bending mode), and location solves there failed at floors of 1e-10 and, on finer
    meshes, 2e-8. Measured effect on the onset (h = 0.2, order 2, z pins on the rim): 4e-6 in mu
    between floors 1e-8 and 1e-7 (below the location tolerance), 2.4e-4 at 1e-6."""
    start = time.perf_counter()
    problem, mesh, pins = graded_plate_solid(p, maxh=maxh, layers=layers, order=order)
    mesh_seconds = time.perf_counter() - start
    path, onset = _graded_onset_path(problem, mu_max=mu_max, step=step, tol=tol, progress=progress, history=history,
                                     newton_options=newton_floor_options(problem, problem.mu, floor=newton_floor,
                                                                         step=step))
    row = {"model": "solid3d", "order": order, "maxh": maxh, "p": p, "layers": layers, "elements": mesh.ne,
           **onset}
    if path.events:
        residual = problem.state.CreateVector()
        problem.residual(problem.state, residual)
        w = without_rigid_deflection(problem.parts(path.events[0].mode)[0][2], mesh)
        row.update(**plate_mode_wave(ngs.CF((0.0, 0.0, w)), mesh), pin_reactions=[float(residual[d]) for d in pins])
    row["seconds"] = time.perf_counter() - start - mesh_seconds
    return row
