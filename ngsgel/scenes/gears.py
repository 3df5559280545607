"""Gears from a shrinking film-coated gel tube (thesis ch. 4, MODEL.md scene B), plane strain.

A gel annulus ``Ri = 1 < r < Ro = 2`` (Nv = 1e-3, chi = 0.5, free swollen at mu = 0) carries bonded
neo-Hookean films inside (thickness ``Ri/(Ri/tfi)``) and outside (``Ro/(Ro/tfo)``), moduli
``Efi``, ``Efo`` in units of ``Es = 3 Nv`` (the thesis's 3NkT), Poisson ratio ``--nu-film``
(0.3: the thesis does not give it). ``mu`` falls from 0 until a free gel would keep ``--volume`` of
its volume. ``--axial fixed`` (default, MODEL.md): plane strain, the axial stretch stays at the
reference; ``--axial free``: generalized plane strain, a long tube with free ends (one uniform
axial stretch of gel and films, a global unknown fixed by zero net axial force; the free gel of
the end volume then shrinks isotropically).

Single run (default): the driver follows ``mu`` with a stability check at every step; the first
loss of stability is located (critical ``mu``, volume fraction, film hoop stresses, wave numbers
of the critical mode on both films), the path switches onto the buckled branch along the
critical mode and follows it to the end without further checks (one spectrum at the end says
whether the final gear is stable). Rigid motions are removed by three tangential point
constraints that carry no load (``ngsgel.supports``). Outputs in ``--out``: ``params.json``,
``path.csv/.jsonl`` (every step), ``summary.json``, ``gear.png`` (deformed films and gel),
``gear.vtu`` (not with ``--quick``).

Sweeps (``--sweep``, values from ``--values``): ``efo``, ``efi``, ``ri_tfi``, ``ro_tfo`` (thesis
figs. 4-1 to 4-4: FE onset film, ``mu``, gel volume and wave number against one parameter, with
the ring-on-foundation analysis and the thesis's eq. 4-1; ``efo`` also bisects the analysis's
switch of the first-buckling film and the Efo ranges where each film buckles before the end),
``convergence`` (onset and wave numbers at several resolutions with wall times). Each writes
``sweep_<name>.csv`` / ``<name>.csv`` and a picture; ``--resume DIR`` goes on with a stopped sweep
from the first case it has no row of.
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import asdict, dataclass

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import ngsolve as ngs
from scipy.sparse.linalg import LinearOperator, eigsh

import geometries as geo
from ngsgel import EquilibriumProblem, GeneralizedPlaneStrain, PlaneStrain
from ngsgel.continuation import BorderedCorrector, follow_path
from ngsgel.scenes.film_tube import (FILM_INNER, FILM_OUTER, GEL, FilmTube, RadialTube, ring_onset,
                              thesis_ring_estimate)
from ngsgel.newton import NewtonError
from ngsgel.output import (History, Progress, RunDirectory, VTKSeries, command_options, quick_run, resume_arguments,
                           scene_parser)
from ngsgel.patterns import periodic_peaks, sample_on_circle, wave_number
from ngsgel.stability import arpack_start, free_matrix, load_rate, mass_matrix, mode_function, negative_count
from ngsgel.stepping import ramp
from ngsgel.supports import pin_rigid_modes, pin_vertex_component, vertex_dof
from ngsgel.threads import configured_threads

NV, CHI = 1e-3, 0.5
ES = 3 * NV  # the thesis's Es = 3NkT, in units of kT/v
RI, RO = 1.0, 2.0
SAMPLES = 2048  # points per circle for wave analysis and pictures
TOOTH_DIRECTION = {"inner": -1.0, "outer": 1.0}  # teeth point inward on the inner film, outward on the outer


@dataclass(frozen=True)
class Scene:
    """Parameters of one gear run (thesis names; moduli relative to ``Es``)."""

    efi: float = 12.5
    efo: float = 7.23
    ri_tfi: float = 50.0
    ro_tfo: float = 100.0
    nu_film: float = 0.3
    volume: float = 0.7
    axial: str = "fixed"  # "fixed": plane strain; "free": generalized plane strain (free ends)

    def tube(self) -> FilmTube:
        return FilmTube(Ri=RI, Ro=RO, tfi=RI / self.ri_tfi, tfo=RO / self.ro_tfo, Efi=self.efi * ES,
                        Efo=self.efo * ES, nu_film=self.nu_film, Nv=NV, chi=CHI, axial=self.axial)


@dataclass(frozen=True)
class Resolution:
    """``n_theta`` cells around (a multiple of 4, for the rigid-mode supports), element
    ``order``, gel cell size ``maxh`` away from the films, ``film_layers`` cells across each film."""

    n_theta: int = 256
    order: int = 2
    maxh: float = 0.2
    film_layers: int = 2


def check_scene(scene: Scene) -> None:
    """Bad input raises ValueError naming the parameter and its range, before any work."""
    ranges = {"efi": (0.01, 1e4), "efo": (0.01, 1e4), "ri_tfi": (2.0, 1e3), "ro_tfo": (2.0, 1e3),
              "nu_film": (-0.99, 0.499), "volume": (0.3, 0.99)}
    for name, (lo, hi) in ranges.items():
        value = getattr(scene, name)
        if not isinstance(value, (int, float)) or not math.isfinite(value) or not lo <= value <= hi:
            raise ValueError(f"{name} must lie in [{lo}, {hi}], got {value!r}")
    if scene.axial not in ("fixed", "free"):
        raise ValueError(f"axial must be 'fixed' or 'free', got {scene.axial!r}")
    if RI / scene.ri_tfi + RO / scene.ro_tfo >= RO - RI:
        raise ValueError("ri_tfi, ro_tfo: the films must be thinner than the wall together")


def check_resolution(res: Resolution) -> None:
    if not isinstance(res.n_theta, int) or res.n_theta < 16 or res.n_theta % 4:
        raise ValueError(f"n_theta must be a multiple of 4 and >= 16, got {res.n_theta!r}")
    if not isinstance(res.order, int) or not 1 <= res.order <= 5:
        raise ValueError(f"order must be an integer in [1, 5], got {res.order!r}")
    if not isinstance(res.maxh, (int, float)) or not 0.005 <= res.maxh <= 1.0:
        raise ValueError(f"maxh must lie in [0.005, 1], got {res.maxh!r}")
    if not isinstance(res.film_layers, int) or not 1 <= res.film_layers <= 8:
        raise ValueError(f"film_layers must be an integer in [1, 8], got {res.film_layers!r}")


# ----------------------------------------------------------------------------- model
class GearModel:
    """The plane-strain FE model of one scene and its measurements."""

    def __init__(self, scene: Scene, res: Resolution):
        check_scene(scene)
        check_resolution(res)
        self.scene, self.res, self.tube = scene, res, scene.tube()
        t = self.tube
        self.bundle = geo.tube_plane(Ri=RI, Ro=RO, tfi=t.tfi, tfo=t.tfo, maxh=res.maxh, n_theta=res.n_theta,
                                     film_layers=res.film_layers, quad=True)
        self.mesh = self.bundle.mesh
        # NGSolve's sparse LDL^T (no pivoting; it factors the indefinite tangents past the onset,
        # and a failed factorisation would show as a Newton failure): 8x faster than UMFPACK's
        # LU here (0.21 s against 1.7 s per factorisation at 22k dofs)
        kinematics = PlaneStrain() if scene.axial == "fixed" else GeneralizedPlaneStrain()
        self.problem = EquilibriumProblem(self.mesh, kinematics=kinematics, materials=t.materials(),
                                          lam0=t.lam0, mu=t.mu0, order=res.order, inverse="sparsecholesky")
        # supports on the gel's inner surface, where the structured mesh has vertices at 0, pi/2, pi
        pin_rigid_modes(self.problem, radius=RI)
        self.mu_end = t.mu_at_volume_fraction(scene.volume)
        e_r = ngs.CF((ngs.x, ngs.y)) / ngs.sqrt(ngs.x**2 + ngs.y**2)
        e_t = ngs.CF((-ngs.y, ngs.x)) / ngs.sqrt(ngs.x**2 + ngs.y**2)
        self.e_r = e_r
        sigma = self.problem.stress()
        sigma2 = ngs.CF((sigma[0, 0], sigma[0, 1], sigma[1, 0], sigma[1, 1]), dims=(2, 2))
        self.hoop = ngs.InnerProduct(sigma2 * e_t, e_t)  # reference e_theta: the pre-buckling state is axisymmetric
        self.areas = self.bundle.region_measures
        self.radii = {"inner": t.film("inner")[0], "outer": t.film("outer")[0]}

    def volume_fraction(self) -> float:
        det = ngs.Det(self.problem.deformation_gradient(self.problem.displacement))
        return self.problem.integrate(det, region=GEL) / self.areas[GEL]

    def mean_hoop_stress(self, region: str) -> float:
        return self.problem.integrate(self.hoop, region=region) / self.areas[region]

    def radial_signal(self, field, film: str) -> np.ndarray:
        """Radial component of a displacement field on the film's reference mid-circle."""
        samples = sample_on_circle(ngs.InnerProduct(field, self.e_r), self.mesh, center=(0.0, 0.0),
                                   radius=self.radii[film], n=SAMPLES)
        return samples.values

    def waves(self, field, film: str, *, max_mode: int = 200) -> dict:
        signal = self.radial_signal(field, film)
        analysis = wave_number(signal - signal.mean(), max_mode=max_mode)
        return {"k": analysis.k, "amplitude": analysis.amplitude, "purity": analysis.purity}

    def qoi(self) -> dict:
        u = self.problem.displacement
        q = {"volume_fraction": self.volume_fraction, "axial_stretch": self.problem.axial_stretch,
             "hoop_inner": lambda: self.mean_hoop_stress(FILM_INNER),
             "hoop_outer": lambda: self.mean_hoop_stress(FILM_OUTER)}
        for film in ("inner", "outer"):
            q[f"amplitude_{film}"] = (lambda f=film: self.waves(u, f)["amplitude"])
            q[f"k_{film}"] = (lambda f=film: self.waves(u, f)["k"])
        return q


