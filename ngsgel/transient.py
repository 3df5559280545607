"""Transient swelling: coupled displacement and chemical potential with Suo's kinetics.

Unknowns ``(u, mu)`` on the swollen reference (MODEL.md section 3), backward Euler or the
variable-step BDF2 in time. Per step the problem is a ``NonlinearSystem`` for ``ngsgel.newton``:

    u-equation:   d/du  sum_regions int W'(F', mu) dV'                       = 0
    mu-equation:  -int (J' - a1 J'_n + a2 J'_{n-1}) q
                  + b dt (J' - lam0^-3) C'^-1 Grad mu . Grad q dV' + b dt int j_in q dA' = 0

Backward Euler: ``a1 = 1, a2 = 0, b = 1``. BDF2 with the step ratio ``w = dt / dt_{n-1}``:
``a2 = w^2 / (1 + 2w)``, ``a1 = 1 + a2``, ``b = (1 + w) / (1 + 2w)`` (the BDF2 derivative
``((1+2w)/(1+w) J'_{n+1} - (1+w) J'_n + w^2/(1+w) J'_{n-1}) / dt`` times ``b dt``).
The mu-equation is multiplied by ``-b dt``: then the coupling blocks are transposes of each other
(``d2W'/dF' dmu = -dJ'/dF'``) and the system is well scaled for any ``dt``. The derivative of
the mobility (and the lumped mass below) make the tangent unsymmetric, hence umfpack.

With P1 chemical potential the mass term ``int (J' - J'_n) q`` is lumped (vertex quadrature).
With consistent mass even the inf-sup stable pair violates the maximum principle for
``dt << h^2 / Dc``: after an immersion step mu undershoots by ~30 % of the step next to the
wetted boundary (Vermeer & Verruijt 1981; Rodrigo et al. 2016); lumped, it stays within bounds.
The u-equation keeps the energy's quadrature, so steady states are exactly the equilibrium
problem's (same ``quadrature_order``).

``march`` steps a problem in time (BDF2 by default) with the step chosen by an estimate of the
local time error (``rtol``), cut back where Newton fails, and lands on requested output times;
every step yields a ``StepRecord`` with the solvent balance.

On an MPI-distributed mesh (``ngsgel.parallel``, 3D) the problem solves with the parallel
solver and reductions of ``parallel.newton_parts``; its solvent amounts, admissibility test and
``march``'s time-error and change norms are global, so every rank takes the same steps, and
checkpoints hold every rank's part (docs/parallel.md).
"""

from __future__ import annotations

import math
import os
import pickle
from collections.abc import Callable, Iterable, Mapping
from dataclasses import asdict, dataclass, field
from numbers import Real
from pathlib import Path

import numpy as np
import ngsolve as ngs

from .kinematics import Kinematics
from .materials import FloryRehnerGel, Material
from . import parallel
from .newton import FreeDofReductions, LinearSolver, NewtonError, NewtonResult, newton
from .output import report_progress
from .problem import EquilibriumProblem, GelBody, Lam0, quadrature_rules

__all__ = ["TransientProblem", "StepRecord", "TransientResult", "TransientError", "march", "time_ramp",
           "SCHEMES", "MAX_RATIO", "MarchCheckpoint"]


def _as_cf(value) -> ngs.CoefficientFunction:
    return value if isinstance(value, ngs.CoefficientFunction) else ngs.CF(value)


def _vertex_rules() -> dict:
    """Quadrature at the vertices: with P1 test functions it lumps the mass term (diagonal in
    the mu dofs), the classical cure for the overshoot of consistent mass at small dt."""
    def rule(points, volume):
        return ngs.IntegrationRule(points=points, weights=[volume / len(points)] * len(points))
    square = [(0, 0), (1, 0), (1, 1), (0, 1)]
    return {ngs.ET.SEGM: rule([(0,), (1,)], 1.0),
            ngs.ET.TRIG: rule([(0, 0), (1, 0), (0, 1)], 0.5),
            ngs.ET.QUAD: rule(square, 1.0),
            ngs.ET.TET: rule([(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)], 1 / 6),
            ngs.ET.PRISM: rule([(x, y, z) for z in (0, 1) for x, y in ((0, 0), (1, 0), (0, 1))], 0.5),
            ngs.ET.HEX: rule([(x, y, z) for z in (0, 1) for x, y in square], 1.0)}


def time_ramp(t: ngs.Parameter, *, start: float, end: float, duration: float) -> ngs.CoefficientFunction:
    """``start`` at ``t = 0`` linearly to ``end`` at ``t = duration``, then held: a smooth
    alternative to an immersion step."""
    if not duration > 0:
        raise ValueError(f"duration must be > 0, got {duration!r}")
    return start + (end - start) * ngs.IfPos(t - duration, 1.0, t / duration)


