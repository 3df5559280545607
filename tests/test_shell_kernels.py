"""GelShell's compiled kernels (``kernels="compiled"``, issue 34) against its Python forms (the
reference model): the same energy, residual and tangent at random states of the half cap, of the
graded disk (``Nv`` a field) and after ``update_edge_normals``; the same Newton solve; the same
tangent on 2 threads as on 1; the kept element shapes against a fresh evaluation; the fallback of
``kernels="auto"`` and the errors of ``"compiled"``.

Tolerances are the round-off floors measured for issue 34 on the h = 0.2 half cap at a random
state: the tangent differs by 2.7e-15 of its largest entry (the kernels sum the same terms in
another order), so 1e-13 relative. The residual's largest difference is an absolute 3.5e-20: the
gel's mixing stresses are O(1 kT per dry volume) term by term and cancel to the ~1e-3 network
stress, so their round-off is eps times the residual of a unit pressure (4.2e-19 there; mu enters
the energy as -mu (J - 1), so that residual is r(mu + 1) - r(mu), exactly). The floor asserted is
that number, and 1e-13 of the largest residual entry above it.

The kernels are compiled once per machine and NGSolve version (~25 s, into the user's cache):
``kernel_module`` does it once per test session; without a C++ compiler the tests that need it
are skipped.
"""

from __future__ import annotations

import os
import re
import shutil

import numpy as np
import ngsolve as ngs
import pytest
import scipy.sparse as sp

from ngsgel.kernels import KernelsUnavailable, load_shell_kernels, loader
from ngsgel.scenes.shell_cases import GEL, MICROLENS_T, graded_plate_shell, indented_half_cap_shell
from ngsgel.shell import GelShell
from geometries import cap_midsurface

EPS = np.finfo(float).eps
TANGENT_RTOL = 1e-13
RESIDUAL_RTOL = 1e-13


@pytest.fixture(scope="session")
def kernel_module():
    if not os.environ.get("CXX") and not any(shutil.which(c) for c in ("g++", "c++", "clang++")):
        pytest.skip("no C++ compiler: the compiled shell kernels cannot be built here")
    return load_shell_kernels()


@pytest.fixture(autouse=True)
def one_thread():
    before = ngs.GetNumThreads()
    ngs.SetNumThreads(1)
    yield
    ngs.SetNumThreads(before)


def perturb(shell: GelShell, seed: int) -> None:
    """A random state near the reference: displacements ~1e-2 t, hybrid rotations ~1e-2,
    thickness stretches 1 + ~1e-2."""
    rng = np.random.default_rng(seed)
    values = shell.state.FV().NumPy()
    space = shell.space
    for i, size in enumerate([1e-2 * shell.thickness, 1e-2] + [1e-2] * (len(space.components) - 2)):
        block = space.Range(i)
        values[block.start:block.stop] += size * rng.standard_normal(block.stop - block.start)


def pair(build) -> dict[str, GelShell]:
    """The shell ``build(kernels=...)`` on both paths, at the same random state."""
    shells = {kind: build(kernels=kind) for kind in ("python", "compiled")}
    for shell in shells.values():
        perturb(shell, seed=3)
    assert shells["compiled"].compiled_kernels and not shells["python"].compiled_kernels
    return shells


def tangent(shell: GelShell) -> sp.csr_matrix:
    return sp.csr_matrix(shell.tangent(shell.state).CSR()).copy()  # CSR() views the form's memory


def residual(shell: GelShell) -> np.ndarray:
    r = shell.state.CreateVector()
    shell.residual(shell.state, r)
    return r.FV().NumPy().copy()


def residual_floor(shell: GelShell) -> float:
    """eps times the largest entry of the residual of a unit pressure (see the module notes)."""
    mu = shell.mu.Get()
    before = residual(shell)
    shell.mu.Set(mu + 1.0)
    after = residual(shell)
    shell.mu.Set(mu)
    return EPS * np.abs(after - before).max()


