"""Nonlinear Kirchhoff–Love shell for thin gel walls in equilibrium with a homogeneous ``mu``.

Model
-----
The mesh is the mid-surface of the swollen reference (a 2D manifold in 3D, e.g.
``geometries.cap_midsurface``), thickness ``t`` in that reference. A material point at height
``zeta`` along the reference normal ``N`` moves to ``phi + zeta lever n`` (``phi = X + u`` the
deformed mid-surface, ``n`` its unit normal, ``lever`` the mean thickness stretch: the deformed
lever arm), and the thickness direction is stretched by ``lam3_q`` at the through-thickness point
``q``. The in-plane deformation gradient of the layer at ``zeta`` is exact for this kinematics,

    F_in(zeta) = (Fm + zeta lever Fm C^+ S) A(zeta)^-1,      A(zeta) = P + zeta grad N + N (x) N,

``Fm = P + grad_s u`` the mid-surface gradient, ``C = Fm^T Fm``, ``S = Fm^T grad_s n`` the deformed
curvature in reference coordinates, ``A`` the reference shifter. The 3D deformation gradient of
the layer is ``F_q = F_in(zeta_q) + lam3_q n (x) N`` and the energy per unit reference mid-surface
area is the gel's own energy (``material.reference_energy``, one formula) integrated through the
thickness by Gauss–Legendre quadrature with the reference volume element ``det A``:

    psi = t/2 sum_q w_q det A(zeta_q) W'(F_q, mu).

Plane stress is not imposed by a formula: each ``lam3_q`` is an unknown (an element-wise
polynomial, ``SurfaceL2``) and minimising the energy makes ``dW'/dlam3 = 0``, i.e. zero normal
stress at every through-thickness point (in the L2 sense of its space). Bending therefore comes
from the same energy: for small ``zeta S`` it is ``t^3/24 kappa : C_ps : kappa`` with the
plane-stress tangent moduli of the *current* membrane state (so a swollen or graded membrane
changes its bending stiffness consistently); two quadrature points integrate that leading term
exactly. Uniform dilation of a curved or flat reference is represented exactly (free swelling
of a shell is the closed form ``lam_free(mu)`` to round-off).

Discretisation (locking-free for thin walls)
--------------------------------------------
``u`` is continuous (``VectorH1``, order ``k >= 2``), so normals jump across element edges. The
curvature is distributional: inside elements it is ``S`` from the surface Hessian of ``u``; on
edges it is the jump of the normal angle, measured element by element against an averaged
reference normal (as in the HHJ shells of Neunteufel & Schöberl, Comput. Struct. 2024) and
shared through a hybrid rotation unknown on the edges (``NormalFacetSurface``, order ``k-1``).
Instead of a condensed moment field (a saddle point) the edge terms are a hybridised symmetric
interior penalty written as an energy,

    sum_T int_dT  m_mumu theta_T + (alpha D / 2h) theta_T^2,   theta_T = angle jump_T + omega . mu_T,

with ``m`` the element's bending moment: consistent (the exact solution has ``theta_T = 0`` and
the first variation gives the moment–rotation coupling of the distributional curvature), and the
whole Hessian stays symmetric positive definite at stable states, so the stability tools
(inertia, spectra) see the physical stability of the shell. By default ``m`` in the edge terms is
the linearised moment ``-t^3/12 C_ps(reference) : (S - |cof Fm N|^(1/2) grad N)`` (zero under
uniform dilation, exact in the linear range); ``consistent_moment=True`` uses ``-dpsi/dS`` of the
full energy instead, ~4x dearer to assemble (on the cap swelling benchmark the two differ by
0.03 %). There is no shear strain (Kirchhoff–Love), hence no shear locking as ``t -> 0``.

Boundary conditions: ``clamp`` (displacement and rotation), ``simply_support`` (displacement),
``symmetry`` (normal displacement and rotation), ``fix``/``prescribe`` (components),
``prescribe_region`` (a component on a whole surface region: a rigid indenter patch), free edges
by default; dead loads on surface regions, edge moments and point loads at mesh vertices, scaled
by ``Parameter`` s. The class implements the ``NonlinearSystem`` protocol of ``ngsgel.newton`` and
what ``ramp``, ``follow_path`` and ``ngsgel.stability`` use (``mass_matrix``, ``integrate``).

Limits: each element measures its normal angle against the averaged edge normal; past ~80
degrees of rotation against it ``acos`` degenerates, so runs with large rotations call
``update_edge_normals`` between load steps (a strip rolled to a quarter circle this way is exact
to 4e-5). Membrane locking of curved shells is not treated by Regge interpolation (order 3 gave
the Reissner point-load stiffness of a t/r = 0.005 cap to 0.4 %).

Cost: the energy's residual and tangent are evaluated by compiled C++ kernels (``kernels``,
``ngsgel.kernels``: the same energy, residual and tangent as the symbolic forms to round-off) or
by NGSolve's symbolic forms, whose tangent differentiates the through-thickness gel law with the
surface Hessian of ``u`` inside it twice at every point. One Newton iteration with a stability
check of the microlens half cap (h = 0.05, 0.01 on the apex patch, order 3: 1731 triangles,
51204 free unknowns; one thread, medians of 3; two runs, at load 0.6-0.9 and 1.5-2.6) took
1.96-2.57 s with the kernels against 16.3-17.1 s with the symbolic forms (8.7x and 6.3x): the
tangent 0.66-0.90 s against 13.3-14.1 s (21x and 15x), the residual 0.27-0.38 s against 1.57 s
(5.8x and 4.1x). The kernels' tangent is 2.4x their residual (the symbolic one 8.5-9x), and the
factorisation and negative count are now half of the iteration.
"""

