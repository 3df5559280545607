"""Equilibrium of gels and films: materials bound to mesh regions, boundary conditions, loads.

The problem owns the finite element space, the displacement and the energy form. It is a
``NonlinearSystem`` for ``ngsgel.newton`` and knows nothing of how its load parameters are
stepped. The computational reference is the mesh: for gels a swollen state ``lam0`` (MODEL.md
section 2), for films their stress-free bonded state.

Kinematics with an axial unknown (``GeneralizedPlaneStrain``, ``PolarGeneralizedPlaneStrain``)
make the space the product of the displacement space and a ``NumberSpace`` holding the axial
strain ``e`` (one global dof, the last one); ``displacement`` is then the first component of the
state, ``axial_stretch()`` is ``1 + e`` and ``parts(gf)`` splits any GridFunction of the space.
"""

from __future__ import annotations

import contextlib
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from numbers import Real

import numpy as np
import ngsolve as ngs

from .contact import SelfContact
from .kinematics import Kinematics
from .materials import FloryRehnerGel, Material, check_reference_stretch
from . import parallel
from .newton import FreeDofReductions, LinearSolver, NewtonResult, newton

__all__ = ["EquilibriumProblem", "GelBody"]


@dataclass
class _Prescribed:
    boundary: str
    component: int
    value: ngs.CoefficientFunction


def _as_cf(value) -> ngs.CoefficientFunction:
    return value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(value)


# A reference stretch from the dry state: one number or field for every gel region, or one per region.
Lam0 = float | ngs.CoefficientFunction | Mapping[str, float | ngs.CoefficientFunction]
_LAM0_FORMS = "a number >= 1, a scalar CoefficientFunction (a field) or a mapping region -> either"


def _reference_stretches(mesh: ngs.Mesh, materials: Mapping[str, Material], lam0: Lam0 | None
                         ) -> dict[str, float | ngs.CoefficientFunction]:
    """Each region's stretch of the mesh from the dry state: ``lam0`` (checked) in regions whose
    material has a swollen reference, 1 elsewhere (a film's mesh state is its stress-free state)."""
    swelling = sorted(name for name, mat in materials.items() if mat.swollen_reference)
    if lam0 is None:
        if swelling:
            raise ValueError(f"lam0 is required: regions {swelling} hold gels, whose mesh is a swollen state of "
                             f"the dry gel; give lam0 as {_LAM0_FORMS}")
        given = {}
    elif isinstance(lam0, Mapping):
        for name in lam0:
            if name not in materials:
                raise ValueError(f"lam0 names unknown region {name!r}; the mesh has regions {sorted(materials)}")
            if name not in swelling:
                raise ValueError(f"lam0 is given for region {name!r}, whose {type(materials[name]).__name__} is "
                                 f"stress-free in the mesh state; give lam0 for the gel regions {swelling} only")
        missing = [name for name in swelling if name not in lam0]
        if missing:
            raise ValueError(f"lam0 has no value for the gel regions {missing}; give one for every gel region")
        given = dict(lam0)
    else:
        given = {name: lam0 for name in swelling}
    stretches = {}
    for name in materials:
        value = check_reference_stretch(given.get(name, 1.0), what=f"lam0 of region {name!r}")
        if isinstance(value, ngs.CoefficientFunction):
            below = ngs.Integrate(ngs.IfPos(1.0 - value, 1.0, 0.0), mesh, definedon=mesh.Materials(name), order=6)
            if below > 0:
                raise ValueError(f"lam0 of region {name!r} is a field below 1 (drier than dry) somewhere in "
                                 f"the region; it must be >= 1 everywhere")
        stretches[name] = value
    return stretches


def quadrature_rules(order: int) -> dict:
    """The standard rule of ``order`` for every element type, for ``dx(intrules=...)``."""
    return {et: ngs.IntegrationRule(et, order) for et in
            (ngs.ET.SEGM, ngs.ET.TRIG, ngs.ET.QUAD, ngs.ET.TET, ngs.ET.PRISM, ngs.ET.HEX)}