def classify(model: GearModel, threshold: float) -> dict:
    """Teeth on a film where the non-axisymmetric radial displacement of its mid-circle has a
    dominant-mode amplitude of at least ``threshold`` film thicknesses; tooth counts from the
    periodic peaks of that signal (teeth point inward for the inner film, outward for the outer)."""
    u = model.problem.displacement
    result = {}
    for film, thickness in (("inner", model.tube.tfi), ("outer", model.tube.tfo)):
        signal = model.radial_signal(u, film)
        w = model.waves(u, film)
        peaks = periodic_peaks(TOOTH_DIRECTION[film] * (signal - signal.mean()), relative_prominence=0.3)
        result[film] = {"teeth": bool(w["amplitude"] >= threshold * thickness), "k": w["k"],
                        "amplitude": w["amplitude"], "amplitude_over_t": w["amplitude"] / thickness,
                        "purity": w["purity"], "tooth_count": peaks.count}
    kind = {(True, False): "inner teeth", (False, True): "outer teeth", (True, True): "double teeth",
            (False, False): "no teeth"}[(result["inner"]["teeth"], result["outer"]["teeth"])]
    return {"type": kind, **result}


# ----------------------------------------------------------------------------- runs
def onset(model: GearModel, *, history=None, progress=None, start_mu: float | None = None,
          step_fraction: float = 0.03, tol_fraction: float = 2e-4):
    """Follow ``mu`` down with stability checks until the first loss of stability, then locate it
    by bisection on the exact negative count to ``tol_fraction`` of the ``mu`` span.

    Without checks up to ``start_mu`` (a fraction of the analysis's onset: a check costs a
    spectrum); if the state there is already unstable the run starts over with checks from
    ``mu0``. The location is done here rather than by the driver's secant on the lowest
    eigenvalue: the lowest eigenvalue before the onset belongs to a soft global (ovalisation)
    mode of the tube that never crosses zero, so the secant on it converges only at bisection
    speed, each iteration paying a full spectrum; the count needs one factorisation.
    Returns the onset record (None if stable to the end) and the critical state, ``mu`` and
    mode (a free-dof vector)."""
    p = model.problem
    span = abs(model.mu_end - model.tube.mu0)
    saved = p.save_state()

    def negative() -> int:
        return negative_count_of(p)

    if start_mu is not None and model.mu_end < start_mu < model.tube.mu0:
        ramp(p, p.mu, start_mu)
        if negative() > 0:
            p.restore_state(saved)
            p.mu.Set(model.tube.mu0)
    # absolute floor as the driver's: a solve starting next to its solution cannot reduce a
    # round-off residual by a relative factor (also for the driver's first solve, at an already
    # converged state: with p = 3 its relative target 1e-27 lay below the round-off 1e-16)
    atol = 1e-10 * span * step_fraction * float(np.linalg.norm(load_rate(p, p.mu).residual))
    # the exact negative count at every step (one LDL^T, ~0.5 s), no spectrum (~10 s)
    result = follow_path(
        p, p.mu, method="natural", step=span * step_fraction, max_step=span * step_fraction,
        target=model.mu_end, qoi={**model.qoi(), "negative_count": negative, "phase_pin_reaction": lambda: math.nan}, history=history, progress=progress,
        keep_states=True, stop=lambda pt: pt.qoi["negative_count"] > 0, newton_options={"atol": atol})
    if result.points[0].qoi["negative_count"]:
        raise RuntimeError("the first checked state is unstable although it was checked stable")
    if not result.points[-1].qoi["negative_count"]:
        return None, None
    a, b = result.points[-2], result.points[-1]
    lo, hi = (a.parameter, a.state), (b.parameter, b.state)  # stable, unstable
    while abs(hi[0] - lo[0]) > tol_fraction * span:
        s = 0.5
        p.restore_state(lo[1] + s * (hi[1] - lo[1]))
        p.mu.Set(lo[0] + s * (hi[0] - lo[0]))
        p.solve(atol=atol)
        point = (p.mu.Get(), p.save_state())
        if negative() > 0:
            hi = point
        else:
            lo = point
    # the critical pair: the two most negative eigenvalues on the unstable side of the bracket
    # (all negative ones are computed). Not the two lowest on the stable side: the crossing pair
    # falls steeply and can still lie above the soft global mode there (Efo/Es = 1 and 8.8: the
    # two lowest were the global mode and one member of the pair, split 3.5 and 0.87, and the
    # mixed mode broke the branch switch). A free ring's pair is cos and sin with equal
    # eigenvalues; the rigid-mode pins on the gel's inner surface change the eigenvalues (not the
    # inertia) of modes that move them, so an inner-film pair is split (Efo/Es = 1: -6.7e-6 and
    # -1.4e-6), an outer-film pair is not (split ~1e-10); the split is recorded. The mode is
    # their combination that is mirror-symmetric about the x axis, with a tooth of the buckling
    # film at angle 0 (``tooth_at_angle_zero``), see ``switch_branch`` (the branch switch
    # converges from it onto the buckled branch).
    p.restore_state(hi[1])
    p.mu.Set(hi[0])
    negative_after = negative()
    eigenvalues, modes = negative_modes(p, negative_after)
    split = abs(float(eigenvalues[1] - eigenvalues[0])) / abs(float(eigenvalues[0]))
    phi = mirror_symmetric_mode(model, modes[:, :2])
    mode = mode_function(p, phi)
    qoi = {k: f() for k, f in model.qoi().items()}
    mode_waves = {film: model.waves(p.parts(mode)[0], film) for film in ("inner", "outer")}
    located = max(mode_waves, key=lambda f: mode_waves[f]["amplitude"])
    mode = mode_function(p, tooth_at_angle_zero(model, phi, located))
    record = {"mu_cr": 0.5 * (lo[0] + hi[0]), "mu_bracket": [lo[0], hi[0]], "negative_after": negative_after,
              "eigenvalues_after": [float(v) for v in eigenvalues],
              "volume_fraction_cr": qoi["volume_fraction"], "axial_stretch_cr": qoi["axial_stretch"],
              "hoop_inner_cr": qoi["hoop_inner"], "hoop_outer_cr": qoi["hoop_outer"],
              "mode_k_inner": mode_waves["inner"]["k"], "mode_k_outer": mode_waves["outer"]["k"],
              "mode_amplitude_ratio_inner_outer": mode_waves["inner"]["amplitude"] / mode_waves["outer"]["amplitude"],
              "mode_film": located, "mode_k": mode_waves[located]["k"],
              "pair_eigenvalue_split": split,
              "mode_film_amplitude": mode_waves[located]["amplitude"]}
    if history is not None:
        history.append({"step": "onset", "parameter": record["mu_cr"], **qoi, "negative": negative_after,
                        "events": f"onset {located} film, {record['mode_k']} waves"})
    return record, (hi[1], hi[0], mode)