def assert_same_forms(shells: dict[str, GelShell]) -> None:
    python, compiled = shells["python"], shells["compiled"]
    K_python, K_compiled = tangent(python), tangent(compiled)
    assert abs(K_compiled - K_python).max() <= TANGENT_RTOL * abs(K_python).max()
    r_python, r_compiled = residual(python), residual(compiled)
    assert np.abs(r_compiled - r_python).max() <= RESIDUAL_RTOL * np.abs(r_python).max() + residual_floor(python)
    assert compiled.energy() == pytest.approx(python.energy(), rel=1e-14, abs=0.0)


def half_cap(**options) -> GelShell:
    return indented_half_cap_shell(maxh=0.2, apex_maxh=0.2, **options)


def test_half_cap_same_energy_residual_and_tangent(kernel_module):
    assert_same_forms(pair(half_cap))


def test_graded_disk_same_energy_residual_and_tangent(kernel_module):
    shells = pair(lambda **kernels: graded_plate_shell(2.0, maxh=0.2, order=3, half=True, **kernels)[0])
    assert isinstance(shells["compiled"].material.Nv, ngs.CoefficientFunction)
    assert_same_forms(shells)


def test_same_forms_after_update_edge_normals(kernel_module):
    shells = pair(half_cap)
    before = tangent(shells["compiled"])
    for shell in shells.values():
        shell.update_edge_normals()
    # the update must reach the kernel: it changes the tangent far above the tolerance
    assert abs(tangent(shells["compiled"]) - before).max() > 1e-6 * abs(before).max()
    assert_same_forms(shells)


def test_newton_solve_reaches_the_same_state(kernel_module):
    results, states = {}, {}
    for kind in ("python", "compiled"):
        shell = half_cap(kernels=kind)
        results[kind] = shell.solve()
        states[kind] = shell.save_state()
    assert results["python"].iterations >= 3  # the apex push takes a real solve
    assert results["compiled"].iterations == results["python"].iterations
    # both follow the same iterates up to round-off; converged means steps below newton_xtol
    assert np.abs(states["compiled"] - states["python"]).max() <= shell.newton_xtol


def test_kept_element_shapes_give_a_fresh_shells_forms_bit_for_bit(kernel_module):
    """The kernels keep each element's B (the reference geometry's part) from its first
    evaluation: later states, and a return to an earlier one, must give what a shell that
    evaluates them first gives."""
    first = {}
    for seed in (5, 7):
        fresh = half_cap(kernels="compiled")
        perturb(fresh, seed=seed)
        first[seed] = (tangent(fresh), residual(fresh), fresh.energy())
    shell = half_cap(kernels="compiled")
    reference = shell.save_state()
    for seed in (5, 7, 5):
        shell.restore_state(reference)
        perturb(shell, seed=seed)
        K, r, energy = first[seed]
        assert (tangent(shell) != K).nnz == 0
        assert np.array_equal(residual(shell), r)
        assert shell.energy() == energy


def test_two_threads_give_the_tangent_and_residual_of_one(kernel_module):
    shell = half_cap(kernels="compiled")
    perturb(shell, seed=5)
    ngs.SetNumThreads(2)
    with ngs.TaskManager():  # the first evaluation: the elements' shapes are built on two threads
        K2, r2 = tangent(shell), residual(shell)
    ngs.SetNumThreads(1)
    K1, r1 = tangent(shell), residual(shell)
    # the same element matrices, summed into the global ones in a schedule-dependent order
    assert abs(K2 - K1).max() <= TANGENT_RTOL * abs(K1).max()
    assert np.abs(r2 - r1).max() <= RESIDUAL_RTOL * np.abs(r1).max() + residual_floor(shell)


def small_cap(**options) -> GelShell:
    bundle = cap_midsurface(H=0.3, maxh=0.5, curve_order=2)
    return GelShell(bundle.mesh, material=GEL, lam0=GEL.lam_free(0.0), thickness=MICROLENS_T, order=2, **options)