@dataclass
class StepRecord:
    """Diagnostics of one converged time step (solvent amounts per the kinematics' volume).

    ``step_uptake`` is ``int (J'_{n+1} - J'_n) dV'``; ``wetted_inflow`` the solvent that entered
    through the immersed boundaries during the step (from the mu-equation's residual on their
    dofs), ``prescribed_inflow`` through prescribed-flux boundaries; ``balance_error`` is
    ``step_uptake - wetted_inflow - prescribed_inflow``. With BDF2 (``order`` 2) the inflows are
    the flux integrated with the scheme's own weights: the mu-equation summed over all dofs says
    ``dC_{n+1} - a2 dC_n = b dt Q_{n+1}`` (``dC`` a step's uptake, ``Q`` the inflow rate), so the
    inflow of the step is ``I_{n+1} = b dt Q_{n+1} + a2 I_n`` (``I_n = dt Q_n`` for a backward
    Euler step); its balance error is this step's round-off plus ``a2 < 1`` times the last one's.

    ``error``: the estimated local time error over its tolerance (``march`` with ``rtol``; NaN
    where not estimated), ``rejected``: attempts of this step refused by that estimate,
    ``cutbacks``: attempts on which Newton failed.
    """

    time: float
    dt: float
    iterations: int
    line_search_cuts: int
    content: float
    uptake: float
    step_uptake: float
    wetted_inflow: float
    prescribed_inflow: float
    exchanged: float
    balance_error: float
    order: int = 1
    error: float = math.nan
    rejected: int = 0
    cutbacks: int = 0
    output: bool = False

    @property
    def wetted_flux(self) -> float:
        """Mean inflow rate through the immersed boundaries over the step."""
        return self.wetted_inflow / self.dt

    @property
    def relative_balance_error(self) -> float:
        scale = max(abs(self.step_uptake), abs(self.wetted_inflow + self.prescribed_inflow))
        return abs(self.balance_error) / scale if scale > 0 else 0.0

    def row(self) -> dict:
        return {**asdict(self), "wetted_flux": self.wetted_flux,
                "relative_balance_error": self.relative_balance_error}


@dataclass
class TransientResult:
    completed: bool
    records: list[StepRecord] = field(default_factory=list)
    message: str = ""

    @property
    def steps(self) -> int:
        return len(self.records)

    @property
    def cutbacks(self) -> int:
        return sum(r.cutbacks for r in self.records)

    @property
    def rejected(self) -> int:
        return sum(r.rejected for r in self.records)

    @property
    def outputs(self) -> list[StepRecord]:
        return [r for r in self.records if r.output]

    def column(self, name: str) -> np.ndarray:
        return np.array([getattr(r, name) for r in self.records])


class TransientError(RuntimeError):
    """``dt`` fell below ``dt_min``; the problem holds the last accepted step."""

    def __init__(self, message: str, result: TransientResult):
        super().__init__(message)
        self.result = result


SCHEMES = ("bdf2", "backward_euler")


@dataclass
class MarchCheckpoint:
    """What ``march`` needs to go on after its last accepted step as if it had not stopped: the
    problem's state and step memory (``problem``: ``TransientProblem._checkpoint()``), the march's
    start (``t0``, ``start``), its step control (``dt``: the next step it would try; ``history``:
    the last accepted states, for the predictor and the error estimate; ``change``: the largest
    change of each field so far), its records, and ``data``: what the caller's
    ``checkpoint_data()`` returned after that step (e.g. a scene's rows and events).

    ``save`` writes a pickle (atomically: a stopped run never leaves half a file); load only
    checkpoints your own runs wrote. ``ranks``: the number of MPI processes that wrote it (1: a
    serial run); on a distributed mesh the states are each rank's own dofs, so rank 0 writes
    every rank's checkpoint into one file, ``load`` takes this rank's, and a checkpoint resumes
    on the number of processes that wrote it only."""

    t0: float
    t_end: float
    start: np.ndarray
    problem: tuple
    history: list
    change: np.ndarray
    dt: float
    records: list
    data: object = None
    ranks: int = 1

    def save(self, path: str | Path, *, comm=None) -> None:
        """Write the pickle; with an mpi4py ``comm`` of several ranks (a distributed problem's)
        every rank's checkpoint is gathered and rank 0 writes the list of them."""
        content = self
        if comm is not None and comm.size > 1:
            content = comm.gather(self, root=0)
            if comm.rank != 0:
                return
        path = Path(path)
        partial = path.with_name(path.name + ".partial")
        partial.write_bytes(pickle.dumps(content))
        os.replace(partial, path)

    @classmethod
    def load(cls, path: str | Path) -> MarchCheckpoint:
        """The checkpoint in ``path``; this rank's part of a distributed run's (ValueError where
        this run has another number of processes)."""
        checkpoint = pickle.loads(Path(path).read_bytes())
        if isinstance(checkpoint, list) and checkpoint and all(isinstance(c, cls) for c in checkpoint):
            comm = parallel.world()
            if comm.size != len(checkpoint):
                raise ValueError(f"the march checkpoint {path} was written by {len(checkpoint)} MPI processes, this "
                                 f"run has {comm.size}: a checkpoint resumes on the number of processes that wrote it")
            checkpoint = checkpoint[comm.rank]
        if not isinstance(checkpoint, cls):
            raise ValueError(f"{path} holds a {type(checkpoint).__name__}, not a march checkpoint")
        return checkpoint


@dataclass
class _Step:
    """The last converged step, what BDF2 needs to take the next: its start state and length,
    its end (to tell whether the state was changed since) and its inflows (the balance)."""

    time: float
    dt: float
    start: np.ndarray
    end: np.ndarray
    wetted: float
    prescribed: float