def negative_modes(p, negative: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``negative`` negative eigenvalues (ascending, at least two) of ``K phi = omega M phi``
    at a state just past the onset and their modes (free-dof columns).

    Shift-invert about zero with the problem's own sparse LDL^T of the tangent, not
    ``stability.spectrum``: zero is no eigenvalue (the inertia is known), so no shift search is
    needed; ``spectrum``'s general SuperLU of the shifted matrix (COLAMD ordering, 47 million
    nonzeros in its factors at 29k dofs, p = 3) took 4-6 s of the quick run, the LDL^T 0.05 s.
    The exact count is checked against the eigenvalues found."""
    free = p.free_mask
    K = p.tangent(p.state)
    inv = p._solver.factor(K)
    full, out = p.state.CreateVector(), p.state.CreateVector()

    def solve(v: np.ndarray) -> np.ndarray:
        full.FV().NumPy()[:] = 0.0
        full.FV().NumPy()[free] = np.ravel(v)
        out.data = inv * full
        return out.FV().NumPy()[free].copy()

    n = int(np.count_nonzero(free))
    M = free_matrix(mass_matrix(p), free)
    A, OPinv = free_matrix(K, free), LinearOperator((n, n), matvec=solve, dtype=float)
    if negative >= 2:
        # "SA" of the shift-inverted values 1/omega: the most negative 1/omega are exactly the
        # negative omega (an extreme end of the transformed spectrum, found in few Lanczos steps).
        # Not "LM" (nearest zero): at n_theta = 256, p = 2 the four nearest zero came back as
        # -8.2e-5, +2.8e-5 twice and +3.8e-5, without the second negative one; asking for more
        # until all were found took 8 s at the quick onset
        values, vectors = eigsh(A, k=negative, M=M, sigma=0.0, which="SA", OPinv=OPinv, v0=arpack_start(n))
    else:  # one member of a pair split by the mesh crossed (48 cells, p = 4: n = 24 = 48/2): it and
        # the nearest positive one, its partner
        values, vectors = eigsh(A, k=2, M=M, sigma=0.0, which="LM", OPinv=OPinv, v0=arpack_start(n))
    order = np.argsort(values)
    values, vectors = values[order], vectors[:, order]
    if np.count_nonzero(values < 0) != negative:
        raise RuntimeError(f"{negative} negative eigenvalues expected, found {values}")
    # normalised as ``stability.spectrum``'s modes: phi^T M phi = volume. At least two: a pair split
    # by the mesh can cross one member at a time (48 cells, p = 4: n = 24 = 48/2)
    keep = max(negative, 2)
    return values[:keep], vectors[:, :keep] * math.sqrt(p.integrate(ngs.CF(1.0)))


def phase_points(model: GearModel) -> dict:
    """Where a film's pattern phase is pinned: the vertex of its free surface at angle 0."""
    return {"inner": (RI - model.tube.tfi, 0.0), "outer": (RO + model.tube.tfo, 0.0)}


def mirror_symmetric_mode(model: GearModel, pair: np.ndarray) -> np.ndarray:
    """The combination of a degenerate pair of ring modes (free-dof columns) that is symmetric
    about the x axis: zero ``u_y`` at the films' free-surface vertices at angle 0 (the mesh is
    mirror-symmetric about the x axis, so the pair splits into an even and an odd mode; the
    combination is taken at the vertex where the odd part is largest)."""
    free_idx = np.flatnonzero(model.problem.free_mask)
    rows = [pair[np.searchsorted(free_idx, vertex_dof(model.problem, point=point, component=1)), :] for point in phase_points(model).values()]
    v = max(rows, key=np.linalg.norm)
    return pair @ (np.array([v[1], -v[0]]) / np.linalg.norm(v))