@contextlib.contextmanager
def tangent_differentiated_once():
    """Forms built inside differentiate their energy's second derivative symbolically once, at
    construction (NGSolve's ``symbolic_integrator_uses_diff``), instead of by automatic
    differentiation at every quadrature point. The shell and EquilibriumProblem use it: on issue
    35's 28k block it gives the same tangent to 1e-15 relative in 0.17-0.19 s instead of
    0.25-0.26 s (one thread, best of 3)."""
    before = ngs.ngsglobals.symbolic_integrator_uses_diff
    ngs.ngsglobals.symbolic_integrator_uses_diff = True
    try:
        yield
    finally:
        ngs.ngsglobals.symbolic_integrator_uses_diff = before


class BuiltOnDemand:
    """A discrete problem whose forms and state (the GridFunction ``gf``) are built by
    ``_build()`` on first use, once its boundary conditions and loads are declared."""

    _form: ngs.BilinearForm | None = None

    @property
    def form(self) -> ngs.BilinearForm:
        if self._form is None:
            self._build()
        return self._form

    @property
    def gridfunction(self) -> ngs.GridFunction:
        self.form
        return self.gf

    @property
    def state(self) -> ngs.BaseVector:
        return self.gridfunction.vec

    def save_state(self) -> np.ndarray:
        return self.state.FV().NumPy().copy()

    def restore_state(self, saved: np.ndarray) -> None:
        self.state.FV().NumPy()[:] = saved

    def _build(self) -> None:  # pragma: no cover - interface
        raise NotImplementedError


