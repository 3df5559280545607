"""FEniCSx against ngsgel on issue 35's bonded block, on the same mesh: a peer benchmark.

The problem is ``bench_newton.issue35_problem``: block 1 x 1 x 0.2 bonded at its base, order-2
tetrahedra, ``FloryRehnerGel(Nv=1e-2, chi=0.5)`` referenced at its free swelling at stretch 1.3,
then 20 equal ``mu`` steps (strict) to the free state at 1.6. FEniCSx is not a dependency: it runs
from Debian's ``python3-dolfinx`` 0.5.2 under the system Python, which does not import ngsgel; the
mesh goes between the two as arrays. Install with an optimised BLAS (``--no-install-recommends``
alone leaves netlib's reference BLAS, with which the ramp took 5x the CPU time at 28k)::

    apt-get install --no-install-recommends python3-dolfinx libopenblas0-serial

Then::

    # our venv: the Netgen mesh of a size of bench_newton.ISSUE35_SIZES, and the problem's numbers
    python scripts/peer_fenicsx_block.py --export 28k /tmp/block28k.npz
    # system Python, dolfinx 0.5.2, one MPI rank, one thread: the ramp with MUMPS
    /usr/bin/python3 scripts/peer_fenicsx_block.py --fenicsx /tmp/block28k.npz
    # our venv: ngsgel's ramp on the same mesh (defaults, or --full-newton: reuse_factorisation=False)
    python scripts/peer_fenicsx_block.py --ngsgel 28k [--full-newton]

Each run prints one line: unknowns, converged steps, the ramp's time (predictors and Newton
solves, after the forms are built), Newton iterations (and ngsgel's chord steps), time per
iteration, and the end state's displacement at the top centre (0.5, 0.5, 0.2), its energy and
``int |u|^2`` (exact quadrature), to compare the two codes' results.

The FEniCSx ramp does what ``ngsgel.ramp`` and ``ngsgel.newton`` (``reuse_factorisation=False``)
do: the same energy (UFL derivative and Hessian of ``W(lam0 F', mu) / lam0^3``) with NGSolve's
default rule for it (the symmetric 4-point rule of degree 2, which is basix's default degree-2
rule: the same points); the tangent predictor for the first step (kept if admissible and better),
secant predictors after it (kept if admissible); Newton converged when the free residual is at
most 1e-11 of the largest seen in the solve, or a full step moves no dof by more than 1e-13; a
backtracking line search until admissible (``J > 1`` at the energy's points) and
``|r| <= (1 - 1e-4 alpha) |r_old|``; the linear solve: PETSc ``preonly`` with a Cholesky (LDL^T,
MUMPS symmetric) factorisation, refactorised numerically every iteration. Not mirrored:
ngsgel's absolute floor ``residual_floor``, its round-off estimate, which ends some of its steps
(criterion "floor") before the relative test would; and the residual norms are of
different bases (NGSolve's hierarchical P2 against Lagrange P2). So the two codes' iteration
counts may differ by the odd iteration.
"""
from __future__ import annotations

import argparse
import json
import os
import sys
import time

import numpy as np

TOP_CENTRE = (0.5, 0.5, 0.2)
RTOL, XTOL, MAXIT, MIN_STEP = 1e-11, 1e-13, 30, 2.0**-12  # ngsgel.newton's defaults


def report(result: dict) -> None:
    parts = ", ".join(f"{k[:-2]} {t:.1f}s" for k, t in result.items()
                      if k.endswith("_s") and k not in ("ramp_s", "cpu_s"))
    chords = f" + {result['chord_steps']} chord steps" if result.get("chord_steps") else ""
    u_top = ", ".join(f"{c:.12e}" for c in result["u_top"])
    print(f"{result['code']}: {result['ndof']} unknowns, {result['steps']}/20 steps, ramp {result['ramp_s']:.2f}s "
          f"(CPU {result['cpu_s']:.2f}s), {result['iterations']} iterations{chords}, "
          f"{result['ramp_s'] / result['iterations']:.3f}s per iteration ({parts}); u(top centre) = ({u_top}), "
          f"energy {result['energy']:.15e}, int |u|^2 {result['u_squared']:.15e}", flush=True)
    print(json.dumps(result), flush=True)


# --------------------------------------------------------------- our venv: mesh and ngsgel's run
def export(size: str, out: str) -> None:
    import ngsolve as ngs
    import bench_newton as bn

    prob = bn.issue35_problem(bn.ISSUE35_SIZES[size], "auto")
    mesh = prob.mesh
    points = np.array([v.point for v in mesh.vertices])
    tets = np.array([[v.nr for v in el.vertices] for el in mesh.Elements(ngs.VOL)], dtype=np.int64)
    bottom = sorted({v.nr for el in mesh.Elements(ngs.BND) if el.mat == "bottom" for v in el.vertices})
    np.savez(out, points=points, tets=tets, bottom=np.array(bottom, dtype=np.int64), ndof=prob.space.ndof,
             Nv=bn.ISSUE35_GEL.Nv, chi=bn.ISSUE35_GEL.chi, lam0=prob.lam0, mu0=prob.mu.Get(),
             mu_values=np.array(bn.issue35_mu_values()))
    print(f"{size}: {len(points)} vertices, {len(tets)} tetrahedra, {len(bottom)} bottom vertices, "
          f"{prob.space.ndof} unknowns -> {out}")