class TransientProblem(GelBody):
    """Coupled swelling in time: displacement of order ``order`` and chemical potential of
    order ``mu_order`` (default ``order - 1``, the inf-sup stable pair; ``mu_order=order``
    gives equal orders, which oscillate after an immersion step). ``lumped`` (default: when
    ``mu_order == 1``) lumps the solvent mass, see the module notes. ``inverse``: the linear
    solver of the unsymmetric tangent, ``"auto"`` (NGSolve's ``"umfpack"``; on a distributed mesh
    ``"masterinverse"``) or a name: an NGSolve sparse direct solver (serial), ``"masterinverse"``
    (distributed, ``parallel.DistributedSolver``; its ``"bddc"`` is refused, NotImplementedError).
    ``viscosity`` (default 0: none) adds a pseudo-viscous force ``eta (u - u_n)/dt`` to the
    u-equation, the stabiliser that carries a run through a snap (a crease forming) where the
    quasi-static state jumps; ``viscous_dissipation()`` gives its work in the last step.

    The initial state is the swollen reference at ``mu0`` (a number or a field); ``reset``
    starts again from there or from an ``EquilibriumProblem``'s state (needed for graded gels
    with a uniform ``lam0``, which is not stress-free, and for a dry reference ``lam0 = 1``,
    whose undeformed state is not admissible; ``lam0`` per region or as a field: ``GelBody``).
    ``t`` is the time ``Parameter`` at the end of the step being solved: boundary values may
    depend on it.

    On a mesh distributed over MPI ranks (``parallel.distribute_mesh``; 3D) every rank runs the
    same calls; self-contact and kinematics with an axial unknown do not run there.

    Example::

        prob = TransientProblem(mesh, kinematics=PlaneStrain(), materials=gel,
                                lam0=gel.lam_free(-1.0), mu0=-1.0)
        prob.fix("bottom"); prob.fix("left|right", "x")
        prob.immerse("top", 0.0)
        result = march(prob, 10.0, output_times=[0.1, 1.0])
    """

    runs_distributed = True

    def __init__(self, mesh: ngs.Mesh, *, kinematics: Kinematics,
                 materials: Mapping[str, Material] | Material, lam0: Lam0 | None = None, mu0,
                 order: int = 2, mu_order: int | None = None, lumped: bool | None = None,
                 inverse: str = "auto", viscosity: float = 0.0):
        if kinematics.axial_unknown:
            raise ValueError(f"kinematics {kinematics.name!r} (an axial unknown) is not supported by transient "
                             "problems; use it with EquilibriumProblem")
        # The mass term and the content integrals must use the same points for the balance to
        # close to round-off: pinned, 2 order (pass the same to an EquilibriumProblem to compare).
        super().__init__(mesh, kinematics=kinematics, materials=materials, lam0=lam0, order=order,
                         quadrature_order=2 * order)
        for name, mat in self.materials.items():
            if not isinstance(mat, FloryRehnerGel):
                raise ValueError(f"region {name!r}: transient runs need a FloryRehnerGel in every region "
                                 f"(solvent kinetics of other materials is not modelled), got {type(mat).__name__}")
        mu_order = order - 1 if mu_order is None else mu_order
        if not isinstance(mu_order, int) or not 1 <= mu_order <= order:
            raise ValueError(f"mu_order must be an integer in [1, order={order}] (order >= 2 for the "
                             f"default mu_order = order - 1), got {mu_order!r}")
        if isinstance(mu0, Real):
            if not math.isfinite(mu0):
                raise ValueError(f"mu0 must be finite, got {mu0!r}")
        elif not isinstance(mu0, ngs.CoefficientFunction):
            raise ValueError(f"mu0 must be a number or a CoefficientFunction, got {type(mu0).__name__}")
        self.mu_order = mu_order
        self.lumped = mu_order == 1 if lumped is None else lumped
        self.mu0 = _as_cf(mu0)
        if inverse == "bddc":
            # measured on a bonded block under mpiexec -n 3 (318 free dofs, a 17-step march, 39
            # solves): 553 Krylov iterations per solve on average, CG being stopped at 500 (it
            # does not converge on the unsymmetric tangent) and GMRES finishing
            raise NotImplementedError("inverse='bddc' does not serve transient problems: BDDC-preconditioned CG "
                                      "fails on their unsymmetric tangent; use 'masterinverse' (the default "
                                      "'auto' on a distributed mesh)")
        self.inverse = inverse
        if not (isinstance(viscosity, Real) and math.isfinite(viscosity) and viscosity >= 0):
            raise ValueError(f"viscosity must be a finite number >= 0, got {viscosity!r}")
        self.viscosity = float(viscosity)
        self.t = ngs.Parameter(0.0)
        self.dt = ngs.Parameter(1.0)
        self._flux_weight = ngs.Parameter(1.0)  # b dt of the module notes
        self.time = 0.0
        self._previous: _Step | None = None
        # exact for the polynomial part of the mass term in every kinematics (3D: det is of
        # degree 3 (order - 1), times q; axisymmetric: r J' of degree 3 order - 2, times q)
        self._wetted: list[tuple[str, ngs.CoefficientFunction]] = []
        self._fluxes: list[tuple[str, ngs.CoefficientFunction]] = []
        self._form = None

    # ----------------------------------------------------------- boundary conditions
    def immerse(self, boundary: str, mu_ext=0.0) -> None:
        """``mu = mu_ext`` on ``boundary`` (in contact with solvent): a number, or a
        CoefficientFunction of ``self.t`` (a step, ``time_ramp``) and of space."""
        self._check_open()
        self._check_boundary(boundary)
        self._wetted.append((boundary, _as_cf(mu_ext)))

    def add_flux(self, boundary: str, inflow) -> None:
        """Prescribed solvent inflow per unit reference area and time (normalised units: solvent
        volume per swollen-reference area, ``L / (L^2/D)``), a number or a CF of ``self.t``.
        Boundaries neither immersed nor given a flux are impermeable."""
        self._check_open()
        self._check_boundary(boundary)
        self._fluxes.append((boundary, _as_cf(inflow)))

    # ---------------------------------------------------------------- discrete problem
    def _grad3(self, f) -> ngs.CoefficientFunction:
        """Reference gradient as a 3-vector in the coordinates of the kinematics' ``F``."""
        g = ngs.Grad(f)
        dim = self.mesh.dim
        return g if dim == 3 else ngs.CF(tuple(g[i] for i in range(dim)) + (0,) * (3 - dim))

    def _content_density(self, Fp) -> ngs.CoefficientFunction:
        """``w (J' - lam0^-3)``, solvent volume per mesh measure; guarded because the hoop
        stretch ``u_r / r`` is 0/0 on the axis, where the weight vanishes."""
        w = self.kinematics.volume_weight()
        return ngs.IfPos(w, w * (ngs.Det(Fp) - self.lam0_field**-3), 0.0)

    def _apply(self, functional: ngs.LinearForm) -> float:
        functional.Assemble()
        return ngs.InnerProduct(functional.vec, self._one)

    def _build(self) -> None:
        mesh, lam0, w = self.mesh, self.lam0_field, self.kinematics.volume_weight()
        wetted = "|".join(b for b, _ in self._wetted)
        self.mu_space = ngs.H1(mesh, order=self.mu_order, dirichlet=wetted)
        X = self.mixed_space = ngs.FESpace([self.space, self.mu_space])
        (u, mu), (du, q) = X.TnT()
        self.gf = ngs.GridFunction(X, name="state")
        self._old = ngs.GridFunction(X)
        self._older = ngs.GridFunction(X)  # the state before the last step, for BDF2
        self._target = ngs.GridFunction(X)

        # The energy's mu-derivative is minus the solvent content, -(J' - lam0^-3) q: Variation
        # gives the u-equation (exactly the equilibrium problem's), the mass term at t_{n+1}
        # and symmetric coupling blocks at once, and NGSolve linearises an energy far faster
        # than a hand-written residual. Terms without the unknowns are vectors assembled once
        # per step with the same quadrature, so J' - J'_n cancels where nothing changed.
        rules = quadrature_rules(self.quadrature_order)
        mass_rules = _vertex_rules() if self.lumped else rules
        Fp = self.deformation_gradient(u)
        energy = self.region_sum(lambda mat, name: mat.reference_energy(Fp, mu, self.lam0_of(name)))
        energy = self.with_surface_energies(energy, u)
        mobility = (ngs.Det(Fp) - lam0**-3) * ngs.Inv(Fp.trans * Fp)
        form = ngs.BilinearForm(X)
        if self.viscosity > 0:
            # pseudo-viscous stabiliser: Rayleigh dissipation eta/2 |u - u_n|^2 / dt per reference
            # volume, a force eta (u - u_n)/dt that carries the u-equation through snaps
            # (creasing) where the quasi-static state jumps; zero in a steady state
            du_step = u - self._old.components[0]
            energy = energy + (self.viscosity / (2 * self.dt) * w * ngs.InnerProduct(du_step, du_step)) * ngs.dx(intrules=rules)
        form += ngs.Variation(energy)
        self._attach_self_contacts(form, u, X, lambda gf: gf.components[0])
        if self.lumped:  # replace the energy's consistent mass by the lumped one
            form += (self._content_density(Fp) * q).Compile() * ngs.dx(intrules=rules)
            form += (-self._content_density(Fp) * q).Compile() * ngs.dx(intrules=mass_rules)
        form += (-self._flux_weight * w * ngs.InnerProduct(mobility * self._grad3(mu), self._grad3(q))).Compile() * ngs.dx
        self._form = form

        def functional(density, dx=ngs.dx(intrules=mass_rules)) -> ngs.LinearForm:
            lf = ngs.LinearForm(X)
            lf += (density * q).Compile() * dx
            return lf

        # Solvent amounts are these functionals applied to the constant 1 of the mu space: the
        # same discrete integrals as in the mu-equation, whichever quadrature it uses.
        F_old = self.deformation_gradient(self._old.components[0])
        F_now = self.deformation_gradient(self.gf.components[0])
        self._old_content = functional(self._content_density(F_old))
        self._older_content = functional(self._content_density(self.deformation_gradient(self._older.components[0])))
        self._history_content = self._old_content.vec.CreateVector()  # a1 C_n - a2 C_{n-1}, per dof
        self._content = functional(self._content_density(F_now))
        self._step_uptake = functional(self._content_density(F_now) - self._content_density(F_old))
        self._inflow = ngs.LinearForm(X)  # prescribed solvent inflow during the step
        for boundary, inflow in self._fluxes:
            self._inflow += (self._flux_weight * w * inflow * q) * ngs.ds(definedon=mesh.Boundaries(boundary),
                                                                           intrules=rules)

        self.free_mask = np.array(list(X.FreeDofs()), dtype=bool)
        if parallel.is_distributed(mesh):  # a parallel solver, norms and sums over all ranks
            self._solver, self.reductions = parallel.newton_parts(self)
        else:
            self._solver = LinearSolver(X.FreeDofs(), inverse="umfpack" if self.inverse == "auto" else self.inverse)
            self.reductions = FreeDofReductions(self.free_mask)
        self._outside = self.outside_count(X, u)
        # Residual entries are stresses and solvent volumes times element volumes, each O(1)
        # per unit volume, summed from terms of O(1) that cancel: near steady state a step's
        # relative tolerance would ask for less than their round-off. Measured floors: ~1e-15
        # of the body's volume in 1D/2D, up to 1.1e-13 on a curved 3D octant (P2-P1).
        self.residual_floor = 1e-12 * ngs.Integrate(w, mesh)
        one = ngs.GridFunction(X)
        one.components[1].Set(1.0)
        self._one = one.vec
        # restricted to the immersed dofs: the residual there is minus the solvent that entered
        self._one_wetted = one.vec.CreateVector()  # cumulated, as one.vec: every copy of a dof holds it
        self._one_wetted.FV().NumPy()[:] = np.where(self.free_mask, 0.0, one.vec.FV().NumPy())
        self.reset()

    @property
    def displacement(self) -> ngs.GridFunction:
        return self.gridfunction.components[0]

    @property
    def chemical_potential(self) -> ngs.GridFunction:
        return self.gridfunction.components[1]

    # -------------------------------------------------------- NonlinearSystem protocol
    def residual(self, x, out) -> None:
        self._update_self_contacts(x)
        self.form.Apply(x, out)
        out.data += self._history_content
        out.data += self._inflow.vec

    def tangent(self, x):
        self._update_self_contacts(x)
        self.form.AssembleLinearization(x)
        return self.form.mat

    def prescribed(self, out) -> None:
        target = self._target
        target.vec[:] = 0.0
        gu, gmu = target.components
        for p in self._prescribed:
            self._set_on_boundary(gu if self.mesh.dim == 1 else gu.components[p.component], p.value, p.boundary)
        for boundary, mu_ext in self._wetted:
            self._set_on_boundary(gmu, mu_ext, boundary)
        out.data = target.vec

    def _set_on_boundary(self, gf: ngs.GridFunction, value: ngs.CoefficientFunction, boundary: str) -> None:
        if self.mesh.dim > 1:
            gf.Set(value, ngs.BND, definedon=self.mesh.Boundaries(boundary))
            return
        # 1D: boundaries are points, whose only dof is the vertex value
        names = set(boundary.split("|"))
        for el in gf.space.Elements(ngs.BND):
            if el.mat in names:
                (vertex,) = el.vertices
                gf.vec[el.dofs[0]] = value(self.mesh(*self.mesh[vertex].point))

    def admissible(self, x) -> bool:
        return bool(self.reductions.sum(self._outside.Energy(x)) == 0.0)  # distributed: over all ranks

    # ------------------------------------------------------------------- time stepping
    def reset(self, *, equilibrium: EquilibriumProblem | None = None) -> None:
        """Back to time 0: the swollen reference at ``mu0``, or ``equilibrium``'s displacement
        and chemical potential (same mesh, order and displacement conditions)."""
        self.form
        gu, gmu = self.gf.components
        if equilibrium is None:
            gu.vec[:] = 0.0
            gmu.Set(self.mu0)
        else:
            if equilibrium.mesh is not self.mesh or equilibrium.space.ndof != self.space.ndof:
                raise ValueError("the equilibrium problem must use the same mesh and displacement order")
            gu.vec.data = equilibrium.state
            gmu.Set(equilibrium.mu)
        self.time = 0.0
        self.t.Set(0.0)
        self._previous = None
        self.initial_content = self._apply(self._content)
        self.uptake = 0.0
        self.exchanged = 0.0

    def step_to(self, t_new: float, *, scheme: str = "backward_euler", guess: np.ndarray | None = None,
                **newton_options) -> StepRecord:
        """One step from ``self.time`` to ``t_new``: backward Euler, or with ``scheme="bdf2"`` the
        variable-step BDF2 through this step and the last one (backward Euler where there is no
        last step to go on from: after ``reset``, or when the state was changed since). Newton
        starts from ``guess`` (a state vector, e.g. an extrapolation of the last states) if it is
        admissible, else from the current state. Raises ``NewtonError`` with time and state
        unchanged when Newton fails (including steps that would dry the gel). The pseudo-viscous
        force stays a backward difference in either scheme: it is a stabiliser, not physics."""
        if scheme not in SCHEMES:
            raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
        dt = t_new - self.time
        if not dt > 0:
            raise ValueError(f"t_new must be after the current time {self.time}, got {t_new!r}")
        x = self.state
        if self._previous is None and not self.admissible(x):  # a run's start, checked once
            raise ValueError("the starting state is not admissible (J <= 1 somewhere); with a dry reference "
                             "(lam0 = 1) the undeformed mesh is the dry state, at equilibrium with no finite mu0: "
                             "start from a swollen equilibrium, reset(equilibrium=...)")
        previous = self._previous if scheme == "bdf2" and self._continues() else None
        if previous is None:
            a1, a2, b = 1.0, 0.0, 1.0
        else:
            ratio = dt / previous.dt
            a2 = ratio**2 / (1 + 2 * ratio)
            a1, b = 1 + a2, (1 + ratio) / (1 + 2 * ratio)
        start = self.save_state()
        self._old.vec.data = x
        self.t.Set(t_new)
        self.dt.Set(dt)
        self._flux_weight.Set(b * dt)
        self._old_content.Assemble()
        if previous is None:
            self._history_content.data = self._old_content.vec
        else:
            self._older.vec.FV().NumPy()[:] = previous.start
            self._older_content.Assemble()
            if parallel.is_distributed(self.mesh):
                # march's times are numpy scalars, and a numpy scalar times an NGSolve vector is a
                # numpy array of this rank's entries: assigned to a distributed vector it loses
                # the vector's parallel status (wrong residuals), and it crashes on a rank without
                # dofs. (Serially that array is kept: its rounding is the serial runs' own.)
                a1, a2 = float(a1), float(a2)
            self._history_content.data = a1 * self._old_content.vec - a2 * self._older_content.vec
        self._inflow.Assemble()
        if guess is not None:
            self.restore_state(guess)
            if not self.admissible(x):
                self.restore_state(start)
        try:
            result: NewtonResult = newton(self, self._solver, **{"atol": self.residual_floor, **newton_options})
        except NewtonError:
            self.restore_state(start)
            self.t.Set(self.time)
            raise
        self.time = t_new
        r = x.CreateVector()
        self.residual(x, r)
        # this step's inflows with the scheme's weights (see StepRecord)
        wetted = -ngs.InnerProduct(r, self._one_wetted)
        prescribed = ngs.InnerProduct(self._inflow.vec, self._one)
        if previous is not None:
            wetted += a2 * previous.wetted
            prescribed += a2 * previous.prescribed
        step_uptake = self._apply(self._step_uptake)
        self.uptake += step_uptake
        self.exchanged += wetted + prescribed
        self._previous = _Step(time=t_new, dt=dt, start=start, end=self.save_state(), wetted=wetted,
                               prescribed=prescribed)
        return StepRecord(time=t_new, dt=dt, iterations=result.iterations, line_search_cuts=result.line_search_cuts,
                          content=self._apply(self._content), uptake=self.uptake, step_uptake=step_uptake,
                          wetted_inflow=wetted, prescribed_inflow=prescribed, exchanged=self.exchanged,
                          balance_error=step_uptake - wetted - prescribed, order=1 if previous is None else 2)

    def _continues(self) -> bool:
        """Whether the state is still the end of the last step, so that BDF2 may go on from it."""
        last = self._previous
        return last is not None and last.time == self.time and not self.reductions.any(
            last.end != self.state.FV().NumPy())  # on every rank

    def _checkpoint(self) -> tuple:
        return self.save_state(), self.time, self.uptake, self.exchanged, self._previous

    def _rewind(self, checkpoint: tuple) -> None:
        """Back to a ``_checkpoint``: undoes the steps since (``march`` refusing a step)."""
        state, self.time, self.uptake, self.exchanged, self._previous = checkpoint
        self.restore_state(state)
        self.t.Set(self.time)

    # --------------------------------------------------------------------- outputs
    def viscous_dissipation(self) -> float:
        """Energy dissipated by the ``viscosity`` stabiliser in the last step,
        ``int eta |u - u_n|^2 / dt dV'`` (0 without it)."""
        if self.viscosity == 0:
            return 0.0
        du_step = self.displacement - self._old.components[0]
        return self.viscosity / self.dt.Get() * self.integrate(ngs.InnerProduct(du_step, du_step))

    def volume_ratio(self) -> ngs.CoefficientFunction:
        """``J`` relative to the dry state."""
        return self.lam0_field**3 * ngs.Det(self.deformation_gradient(self.displacement))

    def stress(self) -> ngs.CoefficientFunction:
        return self.cauchy_stress(self.displacement, self.chemical_potential)

    def integrate(self, cf) -> float:
        """Integral over the reference body (with the kinematics' volume weight)."""
        return ngs.Integrate(self.kinematics.volume_weight() * cf, self.mesh, order=self.quadrature_order)

    def fields(self) -> dict[str, ngs.CoefficientFunction]:
        """Named fields for VTK output."""
        sigma = self.stress()
        return {"displacement": self.displacement, "mu": self.chemical_potential, "J": self.volume_ratio(),
                "sigma_xx": sigma[0, 0], "sigma_yy": sigma[1, 1], "sigma_zz": sigma[2, 2],
                "sigma_xy": sigma[0, 1]}