class GelBody(BuiltOnDemand):
    """Mesh, kinematics, materials per region and the displacement space: what equilibrium and
    transient problems share. Boundary conditions must be declared before the space is built
    (the first access to ``space``). ``quadrature_order`` pins the rule of the energy
    integrals (NGSolve's default otherwise, which depends on the space and the integrand).

    ``lam0``: the stretch of the mesh from the dry state in the gel regions, each stress-free
    where it is in equilibrium with its own free swelling: one number for all of them, a field
    (a CoefficientFunction, e.g. a graded reference), or a mapping region -> number or field,
    e.g. a bilayer whose layers have different cross-link densities, each referenced at its own
    free swelling at a common ``mu0``::

        lam0={"top": soft.lam_free(mu0), "bottom": stiff.lam_free(mu0)}

    Kinematics act on the deformation from each region's reference (plane strain holds each
    region's out-of-plane stretch at its ``lam0``). Needed only with gel regions. ``lam0 = 1``
    is the dry body (e.g. a layer bonded dry): the undeformed mesh is then outside the
    admissible set ``J > 1`` (the mixing pressure is ``-inf`` at ``J = 1``), so set a swollen
    starting displacement before the first solve."""

    runs_distributed = False  # on an MPI-distributed mesh (ngsgel.parallel): set where a problem does

    def __init__(self, mesh: ngs.Mesh, *, kinematics: Kinematics,
                 materials: Mapping[str, Material] | Material, lam0: Lam0 | None = None, order: int = 2,
                 quadrature_order: int | None = None):
        if parallel.is_distributed(mesh) and not self.runs_distributed:
            raise ValueError(f"{type(self).__name__} does not run on a distributed mesh yet; EquilibriumProblem "
                             "and TransientProblem do (docs/parallel.md)")
        kinematics.check_mesh(mesh)
        if not isinstance(order, int) or order < 1:
            raise ValueError(f"order must be an integer >= 1, got {order!r}")
        regions = set(mesh.GetMaterials())
        if isinstance(materials, Material):
            materials = {name: materials for name in sorted(regions)}
        for name in materials:
            if name not in regions:
                raise ValueError(f"unknown region {name!r}; the mesh has regions {sorted(regions)}")
        missing = regions - set(materials)
        if missing:
            raise ValueError(f"regions {sorted(missing)} have no material; give one for every region")
        self.mesh = mesh
        self.kinematics = kinematics
        self.materials = dict(materials)
        self._lam0 = _reference_stretches(mesh, self.materials, lam0)
        values = list(self._lam0.values())
        uniform = all(isinstance(v, float) and v == values[0] for v in values)
        # lam0 over the whole mesh, for expressions not split by region (1 in films); a number where
        # every region shares it, so the forms stay those of a single reference
        self.lam0_field: float | ngs.CoefficientFunction = values[0] if uniform else mesh.MaterialCF(self._lam0)
        self.order = order
        self.quadrature_order = quadrature_order
        self._fixed: dict[int, list[str]] = {i: [] for i in range(len(kinematics.components))}
        self._prescribed: list[_Prescribed] = []
        self._surface_energies: list[tuple[str, Callable]] = []
        self._self_contacts: list[SelfContact] = []
        self._space = None

    # ---------------------------------------------------------- boundary conditions
    def _check_boundary(self, boundary: str) -> None:
        names = set(self.mesh.GetBoundaries())
        for part in boundary.split("|"):
            if part not in names:
                raise ValueError(f"unknown boundary {part!r}; the mesh has boundaries {sorted(names)}")

    def _components(self, components) -> list[int]:
        if components is None:
            return list(range(len(self.kinematics.components)))
        if isinstance(components, str):
            components = [components]
        return [self.kinematics.component_index(c) for c in components]

    def _check_open(self) -> None:
        if self._space is not None:
            raise RuntimeError("boundary conditions must be declared before the first solve")

    def fix(self, boundary: str, components=None) -> None:
        """Zero displacement of the given components (all by default) on ``boundary``."""
        self._check_open()
        self._check_boundary(boundary)
        for i in self._components(components):
            self._fixed[i].append(boundary)

    def prescribe(self, boundary: str, component: str, value) -> None:
        """Displacement component ``component`` equals ``value`` (a number or a
        CoefficientFunction, e.g. ``depth * load`` with a ``Parameter`` load) on ``boundary``."""
        self._check_open()
        self._check_boundary(boundary)
        (i,) = self._components(component)
        self._fixed[i].append(boundary)
        self._prescribed.append(_Prescribed(boundary, i, _as_cf(value)))

    def add_surface_energy(self, boundary: str, density: Callable) -> None:
        """Extra energy on ``boundary``: ``density(u)`` is a CoefficientFunction of the
        displacement (trial function) per unit reference boundary measure, e.g. a contact penalty
        (``ngsgel.contact``). It enters the u-equation of equilibrium and transient problems."""
        self._check_open()
        self._check_boundary(boundary)
        if not callable(density):
            raise ValueError(f"density must be a callable u -> CoefficientFunction, got {type(density).__name__}")
        self._surface_energies.append((boundary, density))

    def add_self_contact(self, boundary: str, *, penalty: float, maxdist: float = 0.0, intorder: int = 4) -> None:
        """Penalty self-contact of ``boundary`` (``ngsgel.contact.SelfContact``): faces of it that
        meet, e.g. a crease closing anywhere along a free surface, do not pass through each other
        (beyond the penalty's penetration ``p / (2 k)`` at contact pressure ``p``). 2D meshes
        (plane strain, axisymmetric sections) only."""
        self._check_open()
        self._check_boundary(boundary)
        self._self_contacts.append(SelfContact(self.mesh, boundary, penalty=penalty, maxdist=maxdist,
                                               intorder=intorder))

    def _attach_self_contacts(self, form: ngs.BilinearForm, u, space: ngs.FESpace,
                              displacement_of: Callable[[ngs.GridFunction], ngs.GridFunction]) -> None:
        """Add the self-contact energies to ``form`` (``u``: the displacement trial function);
        ``displacement_of`` views the displacement of a GridFunction of ``space``."""
        self._contact_state = ngs.GridFunction(space) if self._self_contacts else None
        self._paired_state: np.ndarray | None = None  # the state the current pairs belong to
        for contact in self._self_contacts:
            contact.attach(form, u, self.kinematics.volume_weight())
        if self._self_contacts:
            self._contact_displacement = displacement_of(self._contact_state)

    def _update_self_contacts(self, x) -> None:
        """The self-contact pairs of the state ``x``: before every evaluation of the form there.
        Newton evaluates residual and tangent at the same state; the pairs are searched once per
        state (a new search also re-creates the matrix graph, so the tangent is re-allocated)."""
        if not self._self_contacts:
            return
        self.form  # built: the contact state exists
        values = x.FV().NumPy()
        if self._paired_state is not None and np.array_equal(values, self._paired_state):
            return
        self._contact_state.vec.data = x
        for contact in self._self_contacts:
            contact.update(self._contact_displacement)
        self._paired_state = values.copy()

    def with_surface_energies(self, energy, u):
        """``energy`` plus the surface energies declared with ``add_surface_energy``."""
        w = self.kinematics.volume_weight()
        rules = {} if self.quadrature_order is None else quadrature_rules(self.quadrature_order)
        for boundary, density in self._surface_energies:
            energy = energy + (w * density(u)) * ngs.ds(definedon=self.mesh.Boundaries(boundary), intrules=rules)
        return energy

    # ---------------------------------------------------------------- space, fields
    @property
    def space(self) -> ngs.FESpace:
        if self._space is None:
            if self.mesh.dim == 1:  # one radial component: a scalar space
                space = ngs.H1(self.mesh, order=self.order, dirichlet="|".join(self._fixed[0]))
            else:
                flags = {f"dirichlet{'xyz'[i]}": "|".join(b) for i, b in self._fixed.items() if b}
                space = ngs.VectorH1(self.mesh, order=self.order, **flags)
            # the axial strain: one global dof after the displacement dofs
            self._space = space * ngs.NumberSpace(self.mesh) if self.kinematics.axial_unknown else space
        return self._space

    def parts(self, gf):
        """``(displacement, axial strain)`` of a GridFunction (or trial/test function) of
        ``space``; the axial strain is None for kinematics without an axial unknown."""
        if self.kinematics.axial_unknown:
            u, axial = (gf.components if isinstance(gf, ngs.GridFunction) else gf)
            return u, axial
        return gf, None

    @property
    def axial_dof(self) -> int:
        """Number of the axial-strain dof (the last one); ValueError without an axial unknown.
        ``fix_dof(axial_dof)`` holds the axial stretch at its current value's target (1: plane
        strain)."""
        if not self.kinematics.axial_unknown:
            raise ValueError(f"kinematics {self.kinematics.name!r} has no axial unknown")
        return self.space.ndof - 1

    def axial_stretch(self) -> float:
        """Axial stretch of the state relative to the reference: ``1 + e`` (1 if the kinematics
        holds it)."""
        if not self.kinematics.axial_unknown:
            return 1.0
        return 1.0 + float(self.state.FV().NumPy()[self.axial_dof])

    def deformation_gradient(self, u, axial=None) -> ngs.CoefficientFunction:
        """``F'`` of displacement ``u``; with an axial unknown, ``axial`` defaults to the current
        state's axial strain."""
        if not self.kinematics.axial_unknown:
            return self.kinematics.deformation_gradient(u)
        if axial is None:
            axial = self.parts(self.gridfunction)[1]
        return self.kinematics.deformation_gradient(u, axial=axial)

    def evaluate(self, field: ngs.CoefficientFunction, point) -> float | np.ndarray:
        """``field`` (a GridFunction, its gradient, a stress, ...) at the reference ``point``
        (``mesh.dim`` coordinates): a float for a scalar field, else a numpy array of the field's
        shape (``(n,)``, ``(n, m)``), whatever the kinematics (NGSolve itself gives a float or a
        flat tuple: a 1D gradient is a 1-tuple, a 3x3 stress 9 numbers)."""
        coordinates = np.asarray(point, dtype=float)
        if coordinates.shape != (self.mesh.dim,) or not np.all(np.isfinite(coordinates)):
            raise ValueError(f"point must be {self.mesh.dim} finite coordinates on this {self.mesh.dim}D mesh, "
                             f"got {point!r}")
        where = self.mesh(*coordinates)
        if where.nr < 0:
            raise ValueError(f"point {tuple(coordinates)} lies outside the mesh")
        value = field(where)
        return float(np.squeeze(value)) if field.dim == 1 else np.reshape(value, tuple(field.dims))

    @property
    def lam0(self) -> float:
        """The reference stretch shared by every gel region (1 without gels); ValueError where it
        differs between regions or is a field (use ``lam0_of(region)`` or ``lam0_field``)."""
        values = [v for name, v in self._lam0.items() if self.materials[name].swollen_reference] or [1.0]
        if not all(isinstance(v, float) and v == values[0] for v in values):
            raise ValueError("lam0 differs between the gel regions or is a field here; use lam0_of(region) "
                             "or lam0_field")
        return values[0]

    def lam0_of(self, region: str) -> float | ngs.CoefficientFunction:
        """Stretch of the mesh from the dry state in ``region`` (1 where the material is not a gel)."""
        try:
            return self._lam0[region]
        except KeyError:
            raise ValueError(f"unknown region {region!r}; the mesh has regions {sorted(self._lam0)}") from None

    def region_sum(self, integrand_of) -> ngs.SumOfIntegrals:
        """``sum_region integrand_of(material, region) * weight * dx(region)``."""
        w = self.kinematics.volume_weight()
        rules = {} if self.quadrature_order is None else quadrature_rules(self.quadrature_order)
        total = None
        for name, mat in self.materials.items():
            term = (w * integrand_of(mat, name)).Compile() * ngs.dx(definedon=self.mesh.Materials(name), intrules=rules)
            total = term if total is None else total + term
        return total

    def cauchy_stress(self, u, mu, axial=None) -> ngs.CoefficientFunction:
        """Cauchy stress (3x3) of the material in each region."""
        Fp = self.deformation_gradient(u, axial)
        values = {name: mat.reference_cauchy(Fp, mu, self.lam0_of(name)) for name, mat in self.materials.items()}
        return self.mesh.MaterialCF(values)

    def outside_count(self, space, u, axial=None) -> ngs.BilinearForm:
        """A form whose ``Energy(x)`` is zero exactly when the state ``x`` is inside every
        material's admissible set (J > 1 for a gel) at the points where the energy is evaluated.

        It tests the points the energy sees (same regions, weights and rules), no more: a finer
        rule (order 2p + 2 did) also tests points the energy never sees, and near a singular
        corner (a bonded block's base corners, issue 35) the discrete equilibrium is outside
        J > 1 at some of them, so Newton stalled against a boundary of no physical meaning."""
        Fp = self.deformation_gradient(u, axial)
        form = ngs.BilinearForm(space, symmetric=True)
        form += ngs.Variation(self.region_sum(lambda mat, name: ngs.IfPos(mat.margin(Fp, self.lam0_of(name)), 0.0, 1.0)))
        return form