@pytest.mark.parametrize("environment, reason", [({"CXX": "/nonexistent/c++"}, "CXX='/nonexistent/c++'"),
                                                 ({"CXX": None, "PATH": ""}, "no C++ compiler")])
def test_without_compiler_auto_falls_back_and_compiled_raises(monkeypatch, tmp_path, environment, reason):
    monkeypatch.setenv("NGSGEL_CACHE", str(tmp_path))  # an empty cache: the kernels must be built
    for name, value in environment.items():
        if value is None:
            monkeypatch.delenv(name, raising=False)
        else:
            monkeypatch.setenv(name, value)
    with pytest.warns(RuntimeWarning, match=re.escape(reason)):
        shell = small_cap(kernels="auto")
        assert not shell.compiled_kernels
    with pytest.raises(KernelsUnavailable, match=re.escape(reason)):
        small_cap(kernels="compiled").form


def test_a_compile_error_names_the_compilers_message_and_is_not_retried(monkeypatch, tmp_path, kernel_module):
    source = tmp_path / "broken.cpp"
    source.write_text("#error deliberately broken\n")
    monkeypatch.setattr(loader, "SOURCE", source)
    monkeypatch.setenv("NGSGEL_CACHE", str(tmp_path / "cache"))
    target = loader._module_path()
    with pytest.raises(KernelsUnavailable, match="deliberately broken"):
        load_shell_kernels()
    assert not target.exists() and not list(target.parent.glob("*.partial"))
    # a second try would fail on the missing compiler: the first build's error comes back instead
    monkeypatch.setenv("CXX", "/nonexistent/c++")
    with pytest.raises(KernelsUnavailable, match="deliberately broken"):
        load_shell_kernels()


def test_the_cache_key_follows_the_source(monkeypatch, tmp_path):
    monkeypatch.setenv("NGSGEL_CACHE", str(tmp_path))
    shipped = loader._module_path()
    changed = tmp_path / "changed.cpp"
    changed.write_bytes(loader.SOURCE.read_bytes() + b"// a comment\n")
    monkeypatch.setattr(loader, "SOURCE", changed)
    assert loader._module_path() != shipped and loader._module_path().parent.parent == shipped.parent.parent


def test_missing_python_headers_are_named(monkeypatch, tmp_path, kernel_module):
    monkeypatch.setenv("NGSGEL_CACHE", str(tmp_path))
    get_path = loader.sysconfig.get_path
    monkeypatch.setattr(loader.sysconfig, "get_path", lambda name: str(tmp_path) if name == "include" else get_path(name))
    with pytest.raises(KernelsUnavailable, match="no Python headers"):
        load_shell_kernels()


OPTIONS_THE_KERNELS_LACK = [({"thickness_points": 3}, "thickness_points=3"),
                            ({"consistent_moment": True}, "consistent_moment=True"),
                            ({"realcompile": True}, "realcompile=True")]


@pytest.mark.parametrize("options, message", OPTIONS_THE_KERNELS_LACK)
def test_compiled_refuses_options_the_kernels_lack(options, message):
    with pytest.raises(ValueError, match=f"kernels='compiled' does not cover {message}"):
        small_cap(kernels="compiled", **options)


# (not realcompile: its fallback's build compiles the Python residual, ~20 s)
@pytest.mark.parametrize("options, message", OPTIONS_THE_KERNELS_LACK[:2])
def test_auto_takes_the_python_forms_for_options_the_kernels_lack(options, message):
    with pytest.warns(RuntimeWarning, match=message):
        assert not small_cap(kernels="auto", **options).compiled_kernels


@pytest.mark.parametrize("value", ["fast", None, True])
def test_kernels_must_be_a_known_choice(value):
    with pytest.raises(ValueError, match=r"kernels must be one of \('auto', 'compiled', 'python'\)"):
        small_cap(kernels=value)