def tooth_at_angle_zero(model: GearModel, phi: np.ndarray, film: str) -> np.ndarray:
    """``phi`` (free-dof column) or ``-phi``: the one with a tooth of ``film`` at its phase point.

    The sign of the mirror-symmetric combination follows the orientation of the basis ARPACK
    returns for the pair, i.e. round-off, and the two signs start different branches on the
    mesh (quick run, Efo/Es = 7.23: a tooth at angle 0 ended with 0 negative eigenvalues, a gap
    between teeth with 11, energy 4.4e-8 higher; a 1e-15 change of the tangent flipped the sign)."""
    free_idx = np.flatnonzero(model.problem.free_mask)
    # the phase points lie on the positive x axis: u_x is the radial displacement there
    radial = phi[np.searchsorted(free_idx, vertex_dof(model.problem, point=phase_points(model)[film], component=0))]
    if radial == 0.0:
        raise RuntimeError(f"the critical mode does not move the {film} film's phase point radially: no tooth sign")
    return phi if TOOTH_DIRECTION[film] * radial > 0 else -phi


def switch_branch(model: GearModel, critical, record: dict, *, film_amplitude: float = 0.25,
                  path_tol: float = 1e-10) -> dict:
    """Converge onto the buckled branch at a prescribed amplitude of the critical mode: the state
    is the located critical state plus ``s`` times the mode plus a correction orthogonal to the
    mode, ``mu`` is an unknown (bordered Newton, the driver's branch-switch corrector), ``s`` such
    that the buckling film's radial amplitude is ``film_amplitude`` film thicknesses. Pins the
    pattern's phase first (``u_y = 0`` at the buckling film's free-surface vertex at angle 0).

    Why amplitude control: a natural step (fixed ``mu`` past the critical one, guessed amplitude)
    needs the amplitude to be right; 0.25 t_f at 3 % of the span past the onset (true: 0.66 t_f)
    took 19 Newton iterations, most of them line-search cut, against 3-5 with the amplitude
    prescribed (Efo/Es = 100, coarse mesh).

    Why the pin: on the buckled branch of a ring the rotation of the pattern relative to the
    material is a zero mode of the continuum, broken only by the mesh (lowest tangent eigenvalue
    3.9e-12 against 3.2e-5 for the next at the first buckled state, Efo/Es = 100, coarse mesh).
    Newton's step then has a huge component along it, the line search cuts it to nothing and the
    residual stagnates (at 5e-12 ... 2e-7 of an initial 1e-4 in 40 iterations). The critical mode
    is the mirror-symmetric member of the pair, the buckled states stay mirror-symmetric and the
    pin carries no load in them (its reaction is recorded along the path). Stability checks on
    the pinned branch miss instabilities that are odd about the x axis.
    ``path_tol``: absolute residual floor of every solve on the branch, relative to the load
    scale ``span |dR/dmu|`` (the round-off floor is ~1e-13 of it).
    Returns the pinned dof, the Newton record and the ``mu`` of the first buckled state."""
    state, mu, mode = critical
    p = model.problem
    thickness = model.tube.tfi if record["mode_film"] == "inner" else model.tube.tfo
    dof = pin_vertex_component(p, point=phase_points(model)[record["mode_film"]], component=1)
    free = p.free_mask
    phi = mode.vec.FV().NumPy()[free]
    span = abs(model.mu_end - model.tube.mu0)
    atol = path_tol * span * float(np.linalg.norm(load_rate(p, p.mu).residual))
    # The guess (critical state plus s times the mode, at the critical mu) is off the branch by
    # O(s^2): the branch bends away from the mode and mu moves like s^2. Iterations to the floor
    # from 0.125 / 0.25 / 0.5 / 0.75 / 1 t_f, quick mesh: Efo/Es = 7.23 3 / 4 / 5 / 7 / none in
    # 40; Efo/Es = 100 3 / 4 / 5 / 6 / 7 (its residual rose at the second). Without a line search
    # an iterate outside Newton's basin wanders: from 1 t_f at Efo/Es = 7.23 (its branch reaches
    # 0.7 t_f at the end) it did not converge in 40 iterations, or, from the other sign of the
    # mode, landed at the 15th, 1.45 spans past the onset (Efo/Es = 1 and 8.8 at 0.25 t_f:
    # residual 1.6e-3 and 5.6e-3 after 30 iterations). So an attempt fails at its first iteration
    # that does not lower the residual (``monotone``: from 1 t_f at Efo/Es = 7.23 the fourth or
    # the ninth, by the sign) and the amplitude is halved, at most three times; every failure is
    # recorded
    corrector = BorderedCorrector(p, p.mu, atol=atol, maxit=15, monotone=True)
    failures = []
    for attempt in range(4):
        amplitude = film_amplitude / 2**attempt
        scale = amplitude * thickness / record["mode_film_amplitude"]
        guess = state + scale * mode.vec.FV().NumPy()
        guess[dof] = 0.0  # zero up to round-off already (axisymmetric state, mirror-symmetric mode)
        try:
            result = corrector.solve((guess, mu), (state[free], mu), (phi / (phi @ phi), 0.0), scale)
            break
        except NewtonError as err:
            failures.append({"film_amplitude": amplitude, "message": str(err)})
    else:
        raise RuntimeError(f"no buckled state found along the critical mode: {failures}")
    return {"dof": dof, "iterations": result.iterations, "residuals": result.residuals, "mu": p.mu.Get(), "atol": atol,
            "film_amplitude": amplitude, "failed_attempts": failures,
            "mu_past_onset_fraction": (p.mu.Get() - mu) / (model.mu_end - model.tube.mu0)}


def analysis(scene: Scene, mu_end: float, stiffnesses=("michell", "lame"), *, steps: int = 16,
             tol_fraction: float = 1e-4) -> dict:
    """Ring-on-foundation onsets of both films (Michell stiffness, and the thesis's Lame one):
    ``steps`` grid steps to the end, bisection to ``tol_fraction`` of ``|mu_end|``."""
    tube = scene.tube()
    radial = RadialTube(tube)
    out = {}
    for stiffness in stiffnesses:
        for film in ("inner", "outer"):
            o = ring_onset(tube, film, mu_end=mu_end, stiffness=stiffness, radial=radial, steps=steps,
                           tol=abs(mu_end) * tol_fraction)
            out[f"{stiffness}_{film}"] = asdict(o)
        mi, mo = out[f"{stiffness}_inner"]["mu"], out[f"{stiffness}_outer"]["mu"]
        first = None if mi is None and mo is None else (
            "inner" if mo is None or (mi is not None and mi > mo) else "outer")
        out[f"{stiffness}_first"] = first
    return out