CHORD_MIN_FREE_DOFS = 20000


def chord_steps_pay(dim: int, free_dofs: int) -> bool:
    """Whether Newton should first try chord steps with the last factorisation (``newton``'s
    ``reuse_factorisation``, paced by measured times: ``chord_pacing``): on 3D meshes of at least
    ``CHORD_MIN_FREE_DOFS`` free dofs, where a full iteration (assembly and factorisation) costs
    several chord steps (a residual and a solve each). Measured on issue 35's bonded gel block
    (order 2, 20-step ramp, one thread, docs/benchmarks.md): 28k unknowns, paced chord steps 23.9 s
    against 36.9 s of full Newton (unpaced chord steps, which continue while each cuts the
    residual 4x, took 47 s: ~18 cheap steps where 3 full ones do); 53k 0.50x. On small meshes a
    factorisation is cheap, and chord steps stop at the tolerance asked for where a last full
    Newton step lands far below it: that accuracy costs little there and is kept, and runs repeat
    bit for bit (pacing depends on times). 2D and 1D problems keep full Newton (not measured to
    pay; their validated paths stay as they were). The choice is logged once per kind."""
    pays = dim == 3 and free_dofs >= CHORD_MIN_FREE_DOFS
    reason = ("chord steps with the last factorisation before each full Newton iteration (3D, "
              f"at least {CHORD_MIN_FREE_DOFS} free dofs)" if pays else
              f"full Newton iterations ({dim}D" + (f", fewer than {CHORD_MIN_FREE_DOFS} free dofs)" if dim == 3 else ")"))
    if reason not in _logged_choices:
        _logged_choices.add(reason)
        _log.info("reuse_factorisation='auto': %s; EquilibriumProblem(reuse_factorisation=...) overrides", reason)
    return pays