# Variable-step BDF2 is zero-stable for step ratios below 1 + sqrt(2) (Grigorieff 1983); 2 keeps a
# margin, and with it the weight a2 <= 0.8 with which a step's balance round-off enters the next.
MAX_RATIO = 2.0
# the elementary error controller: safety factor, largest cut after a refused step
_SAFETY = 0.9
_MIN_RATIO = 0.2
# Newton leaves every entry of a state uncertain to about its xtol (1e-13 in the problem's units):
# differences of the error estimate below 1000 times that are noise, not time error
_NOISE = 1e-10


def _extrapolate(history: list[tuple[float, np.ndarray]], t_new: float, order: int) -> np.ndarray:
    """The polynomial through the last ``order + 1`` states, at ``t_new``: the explicit predictor
    of that order."""
    last = history[-(order + 1):]
    return sum(math.prod((t_new - tk) / (tj - tk) for k, (tk, _) in enumerate(last) if k != j) * yj
               for j, (tj, yj) in enumerate(last))


def _time_error(history: list[tuple[float, np.ndarray]], t_new: float, y_new: np.ndarray, predicted: np.ndarray,
                order: int, fields: list[tuple[slice, np.ndarray]], tolerance: np.ndarray,
                largest: Callable[[float], float]) -> float:
    """Milne's device: the local error of the step to ``t_new`` (order 1: backward Euler, 2:
    BDF2, both from exact past values) is a fixed multiple of the difference between its solution
    and ``predicted``, the extrapolation of the last ``order + 1`` states (the predictor of the same
    order): both errors are proportional to the same derivative of the solution, with constants
    from the step lengths. Returns the largest error of a free dof of each field (``fields``:
    the field's slice of the state and its free dofs) over that field's ``tolerance``; ``largest``
    takes the largest of a number over all processes (the problem's ``reductions.max``)."""
    times = [t for t, _ in history[-(order + 1):]]
    h, hp = t_new - times[-1], times[-1] - times[-2]
    if order == 1:
        # backward Euler's error h^2/2 y'', the linear predictor's -h (h + hp)/2 y''
        factor = h / (2 * h + hp)
    else:
        # BDF2's error -c3 y''' (c3 the y''' coefficient of its truncation error, a1 and a2 as
        # in the module notes), the quadratic predictor's -h (h + hp) (h + hp + hpp)/6 y'''
        hpp = times[-2] - times[-3]
        ratio = h / hp
        a2 = ratio**2 / (1 + 2 * ratio)
        c3 = ((1 + a2) * h**3 - a2 * (h + hp) ** 3) / 6
        factor = -c3 / (h * (h + hp) * (h + hp + hpp) / 6 - c3)
    difference = y_new - predicted
    return max(abs(factor) * largest(float(np.max(np.abs(difference[part][free]), initial=0.0))) / tol
               for (part, free), tol in zip(fields, tolerance))