def analysis_switch_point(base: Scene, stiffness: str, *, lo: float = 1.0, hi: float = 100.0,
                          rtol: float = 1e-3, far_volume: float = 0.5) -> float | None:
    """``Efo/Es`` at which the analysis's inner and outer onsets coincide (the thesis's 6.5), by
    bisection in ``log Efo`` between ``lo`` (inner first) and ``hi`` (outer first). The onsets are
    followed past the run's end, to a free-gel volume fraction ``far_volume``: near the switch
    both lie just past 70 % (an earlier version cut them at the end and so found the ``Efo`` at
    which the outer onset reaches the end, 3.37, instead of the crossing, 3.33). A film that does
    not buckle before ``far_volume`` counts as buckling there. None if ``lo``, ``hi`` do not
    bracket a switch."""
    def outer_first(efo: float) -> bool:
        scene = Scene(**{**asdict(base), "efo": efo})
        tube = scene.tube()
        mu_far = tube.mu_at_volume_fraction(min(far_volume, scene.volume))
        radial = RadialTube(tube)
        mus = {}
        for film in ("inner", "outer"):
            mu = ring_onset(tube, film, mu_end=mu_far, stiffness=stiffness, radial=radial, steps=30, tol=1e-9).mu
            mus[film] = mu_far if mu is None else mu
        return mus["outer"] > mus["inner"]

    if outer_first(lo) or not outer_first(hi):
        return None
    while hi / lo > 1 + rtol:
        mid = math.sqrt(lo * hi)
        lo, hi = (lo, mid) if outer_first(mid) else (mid, hi)
    return math.sqrt(lo * hi)


def double_onset_zone(base: Scene, stiffness: str = "michell", *, lo: float = 0.3, hi: float = 100.0,
                      rtol: float = 1e-3) -> dict:
    """Where each film reaches its critical force before the run's end (analysis, each film on
    its own): the inner film for ``Efo/Es`` below ``inner_below``, the outer for ``Efo/Es`` above
    ``outer_above``. If ``outer_above < inner_below`` both films buckle before the end in between
    (the analysis's double-teeth zone); otherwise neither does there (a zone of round tubes)."""
    def onset_before_end(film: str, efo: float) -> bool:
        scene = Scene(**{**asdict(base), "efo": efo})
        tube = scene.tube()
        return ring_onset(tube, film, mu_end=tube.mu_at_volume_fraction(scene.volume), stiffness=stiffness,
                          steps=30, tol=1e-9).mu is not None

    edges = {}
    for film, key in (("inner", "inner_below"), ("outer", "outer_above")):
        a, b = lo, hi  # the inner film buckles at a, not at b; the outer the other way round
        if onset_before_end(film, a) == onset_before_end(film, b):
            edges[key] = None
            continue
        while b / a > 1 + rtol:
            mid = math.sqrt(a * b)
            if onset_before_end(film, mid) == onset_before_end(film, a):
                a = mid
            else:
                b = mid
        edges[key] = math.sqrt(a * b)
    i, o = edges["inner_below"], edges["outer_above"]
    edges["kind"] = None if i is None or o is None else ("double" if o < i else "round")
    return edges


def check_start(ana: dict, fraction: float = 0.8) -> float | None:
    """Where the stability checks start: ``fraction`` of the earliest onset ``mu`` that the
    Michell analysis predicts (None, i.e. from the start, if it predicts none)."""
    mus = [ana[f"michell_{film}"]["mu"] for film in ("inner", "outer") if ana[f"michell_{film}"]["mu"] is not None]
    return fraction * max(mus) if mus else None


def draw_gear(model: GearModel, path, *, title: str = "", ax=None) -> None:
    """Deformed gel and films, filled between their deformed boundary circles."""
    u = model.problem.displacement
    t = model.tube
    theta = 2 * np.pi * np.arange(SAMPLES + 1) / SAMPLES
    # stay inside the boundary circles, which the mesh approximates by chords
    eps = 0.3 * min(t.tfi, t.tfo) / model.res.film_layers

    def curve(radius):
        s = sample_on_circle(u, model.mesh, center=(0.0, 0.0), radius=radius, n=SAMPLES)
        xy = s.points + s.values
        return np.vstack([xy, xy[:1]])

    own = ax is None
    if own:
        fig, ax = plt.subplots(figsize=(6, 6))
    bands = [(RI - t.tfi + eps, RI - eps, "tab:red", "inner film"), (RI + eps, RO - eps, "0.8", "gel"),
             (RO + eps, RO + t.tfo - eps, "tab:blue", "outer film")]
    for a, b, color, label in bands:
        inner, outer = curve(a), curve(b)
        ax.fill(np.concatenate([outer[:, 0], inner[::-1, 0]]), np.concatenate([outer[:, 1], inner[::-1, 1]]),
                color=color, lw=0, label=label)
    ref = 1.0
    ax.plot(RO * ref * np.cos(theta), RO * ref * np.sin(theta), "k:", lw=0.5, label="reference outer radius")
    ax.set_aspect("equal")
    ax.axis("off")
    ax.set_title(title, fontsize=9)
    if own:
        ax.legend(loc="upper right", fontsize=7)
        fig.tight_layout()
        fig.savefig(path, dpi=150)
        plt.close(fig)


def negative_count_of(p) -> int:
    """Exact number of negative eigenvalues of the tangent on the free dofs."""
    return negative_count(free_matrix(p.tangent(p.state), p.free_mask))


def pin_reaction(p, dof: int) -> float:
    r = p.state.CreateVector()
    p.residual(p.state, r)
    return float(r.FV().NumPy()[dof])


