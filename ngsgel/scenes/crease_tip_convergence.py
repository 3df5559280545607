"""Mesh convergence of the transient crease onset with surface energy: the geometry of the groove
at fixed times, and the onset, for a sequence of surface meshes (docs/creases.md, "Why the onset
did not converge").

Each run is ``ngsgel/scenes/creases.py``'s transient problem (``creases.build_transient``, same onset
criterion: the first step with a surface point other than the corner on the mirror plane x <= 0),
marched with ``dt_max`` up to ``--t-fine`` and with ``--dt-fine`` after it, so that the onset is
bracketed to ``dt_fine``. The deformed top (4 points per P2 edge) is stored at every step
(``<out>/<label>.npz``), and the table compares, at fixed times and at the last step before the
onset: the groove depth, the height of the tip (the corner X = 0), the radius of curvature of the
surface at the tip (exact for the P2 edge at the corner), and the half-width x of the groove at
fixed heights y.

    ngsgel run crease-tip-convergence --out results/crease_tip --tip-h 0.005,0.0025,0.00125
"""

from __future__ import annotations

import json
import os
import time

import numpy as np
import ngsolve as ngs


from ngsgel.scenes import creases
from ngsgel.contact import surface_line
from ngsgel.output import Progress, scene_parser
from ngsgel.transient import march
from ngsgel.scenes.creases import tip_geometry


class _Done(Exception):
    """Ends the march shortly after the onset."""


def half_width(x: np.ndarray, y: np.ndarray, level: float) -> float:
    """x of the groove face at height ``level``, walking down from the crest (nan below the tip)."""
    j = int(np.argmax(y))
    while j > 0 and y[j - 1] > level:
        j -= 1
    return float(np.interp(level, [y[j - 1], y[j]], [x[j - 1], x[j]])) if j > 0 else float("nan")


def run(setup: creases.Setup, *, t_end: float, t_fine: float, dt_max: float, dt_fine: float,
        times: list[float]) -> dict:
    """March one case; the surface at every step, the onset bracket and the wall time."""
    prob = creases.build_transient(setup)
    rec = {"t": [], "x": [], "y": [], "swollen": []}
    state = {"onset": None, "previous": 0.0, "X": None}
    wall0 = time.perf_counter()

    def on_step(p, r) -> None:
        line = surface_line(p.displacement, p.mesh, "top")
        state["X"] = line.reference[:, 0]
        rec["t"].append(r.time)
        rec["x"].append(line.current[:, 0])
        rec["y"].append(line.current[:, 1])
        rec["swollen"].append(creases.swelling_state(p, setup)["swollen_depth"])
        if state["onset"] is None:
            if np.any((state["X"] > 0) & (line.current[:, 0] <= 0)):  # creases.surface_state's criterion
                state["onset"] = r.time
            else:
                state["previous"] = r.time
        elif r.time > state["onset"] + 2 * dt_fine:
            raise _Done()

    kw = {"dt_min": setup.ramp * 1e-7, "on_step": on_step}
    try:  # steps up to dt_max before t_fine (landing on the comparison times), dt_fine after
        march(prob, t_fine, dt_start=setup.ramp / 10, dt_max=dt_max,
              output_times=[t for t in times if t < t_fine], **kw)
        march(prob, t_end, dt_start=dt_fine, dt_max=dt_fine, output_times=[t for t in times if t > t_fine], **kw)
    except _Done:
        pass
    return {"X": state["X"], **{k: np.array(v) for k, v in rec.items()}, "onset": state["onset"],
            "previous": state["previous"], "wall": time.perf_counter() - wall0, "ndof": prob.mixed_space.ndof}


def describe(r: dict, times: list[float], levels: list[float]) -> list[dict]:
    """Geometry at each comparison time and at the last step before the onset."""
    rows = []
    picks = [(f"t = {t:g}", int(np.argmin(abs(r["t"] - t)))) for t in times if t <= r["t"][-1]]
    if r["onset"] is not None:
        picks.append(("before onset", int(np.searchsorted(r["t"], r["previous"]))))
    for label, i in picks:
        x, y = r["x"][i], r["y"][i]
        angle, radius = tip_geometry(x, y)
        rows.append({"at": label, "time": float(r["t"][i]), "groove_depth": float(y.max() - y[0]),
                     "tip_y": float(y[0]), "tip_angle_deg": angle, "tip_radius": radius,
                     "swollen_depth": float(r["swollen"][i]),
                     **{f"x_at_y{lv:g}": half_width(x, y, lv) for lv in levels}})
    return rows


