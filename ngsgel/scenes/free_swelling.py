"""Free swelling of a gel: stretch against chemical potential, closed form and finite elements.

For chi in {0.1, 0.5, 0.8, 1.0} at Nv = 1e-3, a block swells or shrinks from a swollen reference
as mu is ramped; the stretch of its corner is compared with the closed form in all three model
dimensions. In plane strain the out-of-plane stretch stays at the reference value, so the
in-plane stretch follows its own closed form (``lam_plane_strain``).

    ngsgel run free-swelling --out results/free_swelling [--quick]
"""

from __future__ import annotations

import time

import numpy as np
from ngsolve.meshes import MakeStructured2DMesh, MakeStructured3DMesh

from ngsgel import Axisymmetric, EquilibriumProblem, FloryRehnerGel, PlaneStrain, Solid3D, ramp
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser, silence_progress

CHIS = (0.1, 0.5, 0.8, 1.0)
NV = 1e-3
MU_REF = -0.1

# unit square: left x=0, bottom y=0; unit cube (ngsolve.meshes names): back x=0, left y=0, bottom z=0
MODELS = {
    "solid3d": (Solid3D, lambda: MakeStructured3DMesh(nx=1, ny=1, nz=1), [("back", "x"), ("left", "y"), ("bottom", "z")]),
    "axisymmetric": (Axisymmetric, lambda: MakeStructured2DMesh(nx=1, ny=1), [("left", "r"), ("bottom", "z")]),
    "plane": (PlaneStrain, lambda: MakeStructured2DMesh(nx=1, ny=1), [("left", "x"), ("bottom", "y")]),
}


def fe_stretches(gel: FloryRehnerGel, model: str, mus: np.ndarray, *, order: int = 2) -> np.ndarray:
    """Corner stretch of the swelling block at each ``mu`` (ramped from ``MU_REF`` both ways)."""
    kinematics, make_mesh, symmetry = MODELS[model]
    lam0 = gel.lam_free(MU_REF)
    stretches = {}
    for branch in (mus[mus < MU_REF][::-1], mus[mus >= MU_REF]):
        mesh = make_mesh()
        prob = EquilibriumProblem(mesh, kinematics=kinematics(), materials=gel, lam0=lam0, mu=MU_REF, order=order)
        for boundary, component in symmetry:
            prob.fix(boundary, component)
        corner = mesh(*([1.0] * mesh.dim))
        for mu in branch:
            ramp(prob, prob.mu, float(mu))
            stretches[float(mu)] = lam0 * (1 + prob.displacement(corner)[0])
    return np.array([stretches[float(mu)] for mu in mus])


def run(out: str, *, quick: bool = False) -> list[dict]:
    run_dir = RunDirectory(out, params={"Nv": NV, "chis": CHIS, "mu_reference": MU_REF, "quick": quick})
    progress = Progress("free_swelling")
    n_fe = 4 if quick else 8
    rows = []
    with History(run_dir.file("stretch.csv")) as history:
        for chi in CHIS:
            gel = FloryRehnerGel(Nv=NV, chi=chi)
            mus = np.concatenate([-np.geomspace(3.0, 1e-3, n_fe), [0.0]])
            for model in MODELS:
                start = time.perf_counter()
                lam_fe = fe_stretches(gel, model, mus)
                wall = time.perf_counter() - start
                lam0 = gel.lam_free(MU_REF)
                for mu, lam in zip(mus, lam_fe):
                    exact = gel.lam_plane_strain(mu, lam0) if model == "plane" else gel.lam_free(mu)
                    row = {"chi": chi, "model": model, "mu": mu, "lam_fe": lam, "lam_exact": exact,
                           "rel_error": abs(lam / exact - 1)}
                    history.append(row)
                    rows.append(row)
                worst = max(r["rel_error"] for r in rows if r["chi"] == chi and r["model"] == model)
                progress(f"chi={chi} {model:13s} {len(mus)} states, max rel. error {worst:.1e}, {wall:.2f}s")
    plot(rows, run_dir.file("stretch.png"))
    return rows


def plot(rows: list[dict], path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    markers = {"solid3d": "o", "axisymmetric": "x", "plane": "s"}
    for i, chi in enumerate(CHIS):
        color = f"C{i}"
        gel = FloryRehnerGel(Nv=NV, chi=chi)
        mu_line = np.concatenate([-np.geomspace(3.0, 1e-4, 200), [0.0]])
        ax.plot(mu_line, [gel.lam_free(m) for m in mu_line], color=color, label=f"chi = {chi}")
        lam0 = gel.lam_free(MU_REF)
        ax.plot(mu_line, [gel.lam_plane_strain(m, lam0) for m in mu_line], color=color, ls="--", lw=0.8)
        for model, marker in markers.items():
            pts = [(r["mu"], r["lam_fe"]) for r in rows if r["chi"] == chi and r["model"] == model]
            mu, lam = np.array(pts).T
            ax.plot(mu, lam, marker, color=color, mfc="none", ms=5,
                    label=f"FE {model}" if i == 0 else None)
    ax.set_xscale("symlog", linthresh=1e-3)
    ax.set_xlabel("chemical potential mu [kT]")
    ax.set_ylabel("stretch from the dry state")
    ax.set_title(f"Free swelling, Nv = {NV} (dashed: plane strain, lam_z held)")
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> None:
    parser = scene_parser(__doc__, out="results/free_swelling", quick="fewer states")
    args = parser.parse_args(argv)
    with silence_progress(args.quiet):
        rows = run(args.out, quick=quick_run(args))
    worst = max(r["rel_error"] for r in rows)
    print(f"{len(rows)} FE states, largest relative error against the closed form {worst:.2e}; "
          f"results in {args.out}")


if __name__ == "__main__":
    main()