from __future__ import annotations

import functools
import math
import operator
import warnings
from collections.abc import Sequence
from numbers import Real

import numpy as np
import ngsolve as ngs

from . import kernels as _kernels
from .linalg import resolve_inverse
from .materials import FloryRehnerGel, _check_lam0
from .newton import LinearSolver, NewtonResult, newton
from .problem import BuiltOnDemand, tangent_differentiated_once

__all__ = ["GelShell", "plate_bending_stiffness"]

_COMPONENTS = ("x", "y", "z")
KERNEL_CHOICES = ("auto", "compiled", "python")


def plate_bending_stiffness(material: FloryRehnerGel, *, lam0: float, thickness: float) -> float:
    """``D = E t^3 / (12 (1 - nu^2)) = G t^3 / (6 (1 - nu))`` of a free-swollen gel plate at fixed
    ``mu`` (drained: ``E = 2 G (1 + nu)`` with ``nu = drained_poisson_ratio``; note that
    ``youngs_modulus`` is the undrained ``3 G``)."""
    if not isinstance(thickness, Real) or not thickness > 0:
        raise ValueError(f"thickness must be a number > 0, got {thickness!r}")
    G = material.shear_modulus(lam0)
    nu = material.drained_poisson_ratio(lam0)
    return G * thickness**3 / (6.0 * (1.0 - nu))


def _normalize(v):
    return v / ngs.Norm(v)