def main(argv=None) -> list[dict]:
    # lengths in units of the layer thickness H, times in H^2/D (creases.Setup)
    parser = scene_parser(__doc__, out="results/crease_tip", quick=None, swelling=dict(mu0=-0.1, ramp=1e-3))
    parser.add_argument("--tip-h", default="0.005,0.0025,0.00125,0.000625,0.0003125",
                        help="comma-separated surface element sizes at the crease tip (x < --tip-length) / H, "
                             "one run each")
    parser.add_argument("--top-h", type=float, default=0.005,
                        help="surface element size elsewhere / H (at least --tip-h)")
    parser.add_argument("--tip-length", type=float, default=creases.Setup.tip_length,
                        help="length of the top's part with --tip-h elements / H")
    parser.add_argument("--maxh", type=float, default=creases.Setup.maxh, help="element size in the bulk / H")
    parser.add_argument("--amplitude", type=float, default=0.1, help="trough depth / W (W the cell width)")
    parser.add_argument("--surface-tension", type=float, default=creases.SURFACE_TENSION,
                        help="surface energy of the top, gamma / (G H), dimensionless")
    parser.add_argument("--t-end", type=float, default=2.0, help="end time (H^2/D; the run stops after the onset)")
    parser.add_argument("--t-fine", type=float, default=0.3, help="from this time on steps of --dt-fine (H^2/D)")
    parser.add_argument("--dt-max", type=float, default=0.01, help="largest time step before --t-fine (H^2/D)")
    parser.add_argument("--dt-fine", type=float, default=0.001, help="time step after --t-fine (H^2/D)")
    parser.add_argument("--times", default="0.2,0.3,0.4", help="comma-separated comparison times (H^2/D)")
    parser.add_argument("--levels", default="1.065,1.08,1.1", help="comma-separated heights y of the half-width / H")
    parser.add_argument("--threads", type=int, default=1, help="NGSolve threads")
    args = parser.parse_args(argv)
    ngs.SetNumThreads(args.threads)
    times = [float(t) for t in args.times.split(",")]
    levels = [float(v) for v in args.levels.split(",")]
    os.makedirs(args.out, exist_ok=True)
    table = []
    tip_hs = [float(h) for h in args.tip_h.split(",")]
    # a line per run, no fraction done: each halving of tip_h costs several times the one before,
    # so a time left extrapolated over the runs would mislead
    progress = Progress("crease_tip_convergence", quiet=args.quiet)
    for case, tip_h in enumerate(tip_hs):
        progress(f"run {case + 1} of {len(tip_hs)}: tip_h {tip_h:g}")
        setup = creases.Setup(mu0=args.mu0, amplitude=args.amplitude, top_h=max(args.top_h, tip_h), tip_h=tip_h,
                              tip_length=args.tip_length, surface_tension=args.surface_tension, ramp=args.ramp,
                              maxh=args.maxh)
        r = run(setup, t_end=args.t_end, t_fine=args.t_fine, dt_max=args.dt_max, dt_fine=args.dt_fine, times=times)
        label = f"tip_h{tip_h:g}_a{args.amplitude:g}_maxh{args.maxh:g}"
        np.savez(os.path.join(args.out, label + ".npz"), **{k: v for k, v in r.items() if v is not None})
        entry = {"tip_h": tip_h, "top_h": setup.top_h, "maxh": setup.maxh, "amplitude": args.amplitude, "ndof": r["ndof"],
                 "onset": r["onset"], "previous": r["previous"], "wall_seconds": r["wall"],
                 "geometry": describe(r, times, levels)}
        table.append(entry)
        print(f"tip_h {tip_h:g}: onset in ({r['previous']:.4f}, {r['onset']}], {r['ndof']} dofs, {r['wall']:.0f} s")
        for g in entry["geometry"]:
            print("   " + ", ".join(f"{k} {v:.5g}" if isinstance(v, float) else f"{k} {v}" for k, v in g.items()))
        with open(os.path.join(args.out, "table.json"), "w") as f:
            json.dump(table, f, indent=1)
    return table


if __name__ == "__main__":
    main()