def run_single(scene: Scene, res: Resolution, out: str, *, threshold: float, progress=None,
               quick: bool = False, post_buckling: bool = True, path_step: float = 1 / 1000,
               path_max_step: float = 1 / 4, switch_amplitude: float = 0.25, path_tol: float = 1e-10) -> dict:
    run = RunDirectory(out, params={"scene": asdict(scene), "resolution": asdict(res), "Es": ES, "Nv": NV,
                                    "chi": CHI, "Ri": RI, "Ro": RO, "teeth_threshold": threshold})
    start = time.perf_counter()
    model = GearModel(scene, res)
    summary = {"ndof": model.problem.space.ndof, "mu_end": model.mu_end}
    # quick: Michell only, onset to 1e-3 of the span (it only says where the checks start)
    summary["analysis"] = (analysis(scene, model.mu_end, ("michell",), steps=8, tol_fraction=1e-3) if quick
                           else analysis(scene, model.mu_end))
    summary["analysis_seconds"] = time.perf_counter() - start
    with History(run.file("path.csv")) as history:
        # quick: onset bracket 1e-3 of the span (0.58 % of mu_cr at Efo/Es = 100; two bisection
        # solves and exact counts fewer); the switch starts from the unstable end either way
        record, critical = onset(model, history=history, progress=progress,
                                 start_mu=check_start(summary["analysis"]), tol_fraction=1e-3 if quick else 2e-4)
        summary["onset"] = record
        summary["onset_seconds"] = time.perf_counter() - start
        final_negative = None
        p = model.problem
        if record is not None and post_buckling:
            switched = switch_branch(model, critical, record, film_amplitude=switch_amplitude, path_tol=path_tol)
            dof = switched["dof"]
            summary["switch"] = switched
            if switched["mu_past_onset_fraction"] <= 0:
                raise RuntimeError(f"the buckled branch at the prescribed amplitude lies before the onset "
                                   f"(subcritical bifurcation): {switched}")
            # undamped natural steps: the first from the tangent predictor, then secant predictors
            span = abs(model.mu_end - model.tube.mu0)
            # near the onset the amplitude grows like sqrt(mu_cr - mu): a first step of the switch's
            # distance from the onset, doubled after every easy step (a fixed first step of span/48
            # from 0.1 t_f failed five times before it converged, 100 s of the quick run; twice the
            # switch's distance failed once at n_theta = 80, p = 3: 30 iterations, 10 s of CPU,
            # the halved step then took 4)
            first = min(max(switched["mu_past_onset_fraction"], path_step), 1 / 24)
            # at most 12 Newton iterations per step: every converged step took <= 8; a failing one
            # plateaus (residual 1e-5 for 30 iterations, 132 line-search cuts) and is better halved
            path = follow_path(p, p.mu, method="natural", step=span * first, max_step=span * path_max_step,
                               easy_iterations=5, grow=2.0,
                               newton_options={"atol": switched["atol"], "maxit": 12},
                               target=model.mu_end, history=history, progress=progress,
                               # quick: stability only at the end (one LDL^T per step saved)
                               qoi={**model.qoi(), "negative_count": (lambda: math.nan) if quick else (lambda: negative_count_of(p)),
                                    "phase_pin_reaction": lambda: pin_reaction(p, dof)})
            force_scale = span * float(np.linalg.norm(load_rate(p, p.mu).residual))
            final_negative = negative_count_of(p)  # one LDL^T, shared with the final summary
            negative = np.array([pt.qoi["negative_count"] for pt in path.points] + [final_negative])
            unstable = [pt.parameter for pt in path.points if pt.qoi["negative_count"] > 0]  # nan > 0 is False
            summary["path"] = {"steps": len(path.points) - 1, "newton_iterations": int(path.column("iterations").sum()),
                               "phase_pin_reaction_max_relative": float(np.max(np.abs(path.column("phase_pin_reaction"))))
                               / force_scale,
                               "negative_max": int(np.nanmax(negative)),
                               "first_unstable_mu": unstable[0] if unstable else None,
                               "seconds": time.perf_counter() - start - summary["onset_seconds"]}
    if post_buckling:
        summary["final"] = {"mu": p.mu.Get(), "volume_fraction": model.volume_fraction(),
                            "axial_stretch": p.axial_stretch(),
                            "negative_eigenvalues": negative_count_of(p) if final_negative is None else final_negative,
                            **classify(model, threshold)}
    else:  # the gear's type predicted by the film the critical mode lives on
        summary["final"] = None
        summary["predicted_type"] = None if record is None else f"{record['mode_film']} teeth"
    summary["seconds"] = time.perf_counter() - start
    run.write_json("summary.json", summary)
    if not quick:  # 1.2 s of the quick run; the picture and the CSV/JSON stay
        VTKSeries(model.mesh, p.fields(), run.file("gear")).write(0.0)
    kind = summary["final"]["type"] if post_buckling else "onset only"
    draw_gear(model, run.file("gear.png"),
              title=f"Efi/Es={scene.efi:g}, Efo/Es={scene.efo:g}, Ri/tfi={scene.ri_tfi:g}, Ro/tfo={scene.ro_tfo:g}: "
                    f"{kind}, volume {model.volume_fraction():.3f}")
    return summary


# ----------------------------------------------------------------------------- sweeps
def write_table(path, rows: list[dict]) -> None:
    keys = list(dict.fromkeys(k for r in rows for k in r))
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=keys)
        writer.writeheader()
        writer.writerows(rows)


class SweepTable:
    """A sweep's rows, rewritten after every case: ``<stem>.csv`` to read and ``<stem>.json``, from
    which a resumed sweep (``resume``) takes the cases done and goes on with the next."""

    def __init__(self, run: RunDirectory, stem: str, *, resume: bool):
        self.run, self.stem = run, stem
        done = run.file(f"{stem}.json")
        self.rows: list[dict] = json.loads(done.read_text()) if resume and done.exists() else []

    def done(self, index: int, case: dict) -> bool:
        """Whether case ``index`` of the sweep was computed (its row holds ``case``'s values)."""
        if index >= len(self.rows):
            return False
        stored = {key: self.rows[index].get(key) for key in case}
        if stored != case:
            raise ValueError(f"row {index} of {self.run.file(self.stem + '.json')} is of the case {stored}, "
                             f"not {case}: the sweep cannot be resumed")
        return True

    def add(self, row: dict) -> None:
        self.rows.append(row)
        write_table(self.run.file(f"{self.stem}.csv"), self.rows)
        self.run.write_json(f"{self.stem}.json", self.rows)


SWEEPS = {  # parameter: (values, what the sweep reproduces)
    "efo": ((1.0, 3.0, 5.8, 7.23, 8.8, 20.0, 100.0), "figs. 4-1/4-2 and 4-4B: the first-buckling film against Efo/Es"),
    "efi": ((5.0, 12.5, 25.0, 50.0), "fig. 4-3B: inner teeth against Efi/Es (run with --efo 1)"),
    "ri_tfi": ((20.0, 30.0, 50.0, 80.0), "fig. 4-3A: inner teeth against Ri/tfi (run with --efo 1)"),
    "ro_tfo": ((50.0, 100.0, 150.0), "fig. 4-4A: outer teeth against Ro/tfo (run with --efi 1)"),
}


