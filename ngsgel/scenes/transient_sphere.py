"""Swelling of a gel ball from a dry-ish state, computed three ways: a 3D octant, an
axisymmetric section and the spherically symmetric line.

The ball (unit radius in the swollen reference at ``mu0``) is immersed in a bath at
``mu_ext`` (a ramp of length ``--ramp``: an ideal step is no physical immersion, and a
Newton solve cannot follow a jump of the boundary value on a fine 3D mesh). The three models
solve the same problem; the spherically symmetric line on a fine mesh is the reference. For
each model and mesh size the script prints and saves the largest uptake error over the whole
history (relative to the final uptake), the largest difference between the 3D and the
axisymmetric history at the same mesh size, and the wall time: the 3D model agrees with the
axisymmetric one within their discretisation errors, and costs tens of times more.

All models take exactly the same time steps (every step is an output), so the differences
are spatial. The default swelling (``mu`` -1 -> -0.1, ``Nv = 1e-2``: 1.6x the volume) stays
below the surface instability of a swelling skin (its in-plane compression is 15 %); a bath
at ``mu = 0`` (4.2x) compresses the skin by 38 % and a fine 3D mesh resolves skin wrinkles
that the axisymmetric and spherical models cannot have.

    ngsgel run transient-sphere --out results/transient_sphere [--quick]
"""

from __future__ import annotations

import math
import time

import numpy as np

from geometries import ball_octant, ball_section, sphere_radial
from ngsgel import Axisymmetric, FloryRehnerGel, Solid3D, SphericalSymmetric
from ngsgel.output import History, Progress, RunDirectory, VTKSeries, quick_run, scene_parser, silence_progress
from ngsgel.transient import TransientProblem, TransientResult, march, time_ramp

MODELS = ("line", "axisymmetric", "3d")
# the part of the ball each model's mesh stands for
SHARE = {"line": 1.0, "axisymmetric": 0.5, "3d": 0.125}


def build(model: str, *, h: float, gel: FloryRehnerGel, mu0: float, mu_ext: float,
          ramp: float) -> TransientProblem:
    """The ball swelling problem in ``model`` on a mesh of size ``h`` (order 2 / 1)."""
    common = dict(materials=gel, lam0=gel.lam_free(mu0), mu0=mu0)
    if model == "line":
        prob = TransientProblem(sphere_radial(outer=1.0, maxh=h).mesh, kinematics=SphericalSymmetric(), **common)
        prob.fix("inner")  # the centre
        surface = "outer"
    elif model == "axisymmetric":
        prob = TransientProblem(ball_section(maxh=h).mesh, kinematics=Axisymmetric(), **common)
        prob.fix("axis", "r")
        prob.fix("equator", "z")
        surface = "surface"
    elif model == "3d":
        prob = TransientProblem(ball_octant(maxh=h).mesh, kinematics=Solid3D(), **common)
        for plane, component in (("xsym", "x"), ("ysym", "y"), ("zsym", "z")):
            prob.fix(plane, component)
        surface = "surface"
    else:
        raise ValueError(f"model must be one of {MODELS}, got {model!r}")
    prob.immerse(surface, time_ramp(prob.t, start=mu0, end=mu_ext, duration=ramp))
    return prob


def time_grid(ramp: float, t_end: float, steps: int) -> np.ndarray:
    """Ten steps through the ramp, then geometric steps to ``t_end``."""
    return np.concatenate([np.linspace(ramp / 10, ramp, 10), np.geomspace(1.25 * ramp, t_end, steps)])


def uptake_history(prob: TransientProblem, times: np.ndarray, *, share: float,
                   on_step=None) -> tuple[np.ndarray, TransientResult]:
    """Uptake of the whole ball at ``times`` (the mesh stands for ``share`` of it), one
    backward Euler step per interval (steps grow whatever Newton's effort, so every model gets
    the same grid unless a step fails and is cut back, which the result records): no error
    control, which would give each model its own steps."""
    result = march(prob, float(times[-1]), dt_start=float(times[0]), output_times=times, dt_over_t=None,
                   scheme="backward_euler", rtol=None, grow=2.0, easy_iterations=10**6, on_step=on_step)
    return np.array([r.uptake for r in result.outputs]) / share, result


