"""Creases on a thick gel layer during transient swelling (MODEL.md scene E), plane strain.

A layer of thickness ``H`` (swollen reference at ``mu0``, stretch ``lam0`` from dry) is bonded to a
rigid substrate and immersed at its top at t = 0 (``mu`` ramped from ``mu0`` to 0 over ``--ramp``).
The computational cell is ``[0, W] x [0, H]`` with roller sides, which are mirror planes (zero
flux, no shear): the cell is half a period ``2 W`` of a periodic crease pattern. A surface
imperfection ``-a cos(pi x / W)`` puts a shallow trough on the left mirror line, where a crease
nucleates (``--seed``: a random mirror-symmetric imperfection instead, for wide cells where the
pattern chooses its own spacing). The faces of a crease on a mirror line meet on it: their
self-contact is contact with that plane (penalty, ``ngsgel.contact.plane_contact``); creases
anywhere else close on the general self-contact of the top (``ngsgel.contact.SelfContact``, the
same penalty; ``--no-self-contact`` leaves it out). Every step checks that the surface neither
crosses the mirror planes (beyond the penalty's penetration, reported) nor itself: faces held by
the penalty overlap by a thin sliver (its width is reported), the bottom of a closed crease may
fold through itself within a few elements (counted and reported: the P2 edges cannot make the
hairpin); any other loop is a crossing, and the run stops there.

Per run (``--out``): step history (``history.csv``: time, dt, Newton, solvent uptake, balance
error, swollen depth, surface-layer stretch ratio, groove and crease depth, contact length,
penetration, self-crossings, creases and spacing of the mirrored profile), the crease onset
(first step with the faces in contact) and the state there (``summary.json``), surface profiles
and figures, and a VTK series.

Surface energy of the gel-solvent interface (``--surface-tension gamma/(G H)``, default
``SURFACE_TENSION`` = 0.02; 0 = the sharp-interface model) adds ``gamma |F' t|`` on the top
(``ngsgel.surface``): the elastocapillary length ``gamma/G`` regularises the crease tip, and the
quasi-static crease threshold converges once ``top_h`` is well below it (docs/creases.md). The
transient onset needs the crease tip resolved far below it (``--tip-h`` <= l/16 on x < 2 l): the
groove bottom sharpens to < l/20 before the faces meet. ``tip_sharpening`` in the summary (the
time at which the tip radius reaches l/4) converges; the contact time drifts ~3 % per halving of
``tip_h`` (docs/creases.md, "Why the onset did not converge").

``--equilibrium`` runs the quasi-static counterpart instead (``mu`` homogeneous, raised
slowly): the linear (wrinkling) threshold of the flat layer from the exact inertia of the tangent
at the closed-form homogeneous states (bisection in ``mu``), on a list of meshes, and the crease
threshold (first contact) of the imperfect layer for a list of amplitudes. ``--study`` runs the
transient onset for several meshes, time-step limits and amplitudes with wall times.

    ngsgel run creases --out results/creases [--quick] [--equilibrium] [--study]
    ngsgel run creases --resume results/creases   # a stopped transient run, on from its last step
"""

from __future__ import annotations

import contextlib
import math
import time
from dataclasses import dataclass

import numpy as np
import ngsolve as ngs


from geometries.layers import layer_plane
from ngsgel import EquilibriumProblem, FloryRehnerGel, NewtonError, PlaneStrain
from ngsgel.contact import crossing_loops, plane_contact, surface_line
from ngsgel.output import (History, Progress, RunDirectory, VTKSeries, command_options, quick_run, resume_arguments,
                           scene_parser, silence_progress)
from ngsgel.patterns import crease_positions, power_law_fit, sample_on_line
from ngsgel.surface import surface_tension as surface_tension_density
from ngsgel.stability import free_matrix, negative_count, spectrum
from ngsgel.stepping import RampError, ramp
from scipy.optimize import brentq
from scipy.stats import spearmanr
from ngsgel.transient import MarchCheckpoint, TransientError, TransientProblem, march, time_ramp

BIOT_RATIO = 3.383  # Biot (1963): incompressible neo-Hookean half-space, plane strain, lam2/lam1 at wrinkling
CREASE_RATIO = 2.4  # Hong, Zhao & Suo (2009): energetic crease threshold, lam2/lam1 (strain 0.35)
# A crossed loop spanning at most this many surface elements, with no loop inside it, is the
# unresolved bottom of a closed crease (the fold of the tip through itself; 3 elements measured
# at a closed interior crease, tests/test_creases.py)
TIP_LOBE_EDGES = 4
# Default surface energy of the gel-solvent interface, gamma / (G H) (the elastocapillary length
# gamma/G over the layer thickness); see docs/creases.md for physical numbers. 0: no surface energy.
SURFACE_TENSION = 0.02
KT_OVER_V = 1.38e-23 * 298 / 3.0e-29  # Pa: the stress unit for water at 25 C (v = 3e-29 m^3)