_log = logging.getLogger("ngsgel.problem")
_logged_choices: set[str] = set()


class EquilibriumProblem(GelBody):
    """Static equilibrium at a chemical potential ``mu``: a number (held in ``self.mu``, an
    NGSolve ``Parameter`` to be stepped) or a CoefficientFunction field.

    Example::

        gel = FloryRehnerGel(Nv=1e-3, chi=0.5)
        prob = EquilibriumProblem(mesh, kinematics=PlaneStrain(), materials=gel,
                                  lam0=gel.lam_free(-0.05), mu=-0.05)
        prob.fix("left", "x"); prob.fix("bottom", "y")
        prob.mu.Set(0.0); prob.solve()
    """

    runs_distributed = True

    def __init__(self, mesh: ngs.Mesh, *, kinematics: Kinematics,
                 materials: Mapping[str, Material] | Material, lam0: Lam0 | None = None, mu=0.0, order: int = 2,
                 inverse: str = "auto", quadrature_order: int | None = None,
                 reuse_factorisation: bool | str = "auto"):
        # inverse: ngsgel.newton.LinearSolver's ("auto": MKL PARDISO where installed, else sparsecholesky)
        # reuse_factorisation: solve's default of newton's option; "auto": chord_steps_pay decides
        if reuse_factorisation not in (True, False, "auto"):
            raise ValueError(f"reuse_factorisation must be True, False or 'auto', got {reuse_factorisation!r}")
        super().__init__(mesh, kinematics=kinematics, materials=materials, lam0=lam0, order=order,
                         quadrature_order=quadrature_order)
        if isinstance(mu, Real):
            self._check_mu(float(mu))
            mu = ngs.Parameter(float(mu))
        elif not isinstance(mu, ngs.CoefficientFunction):
            raise ValueError(f"mu must be a number, a Parameter or a CoefficientFunction, got {type(mu).__name__}")
        self.mu = mu
        self.inverse = inverse
        self._reuse_factorisation = reuse_factorisation
        self._tractions: list[tuple[str, ngs.CoefficientFunction]] = []
        self._form = None

    @property
    def reuse_factorisation(self) -> bool:
        """``solve``'s default of Newton's ``reuse_factorisation`` (``"auto"`` resolved)."""
        if self._reuse_factorisation != "auto":
            return self._reuse_factorisation
        self.form  # the free dofs
        return chord_steps_pay(self.mesh.dim, self.reductions.free_count)

    def _check_mu(self, mu: float) -> None:
        for mat in self.materials.values():
            if isinstance(mat, FloryRehnerGel) and isinstance(mat.Nv, Real):
                mat.lam_free(mu)  # raises ValueError naming mu and its range

    def add_traction(self, boundary: str, traction) -> None:
        """Dead load per unit reference area (a vector with one entry per component)."""
        self._check_open()
        self._check_boundary(boundary)
        t = _as_cf(tuple(traction) if not isinstance(traction, ngs.CoefficientFunction) else traction)
        if t.dim != len(self.kinematics.components):
            raise ValueError(f"traction must have {len(self.kinematics.components)} components, got {t.dim}")
        self._tractions.append((boundary, t))

    # ------------------------------------------------------------ the discrete problem
    def _build(self) -> None:
        V = self.space
        u, axial = self.parts(V.TrialFunction())
        Fp = self.deformation_gradient(u, axial)
        energy = self.region_sum(lambda mat, name: mat.reference_energy(Fp, self.mu, self.lam0_of(name)))
        energy = self.with_surface_energies(energy, u)
        w = self.kinematics.volume_weight()
        for boundary, t in self._tractions:
            energy += -(w * ngs.InnerProduct(t, u)) * ngs.ds(definedon=self.mesh.Boundaries(boundary))
        with tangent_differentiated_once():
            form = ngs.BilinearForm(V, symmetric=True)
            form += ngs.Variation(energy)
        self._attach_self_contacts(form, u, V, lambda gf: self.parts(gf)[0])
        self._form = form
        self.gf = ngs.GridFunction(V, name="displacement")
        self._target = ngs.GridFunction(V)
        self._renew_free_dofs()
        self._outside = self.outside_count(V, u, axial)

    def _renew_free_dofs(self) -> None:
        V = self.space
        self.free_mask = np.array(list(V.FreeDofs()), dtype=bool)
        if parallel.is_distributed(self.mesh):  # a parallel solver, norms and sums over all ranks
            self._solver, self.reductions = parallel.newton_parts(self)
        else:
            self._solver = LinearSolver(V.FreeDofs(), inverse=self.inverse)
            self.reductions = FreeDofReductions(self.free_mask)

    def fix_dof(self, dof: int) -> None:
        """Fix one degree of freedom (e.g. a vertex's displacement component, see
        ``ngsgel.supports.vertex_dof``) at zero like ``fix``, also after the problem has been built
        and solved (the next solve moves it to zero; the free-dof mask and the solver are renewed)."""
        if parallel.is_distributed(self.mesh):
            raise ValueError("fix_dof takes a dof number of one process: not on a distributed mesh")
        free = self.space.FreeDofs()
        if not 0 <= dof < len(free):
            raise ValueError(f"dof must be in [0, {len(free)}), got {dof!r}")
        if not free[dof]:
            raise ValueError(f"dof {dof} is already fixed")
        free.Clear(dof)
        if self._form is not None:
            self._renew_free_dofs()

    @property
    def displacement(self) -> ngs.GridFunction:
        return self.parts(self.gridfunction)[0]

    def residual(self, x, out) -> None:
        self._update_self_contacts(x)
        self.form.Apply(x, out)

    def tangent(self, x):
        self._update_self_contacts(x)
        self.form.AssembleLinearization(x)
        return self.form.mat

    def energy(self, x=None) -> float:
        x = self.state if x is None else x
        self._update_self_contacts(x)
        energy = self.form.Energy(x)
        return self.reductions.sum(energy)  # on a distributed mesh: each rank's subdomain summed

    def prescribed(self, out) -> None:
        out[:] = 0.0
        target = self.parts(self._target)[0]  # a view of the displacement part of self._target
        for p in self._prescribed:
            if self.mesh.dim == 1:
                target.Set(p.value)  # 1D spaces have no boundary evaluator; only the end dof is used
            else:
                target.components[p.component].Set(p.value, ngs.BND, definedon=self.mesh.Boundaries(p.boundary))
        out.data = self._target.vec

    def admissible(self, x) -> bool:
        return bool(self.reductions.sum(self._outside.Energy(x)) == 0.0)

    # Round-off of the residual: each entry sums stress terms times shape-function gradients,
    # and the terms are of the size of the energy density at strains of order one (a gel's
    # mu J and mixing terms cancel in its net stress but not in their rounding). Measured
    # round-off plateaus of the free residual, over eps E_s N^(1/d - 1/2) / V^(1/d): 0.18-0.22
    # (film columns, arches), 0.25-0.83 (plane-strain gels), 1.9-2.2 (3D gel blocks, a film on a
    # gel), 12 (1D spherical gel, order 6); 100 keeps the floor above all of them. For gels it
    # lies below rtol times an ordinary load step's starting residual; for slender film
    # structures it can bind (a column: 2e-13, 4e-10 of its axial force, where rtol asked for
    # 1e-18 and Newton crawled at 3e-16 until the increment test stopped it).
    ROUND_OFF_FACTOR = 100.0

    @property
    def residual_floor(self) -> float:
        """Newton's default absolute floor ``atol``: the round-off level of the free residual at
        the current loads, ``100 eps E_s N^(1/d - 1/2) / V^(1/d)``. ``E_s``: the energy scale, the
        integral over the body of ``|W'(I)| + |W'(2I)|`` (each region's energy density at the
        reference, where admissible, and at twice its size, at the current ``mu``); ``N`` the free dofs, ``V`` the
        body's measure, ``d`` the mesh dimension, so ``E_s / (N h)`` with ``h = (V/N)^(1/d)`` is a
        dof's force scale and ``sqrt(N)`` sums the rounding of ``N`` of them. Below it a relative
        criterion asks for digits the residual does not have (a tiny load step next to a critical
        state crawled for 30 iterations at 3e-16 towards 1e-27); its cost is one integral over
        the mesh per solve."""
        self.form
        # a dry reference (lam0 = 1) is not admissible, its W' is 0 * log(0): left out
        sizes = {name: ngs.IfPos(mat.margin(ngs.Id(3), self.lam0_of(name)),
                                 ngs.Norm(mat.reference_energy(ngs.Id(3), self.mu, self.lam0_of(name))), 0.0)
                 + ngs.Norm(mat.reference_energy(2 * ngs.Id(3), self.mu, self.lam0_of(name)))
                 for name, mat in self.materials.items()}
        energy = self.integrate(self.mesh.MaterialCF(sizes))
        free, d = self.reductions.free_count, self.mesh.dim
        measure = self.integrate(ngs.CF(1.0))
        return self.ROUND_OFF_FACTOR * np.finfo(float).eps * energy * free ** (1 / d - 0.5) / measure ** (1 / d)

    def solve(self, **newton_options) -> NewtonResult:
        """Newton at the current parameter values (``ngsgel.newton.newton``'s options; ``atol``
        defaults to ``residual_floor``, ``reuse_factorisation`` to the problem's); raises
        ``NewtonError`` on failure."""
        self.form
        if "atol" not in newton_options:
            newton_options["atol"] = self.residual_floor
        if "reuse_factorisation" not in newton_options:
            newton_options["reuse_factorisation"] = self.reuse_factorisation
            newton_options.setdefault("chord_pacing", self._reuse_factorisation == "auto")
        with ngs.TaskManager():  # threads assembly and factorisation; a no-op when already active
            return newton(self, self._solver, **newton_options)

    # --------------------------------------------------------------------- outputs
    def stress(self) -> ngs.CoefficientFunction:
        return self.cauchy_stress(self.displacement, self.mu)

    def axial_force(self, *, region: str | None = None) -> float:
        """Net axial force, ``int w det(F') sigma_zz / F'_zz`` over the reference section (or one
        ``region`` of it): the nominal axial stress from the Cauchy stress, integrated with the
        kinematics' volume weight (a polar radial line: the whole annular section). In plane
        strain the reaction of the axial constraint; zero at an equilibrium of generalized
        plane strain."""
        F = self.deformation_gradient(self.displacement)
        return self.integrate(ngs.Det(F) * self.stress()[2, 2] / F[2, 2], region=region)

    def volume_ratio(self) -> ngs.CoefficientFunction:
        """``J`` relative to the dry state in gel regions (to the bonded state in films)."""
        return self.lam0_field**3 * ngs.Det(self.deformation_gradient(self.displacement))

    def integrate(self, cf, *, region: str | None = None) -> float:
        """Integral over the reference body (with the kinematics' volume weight)."""
        where = self.mesh.Materials(region) if region is not None else None
        return ngs.Integrate(self.kinematics.volume_weight() * cf, self.mesh, definedon=where,
                             order=2 * self.order + 2)

    def fields(self) -> dict[str, ngs.CoefficientFunction]:
        """Named fields for VTK output."""
        sigma = self.stress()
        return {"displacement": self.displacement, "J": self.volume_ratio(),
                "sigma_xx": sigma[0, 0], "sigma_yy": sigma[1, 1], "sigma_zz": sigma[2, 2],
                "sigma_xy": sigma[0, 1]}

