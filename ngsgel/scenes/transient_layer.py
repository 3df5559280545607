"""Transient swelling of a gel layer bonded to a rigid base and immersed at its top.

The layer (unit thickness in the swollen reference, plane strain, laterally constrained by
rollers so the state stays one-dimensional) starts dry-ish at ``mu0`` and its top is brought to
``mu = 0`` over a short ramp (``--ramp``). The solvent front runs down from the top: profiles
of ``mu`` and ``J`` through the thickness at output times, the uptake against ``sqrt(t)``
(linear early on), a VTK time series, the step history (CSV) and a figure go into ``--out``.

    ngsgel run transient-layer --out results/transient_layer [--quick]
"""

from __future__ import annotations

import time

import numpy as np
from ngsolve.meshes import MakeStructured2DMesh

from ngsgel import FloryRehnerGel, PlaneStrain
from ngsgel.output import History, Progress, RunDirectory, VTKSeries, quick_run, scene_parser, silence_progress
from ngsgel.transient import TransientProblem, march, time_ramp

WIDTH = 0.1  # one element across: the layer is laterally infinite


def build(*, Nv: float, chi: float, mu0: float, mu_ext: float, ramp: float, ny: int) -> TransientProblem:
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    # cubic grading towards the wetted top, where the early front is thin
    mesh = MakeStructured2DMesh(nx=1, ny=ny, mapping=lambda x, y: (WIDTH * x, 1 - (1 - y) ** 3))
    prob = TransientProblem(mesh, kinematics=PlaneStrain(), materials=gel, lam0=gel.lam_free(mu0), mu0=mu0)
    prob.fix("bottom")
    prob.fix("left|right", "x")
    prob.immerse("top", time_ramp(prob.t, start=mu0, end=mu_ext, duration=ramp))
    return prob


def profile(prob: TransientProblem, heights: np.ndarray) -> dict[str, np.ndarray]:
    points = prob.mesh(np.full_like(heights, WIDTH / 2), heights)
    u = prob.displacement(points)
    return {"Y": heights, "y": heights + u[:, 1], "mu": prob.chemical_potential(points).ravel(),
            "J": prob.volume_ratio()(points).ravel()}


def run(out: str, *, quick: bool = False, Nv: float = 1e-3, chi: float = 0.5, mu0: float = -1.0,
        mu_ext: float = 0.0, ramp: float = 1e-4, t_end: float | None = None) -> dict:
    ny = 12 if quick else 40
    gel = FloryRehnerGel(Nv=Nv, chi=chi)
    lam0 = gel.lam_free(mu0)
    J_final = lam0**2 * gel.lam_constrained(mu_ext, lam0)
    # the slowest diffusivity is the swollen one: equilibrium after a few H^2 / Dc
    Dc = (1 - 1 / J_final) * (gel.bulk_modulus(J_final ** (1 / 3)) + 4 / 3 * gel.shear_modulus(J_final ** (1 / 3)))
    t_end = (10.0 if quick else 30.0) / Dc if t_end is None else t_end
    outputs = np.geomspace(1e-3, t_end, 8 if quick else 16)[:-1]
    params = {"Nv": Nv, "chi": chi, "mu0": mu0, "mu_ext": mu_ext, "ramp": ramp, "ny": ny, "t_end": t_end,
              "lam0": lam0, "J0": lam0**3, "J_final_equilibrium": J_final, "quick": quick}
    run_dir = RunDirectory(out, params=params)
    progress = Progress("transient_layer")
    prob = build(Nv=Nv, chi=chi, mu0=mu0, mu_ext=mu_ext, ramp=ramp, ny=ny)
    vtk = VTKSeries(prob.mesh, prob.fields(), run_dir.file("layer"))
    heights = 1 - (1 - np.linspace(0, 1, 101)) ** 2
    profiles = {0.0: profile(prob, heights)}
    vtk.write(0.0)

    with History(run_dir.file("history.csv")) as history, \
            History(run_dir.file("profiles.csv")) as profile_rows:
        def on_step(p: TransientProblem, record) -> None:
            history.append(record.row())
            if record.output:
                vtk.write(record.time)
                prof = profile(p, heights)
                profiles[record.time] = prof
                for i in range(len(heights)):
                    profile_rows.append({"time": record.time, **{k: v[i] for k, v in prof.items()}})
                progress(f"t = {record.time:9.3e}  dt = {record.dt:8.2e}  Newton {record.iterations:2d}  "
                         f"uptake {record.uptake:.4e}  balance {record.relative_balance_error:.1e}")

        start = time.perf_counter()
        result = march(prob, t_end, dt_start=min(ramp, t_end) / 20, output_times=outputs, on_step=on_step)
    wall = time.perf_counter() - start
    final_uptake = WIDTH * (J_final / lam0**3 - 1)
    summary = {"steps": result.steps, "cutbacks": result.cutbacks, "wall_seconds": wall,
               "uptake": result.records[-1].uptake, "uptake_equilibrium": final_uptake,
               "max_relative_balance_error": max(r.relative_balance_error for r in result.records),
               "volume_ratio_final": float(profiles[max(profiles)]["J"].mean() / lam0**3)}
    run_dir.write_json("summary.json", summary)
    plot(result, profiles, final_uptake, run_dir.file("transient_layer.png"), title=f"Nv = {Nv}, chi = {chi}, "
         f"mu: {mu0} -> {mu_ext} at the top")
    progress(f"{result.steps} steps ({result.cutbacks} cut-backs) in {wall:.1f}s; uptake "
             f"{summary['uptake']:.5e} of {final_uptake:.5e} at equilibrium")
    return summary


def plot(result, profiles: dict, final_uptake: float, path, *, title: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 3, figsize=(13, 4.2))
    colors = plt.cm.viridis(np.linspace(0, 1, len(profiles)))
    for color, (t, prof) in zip(colors, sorted(profiles.items())):
        axes[0].plot(prof["mu"], prof["y"], color=color, label=f"t = {t:.2g}")
        axes[1].plot(prof["J"], prof["y"], color=color)
    axes[0].set_xlabel("chemical potential mu [kT]")
    axes[1].set_xlabel("volume ratio J")
    for ax in axes[:2]:
        ax.set_ylabel("height (current) / reference thickness")
    axes[0].legend(fontsize=6)
    t = result.column("time")
    axes[2].plot(np.sqrt(t), result.column("uptake") / final_uptake, "o-", ms=2)
    axes[2].set_xscale("log")
    axes[2].set_yscale("log")
    axes[2].set_xlabel("sqrt(t)  [t in L^2 / D]")
    axes[2].set_ylabel("uptake / equilibrium uptake")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> None:
    parser = scene_parser(__doc__, out="results/transient_layer", quick="coarse mesh, fewer outputs",
                          swelling=dict(Nv=1e-3, chi=0.5, mu0=-1.0, mu_ext=0.0, ramp=1e-4))
    args = parser.parse_args(argv)
    with silence_progress(args.quiet):
        summary = run(args.out, quick=quick_run(args), Nv=args.Nv, chi=args.chi,
                      mu0=args.mu0, mu_ext=args.mu_ext, ramp=args.ramp)
    print(f"{summary['steps']} steps, uptake {summary['uptake']:.5e} (equilibrium "
          f"{summary['uptake_equilibrium']:.5e}), final volume ratio {summary['volume_ratio_final']:.2f}; "
          f"results in {args.out}")


if __name__ == "__main__":
    main()