@dataclass
class Setup:
    """Scene parameters (lengths in units of the reference thickness ``H``)."""

    Nv: float = 1e-3
    chi: float = 0.5
    mu0: float = -0.5
    thickness: float = 1.0
    width: float = 0.2
    amplitude: float = 0.01  # of the trough (or max |w| of the random imperfection), as a fraction of the width W
    # where the trough lies: "mirror" (-a cos(pi x / W): on the left mirror line, the crease
    # closes on that plane) or "centre" (a cos(2 pi x / W): at x = W / 2, the crease closes on
    # itself - the mirror cell of half the width, mirrored; a check of the self-contact)
    trough: str = "mirror"
    # random mirror-symmetric imperfection (modes cos(pi m x / W) with 2 W / m >= wavelength)
    # instead of the trough; None: the trough
    seed: int | None = None
    wavelength: float = 0.1
    top_h: float = 0.01  # element size on the surface
    # finer surface size on the part x < tip_length of the top, where the crease tip on the mirror
    # line x = 0 forms (None: top_h everywhere); the onset is set by the resolution there
    tip_h: float | None = None
    tip_length: float = 0.04
    maxh: float = 0.05  # element size in the bulk
    penalty: float = 1e3  # contact stiffness in units of G / top_h
    ramp: float = 1e-5  # duration of the immersion ramp
    threads: bool = False  # NGSolve TaskManager (on a shared 2-core machine it was slower)
    viscosity: float = 1e-3  # pseudo-viscous stabiliser eta / G (time units H^2/D, per unit area)
    surface_tension: float = SURFACE_TENSION  # gamma / (G H): elastocapillary length over thickness
    self_contact: bool = True  # general self-contact of the top (creases off the mirror lines)
    # a self-crossing loop (surface_state) wider than this many surface elements is a crossing,
    # not the penalty's overlap of two faces in contact (~0.03 elements at penalty 1e3)
    overlap_limit: float = 0.1

    @property
    def gamma(self) -> float:
        """Surface energy of the top (gel-solvent interface) in the code's units ``kT H / v``."""
        return self.surface_tension * self.gel.shear_modulus(self.lam0) * self.thickness

    def check(self) -> None:
        for name in ("viscosity", "surface_tension"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")
        for name in ("Nv", "thickness", "width", "top_h", "maxh", "penalty", "ramp", "wavelength", "overlap_limit"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a finite number > 0, got {value!r}")
        if not 0 <= self.amplitude < 0.5:
            raise ValueError(f"amplitude must be in [0, 0.5) (a fraction of the width), got {self.amplitude!r}")
        if self.trough not in ("mirror", "centre"):
            raise ValueError(f"trough must be 'mirror' or 'centre', got {self.trough!r}")
        if self.seed is not None:
            if not (isinstance(self.seed, int) and self.seed >= 0):
                raise ValueError(f"seed must be None or an integer >= 0, got {self.seed!r}")
            if not self.wavelength <= 2 * self.width:
                raise ValueError(f"wavelength must be <= 2 width = {2 * self.width:g}, got {self.wavelength!r}")
        if not self.mu0 < 0:
            raise ValueError(f"mu0 must be < 0 (dry-ish start; the bath is at mu = 0), got {self.mu0!r}")
        if not self.top_h <= self.width / 4:
            raise ValueError(f"top_h must be <= width/4 = {self.width / 4:g}, got {self.top_h!r}")
        if not self.top_h <= self.maxh:
            raise ValueError(f"top_h must be <= maxh = {self.maxh:g}, got {self.top_h!r}")
        if self.tip_h is not None:
            if not (isinstance(self.tip_h, (int, float)) and 0 < self.tip_h <= self.top_h):
                raise ValueError(f"tip_h must be None or in (0, top_h = {self.top_h:g}], got {self.tip_h!r}")
            if not (isinstance(self.tip_length, (int, float)) and 0 < self.tip_length <= self.width / 2):
                raise ValueError(f"tip_length must be in (0, width/2 = {self.width / 2:g}], got {self.tip_length!r}")
        FloryRehnerGel(Nv=self.Nv, chi=self.chi).lam_free(self.mu0)  # raises ValueError on mu0

    @property
    def gel(self) -> FloryRehnerGel:
        return FloryRehnerGel(Nv=self.Nv, chi=self.chi)

    @property
    def lam0(self) -> float:
        """Stretch of the reference (free swelling at ``mu0``) from the dry state."""
        return self.gel.lam_free(self.mu0)

    def ratio(self, mu: float) -> float:
        """Thickness over lateral stretch of the laterally constrained layer at ``mu``."""
        return self.gel.lam_constrained(mu, self.lam0) / self.lam0

    @property
    def surface_h(self) -> float:
        """The smallest element size on the top (at the crease tip when ``tip_h`` is set)."""
        return self.top_h if self.tip_h is None else self.tip_h

    def mesh(self, *, imperfect: bool = True) -> ngs.Mesh:
        a = self.amplitude * self.width if imperfect else 0.0
        corner = {} if self.tip_h is None else {"corner_maxh": self.tip_h, "corner_length": self.tip_length}
        if self.seed is None and self.trough == "mirror":
            shape = {"amplitude": -a, "wavelength": 2 * self.width if a else None}
        elif self.seed is None:
            shape = {"amplitude": a, "wavelength": self.width if a else None}
        else:
            shape = {"amplitude": a, "wavelength": self.wavelength, "seed": self.seed, "mirror": True}
        return layer_plane(width=self.width, thickness=self.thickness, maxh=self.maxh, top_maxh=self.top_h,
                           **shape, **corner).mesh

    def add_surface_tension(self, prob) -> None:
        """Surface energy ``gamma |F' t|`` on the top (none when ``surface_tension`` is 0)."""
        if self.surface_tension > 0:
            prob.add_surface_energy("top", surface_tension_density(self.gamma))

    def add_contact(self, prob) -> None:
        # stiff against the smallest surface elements, where the faces meet
        k = self.penalty * self.gel.shear_modulus(self.lam0) / self.surface_h
        prob.add_surface_energy("top", plane_contact(component=0, position=0.0, side=1, penalty=k))
        prob.add_surface_energy("top", plane_contact(component=0, position=self.width, side=-1, penalty=k))
        if self.self_contact:
            # k/4 per face: both faces are masters and the gap is twice a mirror image's
            # distance to its plane, so this is the mirror lines' penalty (ngsgel.contact)
            prob.add_self_contact("top", penalty=k / 4)


# ----------------------------------------------------------------------------- diagnostics


def tip_geometry(x: np.ndarray, y: np.ndarray, points_per_edge: int = 4) -> tuple[float, float]:
    """Tangent angle (degrees from horizontal; 0 for a mirror-symmetric smooth tip) and radius of
    curvature (> 0 for a groove bottom) of the deformed top at the corner X = 0, from the first
    edge's samples ``x, y`` (``surface_line`` order): a P2 displacement on a straight edge makes
    it a parabola in the edge parameter, so the quadratic fit is exact. Meaningful only where the
    radius spans several elements (docs/creases.md: ``tip_h <= l/16`` for ``R = l/4``)."""
    s = np.arange(points_per_edge + 1) / points_per_edge
    cx = np.polyfit(s, x[:points_per_edge + 1], 2)
    cy = np.polyfit(s, y[:points_per_edge + 1], 2)
    dx, dy, ddx, ddy = cx[1], cy[1], 2 * cx[0], 2 * cy[0]
    bend = dx * ddy - dy * ddx
    radius = (dx * dx + dy * dy) ** 1.5 / bend if bend != 0 else math.inf
    return float(np.degrees(np.arctan2(dy, dx))), float(radius)


def surface_state(prob, setup: Setup) -> dict:
    """Geometry of the deformed surface: crease (contact) on either mirror line, groove depth,
    penetration of the mirror planes, faces in self-contact and self-crossings, creases of the
    mirrored profile."""
    per_edge = 4
    line = surface_line(prob.displacement, prob.mesh, "top", points_per_edge=per_edge)
    X, x, y = line.reference[:, 0], line.current[:, 0], line.current[:, 1]
    W, h = setup.width, line.edge_length
    # With self-contact, faces pressed together overlap by the penalty's thin sliver (a contact),
    # and a closed crease ends in a crossed lobe where its bottom folds within a few elements,
    # which P2 edges cannot do without looping (the unresolved tip; docs/creases.md); any other
    # loop is a crossing. Without self-contact every loop is a crossing.
    slivers, tips, crossed = [], [], []
    for loop in crossing_loops(line.current):
        if setup.self_contact and loop.width <= setup.overlap_limit * h:
            slivers.append(loop)
        elif setup.self_contact and loop.innermost and loop.last - loop.first <= TIP_LOBE_EDGES * per_edge:
            tips.append(loop)
        else:
            crossed.append(loop)
    out = {"penetration": max(0.0, -float(x.min()), float(x.max()) - W) / h,
           "overlap": max((loop.width / h for loop in slivers), default=0.0),  # widest sliver, in elements
           "self_contacts": len(slivers),
           # reference x of the first closed crease held by the self-contact
           "contact_X": float(X[slivers[0].first]) if slivers else float("nan"),
           "tip_lobes": len(tips),
           "tip_lobe_width": max((loop.width / h for loop in tips), default=0.0),
           "tip_lobe_area": max((loop.area / h**2 for loop in tips), default=0.0),
           "tip_X": float(X[tips[0].first]) if tips else float("nan"),
           "self_crossings": len(crossed),
           # reference x of the first crossing (where the surface passed through itself)
           "crossing_X": float(X[crossed[0].first]) if crossed else float("nan")}
    for side, inner, plane in (("left", X > 0, x <= 0.0), ("right", X < W, x >= W)):
        tip = 0 if side == "left" else -1
        touching = inner & plane
        out[f"contact_points_{side}"] = int(np.count_nonzero(touching))
        out[f"crease_depth_{side}"] = float(y[touching].max() - y[tip]) if touching.any() else 0.0
        out[f"tip_y_{side}"] = float(y[tip])
    out["groove_depth"] = float(y.max() - y[0])
    out["tip_angle"], out["tip_radius"] = tip_geometry(x, y, per_edge)
    # mirrored profile over one period [-W, W] (x increasing where the surface is a graph)
    xs, ys = [], []
    for xi, yi in zip(np.clip(x, 0.0, W), y):  # the part of the surface that is a graph over x
        if not xs or xi > xs[-1] + 1e-12 * W:
            xs.append(xi)
            ys.append(yi)
    xs, ys = np.array(xs), np.array(ys)
    xm, ym = np.concatenate([-xs[:0:-1], xs]), np.concatenate([ys[:0:-1], ys])
    creases = crease_positions(ym, xm, relative_depth=0.1)
    out["creases_per_period"] = int(creases.positions.size)
    out["crease_spacing"] = float(creases.mean_spacing) if creases.positions.size >= 2 else 2 * W
    out["profile"] = (x, y)
    return out


def reference_top(mesh: ngs.Mesh, x: float) -> float:
    """Height of the top boundary at ``x`` in the reference (the mesh, imperfection included):
    the straight edge over ``x``."""
    for el in mesh.Elements(ngs.BND):
        if el.mat == "top":
            (xa, ya), (xb, yb) = (mesh[v].point for v in el.vertices)
            if min(xa, xb) <= x <= max(xa, xb):
                return ya + (yb - ya) * (x - xa) / (xb - xa)
    raise ValueError(f"x = {x!r} is not under the top boundary")


def swelling_state(prob, setup: Setup, n: int = 201) -> dict:
    """Away from the crease (x = W/2): depth of the swollen zone (``mu`` above ``mu0 / 2``), in
    reference and current lengths, and the thickness-over-lateral stretch ratio at the surface
    and averaged over the swollen zone (stretches from dry: ``lam0 F'``)."""
    W = setup.width
    H = reference_top(prob.mesh, W / 2)  # the layer's thickness there, imperfection included
    eps = 1e-6 * H
    F = prob.deformation_gradient(prob.displacement)
    ratio_cf = F[1, 1] / F[0, 0]
    start, end = (W / 2, eps), (W / 2, H - eps)
    mu = sample_on_line(prob.chemical_potential, prob.mesh, start=start, end=end, n=n)
    ratio = sample_on_line(ratio_cf, prob.mesh, start=start, end=end, n=n).values
    uy = sample_on_line(prob.displacement, prob.mesh, start=start, end=end, n=n).values[:, 1]
    Y = mu.parameter + eps
    half = setup.mu0 / 2
    wet = mu.values > half
    if not wet.any():
        return {"swollen_depth": 0.0, "swollen_depth_current": 0.0, "surface_ratio": float(ratio[-1]),
                "skin_ratio": float(ratio[-1])}
    i = int(np.argmax(wet))  # first wet sample from the bottom
    if i == 0:
        Yf = 0.0
    else:
        Yf = float(np.interp(half, [mu.values[i - 1], mu.values[i]], [Y[i - 1], Y[i]]))
    yf = Yf + float(np.interp(Yf, Y, uy))
    return {"swollen_depth": H - Yf, "swollen_depth_current": (H + uy[-1]) - yf,
            "surface_ratio": float(ratio[-1]), "skin_ratio": float(ratio[wet].mean())}


# ----------------------------------------------------------------------------- transient run


def spacing_against_depth(depth, grooves, period: float, times=None, *, bins_per_decade: int = 8) -> dict | None:
    """How the groove spacing grows with the swollen depth over a run: the states are binned in
    log depth (so that the many small steps of a snap do not outweigh the rest), the spacing of a
    bin is ``period / median(grooves per period)``; reported per bin, with Spearman's rank
    correlation of spacing and depth over the bins and the exponent ``b`` of ``spacing ~ depth^b``
    (least squares over the bins with two or more grooves per period: at one groove the spacing
    is the cell's period, a bound, not a measurement). Coarsening events: consecutive bins whose
    groove count falls (with the first ``times`` of the later bin, if given). None with fewer than
    three bins."""
    depth, grooves = np.asarray(depth, float), np.asarray(grooves, float)
    times = np.full(depth.shape, np.nan) if times is None else np.asarray(times, float)
    ok = (depth > 0) & (grooves >= 1)
    if ok.sum() < 3:
        return None
    edges = 10.0 ** (np.arange(math.floor(np.log10(depth[ok].min()) * bins_per_decade),
                               math.ceil(np.log10(depth[ok].max()) * bins_per_decade) + 1) / bins_per_decade)
    table = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        inside = ok & (depth >= lo) & (depth < hi)
        if inside.any():
            count = float(np.median(grooves[inside]))
            table.append({"depth": float(np.sqrt(lo * hi)), "grooves": count, "spacing": period / count,
                          "states": int(inside.sum()), "time": float(times[inside][0])})
    if len(table) < 3:
        return None
    d = np.array([r["depth"] for r in table])
    sp = np.array([r["spacing"] for r in table])
    result = {"bins": table, "rank_correlation": float(spearmanr(d, sp).statistic),
              "coarsening": [{"time": b["time"], "depth": b["depth"], "from": a["grooves"], "to": b["grooves"]}
                             for a, b in zip(table, table[1:]) if b["grooves"] < a["grooves"]]}
    several = np.array([r["grooves"] >= 2 for r in table])
    if several.sum() >= 3:
        result["fit"] = power_law_fit(d[several], sp[several])
    return result


@contextlib.contextmanager
def _nothing():
    yield


class _Stop(Exception):
    """Raised from ``on_step`` to end the march once the run has seen what it needs."""


def build_transient(setup: Setup) -> TransientProblem:
    setup.check()
    gel = setup.gel
    prob = TransientProblem(setup.mesh(), kinematics=PlaneStrain(), materials=gel, lam0=setup.lam0, mu0=setup.mu0,
                            viscosity=setup.viscosity * gel.shear_modulus(setup.lam0))
    prob.fix("bottom")
    prob.fix("left|right", "x")
    setup.add_contact(prob)
    setup.add_surface_tension(prob)
    prob.immerse("top", time_ramp(prob.t, start=setup.mu0, end=0.0, duration=setup.ramp))
    return prob


def run_transient(setup: Setup, out: str | None, *, t_end: float = 0.2, dt_max: float | None = None,
                  after_onset: float = 1.5, pictures: int = 6, vtk: bool = True, quiet: bool = False,
                  options: dict | None = None, resume: bool = False) -> dict:
    """March until ``t_end`` or ``after_onset`` times the crease onset time, whichever is first.
    With ``out``, every step rewrites ``checkpoint.pkl`` (``ngsgel.transient.MarchCheckpoint``
    with the rows and events so far); ``resume``: the run in ``out`` goes on from it to the end
    an uninterrupted run reaches (``wall`` column and wall time aside). ``options``: the command
    line, kept in ``params.json`` (``ngsgel.output.resume_arguments``)."""
    setup.check()
    if not t_end > setup.ramp:
        raise ValueError(f"t_end must be > ramp = {setup.ramp:g}, got {t_end!r}")
    if not after_onset >= 1:
        raise ValueError(f"after_onset must be >= 1, got {after_onset!r}")
    if resume and not out:
        raise ValueError("resume needs the run's folder (out)")
    run_dir = RunDirectory(out, params={**setup.__dict__, "lam0": setup.lam0, "t_end": t_end, "dt_max": dt_max,
                                        "after_onset": after_onset, "ratio_final_equilibrium": setup.ratio(0.0),
                                        "options": options}, resume=resume) if out else None
    checkpoint_file = run_dir.file("checkpoint.pkl") if run_dir else None
    if resume and not checkpoint_file.exists():
        raise ValueError(f"no checkpoint {checkpoint_file}: the run stopped before its first step (start it again, "
                         f"without resuming)")
    checkpoint = MarchCheckpoint.load(checkpoint_file) if resume else None
    progress = Progress("creases") if not quiet else (lambda msg: None)
    wall0 = time.perf_counter()
    prob = build_transient(setup)
    prob.form
    ndof = prob.mixed_space.ndof
    series = VTKSeries(prob.mesh, prob.fields(), run_dir.series("creases")) if (run_dir and vtk) else None
    if series and not resume:
        series.write(0.0)
    outputs = list(np.geomspace(max(10 * setup.ramp, 1e-4), t_end, 12)[:-1])
    rows, profiles = [], {}
    state = {"onset": None, "stop_at": t_end, "max_penetration": 0.0, "max_crossings": 0, "dissipation": 0.0,
             "interior": None, "sharpening": None, "max_overlap": 0.0, "max_self_contacts": 0,
             "max_tip_lobe_width": 0.0, "max_tip_lobe_area": 0.0}
    if checkpoint is not None:
        rows, profiles, state = checkpoint.data
    # A mesh-converging onset measure (docs/creases.md): the time at which the groove bottom has
    # sharpened to a tip radius of l/4 (l = gamma/G the elastocapillary length), interpolated
    # linearly in the radius between steps; the contact time itself drifts with the tip mesh.
    sharp_radius = setup.surface_tension * setup.thickness / 4
    history = History(run_dir.file("history.csv")) if run_dir else None
    for row in rows if history else ():  # a resumed run's history: the rows up to its checkpoint
        history.append(row)

    def on_step(p, rec) -> None:
        surf = surface_state(p, setup)
        swell = swelling_state(p, setup)
        x, y = surf.pop("profile")
        state["dissipation"] += p.viscous_dissipation()
        row = {**rec.row(), **swell, **surf, "viscous_dissipation": state["dissipation"], "sqrt_t": math.sqrt(rec.time), "wall": time.perf_counter() - wall0}
        rows.append(row)
        if history:
            history.append(row)
        if surf["penetration"] > state["max_penetration"]:
            state["max_penetration"] = surf["penetration"]
            state["max_penetration_time"] = rec.time
        state["max_crossings"] = max(state["max_crossings"], surf["self_crossings"])
        state["max_overlap"] = max(state["max_overlap"], surf["overlap"])
        state["max_self_contacts"] = max(state["max_self_contacts"], surf["self_contacts"])
        state["max_tip_lobe_width"] = max(state["max_tip_lobe_width"], surf["tip_lobe_width"])
        state["max_tip_lobe_area"] = max(state["max_tip_lobe_area"], surf["tip_lobe_area"])
        radius = surf["tip_radius"] if surf["tip_radius"] > 0 else math.inf  # <= 0: not a groove bottom
        if sharp_radius > 0 and state["sharpening"] is None and radius <= sharp_radius and len(rows) > 1:
            before = rows[-2]["tip_radius"] if rows[-2]["tip_radius"] > 0 else math.inf
            t0, t1 = rows[-2]["time"], rec.time
            t_sharp = t0 + (t1 - t0) * (before - sharp_radius) / (before - radius) if math.isfinite(before) else t1
            # time interpolated; swelling and groove: the state at the step that crossed
            state["sharpening"] = {"time": t_sharp, "previous_time": t0, "step_time": t1, "radius": sharp_radius,
                                   "swollen_depth": swell["swollen_depth"], "surface_ratio": swell["surface_ratio"],
                                   "groove_depth": surf["groove_depth"]}
        on_mirror = surf["contact_points_left"] > 0 or surf["contact_points_right"] > 0
        creased = on_mirror or surf["self_contacts"] > 0 or surf["tip_lobes"] > 0
        interior = surf["self_crossings"] > 0
        near_mirror = min(surf["crossing_X"], setup.width - surf["crossing_X"]) < 2 * setup.surface_h if interior else False
        if interior:
            # The surface passed through itself within this step: next to a mirror line the crease
            # there closed but its faces crossed inside the first two surface elements (the curved
            # P2 edge at the singular tip looped through itself before reaching the plane, where
            # the penalty acts) -- an onset; elsewhere faces met where no contact is modelled
            # (self-contact off) or passed through the self-contact's penalty within one step.
            # Either way the run cannot go on honestly: record and stop.
            row["previous_time"] = rows[-2]["time"] if len(rows) > 1 else 0.0
            where = f"reference x = {surf['crossing_X']:.4f}"
            if near_mirror and state["onset"] is None:
                row["onset_kind"] = "tip self-crossing next to the mirror line"
                state["onset"] = row
                progress(f"CREASE ONSET (tip loop at {where}) at t = {rec.time:.4e}: swollen depth "
                         f"{swell['swollen_depth']:.4f}; stopping, the faces crossed at the tip")
            else:
                state["interior"] = row
                why = "they passed through the self-contact" if setup.self_contact else "self-contact is off"
                progress(f"FACES CROSSED off the mirror lines ({where}) at t = {rec.time:.4e}: swollen "
                         f"depth {swell['swollen_depth']:.4f}; stopping, {why}")
            profiles[rec.time] = (x, y)
            if series:
                series.write(rec.time)
            raise _Stop()
        if creased and state["onset"] is None:
            # the faces met during this step: onset lies in (previous step, this step]
            row["previous_time"] = rows[-2]["time"] if len(rows) > 1 else 0.0
            row["onset_kind"] = ("contact on the mirror line" if on_mirror else
                                 f"self-contact at reference x = {surf['contact_X']:.4f}" if surf["self_contacts"]
                                 else f"crease tip folded at reference x = {surf['tip_X']:.4f}")
            state["onset"] = row
            state["stop_at"] = min(t_end, after_onset * rec.time)
            profiles[rec.time] = (x, y)
            progress(f"CREASE ONSET ({row['onset_kind']}) at t = {rec.time:.4e}: swollen depth {swell['swollen_depth']:.4f}, "
                     f"surface ratio {swell['surface_ratio']:.3f}, skin ratio {swell['skin_ratio']:.3f}")
        if rec.output or (state["onset"] is not None and rec.time >= state["stop_at"]):
            profiles[rec.time] = (x, y)
            if series:
                series.write(rec.time)
        progress(f"t = {rec.time:9.3e} dt = {rec.dt:8.2e} N {rec.iterations:2d} depth {swell['swollen_depth']:.3f} "
                 f"groove {surf['groove_depth']:.4f} crease {surf['crease_depth_left']:.4f} "
                 f"pen {surf['penetration']:.1e} creases {surf['creases_per_period']} closed {surf['self_contacts']} "
                 f"bal {rec.relative_balance_error:.1e}")
        if state["onset"] is not None and rec.time >= state["stop_at"]:
            raise _Stop()

    message = "reached t_end"
    with ngs.TaskManager() if setup.threads else _nothing():
        try:
            # dt_min: snaps (early skin wrinkles, crease closing) are carried by the stabiliser with
            # steps down to ~1e-9; 1e-4 ramp stopped the top_h = 0.01 run with surface energy
            march(prob, t_end, dt_start=setup.ramp / 10, dt_max=dt_max, dt_min=setup.ramp * 1e-7,
                  output_times=outputs, on_step=on_step, checkpoint_file=checkpoint_file,
                  checkpoint_data=lambda: (rows, profiles, state), resume=checkpoint)
        except _Stop:
            if state["interior"] is not None:
                message = ("stopped: faces crossed off the mirror lines " +
                           ("through the self-contact" if setup.self_contact else "(self-contact off)"))
            elif state["onset"]["onset_kind"].startswith("tip"):
                message = "stopped at onset: the crease faces crossed at the tip, next to the mirror line"
            else:
                message = f"stopped at {after_onset} x the onset time"
        except TransientError as err:
            message = f"TransientError: {err}"
            progress(message)
    if history:
        history.close()
    wall = time.perf_counter() - wall0
    onset = state["onset"]
    balance = [r["relative_balance_error"] for r in rows]
    uptake_err = [abs(r["balance_error"]) for r in rows]
    total_uptake = rows[-1]["uptake"] if rows else 0.0
    summary = {"message": message, "steps": len(rows), "ndof": ndof, "wall_seconds": wall,
               "t_last": rows[-1]["time"] if rows else 0.0,
               "onset": None if onset is None else {k: onset[k] for k in (
                   "time", "previous_time", "onset_kind", "swollen_depth", "swollen_depth_current", "surface_ratio",
                   "skin_ratio", "groove_depth", "crease_depth_left", "contact_points_left")},
               "interior_crease": None if state["interior"] is None else {k: state["interior"][k] for k in (
                   "time", "previous_time", "swollen_depth", "swollen_depth_current", "surface_ratio", "skin_ratio",
                   "groove_depth", "creases_per_period", "crease_spacing", "crossing_X")},
               "final": None if not rows else {k: rows[-1][k] for k in (
                   "time", "swollen_depth", "groove_depth", "crease_depth_left", "crease_depth_right",
                   "creases_per_period", "crease_spacing", "self_contacts")},
               "max_relative_balance_error": max(balance) if balance else None,
               "cumulative_balance_error_relative": (sum(uptake_err) / abs(total_uptake)) if total_uptake else None,
               "viscous_dissipation": state["dissipation"],
               "network_energy_scale": setup.gel.shear_modulus(setup.lam0) * setup.width * setup.thickness,
               "max_penetration_over_h": state["max_penetration"], "max_self_crossings": state["max_crossings"],
               "max_overlap_over_h": state["max_overlap"], "max_self_contacts": state["max_self_contacts"],
               "max_tip_lobe_width_over_h": state["max_tip_lobe_width"],
               "max_tip_lobe_area_over_h2": state["max_tip_lobe_area"],
               "tip_sharpening": state["sharpening"],
               "max_penetration_time": state.get("max_penetration_time"),
               "ratio_final_equilibrium": setup.ratio(0.0), "biot_ratio": BIOT_RATIO, "crease_ratio": CREASE_RATIO,
               "spacing_against_depth": spacing_against_depth([r["swollen_depth"] for r in rows],
                                                              [r["creases_per_period"] for r in rows], 2 * setup.width,
                                                              [r["time"] for r in rows])}
    if run_dir:
        run_dir.write_json("summary.json", summary)
        plot_transient(rows, profiles, setup, run_dir.file("creases.png"))
    progress(f"{message}; {len(rows)} steps in {wall:.1f}s, onset "
             f"{'none' if onset is None else format(onset['time'], '.4e')}")
    return summary


def plot_transient(rows, profiles, setup: Setup, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not rows:
        return
    fig, axes = plt.subplots(1, 4, figsize=(18, 4.3))
    times = sorted(profiles)
    colors = plt.cm.viridis(np.linspace(0, 1, max(len(times), 2)))
    for c, t in zip(colors, times):
        x, y = profiles[t]
        axes[0].plot(np.concatenate([-x[::-1], x]), np.concatenate([y[::-1], y]), color=c, label=f"t = {t:.3g}")
    axes[0].set_aspect("equal")
    axes[0].set_xlabel("x (current; mirrored about the crease line)")
    axes[0].set_ylabel("surface height y")
    axes[0].legend(fontsize=6)
    t = np.array([r["time"] for r in rows])
    axes[1].plot(t, [r["groove_depth"] for r in rows], label="groove depth")
    axes[1].plot(t, [r["crease_depth_left"] for r in rows], label="crease (contact) depth")
    axes[1].plot(t, [r["swollen_depth_current"] for r in rows], label="swollen zone depth")
    axes[1].set_xscale("log")
    axes[1].set_xlabel("t [H^2/D]")
    axes[1].legend(fontsize=7)
    axes[2].plot(np.sqrt(t), [r["uptake"] for r in rows], "o-", ms=2)
    axes[2].set_xlabel("sqrt(t)")
    axes[2].set_ylabel("solvent uptake (per unit depth)")
    # the pattern against the depth of the swollen zone (Tanaka: spacing grows with it)
    depth = np.array([r["swollen_depth"] for r in rows])
    axes[3].plot(depth, [r["crease_spacing"] for r in rows], ".", ms=2, label="mean groove spacing")
    closed = np.array([r["self_contacts"] + r["contact_points_left"] + r["contact_points_right"] > 0 for r in rows])
    if closed.any():
        axes[3].axvline(depth[np.argmax(closed)], color="k", lw=0.8, ls=":", label="first faces in contact")
    axes[3].set_xscale("log")
    axes[3].set_yscale("log")
    axes[3].set_xlabel("swollen depth (reference)")
    axes[3].set_ylabel(f"spacing (period {2 * setup.width:g})")
    axes[3].legend(fontsize=7)
    imperfection = (f"trough ({setup.trough}) a/W={setup.amplitude}" if setup.seed is None else
                    f"random (seed {setup.seed}, wavelength >= {setup.wavelength}) a/W={setup.amplitude}")
    fig.suptitle(f"Nv={setup.Nv}, chi={setup.chi}, mu0={setup.mu0}, W={setup.width}, {imperfection}, "
                 f"h={setup.top_h}, gamma/(G H)={setup.surface_tension}")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


# ----------------------------------------------------------------------------- equilibrium counterpart


def build_equilibrium(setup: Setup, *, imperfect: bool, contact: bool) -> EquilibriumProblem:
    setup.check()
    prob = EquilibriumProblem(setup.mesh(imperfect=imperfect), kinematics=PlaneStrain(), materials=setup.gel,
                              lam0=setup.lam0, mu=setup.mu0, quadrature_order=4)
    prob.fix("bottom")
    prob.fix("left|right", "x")
    if contact:
        setup.add_contact(prob)
    setup.add_surface_tension(prob)
    return prob


def set_homogeneous(prob: EquilibriumProblem, setup: Setup, mu: float) -> float:
    """Put the closed-form laterally constrained state at ``mu`` into ``prob``; its free residual."""
    prob.mu.Set(mu)
    stretch = setup.gel.lam_constrained(mu, setup.lam0) / setup.lam0
    prob.displacement.Set(ngs.CF((0.0, (stretch - 1.0) * ngs.y)))
    r = prob.state.CreateVector()
    prob.residual(prob.state, r)
    return float(np.linalg.norm(r.FV().NumPy()[prob.free_mask]))


def linear_threshold(setup: Setup, *, mu_tol: float = 1e-7) -> dict:
    """Lowest ``mu`` at which the flat layer's homogeneous state loses stability (the exact count of
    negative eigenvalues of the tangent turns non-zero), by bisection between ``mu0`` and 0."""
    prob = build_equilibrium(setup, imperfect=False, contact=False)
    wall0 = time.perf_counter()

    def unstable(mu: float) -> bool:
        set_homogeneous(prob, setup, mu)
        return negative_count(free_matrix(prob.tangent(prob.state), prob.free_mask)) > 0

    lo, hi = setup.mu0, 0.0
    if unstable(lo):
        raise RuntimeError("the reference state is already unstable")
    if not unstable(hi):
        return {"mu": None, "ratio": None, "ndof": prob.space.ndof, "wall_seconds": time.perf_counter() - wall0,
                "residual_homogeneous": set_homogeneous(prob, setup, 0.0)}
    while hi - lo > mu_tol:
        mid = 0.5 * (lo + hi)
        lo, hi = (lo, mid) if unstable(mid) else (mid, hi)
    residual = set_homogeneous(prob, setup, hi)
    return {"mu": hi, "ratio": setup.ratio(hi), "ndof": prob.space.ndof, "wall_seconds": time.perf_counter() - wall0,
            "residual_homogeneous": residual}


def fold_estimate(path: list[dict]) -> float | None:
    """``mu`` of the fold (limit point) from the last two states before a snap: near a fold the
    lowest eigenvalue of the tangent vanishes like ``sqrt(mu_c - mu)``, so ``lambda^2`` is linear
    in ``mu``; extrapolated to zero. None when the eigenvalues do not decrease towards the end."""
    pts = [(p["mu"], p["lowest_eigenvalue"]) for p in path if p.get("lowest_eigenvalue") is not None]
    if len(pts) < 2:
        return None
    (m1, l1), (m2, l2) = pts[-2], pts[-1]
    if not (0 < l2 < l1 and m2 > m1):
        return None
    return m2 + l2**2 * (m2 - m1) / (l1**2 - l2**2)


def crease_threshold(setup: Setup, *, step: float = 0.002, start_ratio: float = 1.8, mu_end: float = 0.0,
                     history: History | None = None, eigenvalues: bool = True) -> dict:
    """Raise ``mu`` on the imperfect layer with contact; the crease threshold is the first state with
    the faces in contact (or, if the groove snaps shut, the last converged ``mu``). The ramp starts
    at the ``mu`` where the homogeneous ratio is ``start_ratio`` (well below any threshold), from the
    closed-form homogeneous state as the first Newton guess. With ``eigenvalues`` the lowest
    eigenvalue of the tangent is recorded along the ramp: at a snap it says whether the last state
    is next to a fold (eigenvalue -> 0), and ``fold_estimate`` extrapolates the fold's ``mu``."""
    if not 1.0 < start_ratio < setup.ratio(mu_end):
        raise ValueError(f"start_ratio must be in (1, {setup.ratio(mu_end):.4g}), got {start_ratio!r}")
    prob = build_equilibrium(setup, imperfect=True, contact=True)
    wall0 = time.perf_counter()
    mu_start = brentq(lambda m: setup.ratio(m) - start_ratio, setup.mu0, mu_end, xtol=1e-12)
    try:  # coarse steps up to the start ratio
        ramp(prob, prob.mu, mu_start, step=0.05)
    except RampError as err:  # the groove snapped already: the last converged mu is the threshold
        last = prob.mu.Get()
        return {"amplitude": setup.amplitude, "top_h": setup.top_h, "tip_h": setup.tip_h, "ndof": prob.space.ndof,
                "wall_seconds": time.perf_counter() - wall0, "message": str(err), "mu": last,
                "ratio": setup.ratio(last), "how": "snap before the start ratio (no converged state beyond)",
                "path": []}
    found = {}
    path = []

    def on_step(mu, _result) -> bool:
        surf = surface_state(prob, setup)
        surf.pop("profile")
        path.append({"mu": mu, "ratio": setup.ratio(mu), "groove_depth": surf["groove_depth"],
                     "crease_depth": surf["crease_depth_left"], "penetration": surf["penetration"],
                     "self_crossings": surf["self_crossings"],
                     "lowest_eigenvalue": float(spectrum(prob, count=1, past_negative=True).eigenvalues[0])
                     if eigenvalues else None})
        if history is not None:
            history.append(path[-1])
        if surf["contact_points_left"] > 0 or surf["contact_points_right"] > 0:
            found.update(mu=mu, ratio=setup.ratio(mu), how="contact")
            return True
        if surf["self_contacts"] > 0 or surf["tip_lobes"] > 0:
            where = surf["contact_X"] if surf["self_contacts"] else surf["tip_X"]
            found.update(mu=mu, ratio=setup.ratio(mu), how=f"self-contact at reference x = {where:.4f}")
            return True
        if surf["self_crossings"] > 0:  # the faces met by crossing at the tip (or elsewhere): stop there too
            found.update(mu=mu, ratio=setup.ratio(mu), how=f"faces crossed at reference x = {surf['crossing_X']:.4f}")
            return True
        return False

    message = ""
    try:
        ramp(prob, prob.mu, mu_end, step=step, max_step=step, min_step=1e-6, on_step=on_step)
    except RampError as err:
        last = path[-1]["mu"] if path else setup.mu0
        found.update(mu=last, ratio=setup.ratio(last), how="no converged state beyond (snap)")
        message = str(err)
        fold = fold_estimate(path)
        if path and path[0].get("lowest_eigenvalue") is not None:
            found.update(eigenvalue_first=path[0]["lowest_eigenvalue"], eigenvalue_last=path[-1]["lowest_eigenvalue"],
                         fold_mu=fold, fold_ratio=None if fold is None or fold >= mu_end else setup.ratio(fold))
    return {"amplitude": setup.amplitude, "top_h": setup.top_h, "tip_h": setup.tip_h, "ndof": prob.space.ndof,
            "wall_seconds": time.perf_counter() - wall0, "message": message, **found, "path": path}


def run_equilibrium(setup: Setup, out: str | None, *, meshes, amplitudes, crease_meshes=None,
                    quiet: bool = False) -> dict:
    setup.check()
    progress = Progress("creases-eq") if not quiet else (lambda msg: None)
    run_dir = RunDirectory(out, params={**setup.__dict__, "meshes": list(meshes), "amplitudes": list(amplitudes)}) \
        if out else None
    # closed-form check of the homogeneous state (flat layer, mu ramped by Newton)
    prob = build_equilibrium(setup, imperfect=False, contact=False)
    check = []
    for mu in np.linspace(setup.mu0, 0.0, 6)[1:]:
        prob.mu.Set(float(mu))
        prob.solve()
        top = sample_on_line(prob.displacement, prob.mesh, start=(0.25 * setup.width, setup.thickness),
                             end=(0.75 * setup.width, setup.thickness), n=5).values[:, 1]
        exact = setup.thickness * (setup.ratio(float(mu)) - 1.0)
        check.append({"mu": float(mu), "top_uy": float(top.mean()), "exact": exact,
                      "rel_error": abs(float(top.mean()) - exact) / exact})
        progress(f"homogeneous mu = {mu:.3f}: top u_y {top.mean():.6f} vs closed form {exact:.6f}")
    linear = []
    for h in meshes:
        s = Setup(**{**setup.__dict__, "top_h": h})
        res = linear_threshold(s)
        linear.append({"top_h": h, **res})
        progress(f"linear threshold, h = {h}: mu = {res['mu']}, ratio = {res['ratio']}, ndof {res['ndof']}, "
                 f"{res['wall_seconds']:.1f}s")
    crease = []
    for a in amplitudes:
        for h in crease_meshes or (meshes[-3:-1] if len(meshes) > 2 else meshes):
            s = Setup(**{**setup.__dict__, "amplitude": a, "top_h": h})
            with (History(run_dir.file(f"crease_path_a{a}_h{h}.csv")) if run_dir else contextlib.nullcontext()) as hist:
                try:
                    res = crease_threshold(s, history=hist)
                except (RampError, NewtonError) as err:  # recorded as a failed case, not hidden
                    res = {"amplitude": a, "top_h": h, "wall_seconds": None, "message": f"failed: {err}",
                           "how": "failed", "path": []}
            crease.append({k: v for k, v in res.items() if k != "path"})
            progress(f"crease threshold, a/W = {a}, h = {h}, gamma/GH = {s.surface_tension}: mu = {res.get('mu')}, ratio = {res.get('ratio')} "
                     f"(fold estimate {res.get('fold_ratio')}, lowest eigenvalue {res.get('eigenvalue_first')} -> {res.get('eigenvalue_last')}) "
                     f"({res.get('how')}), {res['wall_seconds']}s {res['message'][:120]}")
    summary = {"homogeneous_check": check, "linear": linear, "crease": crease, "biot_ratio": BIOT_RATIO,
               "crease_ratio_literature": CREASE_RATIO, "ratio_at_mu0": 1.0, "ratio_at_mu_0": setup.ratio(0.0),
               "drained_poisson_ratio": setup.gel.drained_poisson_ratio(setup.lam0)}
    if run_dir:
        run_dir.write_json("equilibrium.json", summary)
    return summary


# ----------------------------------------------------------------------------- study


def run_study(setup: Setup, out: str, *, cases: list[tuple[str, dict, float | None]], t_end: float,
              dt_max: float | None = None) -> list[dict]:
    """Transient onset for each case ``(label, changes to setup, dt_max)``, one row per run with
    its wall time, written as it finishes; ``dt_max`` for the cases that give none."""
    default_dt_max = dt_max
    run_dir = RunDirectory(out, params={**setup.__dict__, "cases": [[k, c, d] for k, c, d in cases]})
    progress = Progress("creases-study")
    rows = []
    with History(run_dir.file("study.csv")) as hist:
        for kind, change, dt_max in cases:
            dt_max = default_dt_max if dt_max is None else dt_max
            s = Setup(**{**setup.__dict__, **change})
            summ = run_transient(s, None, t_end=t_end, dt_max=dt_max, after_onset=1.0, quiet=True)
            onset = summ["onset"] or summ["interior_crease"] or {}
            where = (summ["onset"]["onset_kind"] if summ["onset"] else ("interior" if summ["interior_crease"] else "none"))
            row = {"varied": kind, "crease_at": where, "top_h": s.top_h, "tip_h": s.tip_h, "width": s.width, "amplitude": s.amplitude,
                   "viscosity": s.viscosity, "surface_tension": s.surface_tension, "dt_max": dt_max, "ndof": summ["ndof"], "steps": summ["steps"],
                   "wall_seconds": summ["wall_seconds"], "onset_time": onset.get("time"), "onset_previous_time": onset.get("previous_time"),
                   "onset_swollen_depth": onset.get("swollen_depth"),
                   "onset_swollen_depth_current": onset.get("swollen_depth_current"),
                   "onset_depth_over_width": (onset["swollen_depth"] / s.width) if onset else None,
                   "onset_surface_ratio": onset.get("surface_ratio"), "onset_skin_ratio": onset.get("skin_ratio"),
                   "max_relative_balance_error": summ["max_relative_balance_error"],
                   "cumulative_balance_error_relative": summ["cumulative_balance_error_relative"],
                   "max_penetration_time": summ["max_penetration_time"],
                   "max_penetration_over_h": summ["max_penetration_over_h"],
                   "max_self_crossings": summ["max_self_crossings"],
                   "tip_sharpening_time": (summ["tip_sharpening"] or {}).get("time"), "message": summ["message"]}
            rows.append(row)
            hist.append(row)
            progress(f"{kind}: h={s.top_h} W={s.width} a={s.amplitude} eta={s.viscosity} gamma/GH={s.surface_tension} "
                     f"dt_max={dt_max}: onset t={row['onset_time']} ({where}) depth={row['onset_swollen_depth']} "
                     f"surface ratio={row['onset_surface_ratio']} ({row['wall_seconds']:.1f}s, {row['ndof']} dofs, "
                     f"{row['message']})")
    return rows


# With surface energy (gamma/(G H) as given, default 0.02): onset against the mesh at a fixed
# elastocapillary length (top_h/l = 1, 0.5, 0.25, 0.125 at 0.02), a smaller imperfection on the
# two finest meshes, and the dependence on gamma. Meant for a linearly stable skin, e.g.
# ``--study --mu0 -0.1 --amplitude 0.1 --t-end 5`` (docs/creases.md).
SURFACE_STUDY_CASES = [("mesh", {"top_h": 0.02}, None), ("mesh", {"top_h": 0.01}, None),
                       ("mesh", {"top_h": 0.005}, None), ("mesh", {"top_h": 0.0025}, None),
                       ("amplitude", {"top_h": 0.005, "amplitude": 0.03}, None),
                       ("amplitude", {"top_h": 0.0025, "amplitude": 0.03}, None),
                       ("surface_tension", {"top_h": 0.005, "surface_tension": 0.01}, None),
                       ("surface_tension", {"top_h": 0.005, "surface_tension": 0.04}, None),
                       # the bulk mesh refined with the surface (the swelling front lies in the bulk)
                       ("mesh+bulk", {"top_h": 0.01, "maxh": 0.025}, None),
                       ("mesh+bulk", {"top_h": 0.005, "maxh": 0.0125}, None),
                       ("mesh+bulk", {"top_h": 0.0025, "maxh": 0.00625}, None),
                       ("bulk", {"top_h": 0.005, "maxh": 0.025}, None),
                       ("bulk", {"top_h": 0.0025, "maxh": 0.0125}, None),
                       # only the crease tip refined (x < tip_length): the onset is set there
                       ("tip", {"top_h": 0.005, "tip_h": 0.00125}, None),
                       ("tip", {"top_h": 0.005, "tip_h": 0.000625}, None),
                       ("tip", {"top_h": 0.005, "tip_h": 0.0003125}, None),
                       ("tip", {"top_h": 0.005, "tip_h": 0.00125, "amplitude": 0.03}, None),
                       ("tip", {"top_h": 0.005, "tip_h": 0.000625, "amplitude": 0.03}, None),
                       ("tip", {"top_h": 0.005, "tip_h": 0.0003125, "amplitude": 0.03}, None)]
STUDY_CASES = [("amplitude", {"amplitude": 0.05}, None), ("amplitude", {"amplitude": 0.003}, None),
               ("mesh", {"amplitude": 0.05, "top_h": 0.01}, None),
               ("width", {"width": 0.1, "top_h": 0.01, "maxh": 0.025}, None),
               ("dt_max", {}, 2e-3), ("viscosity", {"viscosity": 1e-2}, None),
               ("mesh", {"amplitude": 0.05, "top_h": 0.005}, None)]


def main(argv=None) -> dict:
    # lengths in units of the scene length L, which --thickness (H) is by default; times in L^2/D
    parser = scene_parser(__doc__, out="results/creases", quick="coarse mesh",
                          swelling=dict(Nv=Setup.Nv, chi=Setup.chi, mu0=Setup.mu0, ramp=Setup.ramp))
    parser.add_argument("--equilibrium", action="store_true", help="quasi-static counterpart instead")
    parser.add_argument("--study", action="store_true", help="onset vs mesh, dt and imperfection")
    parser.add_argument("--study-cases", choices=("sharp", "surface"), default="surface",
                        help="--study: 'surface': mesh, imperfection and gamma with surface energy; "
                        "'sharp': the sharp-interface study (mesh, dt, imperfection, stabiliser; gamma = 0)")
    parser.add_argument("--cases", default="", help="--study: comma-separated indices of the cases to run (default all)")
    parser.add_argument("--width", type=float, default=Setup.width, help="cell width W, half the crease period (L)")
    parser.add_argument("--thickness", type=float, default=Setup.thickness,
                        help="layer thickness H (L: at 1, every length is a fraction of H)")
    parser.add_argument("--amplitude", type=float, default=Setup.amplitude,
                        help="trough depth / W (with --seed: max |w| / W of the random imperfection)")
    parser.add_argument("--trough", choices=("mirror", "centre"), default=Setup.trough,
                        help="where the trough lies: mirror, on the left mirror line, or centre, in the middle "
                             "of the cell")
    parser.add_argument("--seed", type=int, default=None, help="seed of a random mirror-symmetric imperfection "
                        "(modes cos(pi m x / W)) instead of the trough (default: none, the trough)")
    parser.add_argument("--wavelength", type=float, default=Setup.wavelength,
                        help="--seed: shortest wavelength of the random imperfection (L)")
    parser.add_argument("--no-self-contact", action="store_true",
                        help="leave out the self-contact of the top (creases off the mirror lines then stop the run)")
    parser.add_argument("--after-onset", type=float, default=None,
                        help="march until this multiple of the onset time (default 1.5; 1.2 with --quick)")
    parser.add_argument("--crease-meshes", default="", help="--equilibrium: comma-separated surface element sizes "
                        "(L) for the crease threshold (default: the middle two of the linear-threshold meshes)")
    parser.add_argument("--amplitudes", default="0.1,0.03,0.01",
                        help="--equilibrium: comma-separated imperfections a / W for the crease threshold")
    parser.add_argument("--top-h", type=float, default=None,
                        help=f"surface element size (L; default {Setup.top_h:g}, quick 0.02)")
    parser.add_argument("--tip-h", type=float, default=None, help="finer surface element size (L) on x < --tip-length, "
                        "where the crease tip on the mirror line forms (default: top_h everywhere)")
    parser.add_argument("--tip-length", type=float, default=Setup.tip_length,
                        help="length of the top's part with --tip-h elements (L)")
    parser.add_argument("--maxh", type=float, default=Setup.maxh, help="element size in the bulk (L)")
    parser.add_argument("--penalty", type=float, default=Setup.penalty,
                        help="contact stiffness / (G / top-h), dimensionless")
    parser.add_argument("--viscosity", type=float, default=Setup.viscosity,
                        help="pseudo-viscous stabiliser eta / G (L^2/D)")
    parser.add_argument("--surface-tension", type=float, default=Setup.surface_tension,
                        help="surface energy of the top, gamma / (G H), dimensionless: the elastocapillary length "
                        f"over the thickness ({SURFACE_TENSION}: gamma = 0.07 N/m on this gel, G = 1.3e5 Pa, at "
                        "H = 27 um, or on a gel with G = 3.5e3 Pa at H = 1 mm; 0: none, the sharp-interface model)")
    parser.add_argument("--t-end", type=float, default=2.0,
                        help="end time (L^2/D; the run stops earlier, after the onset)")
    parser.add_argument("--dt-max", type=float, default=None,
                        help="largest time step (L^2/D; default: none, steps grow with the time elapsed)")
    parser.add_argument("--resume", default=None, metavar="DIR",
                        help="go on with the stopped transient run in DIR from its last checkpoint, with its options (default: none, a new run)")
    args = resume_arguments(parser, argv)
    with silence_progress(args.quiet):
        return _main(args)


def _main(args) -> dict:
    """The run the parsed options ask for."""
    quick = quick_run(args)
    top_h = args.top_h if args.top_h is not None else (0.02 if quick else Setup.top_h)
    setup = Setup(Nv=args.Nv, chi=args.chi, mu0=args.mu0, thickness=args.thickness, width=args.width,
                  amplitude=args.amplitude, top_h=top_h, tip_h=args.tip_h, tip_length=args.tip_length, maxh=max(args.maxh, top_h) if quick else args.maxh,
                  penalty=args.penalty, ramp=args.ramp, viscosity=args.viscosity,
                  surface_tension=args.surface_tension, trough=args.trough, seed=args.seed, wavelength=args.wavelength,
                  self_contact=not args.no_self_contact)
    setup.check()
    if args.equilibrium:
        meshes = [0.04, 0.02] if quick else [0.02, 0.01, 0.005, 0.0025]  # crease: the middle two
        amplitudes = [0.1] if quick else [float(a) for a in args.amplitudes.split(",")]
        crease_meshes = [float(h) for h in args.crease_meshes.split(",")] if args.crease_meshes else None
        summary = run_equilibrium(setup, args.out, meshes=meshes, amplitudes=amplitudes, crease_meshes=crease_meshes)
        print(f"linear thresholds: {[(r['top_h'], r['ratio']) for r in summary['linear']]}; crease thresholds: "
              f"{[(r['amplitude'], r['top_h'], r.get('ratio')) for r in summary['crease']]}")
        return summary
    if args.study:
        if args.study_cases == "sharp":
            base, cases = Setup(**{**setup.__dict__, "top_h": 0.02, "surface_tension": 0.0}), STUDY_CASES
        else:
            base, cases = Setup(**{**setup.__dict__, "maxh": max(setup.maxh, 0.05)}), SURFACE_STUDY_CASES
        if args.cases:
            cases = [cases[int(i)] for i in args.cases.split(",")]
        rows = run_study(base, args.out, cases=cases, t_end=args.t_end, dt_max=args.dt_max)
        return {"study": rows}
    summary = run_transient(setup, args.out, t_end=args.t_end, dt_max=args.dt_max,
                            after_onset=args.after_onset or (1.2 if quick else 1.5), options=command_options(args),
                            resume=args.resume is not None)
    onset = summary["onset"]
    print("no crease onset before t_end" if onset is None else
          f"crease onset at t = {onset['time']:.4e}: swollen depth {onset['swollen_depth']:.4f} (reference), "
          f"surface ratio {onset['surface_ratio']:.3f}, skin ratio {onset['skin_ratio']:.3f}; max balance error "
          f"{summary['max_relative_balance_error']:.1e}; max penetration/h {summary['max_penetration_over_h']:.1e}; "
          f"results in {args.out}")
    growth = summary["spacing_against_depth"]
    if growth:
        fit = growth.get("fit")
        print("groove spacing against swollen depth: " + ", ".join(
            f"{b['spacing']:.3g} at {b['depth']:.3g}" for b in growth["bins"]) +
              f"; rank correlation {growth['rank_correlation']:+.2f}" +
              (f", spacing ~ depth^{fit['exponent']:.2f} +- {fit['standard_error']:.2f} over {fit['points']} bins"
               if fit else "") + "; coarsening (grooves per period) " + ", ".join(
            f"{c['from']:g} -> {c['to']:g} at depth {c['depth']:.3g} (t = {c['time']:.3g})" for c in growth["coarsening"]))
    sharp = summary["tip_sharpening"]
    if sharp:
        print(f"tip radius l/4 = {sharp['radius']:.4g} reached at t = {sharp['time']:.4e} (groove "
              f"{sharp['groove_depth']:.4f}, swollen depth {sharp['swollen_depth']:.4f})")
    return summary


if __name__ == "__main__":
    main()
