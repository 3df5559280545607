"""Snap-through of a clamped shallow arch under a dead pressure, followed with arc length.

Plane-strain neo-Hookean arch (half span 1, rise ``--rise``, thickness ``--thickness``), half
model with a symmetry plane at mid-span; dead vertical traction ``q = lambda * q_ref`` on the top
face. The load–deflection curve (mid-span deflection over rise) is drawn with stable states in
blue and unstable ones in red, limit points marked. Writes ``params.json``, ``history.csv``
(+ ``.jsonl``) and ``curve.png`` into ``--out``.
"""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import ngsolve as ngs
from ngsolve.meshes import MakeStructured2DMesh

from ngsgel import EquilibriumProblem, NeoHookeanFilm, PlaneStrain
from ngsgel.continuation import PathResult, StabilityOptions, follow_path
from ngsgel.output import History, Progress, RunDirectory, quick_run, scene_parser


def arch_problem(*, rise: float, thickness: float, elements: int, order: int, load_scale: float):
    """Half arch on a structured quad mesh: ``left`` is the symmetry plane, ``right`` the clamped
    support, ``top`` the loaded face. Returns the problem, the load parameter and a deflection
    callable (mid-span deflection of the top face over the rise)."""
    radius = (1 + rise**2) / (2 * rise)
    opening = math.asin(1 / radius)

    def mapping(x, y):
        r = radius - thickness / 2 + y * thickness
        return (r * math.sin(x * opening), r * math.cos(x * opening) - (radius - rise))

    mesh = MakeStructured2DMesh(quads=True, nx=elements, ny=1, mapping=mapping)
    load = ngs.Parameter(0.0)
    # LU with pivoting: the tangent is indefinite between the limit points
    problem = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=NeoHookeanFilm(E=1.0, nu=0.3),
                                 lam0=2.0, order=order, inverse="umfpack")
    problem.fix("left", "x")
    problem.fix("right")
    problem.add_traction("top", ngs.CF((0, -load * load_scale)))
    apex = mesh(0.0, rise + thickness / 2)
    return problem, load, lambda: -problem.displacement(apex)[1] / rise


def plot_path(result: PathResult, qoi: str, path) -> None:
    """Load–deflection curve, stable segments blue, unstable red, events annotated."""
    fig, ax = plt.subplots(figsize=(6, 4.5))
    points = result.points
    for p, q in zip(points[:-1], points[1:]):
        unstable = (p.negative or 0) > 0 or (q.negative or 0) > 0
        ax.plot([p.qoi[qoi], q.qoi[qoi]], [p.parameter, q.parameter], color="tab:red" if unstable else "tab:blue")
    for p in points:
        if p.events:
            ax.plot(p.qoi[qoi], p.parameter, "ko", ms=5)
            ax.annotate(", ".join(p.events), (p.qoi[qoi], p.parameter), textcoords="offset points", xytext=(6, 4),
                        fontsize=8)
    ax.plot([], [], color="tab:blue", label="stable")
    ax.plot([], [], color="tab:red", label="unstable")
    ax.set_xlabel("mid-span deflection / rise")
    ax.set_ylabel("load parameter")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> PathResult:
    parser = scene_parser(__doc__, out="out/buckling_demo", quick="coarse mesh")
    parser.add_argument("--rise", type=float, default=0.06, help="rise of the arch / half span")
    parser.add_argument("--thickness", type=float, default=0.03, help="thickness / half span")
    parser.add_argument("--target", type=float, default=0.06,
                        help="final load parameter lambda, dimensionless (traction lambda 1e-4 E, E the arch's "
                             "Young's modulus)")
    args = parser.parse_args(argv)
    elements, order, max_step = (8, 2, 0.05) if quick_run(args) else (24, 3, 0.02)
    params = {"rise": args.rise, "thickness": args.thickness, "elements": elements, "order": order,
              "E": 1.0, "nu": 0.3, "load_scale": 1e-4, "target": args.target, "max_step": max_step}
    run = RunDirectory(args.out, params=params)
    problem, load, deflection = arch_problem(rise=args.rise, thickness=args.thickness, elements=elements,
                                             order=order, load_scale=params["load_scale"])
    with History(run.file("history.csv")) as history:
        result = follow_path(problem, load, method="arclength", step=0.01, max_step=max_step, target=args.target,
                             qoi={"deflection": deflection}, stability=StabilityOptions(eigenvalues=2),
                             history=history, progress=Progress("buckling_demo", quiet=args.quiet))
    plot_path(result, "deflection", run.file("curve.png"))
    return result


if __name__ == "__main__":
    main()