class GelShell(BuiltOnDemand):
    """Shell of a Flory–Rehner gel on a mid-surface mesh; see the module notes.

    ``mesh``: surface mesh in 3D (regions are ``mesh.Boundaries``, edges ``mesh.BBoundaries``);
    ``lam0``: stretch of the reference from the dry state; ``thickness``: reference thickness;
    ``mu``: number (held in the ``Parameter`` ``self.mu``); ``order``: displacement order
    (>= 2); ``thickness_points``: Gauss points through the thickness (>= 2); ``penalty``:
    dimensionless interior-penalty factor (> 0, scaled by ``order^2 D / h``); ``kernels``: how
    the energy's residual and tangent are evaluated: ``"compiled"`` by the C++ kernels of
    ``ngsgel.kernels`` (compiled at first use into a per-user cache, ~25 s once per machine and
    NGSolve version; raises ``KernelsUnavailable`` when they cannot be built, and ``ValueError``
    for options they do not cover: ``thickness_points != 2``, ``consistent_moment=True``,
    ``realcompile=True``), ``"python"`` by NGSolve's symbolic forms of the same energy (the
    reference model), ``"auto"`` compiled where they build and cover the options, else Python
    with a warning giving the reason; surface loads and edge moments are symbolic terms in
    either case. ``realcompile``: compile the Python forms' energy and first derivative to C++
    for the residual (needs a compiler, ~20 s; the residual 2x faster; the tangent is
    interpreted either way). Pointless with the kernels, whose residual is 4x faster than the
    interpreted one: asking for it asks for the Python forms (an error with
    ``kernels="compiled"``, the Python forms with a warning under ``"auto"``).
    ``inverse``: the sparse factorisation, any of ``LinearSolver``'s. ``"auto"`` (the default):
    MKL PARDISO where installed (``ngsgel[pardiso]``), else UMFPACK. Both give results that are a
    function of the matrix alone (PARDISO in its reproducible mode for the thread count), which
    ``sparsecholesky`` on more than one thread does not (repeated factorisations of one matrix
    solve to results ~1e-15 apart: enough to send a run through a symmetric bifurcation to
    either of two mirror states). PARDISO's LDL^T also gives the tangent's inertia, so a path's
    stability check costs no second factorisation and its eigen solves reuse it; with the
    compiled kernels the factorisation is a large part of a Newton iteration (h = 0.05 half cap,
    49k unknowns: UMFPACK 0.45 s, a PARDISO refactorisation 0.09 s, the tangent 0.7 s).
    """

    # No chord steps with the stability check's factorisation at the start of a path step: they cut
    # the residual of the stiff (membrane) modes and leave the error in the soft bending mode that
    # the path is about to lose stability to, from which Newton then crawls with line-search cuts
    # (graded disk p = 2, h = 0.3, onset path with PARDISO: 537 Newton iterations and 231 s with
    # them, 3 iterations per step and 15.5 s without; the 3D thin solid of the same disk: no change)
    chord_start_after_check = False

    def __init__(self, mesh: ngs.Mesh, *, material: FloryRehnerGel, lam0: float, thickness: float,
                 mu: float = 0.0, order: int = 3, thickness_points: int = 2, penalty: float = 4.0,
                 consistent_moment: bool = False, inverse: str = "auto", realcompile: bool = False,
                 kernels: str = "auto"):
        if mesh.dim != 3 or mesh.ne != 0 or mesh.nface == 0:
            raise ValueError("mesh must be a surface mesh in 3D (a mid-surface: no volume elements)")
        if not isinstance(material, FloryRehnerGel):
            raise ValueError(f"material must be a FloryRehnerGel, got {type(material).__name__}")
        _check_lam0(lam0)
        if not isinstance(thickness, Real) or not (0 < thickness < math.inf):
            raise ValueError(f"thickness must be a finite number > 0, got {thickness!r}")
        if not isinstance(order, int) or order < 2:
            raise ValueError(f"order must be an integer >= 2 (curvature needs second derivatives), got {order!r}")
        if not isinstance(thickness_points, int) or thickness_points < 2:
            raise ValueError(f"thickness_points must be an integer >= 2 (bending needs two layers), got {thickness_points!r}")
        if not isinstance(penalty, Real) or not penalty > 0:
            raise ValueError(f"penalty must be a number > 0, got {penalty!r}")
        if not isinstance(mu, Real) or not math.isfinite(mu):
            raise ValueError(f"mu must be a finite number, got {mu!r}")
        if isinstance(material.Nv, Real):
            material.lam_free(float(mu))  # raises ValueError naming mu and its range
        self.mesh = mesh
        self.material = material
        self.lam0 = float(lam0)
        self.thickness = float(thickness)
        self.order = order
        self.penalty = float(penalty)
        self.inverse = resolve_inverse(inverse, fallback="umfpack")
        self.consistent_moment = bool(consistent_moment)
        if not isinstance(realcompile, bool):
            raise ValueError(f"realcompile must be True or False, got {realcompile!r}")
        self.realcompile = realcompile
        if kernels not in KERNEL_CHOICES:
            raise ValueError(f"kernels must be one of {KERNEL_CHOICES}, got {kernels!r}")
        self.kernels = kernels
        self._kernel_gaps = self._options_kernels_lack(thickness_points)
        if kernels == "compiled" and self._kernel_gaps:
            raise ValueError(f"kernels='compiled' does not cover {'; '.join(self._kernel_gaps)}: "
                             f"use kernels='python' (or 'auto', which falls back to it)")
        self._compiled_kernels_used = None
        self.mu = ngs.Parameter(float(mu))
        xi, wq = np.polynomial.legendre.leggauss(thickness_points)
        self._layers = [(0.5 * self.thickness * float(a), float(b)) for a, b in zip(xi, wq)]
        self._fixed: dict[str, list[str]] = {c: [] for c in _COMPONENTS}
        self._rotation_fixed: list[str] = []
        self._prescribed: list[tuple[str, int, ngs.CoefficientFunction]] = []
        self._region_prescribed: list[tuple[str, int, ngs.CoefficientFunction]] = []
        self._surface_loads: list[tuple[str, ngs.CoefficientFunction]] = []
        self._point_loads: list[tuple[np.ndarray, np.ndarray, ngs.Parameter | None]] = []
        self._edge_moments: list[tuple[str, ngs.CoefficientFunction]] = []
        self._point_constraints: list[tuple[int, int, float | ngs.Parameter]] = []  # vertex, component, value
        self._space = None
        self._form = None

    # ------------------------------------------------------------------ boundary conditions
    def _check_open(self) -> None:
        if self._space is not None:
            raise RuntimeError("boundary conditions and loads must be declared before the first solve")

    def _check_edge(self, boundary: str) -> None:
        names = set(self.mesh.GetBBoundaries())
        for part in boundary.split("|"):
            if part not in names:
                raise ValueError(f"unknown edge {part!r}; the mesh has boundary curves {sorted(names - {''})}")

    def _component(self, component: str) -> str:
        if component not in _COMPONENTS:
            raise ValueError(f"component must be one of {_COMPONENTS}, got {component!r}")
        return component

    def fix(self, boundary: str, components: Sequence[str] | str = _COMPONENTS) -> None:
        """Zero displacement components on the boundary curve(s) ``boundary`` ('a|b')."""
        self._check_open()
        self._check_edge(boundary)
        for c in ([components] if isinstance(components, str) else components):
            self._fixed[self._component(c)].append(boundary)

    def fix_rotation(self, boundary: str) -> None:
        """No rotation about the edge: the edge's normal angle keeps its reference value."""
        self._check_open()
        self._check_edge(boundary)
        self._rotation_fixed.append(boundary)

    def clamp(self, boundary: str) -> None:
        self.fix(boundary)
        self.fix_rotation(boundary)

    def simply_support(self, boundary: str) -> None:
        self.fix(boundary)

    def symmetry(self, boundary: str, *, normal: str) -> None:
        """Symmetry plane with normal along axis ``normal``: that displacement component and the
        rotation about the edge vanish."""
        self.fix(boundary, normal)
        self.fix_rotation(boundary)

    def prescribe(self, boundary: str, component: str, value) -> None:
        """Displacement ``component`` equals ``value`` (number or CoefficientFunction, e.g. with a
        ``Parameter``) on the boundary curve(s) ``boundary``."""
        self.fix(boundary, component)
        cf = value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(float(value))
        self._prescribed.append((boundary, _COMPONENTS.index(component), cf))

    def prescribe_region(self, region: str, component: str, value) -> None:
        """Displacement ``component`` equals ``value`` (number or CoefficientFunction, e.g. with a
        ``Parameter``) on the whole surface region(s) ``region``: a rigid indenter patch (the
        solid models' prescribed apex face); ``ngsgel.stability.conjugate_force`` gives its
        force."""
        self._check_open()
        if not any(self.mesh.Boundaries(region).Mask()):
            raise ValueError(f"region {region!r} matches no surface region; the mesh has {sorted(set(self.mesh.GetBoundaries()))}")
        cf = value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(float(value))
        self._region_prescribed.append((region, _COMPONENTS.index(self._component(component)), cf))

    def add_surface_load(self, region: str, load) -> None:
        """Dead load per unit reference area (3-vector, numbers or CoefficientFunctions) on the
        surface region(s) ``region`` ('.*' for all)."""
        self._check_open()
        if not any(self.mesh.Boundaries(region).Mask()):
            raise ValueError(f"region {region!r} matches no surface region; the mesh has {sorted(set(self.mesh.GetBoundaries()))}")
        cf = load if isinstance(load, ngs.CoefficientFunction) else ngs.CF(tuple(load))
        if cf.dim != 3:
            raise ValueError(f"load must have 3 components, got {cf.dim}")
        self._surface_loads.append((region, cf))

    def add_edge_moment(self, boundary: str, moment) -> None:
        """Dead bending moment per unit reference length (number or CoefficientFunction, e.g.
        with a ``Parameter``) on the free boundary curve(s) ``boundary``: work-conjugate to the
        edge's rotation about its tangent, positive turning the element normal towards the
        outward co-normal."""
        self._check_open()
        self._check_edge(boundary)
        cf = moment if isinstance(moment, ngs.CoefficientFunction) else ngs.CF(float(moment))
        self._edge_moments.append((boundary, cf))

    def _vertex(self, point: Sequence[float]) -> int:
        coords = np.array([v.point for v in self.mesh.vertices])
        dist = np.linalg.norm(coords - np.asarray(point, dtype=float), axis=1)
        vertex = int(np.argmin(dist))
        if dist[vertex] > 1e-8 * max(1.0, float(np.ptp(coords))):
            raise ValueError(f"point {tuple(point)} is not a mesh vertex (nearest is {dist[vertex]:.3g} away)")
        return vertex

    def add_point_load(self, point: Sequence[float], force: Sequence[float], *,
                       scale: ngs.Parameter | None = None) -> None:
        """Concentrated dead force ``scale * force`` at the mesh vertex at ``point`` (must be a
        vertex within 1e-8 of the mesh size)."""
        self._check_open()
        force = np.asarray(force, dtype=float)
        if force.shape != (3,) or not np.all(np.isfinite(force)):
            raise ValueError(f"force must be 3 finite numbers, got {force!r}")
        self._point_loads.append((np.array([self._vertex(point)]), force, scale))

    def prescribe_point(self, point: Sequence[float], component: str, value: float | ngs.Parameter) -> None:
        """Displacement ``component`` of the mesh vertex at ``point`` equals ``value`` (a number or
        a ``Parameter``, e.g. an indentation depth); ``reaction`` gives the force it takes."""
        self._check_open()
        if not isinstance(value, (Real, ngs.Parameter)):
            raise ValueError(f"value must be a number or a Parameter, got {type(value).__name__}")
        self._point_constraints.append((self._vertex(point), _COMPONENTS.index(self._component(component)), value))

    def reaction(self, point: Sequence[float], component: str) -> float:
        """Force the constraint at the vertex at ``point`` exerts on the shell in ``component``
        (minus the internal force there; equals an applied point load at equilibrium)."""
        self.form
        dof = self._vertex_dofs(self._vertex(point))[_COMPONENTS.index(self._component(component))]
        r = self.state.CreateVector()
        self._residual_form.Apply(self.state, r)
        return float(r[dof])

    def _vertex_dofs(self, vertex: int) -> np.ndarray:
        V = self._space.components[0]
        return np.array(V.GetDofNrs(ngs.NodeId(ngs.VERTEX, vertex))) + self._space.Range(0).start

    # ------------------------------------------------------------------ spaces and forms
    @property
    def space(self) -> ngs.FESpace:
        if self._space is None:
            self._build()
        return self._space

    def _build(self) -> None:
        mesh, k = self.mesh, self.order
        flags = {f"dirichlet{c}_bbnd": "|".join(b) for c, b in self._fixed.items() if b}
        for c in _COMPONENTS:  # surface regions are the mesh's BND elements
            regions = [region for region, i, _ in self._region_prescribed if _COMPONENTS[i] == c]
            if regions:
                flags[f"dirichlet{c}"] = "|".join(regions)
        V = ngs.VectorH1(mesh, order=k, **flags)
        W = ngs.NormalFacetSurface(mesh, order=k - 1, dirichlet_bbnd="|".join(self._rotation_fixed))
        L = ngs.SurfaceL2(mesh, order=k - 1)
        self._space = ngs.FESpace([V, W] + [L] * len(self._layers))
        self.gf = ngs.GridFunction(self._space, name="shell")
        self.gf.components[0].vec[:] = 0.0
        for i in range(len(self._layers)):
            self.gf.components[2 + i].Set(1.0, definedon=mesh.Boundaries(".*"))
        # Averaged reference normals on edges: the common direction against which each element
        # measures its normal angle (it must lie between the normals of the two neighbours).
        self._avg_normal = ngs.GridFunction(ngs.VectorFacetSurface(mesh, order=k - 1))
        self._avg_normal.Set(ngs.specialcf.normal(3), dual=True, definedon=mesh.Boundaries(".*"))
        self._avg_normal_ref = ngs.GridFunction(self._avg_normal.space)
        self._avg_normal_ref.vec.data = self._avg_normal.vec

        trial = self._space.TrialFunction()
        u, omega, lams = trial[0], trial[1].Trace(), list(trial[2:])
        external = []  # minus the work of the dead surface loads and edge moments
        for region, load in self._surface_loads:
            external.append(-ngs.InnerProduct(load, u) * ngs.ds(definedon=mesh.Boundaries(region)))
        for boundary, moment in self._edge_moments:
            # the hybrid unknown is (minus) the edge rotation; an indicator of the curve restricts
            # the element-boundary integral to it
            on_curve = ngs.GridFunction(ngs.FacetSurface(mesh, order=0))
            on_curve.Set(1.0, definedon=mesh.BBoundaries(boundary))
            mu_ref = ngs.Cross(ngs.specialcf.normal(3), ngs.specialcf.tangential(3))
            external.append(on_curve * moment * (omega * mu_ref) * ngs.ds(element_boundary=True))
        form = ngs.BilinearForm(self._space, symmetric=True)
        kernel_module = self._load_kernels()
        if kernel_module is not None:
            for integrator in self._kernel_integrators(kernel_module, trial):
                form += integrator
            energy = functools.reduce(operator.add, external) if external else None
        else:
            kin = self._kinematics(u, lams)
            energy = functools.reduce(operator.add, external, kin["psi"] * ngs.ds
                                      + self._edge_energy(u, omega, kin) * ngs.ds(element_boundary=True))
        if energy is not None:
            # The tangent's blocks are differentiated symbolically once (NGSolve's "uses_diff"
            # integrators), interpreted: as fast as C++-compiled forward-mode differentiation at
            # every point, without compiling second derivatives (~10 of a compiled form's ~30 s;
            # compiling the differentiated blocks themselves takes over 10 minutes).
            with tangent_differentiated_once():
                form += ngs.Variation(energy).Compile()  # a flat list of steps: shared subexpressions once
        self._form = form
        self._residual_form = form
        # ``realcompile`` compiles the energy and its first derivative only, for the residual: 2x
        # faster than interpreted
        if self.realcompile:
            compiled = [integral.coef.Compile(realcompile=True, maxderiv=1, wait=True) * integral.symbol
                        for integral in energy]
            self._residual_form = ngs.BilinearForm(self._space, symmetric=True)
            self._residual_form += ngs.Variation(functools.reduce(operator.add, compiled))
        self._scratch = ngs.GridFunction(self._space)
        self._target = ngs.GridFunction(self._space)
        free = self._space.FreeDofs()  # the space's own mask: solvers built from it see the points
        for vertex, component, _ in self._point_constraints:
            free.Clear(int(self._vertex_dofs(vertex)[component]))
        self.free_mask = np.array(list(free), dtype=bool)
        self._solver = LinearSolver(self._space.FreeDofs(), inverse=self.inverse)
        skin = self._kinematics(self._scratch.components[0], list(self._scratch.components[2:]))
        bad = sum(ngs.IfPos(m, 0.0, 1.0) for m in skin["margins"])
        self._indicator = bad.Compile()  # evaluated at every line-search trial point
        state = self._state_kinematics()
        self._volume = state["volume"].Compile()  # a path's quantity at every state
        self._reference_volume = ngs.Integrate(state["reference_volume"], mesh, ngs.BND, order=2 * k + 2)
        self._point_dofs = []
        for vertices, force, scale in self._point_loads:
            self._point_dofs.append((self._vertex_dofs(int(vertices[0])), force, scale))

    def _kinematics(self, u, lams) -> dict:
        """Layer deformation gradients, energy density and moments of displacement ``u`` and
        thickness stretches ``lams`` (trial functions or GridFunctions)."""
        N = ngs.specialcf.normal(3)
        NN = ngs.OuterProduct(N, N)
        P = ngs.Id(3) - NN
        grad_u = ngs.Grad(u).Trace() if isinstance(u, ngs.comp.ProxyFunction) else ngs.Grad(u)
        Fm = P + grad_u
        cof_N = ngs.Cof(Fm) * N
        n = _normalize(cof_N)
        C = Fm.trans * Fm
        C_plus = ngs.Inv(C + NN) - NN
        hesse = u.Operator("hesseboundary")
        H_n = P * ngs.Sym((hesse.trans * n).Reshape((3, 3))) * P
        # the shape operator and the Hessian are tangential and symmetric; NGSolve's curved-element
        # values carry small normal parts (numerical differentiation of the element map) that
        # would strain the thickness column of a uniformly dilated shell
        weingarten = P * ngs.Sym(ngs.Grad(N)) * P
        S = (n * N) * weingarten - H_n  # Fm^T grad_s n
        lever = sum(lams) / len(lams)
        bend_map = Fm * C_plus  # d(layer gradient)/dS, up to zeta lever and A^-1
        mu, lam0, mat = self.mu, self.lam0, self.material
        psi = ngs.CF(0.0)
        dpsi_dS = ngs.CF((0.0,) * 9, dims=(3, 3))
        membrane = ngs.CF((0.0,) * 9, dims=(3, 3))
        # Curvature change that vanishes under uniform dilation (S = lam grad N, |cof Fm N| = lam^2)
        # and is linear in u about the reference: the argument of the linearised edge moment.
        curvature_change = S - ngs.sqrt(ngs.Norm(cof_N)) * weingarten
        linear_moment = -self.thickness**3 / 12 * self._plane_stress(curvature_change, P)
        margins = []
        cauchy = []
        volume = ngs.CF(0.0)
        reference_volume = ngs.CF(0.0)
        for (zeta, w), lam3 in zip(self._layers, lams):
            A = P + zeta * weingarten + NN
            A_inv = ngs.Inv(A)
            weight = 0.5 * self.thickness * w * ngs.Det(A)
            reference_volume = reference_volume + weight
            Fq = (Fm + zeta * lever * bend_map * S) * A_inv + lam3 * ngs.OuterProduct(n, N)
            psi = psi + weight * mat.reference_energy(Fq, mu, lam0)
            piola = mat.first_piola(lam0 * Fq, mu) / lam0**2  # dW'/dF of the swollen reference
            dpsi_dS = dpsi_dS + weight * zeta * lever * bend_map.trans * piola * A_inv.trans
            membrane = membrane + weight * piola * A_inv.trans
            margins.append(lam0**3 * ngs.Det(Fq) - 1.0)
            volume = volume + weight * ngs.Det(Fq)
            cauchy.append(mat.reference_cauchy(Fq, mu, lam0))
        return dict(psi=psi, moment=-dpsi_dS, linear_moment=linear_moment, membrane=membrane, Fm=Fm, n=n, N=N, lever=lever,
                    margins=margins, cauchy=cauchy, volume=volume, reference_volume=reference_volume)

    def _reference_moduli(self):
        """Drained shear modulus ``G`` and Poisson ratio ``nu`` of the reference state (numbers,
        or fields with a graded ``Nv``)."""
        Nv, chi, lam0 = self.material.Nv, self.material.chi, self.lam0
        J0 = lam0**3
        G = Nv / lam0
        K = Nv * (1 / J0 - 1 / (3 * lam0)) + 1 / (J0 * (J0 - 1)) - 2 * chi / J0**2
        return G, (3 * K - 2 * G) / (2 * (3 * K + G))

    def _plane_stress(self, strain, P):
        """Linearised drained plane-stress law of the reference state (local ``Nv``):
        ``2 G (eps + nu / (1 - nu) tr(eps) P)``."""
        G, nu = self._reference_moduli()
        return 2 * G * (strain + nu / (1 - nu) * ngs.Trace(strain) * P)

    def _edge_stiffness(self):
        """Interior-penalty stiffness of the edge angles, ``~ alpha k^2 D / h``."""
        G = self.material.Nv / self.lam0
        return self.penalty * self.order**2 * self.thickness**3 / 3.0 * G / ngs.specialcf.mesh_size

    def _edge_energy(self, u, omega, kin) -> ngs.CoefficientFunction:
        N = kin["N"]
        tau = ngs.specialcf.tangential(3)
        mu_ref = ngs.Cross(N, tau)  # outward co-normal of the element in the reference
        tau_def = _normalize(kin["Fm"] * tau)
        mu_def = ngs.Cross(kin["n"], tau_def)
        avg = self._avg_normal
        avg_def = _normalize(avg - (tau_def * avg) * tau_def)
        # both angles are measured in the plane normal to the edge (reference and deformed), so
        # a reference edge has theta = 0 exactly even where the averaged normal is not normal to it
        ref = self._avg_normal_ref
        avg_ref = _normalize(ref - (tau * ref) * tau)
        theta = ngs.acos(mu_def * avg_def) - ngs.acos(mu_ref * avg_ref) + omega * mu_ref
        moment = kin["moment"] if self.consistent_moment else kin["linear_moment"]
        m_nn = ngs.InnerProduct(moment * mu_ref, mu_ref)
        return m_nn * theta + 0.5 * self._edge_stiffness() * theta**2

    # ------------------------------------------------------------------ compiled kernels
    def _options_kernels_lack(self, thickness_points: int) -> list[str]:
        """The options of this shell that the compiled kernels do not implement."""
        gaps = []
        if thickness_points != _kernels.THICKNESS_POINTS:
            gaps.append(f"thickness_points={thickness_points} (they have {_kernels.THICKNESS_POINTS})")
        if self.consistent_moment:
            gaps.append("consistent_moment=True (they have the linearised edge moment)")
        if self.realcompile:
            gaps.append("realcompile=True (it compiles the Python forms' residual; the kernels' residual is "
                        "compiled already: pass realcompile=False)")
        return gaps

    def _load_kernels(self):
        """The compiled kernel module if this shell uses it, else None (the Python forms);
        ``kernels='auto'`` warns with the reason when it falls back."""
        if self.kernels == "python":
            reason = None
        elif self._kernel_gaps:
            reason = f"the compiled kernels do not cover {'; '.join(self._kernel_gaps)}"
        else:
            try:
                module = _kernels.load_shell_kernels()
            except _kernels.KernelsUnavailable as error:
                if self.kernels == "compiled":
                    raise
                reason = str(error)
            else:
                self._compiled_kernels_used = True
                return module
        if reason is not None:
            # warned from one place: Python's default filter then shows each reason once per process
            warnings.warn(f"GelShell(kernels='auto') uses the Python forms: {reason}", RuntimeWarning)
        self._compiled_kernels_used = False
        return None

    def _kernel_integrators(self, kernel_module, trial) -> list:
        """The area energy ``psi`` and the default edge energy as the compiled integrators. The
        geometry reaches them as CoefficientFunctions evaluated at every assembly: the
        ``Parameter`` ``mu``, a graded ``Nv`` and the averaged edge normals that
        ``update_edge_normals`` changes."""
        u = trial[0]
        grad_u, hesse = ngs.Grad(u).Trace(), u.Operator("hesseboundary")
        N = ngs.specialcf.normal(3)
        P = ngs.Id(3) - ngs.OuterProduct(N, N)
        weingarten = (P * ngs.Sym(ngs.Grad(N)) * P).Reshape((9,))
        area_geometry = ngs.CF((N, weingarten, ngs.CF(self.material.Nv), self.mu))
        area = kernel_module.ShellArea(grad=grad_u, hesse=hesse, lams=list(trial[2:]), geometry=area_geometry,
                                  thickness=self.thickness, lam0=self.lam0, chi=self.material.chi,
                                  zetas=[zeta for zeta, _ in self._layers], weights=[w for _, w in self._layers],
                                  elements=self.mesh.GetNE(ngs.BND))
        G, nu = self._reference_moduli()
        edge_geometry = ngs.CF((N, weingarten, ngs.specialcf.tangential(3), self._avg_normal, self._avg_normal_ref,
                                self._edge_stiffness(), ngs.CF(2 * G), ngs.CF(nu / (1 - nu))))
        edge = kernel_module.ShellEdge(grad=grad_u, hesse=hesse, omega=trial[1].Trace(), geometry=edge_geometry,
                                  thickness=self.thickness, elements=self.mesh.GetNE(ngs.BND))
        return [area, edge]

    @property
    def compiled_kernels(self) -> bool:
        """Whether the forms use the compiled kernels (builds the forms: with ``kernels='auto'``
        that is where the choice is made)."""
        self.form
        return self._compiled_kernels_used

    # ------------------------------------------------------------------ NonlinearSystem
    @property
    def displacement(self) -> ngs.GridFunction:
        return self.gridfunction.components[0]

    def _point_load_vector(self, out) -> None:
        values = out.FV().NumPy()
        values[:] = 0.0
        for dofs, force, scale in self._point_dofs:
            values[dofs] += (1.0 if scale is None else scale.Get()) * force

    def residual(self, x, out) -> None:
        self._residual_form.Apply(x, out)
        if self._point_dofs:
            f = out.CreateVector()
            self._point_load_vector(f)
            out.data -= f

    def tangent(self, x):
        self.form.AssembleLinearization(x)
        return self.form.mat

    def energy(self, x=None) -> float:
        x = self.state if x is None else x
        value = self._residual_form.Energy(x)
        if self._point_dofs:
            f = x.CreateVector()
            self._point_load_vector(f)
            value -= float(np.dot(f.FV().NumPy(), x.FV().NumPy()))
        return value

    def prescribed(self, out) -> None:
        self.form
        out[:] = 0.0
        target = self._target
        target.vec[:] = 0.0
        for boundary, i, value in self._prescribed:
            target.components[0].components[i].Set(value, ngs.BBND, definedon=self.mesh.BBoundaries(boundary))
        for region, i, value in self._region_prescribed:
            target.components[0].components[i].Set(value, ngs.BND, definedon=self.mesh.Boundaries(region))
        for vertex, component, value in self._point_constraints:
            target.vec[int(self._vertex_dofs(vertex)[component])] = value.Get() if isinstance(value, ngs.Parameter) else float(value)
        out.data = target.vec

    def admissible(self, x) -> bool:
        self._scratch.vec.data = x
        bad = ngs.Integrate(self._indicator, self.mesh, ngs.BND, order=2 * self.order + 2)
        return bool(bad == 0.0)

    @property
    def newton_xtol(self) -> float:
        """The residual has a round-off floor from the gel's membrane stresses (~eps t) that the
        thin walls' bending stiffness (~t^3) turns into displacement noise ~ eps / t^2: a
        displacement step below 1e-8 t is converged."""
        return max(1e-13, 1e-8 * self.thickness)

    def solve(self, **newton_options) -> NewtonResult:
        """Newton at the current parameter values; raises ``NewtonError`` on failure."""
        self.form
        newton_options.setdefault("xtol", self.newton_xtol)
        with ngs.TaskManager():
            return newton(self, self._solver, **newton_options)

    def update_edge_normals(self) -> None:
        """Average the current element normals on every edge whose rotation is free, as the
        direction the elements measure their normal angles against (the reference average is
        kept on rotation-fixed edges, where it encodes the clamp). Call between load steps
        when elements rotate by more than a few tens of degrees; the hybrid rotations absorb the
        change at the next solve. Rotation-equivariant: rotating the state rotates the averages."""
        self.form
        N = ngs.specialcf.normal(3)
        u = self.displacement
        current = _normalize(ngs.Cof(ngs.Id(3) - ngs.OuterProduct(N, N) + ngs.Grad(u)) * N)
        self._avg_normal.Set(current, dual=True, definedon=self.mesh.Boundaries(".*"))
        if self._rotation_fixed:
            space = self._avg_normal.space
            region = self.mesh.BBoundaries("|".join(self._rotation_fixed))
            for segment in region.Elements():
                for edge in segment.edges:
                    for dof in space.GetDofNrs(edge):
                        self._avg_normal.vec[dof] = self._avg_normal_ref.vec[dof]

    # ------------------------------------------------------------------ stability support
    def mass_matrix(self) -> ngs.BaseMatrix:
        """Gram matrix for eigenproblems: the displacement's L2 product per reference volume plus
        rotary-inertia-like terms (``t^3/12``) on the rotation and thickness unknowns, so the
        matrix is positive definite; the inertia of the tangent does not depend on it."""
        self.form
        trial, test = self._space.TnT()
        t = self.thickness
        form = ngs.BilinearForm(self._space, symmetric=True)
        form += t * ngs.InnerProduct(trial[0], test[0]) * ngs.ds
        form += t**3 / 12 * ngs.InnerProduct(trial[1].Trace(), test[1].Trace()) * ngs.ds(element_boundary=True)
        for a, b in zip(trial[2:], test[2:]):
            form += t**3 / 12 * a * b * ngs.ds
        form.Assemble()
        return form.mat

    def integrate(self, cf, *, region: str | None = None) -> float:
        """Integral over the reference shell volume of a field constant through the thickness
        (``t`` times the mid-surface integral)."""
        where = self.mesh.Boundaries(region if region is not None else ".*")
        return self.thickness * ngs.Integrate(cf, self.mesh, ngs.BND, definedon=where, order=2 * self.order + 2)

    # ------------------------------------------------------------------ outputs
    def _state_kinematics(self) -> dict:
        return self._kinematics(self.displacement, list(self.gf.components[2:]))

    def thickness_stretch(self) -> ngs.CoefficientFunction:
        """Mean thickness stretch from the reference (multiply by ``lam0`` for the dry state)."""
        lams = list(self.gf.components[2:])
        return sum(lams) / len(lams)

    def membrane_force(self) -> ngs.CoefficientFunction:
        """First-Piola membrane force per unit reference length: ``int P A^-T dzeta`` (3x3)."""
        return self._state_kinematics()["membrane"]

    def bending_moment(self) -> ngs.CoefficientFunction:
        """Bending moment per unit reference length, ``-dpsi/dS`` (tangential 3x3, reference frame)."""
        return self._state_kinematics()["moment"]

    def volume_ratio(self) -> float:
        """Current gel volume over that of the reference (the swollen, unloaded shell), both
        integrated through the thickness with the layer quadrature and the shifter ``det A``."""
        self.form
        return ngs.Integrate(self._volume, self.mesh, ngs.BND, order=2 * self.order + 2) / self._reference_volume

    def layer_cauchy(self, layer: int) -> ngs.CoefficientFunction:
        """Cauchy stress (3x3) at through-thickness point ``layer`` (0 = most negative zeta)."""
        if not 0 <= layer < len(self._layers):
            raise ValueError(f"layer must be in [0, {len(self._layers) - 1}], got {layer!r}")
        return self._state_kinematics()["cauchy"][layer]

    def fields(self) -> dict[str, ngs.CoefficientFunction]:
        """Named fields for VTK output."""
        N = self.membrane_force()
        return {"displacement": self.displacement, "thickness_stretch": self.thickness_stretch(),
                "membrane_trace": ngs.Trace(N), "moment_trace": ngs.Trace(self.bending_moment())}