def ngsgel_ramp(size: str, full_newton: bool) -> None:
    import ngsolve as ngs
    import bench_newton as bn
    from ngsgel import RampError, ramp, set_threads
    from ngsgel.newton import total_work

    prob = bn.issue35_problem(bn.ISSUE35_SIZES[size], "auto")
    # one thread for NGSolve and every BLAS/OpenMP pool loaded by now (MKL with the problem's
    # solver): with the pools at their default, idle OpenMP threads spun for 25 % more CPU time
    # than wall time at 28k, with the same wall time
    set_threads(1)
    cpu_started = time.process_time()
    try:  # as bench_newton.issue35_ramp, keeping the problem for its end state
        result = ramp(prob, prob.mu, values=bn.issue35_mu_values(), strict=True,
                      newton_options={"reuse_factorisation": False} if full_newton else {})
    except RampError as err:
        result = err.result
        print(f"  FAILED: {err}", flush=True)
    cpu_s = time.process_time() - cpu_started
    work = total_work(w for step in result.records for w in step.records)
    u = prob.displacement
    report({"code": "ngsgel " + ("full Newton" if full_newton else "defaults"), "ndof": prob.space.ndof,
            "steps": result.steps, "ramp_s": work.total, "cpu_s": cpu_s,
            "iterations": sum(n.iterations for n in result.newton),
            "chord_steps": sum(n.chord_steps for n in result.newton),
            "criteria": sorted({n.criterion for n in result.newton}),
            **{f"{part}_s": getattr(work, part) for part in ("assembly", "factorisation", "solve", "residual",
                                                            "admissibility", "line_search")},
            "u_top": list(u(prob.mesh(*TOP_CENTRE))), "energy": prob.energy(),
            "u_squared": ngs.Integrate(ngs.InnerProduct(u, u), prob.mesh, order=4)})