def sweep_parameter(base: Scene, res: Resolution, run: RunDirectory, name: str, values, progress=None, *,
                    resume: bool = False) -> list[dict]:
    """FE onset (film, wave number, ``mu`` and gel volume) against one scene parameter, with the
    ring-on-foundation analysis (Michell and our Lame stiffness) and the thesis's eq. 4-1 (its Lame
    stiffness with Es = 3Nv, nu_s = 0.5). Onsets past the thesis's 70 % are found if ``--volume``
    is below 0.7 (``before_70``: the onset ``mu`` lies above the free gel's 70 % ``mu``).
    ``resume``: the values done in ``run`` are taken from its table (``SweepTable``)."""
    table = SweepTable(run, f"sweep_{name}", resume=resume)
    rows = table.rows
    for index, value in enumerate(values):
        if table.done(index, {name: value}):
            continue
        scene = Scene(**{**asdict(base), name: float(value)})
        t0 = time.perf_counter()
        model = GearModel(scene, res)
        ana = analysis(scene, model.mu_end)
        record, _ = onset(model, progress=progress, start_mu=check_start(ana))
        row = {name: value, "fe_mu_cr": record and record["mu_cr"], "fe_film": record and record["mode_film"],
               "fe_k": record and record["mode_k"], "fe_volume_cr": record and record["volume_fraction_cr"],
               "fe_before_70": record and record["mu_cr"] >= model.tube.mu_at_volume_fraction(0.7),
               "fe_ratio_inner_outer": record and record["mode_amplitude_ratio_inner_outer"]}
        for stiffness in ("michell", "lame"):
            for film in ("inner", "outer"):
                row[f"{stiffness}_{film}_mu"] = ana[f"{stiffness}_{film}"]["mu"]
                row[f"{stiffness}_{film}_n"] = ana[f"{stiffness}_{film}"]["n"]
            row[f"{stiffness}_first"] = ana[f"{stiffness}_first"]
        for film in ("inner", "outer"):
            row[f"thesis_{film}_n"] = thesis_ring_estimate(model.tube, film)[0]
        if record is not None:
            n = row[f"michell_{record['mode_film']}_n"]
            row["fe_k_vs_michell_percent"] = 100.0 * (record["mode_k"] - n) / n
        row["seconds"] = time.perf_counter() - t0
        table.add(row)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(11, 4.5))
    x = np.array([r[name] for r in rows], dtype=float)
    for film, color in (("inner", "tab:red"), ("outer", "tab:blue")):
        for stiffness, style in (("michell", "-"), ("lame", "--")):
            y = np.array([np.nan if r[f"{stiffness}_{film}_mu"] is None else r[f"{stiffness}_{film}_mu"] for r in rows])
            ax.plot(x, y, style, color=color, label=f"analysis ({stiffness}), {film} film")
        bx.plot(x, [r[f"michell_{film}_n"] for r in rows], "-", color=color, label=f"Michell, {film}")
        bx.plot(x, [r[f"thesis_{film}_n"] for r in rows], ":", color=color, label=f"thesis eq. 4-1, {film}")
    for r in rows:
        if r["fe_mu_cr"] is not None:
            color = "tab:red" if r["fe_film"] == "inner" else "tab:blue"
            ax.plot(r[name], r["fe_mu_cr"], "o", color=color)
            bx.plot(r[name], r["fe_k"], "o", color=color)
    ax.axhline(base.tube().mu_at_volume_fraction(0.7), color="gray", lw=0.8, label="70 % of a free gel")
    ax.plot([], [], "ko", label="FE onset (colour: film)")
    bx.plot([], [], "ko", label="FE wave number at onset")
    for a in (ax, bx):
        a.set_xscale("log")
        a.set_xlabel(name)
        a.legend(fontsize=7)
    ax.set_ylabel("onset mu (kT)")
    bx.set_ylabel("wave number")
    fig.suptitle(f"{SWEEPS[name][1]}; Efi/Es = {base.efi:g}, Efo/Es = {base.efo:g}, Ri/tfi = {base.ri_tfi:g}, "
                 f"Ro/tfo = {base.ro_tfo:g}", fontsize=8)
    fig.tight_layout()
    fig.savefig(run.file(f"sweep_{name}.png"), dpi=130)
    plt.close(fig)
    return rows


def parse_resolution(text: str) -> Resolution:
    """``n_theta:order:maxh:film_layers`` (command line of ``--sweep convergence``)."""
    parts = text.split(":")
    if len(parts) != 4:
        raise ValueError(f"resolutions must read n_theta:order:maxh:film_layers, got {text!r}")
    res = Resolution(int(parts[0]), int(parts[1]), float(parts[2]), int(parts[3]))
    check_resolution(res)
    return res


# the quick run's resolution, from the convergence table (docs/gears.md, Efo/Es = 100): cubic
# elements, 80 cells around (3.3 per wave), one cell across each film: onset 0.4 % from the finest
# meshes with their 24 waves, 29,280 dofs. The previous quick mesh (96 cells, p = 2, 21,888 dofs)
# gave 22 waves, 5 % off, and an impure post-buckled pattern; p = 2 needs 256 cells (42k dofs)
# for 24 waves, p = 3 with 64 cells gives 23
QUICK = Resolution(80, 3, 0.5, 1)
CONVERGENCE_QUICK = [Resolution(64, 3, 0.5, 1), QUICK]
# the table of docs/gears.md: cells around (p = 2), cells across the films, order at few cells
CONVERGENCE = [Resolution(96, 2, 0.5, 2), Resolution(128, 2, 0.5, 1), Resolution(192, 2, 0.5, 1),
               Resolution(256, 2, 0.2, 1), Resolution(256, 2, 0.2, 2), Resolution(256, 2, 0.2, 3),
               Resolution(384, 2, 0.15, 2), Resolution(512, 2, 0.1, 2), Resolution(64, 3, 0.5, 1), QUICK,
               Resolution(96, 3, 0.5, 1), Resolution(256, 3, 0.2, 2), Resolution(48, 4, 0.5, 1),
               Resolution(64, 4, 0.5, 1)]


def sweep_convergence(scene: Scene, resolutions, run: RunDirectory, progress=None, *,
                      resume: bool = False) -> list[dict]:
    """Onset mu and wave numbers of the critical mode at several resolutions, with wall times.
    ``resume``: the resolutions done in ``run`` are taken from its table (``SweepTable``)."""
    table = SweepTable(run, "convergence", resume=resume)
    rows = table.rows
    start_mu = check_start(analysis(scene, scene.tube().mu_at_volume_fraction(scene.volume), ("michell",)))
    for index, res in enumerate(resolutions):
        if table.done(index, asdict(res)):
            continue
        t0, c0 = time.perf_counter(), time.process_time()
        model = GearModel(scene, res)
        record, _ = onset(model, progress=progress, start_mu=start_mu)
        table.add({**asdict(res), "ndof": model.problem.space.ndof, "mu_cr": record and record["mu_cr"],
                     "mode_film": record and record["mode_film"], "k_inner": record and record["mode_k_inner"],
                     "k_outer": record and record["mode_k_outer"],
                     "volume_cr": record and record["volume_fraction_cr"],
                     "negative_after": record and record["negative_after"],
                     "seconds": time.perf_counter() - t0,
                     # the machine is shared: CPU time of the (single-threaded) run is the fair cost
                     "cpu_seconds": time.process_time() - c0})
    fig, ax = plt.subplots(figsize=(6, 4))
    located = [r for r in rows if r["mu_cr"] is not None]  # (no onset before the end volume: no point)
    ax.plot([r["ndof"] for r in located], [r["mu_cr"] for r in located], "o-")
    for r in located:
        ax.annotate(f"n_theta={r['n_theta']}, p={r['order']}: {r['seconds']:.0f} s", (r["ndof"], r["mu_cr"]),
                    fontsize=7)
    ax.set_xscale("log")
    ax.set_xlabel("degrees of freedom")
    ax.set_ylabel("onset mu")
    fig.tight_layout()
    fig.savefig(run.file("convergence.png"), dpi=130)
    plt.close(fig)
    return rows