def march(problem: TransientProblem, t_end: float, *, output_times: Iterable[float] = (), scheme: str = "bdf2",
          rtol: float | None = 1e-3, dt_start: float | None = None, dt_max: float | None = None,
          dt_min: float | None = None, dt_over_t: float | None = 0.5, grow: float = 1.5, cut: float = 0.25,
          easy_iterations: int = 4, on_step: Callable[[TransientProblem, StepRecord], None] | None = None,
          newton_options: dict | None = None, progress: Callable[[str], None] | None = None,
          checkpoint_file: str | Path | None = None, checkpoint_data: Callable[[], object] | None = None,
          resume: MarchCheckpoint | None = None) -> TransientResult:
    """Advance ``problem`` from its current time to ``t_end``; steps end exactly on
    ``output_times`` and ``t_end`` (records marked ``output``).

    ``scheme``: ``"bdf2"`` (second order; the first steps of a march are backward Euler, which
    needs no earlier step) or ``"backward_euler"`` (first order).

    ``rtol`` (a number in (0, 1), default 1e-3): error control. The local time error of a step,
    estimated from the difference between its solution and the explicit extrapolation of the
    last states of the same order (``_time_error``), must stay below ``rtol`` times the largest
    change of the field since the march began (largest entry over the free dofs; displacement and
    chemical potential each against its own change). A step above that is refused and retried
    shorter; the next step is ``dt * 0.9 (1 / error)^(1/(p+1))`` (p the order) within [0.2, 2]
    times ``dt``. With the default a swelling sphere's radius history is within 0.1 %
    (docs/transient.md). The first two steps have no estimate (the start state may not fit the
    boundary values just after it: an immersion step), and a BDF2 estimate takes three states,
    so under error control BDF2 begins at the fourth step. ``dt_start`` defaults to ``rtol^2``
    times the time to the first output: after a jump of the boundary value (uptake ~ sqrt(t))
    the error of the first steps is then of order ``rtol`` of the uptake at that output.
    ``rtol=None``: no error control; the first step is ``dt_start`` (then required), later steps
    grow by ``grow`` after a step that took at most ``easy_iterations`` Newton iterations (the
    control of earlier versions, which used ``scheme="backward_euler"``).

    Either way steps stay below ``dt_max`` and below ``dt_over_t`` times the time elapsed in this
    march (``None``: no such bound), and a step more than ``MAX_RATIO`` times the last is
    backward Euler (BDF2 is stable up to that ratio; error control never proposes more). A step
    on which Newton fails (including one that would dry the gel) is retried with ``dt * cut``;
    below ``dt_min`` (default: 1e-14 of the span, or 1e-6 of ``dt_start`` if smaller) a
    ``TransientError`` is raised. ``on_step(problem, record)`` runs after every accepted step.
    ``progress``: called with one line at the start and one per accepted step
    (``progress(message)``; a ``ngsgel.output.Progress`` also gets the fraction of the march's
    time span done, for its percent done and time left).

    ``checkpoint_file``: after every accepted step (and ``on_step``) a ``MarchCheckpoint`` is
    written there, holding ``checkpoint_data()`` if given. ``resume`` (one of those, same problem
    set-up and options): the march goes on from it as if it had not stopped, to the same steps
    and states bit for bit; the returned records include the ones before the stop.
    On a distributed mesh every rank calls ``march``; rank 0 writes the checkpoint of all ranks,
    which resumes on as many processes only.
    """
    processes = problem.mesh.comm.size if parallel.runs_distributed(problem) else 1
    if resume is not None:
        if resume.t_end != t_end:
            raise ValueError(f"t_end={t_end!r} differs from the resumed march's {resume.t_end!r}")
        if resume.ranks != processes:
            raise ValueError(f"the march checkpoint was written by {resume.ranks} MPI process(es), this problem runs "
                             f"on {processes}: a checkpoint resumes on the number of processes that wrote it")
        problem.form
        problem._rewind(resume.problem)
    t0 = problem.time if resume is None else resume.t0
    span = t_end - t0
    if not span > 0:
        raise ValueError(f"t_end must be after the current time {t0}, got {t_end!r}")
    if scheme not in SCHEMES:
        raise ValueError(f"scheme must be one of {SCHEMES}, got {scheme!r}")
    if rtol is not None and not (isinstance(rtol, Real) and 0 < rtol < 1):
        raise ValueError(f"rtol must be a number in (0, 1) or None (no error control), got {rtol!r}")
    if dt_over_t is not None and not (isinstance(dt_over_t, Real) and dt_over_t > 0):
        raise ValueError(f"dt_over_t must be a number > 0 or None, got {dt_over_t!r}")
    stops = sorted({float(s) for s in output_times if t0 < s < t_end} | {float(t_end)})
    dt_max = span if dt_max is None else dt_max
    if dt_start is None:
        if rtol is None:
            raise ValueError("dt_start is required without error control (rtol=None)")
        dt_start = min(rtol**2 * (stops[0] - t0), dt_max)
        if dt_min is not None:  # the caller's floor bounds the default first step too
            dt_start = max(dt_start, dt_min)
    # a tight rtol starts with steps far below the span's round-off bound, and needs room below them
    dt_min = min(span * 1e-14, dt_start * 1e-6) if dt_min is None else dt_min
    if not 0 < dt_min <= dt_start <= dt_max:
        raise ValueError(f"need 0 < dt_min <= dt_start <= dt_max, got {dt_min}, {dt_start}, {dt_max}")
    if not (grow >= 1 and 0 < cut < 1):
        raise ValueError(f"need grow >= 1 and 0 < cut < 1, got grow={grow}, cut={cut}")
    problem.form
    fields = [(slice(r.start, r.stop), problem.free_mask[r.start:r.stop])
              for r in (problem.mixed_space.Range(i) for i in range(2))]
    start = problem.save_state()
    # the last three accepted states of this march, from its first step on: the start state may be
    # inconsistent with the boundary values just after it (an immersion step), and an extrapolation
    # through it would see a jump as a rate
    history: list[tuple[float, np.ndarray]] = []
    change = np.zeros(len(fields))  # the largest change of each field since t0
    result = TransientResult(completed=False)
    dt = dt_start
    if resume is None:
        report_progress(progress, f"start: t = {t0:.6g}, end {t_end:.6g}", fraction=0.0)
    else:
        start, history, change, dt = resume.start, list(resume.history), resume.change, resume.dt
        result.records = list(resume.records)
        stops = [s for s in stops if s > problem.time]
        report_progress(progress, f"resumed at t = {problem.time:.6g} (step {len(result.records)}), end {t_end:.6g}",
                        fraction=(problem.time - t0) / span)
    cutbacks = rejected = 0
    while stops:
        stop = stops[0]
        h = min(dt, dt_max)
        if dt_over_t is not None and problem.time > t0:
            h = min(h, dt_over_t * (problem.time - t0))
        h = max(h, dt_min)
        remaining = stop - problem.time
        landing = remaining <= h * (1 + 1e-9)
        if landing:
            h = remaining
        elif rtol is not None and remaining < 2 * h:
            # two equal steps rather than a sliver before the output time, which would hold the
            # next steps to MAX_RATIO times itself
            h = remaining / 2
        # BDF2 goes on from the last step of this march (under error control from the fourth step:
        # its estimate takes three states after the start) if this one is at most MAX_RATIO times
        # as long; otherwise (the start; without error control, a step after one shortened to
        # land) backward Euler. The controller never proposes more than MAX_RATIO times the last.
        order = 2 if (scheme == "bdf2" and len(history) >= (1 if rtol is None else 3)
                      and h <= MAX_RATIO * problem._previous.dt * (1 + 1e-9)) else 1
        t_new = stop if landing else problem.time + h
        # Under error control Newton starts from the predictor (about 40 % fewer iterations on a
        # swelling sphere); without it from the last state, as the step growth there counts them.
        predicted = _extrapolate(history, t_new, order) if rtol is not None and len(history) > order else None
        checkpoint = problem._checkpoint() if rtol is not None else None
        try:
            record = problem.step_to(t_new, scheme="bdf2" if order == 2 else "backward_euler", guess=predicted,
                                     **(newton_options or {}))
        except NewtonError as err:
            cutbacks += 1
            dt = h * cut
            if dt < dt_min:
                result.message = f"dt fell below dt_min={dt_min:g} at t={problem.time:g}: {err}"
                raise TransientError(result.message, result) from err
            continue
        state = problem.save_state()
        if rtol is not None:
            moved = np.maximum(change, [problem.reductions.max(np.max(np.abs(state[part] - start[part]), initial=0.0))
                                        for part, _ in fields])
            if predicted is not None:
                record.error = _time_error(history, record.time, state, predicted, order, fields,
                                           np.maximum(rtol * moved, _NOISE), problem.reductions.max)
            if record.error > 1:  # False for NaN: the first two steps have no estimate
                problem._rewind(checkpoint)
                rejected += 1
                dt = h * max(_MIN_RATIO, _SAFETY * record.error ** (-1 / (order + 1)))
                if dt < dt_min:
                    result.message = (f"dt fell below dt_min={dt_min:g} at t={problem.time:g}: the time error "
                                      f"estimate is {record.error:.3g} times its tolerance")
                    raise TransientError(result.message, result)
                continue
            change = moved
        if landing:
            stops.pop(0)
        record.cutbacks, record.rejected, record.output = cutbacks, rejected, landing
        cutbacks = rejected = 0
        result.records.append(record)
        history = [*history[-2:], (record.time, state)]
        report_progress(progress, f"t = {record.time:.6g}, dt = {record.dt:.3g}, iterations {record.iterations}"
                        + (f", cut-backs {record.cutbacks}" if record.cutbacks else "")
                        + (f", refused {record.rejected}" if record.rejected else ""),
                        fraction=(record.time - t0) / span)
        if on_step is not None:
            on_step(problem, record)
        if rtol is not None:
            factor = MAX_RATIO if not record.error > 0 else _SAFETY * record.error ** (-1 / (order + 1))
            dt = h * min(MAX_RATIO, max(_MIN_RATIO, factor))
        else:
            # a step shortened to land on an output time does not shrink the next one
            base = max(h, dt) if landing else h
            dt = base * grow if record.iterations <= easy_iterations else base
        if checkpoint_file is not None:
            MarchCheckpoint(t0=t0, t_end=t_end, start=start, problem=problem._checkpoint(), history=history,
                            change=change, dt=dt, records=result.records,
                            data=None if checkpoint_data is None else checkpoint_data(), ranks=processes).save(
                checkpoint_file, comm=problem.mesh.comm.mpi4py if processes > 1 else None)
    result.completed = True
    return result