# ------------------------------------------------------------ system Python: dolfinx 0.5 and MUMPS
def fenicsx_ramp(path: str) -> None:
    for var in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ[var] = "1"  # before the libraries load: MUMPS and BLAS on one thread
    from mpi4py import MPI
    from petsc4py import PETSc
    import ufl
    import dolfinx
    import dolfinx.fem.petsc
    import dolfinx.geometry

    if MPI.COMM_WORLD.size != 1:
        raise SystemExit("--fenicsx runs on one MPI rank")
    data = np.load(path)
    domain = ufl.Mesh(ufl.VectorElement("Lagrange", ufl.tetrahedron, 1))
    mesh = dolfinx.mesh.create_mesh(MPI.COMM_SELF, data["tets"], data["points"], domain)
    V = dolfinx.fem.VectorFunctionSpace(mesh, ("Lagrange", 2))
    bottom = {tuple(p) for p in data["points"][data["bottom"]]}  # coordinates pass through unchanged
    facets = dolfinx.mesh.locate_entities_boundary(mesh, 2, lambda x: np.array([tuple(p) in bottom for p in x.T]))
    bcs = [dolfinx.fem.dirichletbc(np.zeros(3, dtype=PETSc.ScalarType),
                                   dolfinx.fem.locate_dofs_topological(V, 2, facets), V)]
    ndof = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
    if ndof != int(data["ndof"]):
        raise SystemExit(f"{ndof} unknowns against ngsgel's {int(data['ndof'])}: not the same space")

    u, v, du = dolfinx.fem.Function(V), ufl.TestFunction(V), ufl.TrialFunction(V)
    mu = dolfinx.fem.Constant(mesh, PETSc.ScalarType(data["mu0"]))
    Nv, chi, lam0 = (float(data[k]) for k in ("Nv", "chi", "lam0"))
    dx = ufl.dx(metadata={"quadrature_degree": 2})  # NGSolve's default for this energy (see the top)
    Fp = ufl.Identity(3) + ufl.grad(u)
    J = lam0**3 * ufl.det(Fp)
    W = (Nv / 2 * (lam0**2 * ufl.inner(Fp, Fp) - 3 - 2 * ufl.ln(J)) + (J - 1) * ufl.ln(1 - 1 / J) - chi / J
         - mu * (J - 1)) / lam0**3
    residual_ufl = ufl.derivative(W * dx, u, v)
    energy_form, residual_form = dolfinx.fem.form(W * dx), dolfinx.fem.form(residual_ufl)
    tangent_form = dolfinx.fem.form(ufl.derivative(residual_ufl, u, du))
    outside_form = dolfinx.fem.form(ufl.conditional(ufl.gt(J, 1), 0.0, 1.0) * dx)
    A = dolfinx.fem.petsc.create_matrix(tangent_form)
    r = dolfinx.fem.petsc.create_vector(residual_form)
    step = r.duplicate()
    ksp = PETSc.KSP().create(MPI.COMM_SELF)
    ksp.setOperators(A)
    ksp.setType("preonly")
    ksp.getPC().setType("cholesky")
    ksp.getPC().setFactorSolverType("mumps")
    x = u.x.array  # the state, a view

    seconds = dict.fromkeys(("assembly", "factorisation", "solve", "residual", "admissibility"), 0.0)

    def timed(part: str, operation):
        start = time.perf_counter()
        value = operation()
        seconds[part] += time.perf_counter() - start
        return value

    def admissible() -> bool:
        return timed("admissibility", lambda: dolfinx.fem.assemble_scalar(outside_form)) == 0.0

    def assemble_residual() -> float:
        with r.localForm() as local:
            local.set(0.0)
        dolfinx.fem.petsc.assemble_vector(r, residual_form)
        dolfinx.fem.petsc.set_bc(r, bcs)  # zero at the bonded dofs (x is zero there)
        return r.norm()

    def residual() -> float:
        """The free residual at ``x`` into ``r``; its norm."""
        return timed("residual", assemble_residual)

    def assemble_tangent() -> None:
        A.zeroEntries()
        dolfinx.fem.petsc.assemble_matrix(A, tangent_form, bcs=bcs)
        A.assemble()

    def factor() -> None:
        timed("assembly", assemble_tangent)
        ksp.setOperators(A)  # marks the operator changed: KSPSetUp alone skips a set-up KSP
        timed("factorisation", ksp.setUp)  # numeric factorisation (analysis at the first)

    def solve() -> np.ndarray:
        timed("solve", lambda: ksp.solve(r, step))
        return step.array

    def newton() -> int:
        rnorm = residual()
        r_max = rnorm
        for it in range(MAXIT + 1):
            if rnorm <= RTOL * r_max:
                return it
            if it == MAXIT:
                break
            factor()
            dx = -solve()
            old, old_norm, step_max, alpha = x.copy(), rnorm, np.abs(dx).max(), 1.0
            while True:
                x[:] = old + alpha * dx
                if admissible():
                    rnorm = residual()
                    if alpha * step_max <= XTOL or rnorm <= (1 - 1e-4 * alpha) * old_norm or rnorm <= RTOL * r_max:
                        break
                alpha *= 0.5
                if alpha < MIN_STEP:
                    raise RuntimeError(f"line search failed at iteration {it + 1} (residual {old_norm:.3e})")
            r_max = max(r_max, rnorm)
            if alpha == 1.0 and step_max <= XTOL:
                return it + 1
        raise RuntimeError(f"no convergence in {MAXIT} iterations (residual {rnorm:.3e})")

    iterations, previous = 0, None
    value = float(data["mu0"])
    started, cpu_started = time.perf_counter(), time.process_time()
    for new in map(float, data["mu_values"]):
        state = x.copy()
        if previous is None:  # tangent predictor from the converged start, kept if admissible and better
            factor()
            mu.value = new
            start_norm = residual()
            start_energy = dolfinx.fem.assemble_scalar(energy_form)
            x[:] = state - solve()
            if not (admissible() and (residual() < start_norm
                                      or dolfinx.fem.assemble_scalar(energy_form) < start_energy)):
                x[:] = state
        else:  # secant predictor, kept if admissible
            mu.value = new
            x[:] = state + (new - value) / (value - previous[0]) * (state - previous[1])
            if not admissible():
                x[:] = state
        iterations += newton()
        previous, value = (value, state), new
    ramp_s, cpu_s = time.perf_counter() - started, time.process_time() - cpu_started

    points = np.array([TOP_CENTRE])
    tree = dolfinx.geometry.BoundingBoxTree(mesh, 3)
    cells = dolfinx.geometry.compute_colliding_cells(mesh, dolfinx.geometry.compute_collisions(tree, points), points)
    u_squared = dolfinx.fem.form(ufl.inner(u, u) * ufl.dx(metadata={"quadrature_degree": 4}))
    report({"code": "FEniCSx " + dolfinx.__version__ + " MUMPS", "ndof": ndof, "steps": len(data["mu_values"]),
            "ramp_s": ramp_s, "cpu_s": cpu_s, "iterations": iterations, **{f"{k}_s": t for k, t in seconds.items()},
            "u_top": [float(c) for c in u.eval(points, cells.links(0)[:1])],
            "energy": dolfinx.fem.assemble_scalar(energy_form),
            "u_squared": dolfinx.fem.assemble_scalar(u_squared)})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    mode = parser.add_mutually_exclusive_group(required=True)
    mode.add_argument("--export", nargs=2, metavar=("SIZE", "OUT.npz"), help="our venv: write the mesh")
    mode.add_argument("--fenicsx", metavar="MESH.npz", help="system Python with dolfinx 0.5: the ramp")
    mode.add_argument("--ngsgel", metavar="SIZE", help="our venv: ngsgel's ramp")
    parser.add_argument("--full-newton", action="store_true", help="with --ngsgel: reuse_factorisation=False")
    args = parser.parse_args()
    if args.export:
        export(*args.export)
    elif args.fenicsx:
        fenicsx_ramp(args.fenicsx)
    else:
        ngsgel_ramp(args.ngsgel, args.full_newton)


if __name__ == "__main__":
    sys.exit(main())