# ----------------------------------------------------------------------------- main
def main(argv=None):
    threads = configured_threads()
    try:
        return _main(argv)
    finally:
        ngs.SetNumThreads(threads)  # the caller's setting (tests run in one process)


def _main(argv=None):
    parser = scene_parser(__doc__, out="out/gears", quick="coarse case")
    parser.add_argument("--efi", type=float, default=12.5, help="inner film modulus Efi / Es (dimensionless)")
    parser.add_argument("--efo", type=float, default=7.23, help="outer film modulus Efo / Es (dimensionless)")
    parser.add_argument("--ri-tfi", type=float, default=50.0, help="Ri / tfi, inner radius over inner film thickness")
    parser.add_argument("--ro-tfo", type=float, default=100.0, help="Ro / tfo, outer radius over outer film thickness")
    parser.add_argument("--nu-film", type=float, default=0.3, help="Poisson ratio of the films (dimensionless)")
    parser.add_argument("--volume", type=float, default=0.7,
                        help="final volume of a free gel / its initial volume (dimensionless)")
    parser.add_argument("--axial", choices=("fixed", "free"), default="fixed",
                        help="fixed: plane strain (MODEL.md); free: generalized plane strain, a long tube with "
                             "free ends (uniform axial stretch, zero axial force)")
    parser.add_argument("--n-theta", type=int, default=None,
                        help=f"cells around, a multiple of 4 (default {Resolution().n_theta}, quick {QUICK.n_theta})")
    parser.add_argument("--order", type=int, default=None,
                        help=f"polynomial order of the displacement (default {Resolution().order}, quick {QUICK.order})")
    parser.add_argument("--maxh", type=float, default=None,
                        help=f"gel cell size away from the films / Ri (default {Resolution().maxh:g}, quick {QUICK.maxh:g})")
    parser.add_argument("--film-layers", type=int, default=None,
                        help=f"cells across each film (default {Resolution().film_layers}, quick {QUICK.film_layers})")
    parser.add_argument("--teeth-threshold", type=float, default=0.5,
                        help="teeth where the wave amplitude is at least this many film thicknesses")
    parser.add_argument("--onset-only", action="store_true",
                        help="stop after the located onset (no post-buckling path)")
    parser.add_argument("--sweep", choices=(*SWEEPS, "convergence"), default=None,
                        help="onset against one parameter (" + "; ".join(f"{k}: {v[1]}" for k, v in SWEEPS.items())
                        + ") or the onset at several resolutions (default: none, a single run)")
    parser.add_argument("--values", type=float, nargs="+", default=None,
                        help="values of the swept parameter, dimensionless like it (default: the sweep's own)")
    parser.add_argument("--resolutions", nargs="+", default=None, metavar="N:P:H:L",
                        help="resolutions of --sweep convergence as n_theta:order:maxh:film_layers, maxh / Ri "
                             "(default: the table of docs/gears.md)")
    parser.add_argument("--switch-amplitude", type=float, default=None,
                        help="amplitude of the first buckled state, in thicknesses of the buckling film "
                             "(default 0.25; quick: 1.0)")
    parser.add_argument("--threads", type=int, default=1,
                        help="NGSolve threads (1: on the shared 2-core machine, load average ~9, one thread "
                             "was 2x faster for the 2D solves and 30x for the radial 1D analysis)")
    parser.add_argument("--resume", default=None, metavar="DIR",
                        help="go on with the stopped sweep in DIR, from the first case it has no row of, with its options (default: none, a new run)")
    args = resume_arguments(parser, argv)
    quick = quick_run(args)
    scene = Scene(efi=args.efi, efo=args.efo, ri_tfi=args.ri_tfi, ro_tfo=args.ro_tfo, nu_film=args.nu_film,
                  volume=args.volume, axial=args.axial)
    default = QUICK if quick else Resolution()
    res = Resolution(n_theta=args.n_theta or default.n_theta, order=args.order or default.order,
                     maxh=args.maxh or default.maxh, film_layers=args.film_layers or default.film_layers)
    check_scene(scene)
    check_resolution(res)
    if not 0 < args.teeth_threshold < 100:
        raise ValueError(f"teeth-threshold must lie in (0, 100), got {args.teeth_threshold!r}")
    if args.switch_amplitude is None:
        # quick: onto the branch at 1 t_f, past the sqrt regime near the onset whose small steps
        # cost most of the path (Efo/Es = 100, quick mesh: 5 steps / 25 Newton iterations and 7
        # bordered ones, against 11 / 53 and 4 from 0.25 t_f; the same final state to 1e-12).
        # A corrector whose residual rises is retried at half the amplitude (``switch_branch``):
        # from 1 t_f it rose at the 2nd iteration at Efo/Es = 100 and at the 4th at 7.23; both
        # then converge from 0.5 t_f in 5 (paths 8 / 39 and 3 / 10)
        args.switch_amplitude = 1.0 if quick else 0.25
    if not 0 < args.switch_amplitude <= 10:
        raise ValueError(f"switch-amplitude must lie in (0, 10], got {args.switch_amplitude!r}")
    if not isinstance(args.threads, int) or args.threads < 1:
        raise ValueError(f"threads must be a positive integer, got {args.threads!r}")
    ngs.SetNumThreads(args.threads)
    progress = Progress("gears", quiet=args.quiet)
    if args.sweep is None:
        summary = run_single(scene, res, args.out, threshold=args.teeth_threshold, progress=progress,
                             quick=quick, post_buckling=not args.onset_only, switch_amplitude=args.switch_amplitude)
        print(json.dumps({k: summary.get(k) for k in ("onset", "final", "seconds")}, indent=1, default=str))
        return summary
    resume = args.resume is not None
    run = RunDirectory(args.out, params={"scene": asdict(scene), "resolution": asdict(res), "sweep": args.sweep,
                                         "options": command_options(args)}, resume=resume)
    if args.sweep in SWEEPS:
        values = args.values or (SWEEPS[args.sweep][0][::3] if quick else SWEEPS[args.sweep][0])
        rows = sweep_parameter(scene, res, run, args.sweep, values, progress, resume=resume)
        if args.sweep == "efo":
            switch = {stiffness: analysis_switch_point(scene, stiffness) for stiffness in ("michell", "lame")}
            run.write_json("switch_point.json", {**switch, "zone_michell": double_onset_zone(scene)})
    else:
        if args.resolutions:
            resolutions = [parse_resolution(text) for text in args.resolutions]
        else:
            resolutions = CONVERGENCE_QUICK if quick else CONVERGENCE
        rows = sweep_convergence(scene, resolutions, run, progress, resume=resume)
    run.write_json("summary.json", {"sweep": args.sweep, "cases": len(rows)})  # done: --resume refuses it
    return rows


if __name__ == "__main__":
    main()