def run(out: str, *, quick: bool = False, Nv: float = 1e-2, chi: float = 0.5, mu0: float = -1.0,
        mu_ext: float = -0.1, ramp: float = 1e-4, t_end: float = 3.0) -> dict:
    sizes = (0.5, 0.35) if quick else (0.5, 0.35, 0.25, 0.18, 0.125)
    reference_cells = 64 if quick else 256
    steps = 30 if quick else 50
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    J0, J1 = gel.lam_free(mu0) ** 3, gel.lam_free(mu_ext) ** 3
    equilibrium_uptake = 4 * math.pi / 3 * (J1 / J0 - 1)
    params = {"Nv": Nv, "chi": chi, "mu0": mu0, "mu_ext": mu_ext, "ramp": ramp, "t_end": t_end, "J0": J0,
              "J_bath": J1, "sizes": sizes, "reference_cells": reference_cells, "quick": quick}
    run_dir = RunDirectory(out, params=params)
    progress = Progress("transient_sphere")
    times = time_grid(ramp, t_end, steps)
    problem = dict(gel=gel, mu0=mu0, mu_ext=mu_ext, ramp=ramp)

    reference, _ = uptake_history(build("line", h=1 / reference_cells, **problem), times, share=SHARE["line"])
    scale = reference[-1]
    histories = {("line", 1 / reference_cells): reference}
    rows = []
    with History(run_dir.file("errors.csv")) as errors:
        for h in sizes:
            for model in MODELS:
                prob = build(model, h=h, **problem)
                vtk = None
                if model == "3d" and h == sizes[-1]:
                    vtk = VTKSeries(prob.mesh, prob.fields(), run_dir.file("ball_3d"))
                    vtk.write(0.0)
                start = time.perf_counter()
                history, result = uptake_history(
                    prob, times, share=SHARE[model], on_step=None if vtk is None else lambda p, r: vtk.write(r.time))
                wall = time.perf_counter() - start
                histories[(model, h)] = history
                row = {"model": model, "h": h, "unknowns": prob.space.ndof, "elements": prob.mesh.ne,
                       "wall_seconds": wall, "steps": result.steps,
                       "cutbacks": sum(r.cutbacks for r in result.records),
                       "max_newton": int(result.column("iterations").max()),
                       "error": float(np.max(np.abs(history - reference)) / scale),
                       "final_error": float(abs(history[-1] - reference[-1]) / scale),
                       "max_balance_error": max(r.relative_balance_error for r in result.records),
                       "difference_3d_axisymmetric": float(np.max(np.abs(history - histories[("axisymmetric", h)]))
                                                           / scale) if model == "3d" else math.nan}
                rows.append(row)
                errors.append(row)
                progress(f"h = {h:5.3f}  {model:12s} {row['unknowns']:6d} unknowns  {wall:7.2f} s  "
                         f"error {row['error']:.3e}  |3d - axisymmetric| {row['difference_3d_axisymmetric']:.3e}")
    with History(run_dir.file("histories.csv")) as out_rows:
        for (model, h), history in histories.items():
            for t, uptake in zip(times, history):
                out_rows.append({"model": model, "h": h, "time": t, "uptake": uptake})
    summary = {"rows": rows, "reference_final_uptake": scale, "equilibrium_uptake": equilibrium_uptake}
    run_dir.write_json("summary.json", summary)
    plot(times, histories, rows, reference, sizes[-1], run_dir.file("transient_sphere.png"))
    return summary


def plot(times, histories, rows, reference, finest: float, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    axes[0].plot(np.sqrt(times), reference / reference[-1], "k-", lw=2, label="line (reference)")
    for model, style in zip(MODELS, ("--", "-.", ":")):
        if (model, finest) in histories:
            axes[0].plot(np.sqrt(times), histories[(model, finest)] / reference[-1], style, label=f"{model}, h = {finest}")
    axes[0].set_xlabel("sqrt(t)")
    axes[0].set_ylabel("uptake / reference final uptake")
    axes[0].legend(fontsize=7)
    for model, marker in zip(MODELS, "osd"):
        sel = [r for r in rows if r["model"] == model]
        axes[1].loglog([r["h"] for r in sel], [r["error"] for r in sel], marker + "-", label=model)
        axes[2].loglog([r["wall_seconds"] for r in sel], [r["error"] for r in sel], marker + "-", label=model)
    sel = [r for r in rows if r["model"] == "3d"]
    axes[1].loglog([r["h"] for r in sel], [r["difference_3d_axisymmetric"] for r in sel], "k^:",
                   label="|3d - axisymmetric|")
    axes[1].set_xlabel("mesh size h")
    axes[1].set_ylabel("max history error / final uptake")
    axes[2].set_xlabel("wall time [s]")
    axes[2].set_ylabel("max history error / final uptake")
    for ax in axes[1:]:
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> None:
    parser = scene_parser(__doc__, out="results/transient_sphere", quick="coarse meshes only",
                          swelling=dict(Nv=1e-2, chi=0.5, mu0=-1.0, mu_ext=-0.1, ramp=1e-4))
    parser.add_argument("--t-end", type=float, default=3.0, help="end of the run (L^2/D, L the ball's radius)")
    args = parser.parse_args(argv)
    with silence_progress(args.quiet):
        summary = run(args.out, quick=quick_run(args), Nv=args.Nv, chi=args.chi,
                      mu0=args.mu0, mu_ext=args.mu_ext, ramp=args.ramp, t_end=args.t_end)
    print(f"{'model':12s} {'h':>6s} {'unknowns':>8s} {'wall [s]':>9s} {'error':>9s} {'|3d-axi|':>9s}")
    for r in summary["rows"]:
        print(f"{r['model']:12s} {r['h']:6.3f} {r['unknowns']:8d} {r['wall_seconds']:9.2f} {r['error']:9.2e} "
              f"{r['difference_3d_axisymmetric']:9.2e}")


if __name__ == "__main__":
    main()
