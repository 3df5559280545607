"""Compile ``shell_kernels.cpp`` against the installed NGSolve at first use and load it.

The C++ ABI of NGSolve is not stable across releases, so the module is built on the user's
machine, once, with the flags NGSolve uses for its own run-time compiled code
(``ngsolve/ngscxx.py``), into a per-user cache keyed on the NGSolve version and a hash of the
source, the flags and the libraries linked: a new NGSolve, Python or source gets a new build,
and an unchanged one loads in milliseconds. Needs a C++20 compiler (``$CXX``, else ``g++``,
``c++`` or ``clang++`` on the PATH) and the Python headers, as NGSolve's ``realcompile`` does.
"""

from __future__ import annotations

import hashlib
import importlib.util
import os
import pathlib
import shutil
import subprocess
import sys
import sysconfig
import time
from types import ModuleType

__all__ = ["THICKNESS_POINTS", "KernelsUnavailable", "cache_directory", "load_shell_kernels"]

SOURCE = pathlib.Path(__file__).with_name("shell_kernels.cpp")
MODULE_NAME = "_shell_kernels"  # the name in the source's PYBIND11_MODULE
# the area kernel's through-thickness points: THICKNESS_POINTS of the source, checked at load
THICKNESS_POINTS = 2
CACHE_VARIABLE = "NGSGEL_CACHE"
_NGSOLVE_LIBRARIES = ("ngsolve", "ngcomp", "ngfem", "ngla", "ngbla", "ngstd", "ngcore")

_loaded: dict[pathlib.Path, ModuleType] = {}  # a pybind11 module cannot be initialised twice
_failed_builds: dict[pathlib.Path, str] = {}  # a compile error is not retried (each try takes ~30 s)


class KernelsUnavailable(RuntimeError):
    """The compiled shell kernels cannot be built or loaded here; the message says why."""


def cache_directory() -> pathlib.Path:
    """``$NGSGEL_CACHE``, else ``$XDG_CACHE_HOME/ngsgel``, else ``~/.cache/ngsgel``."""
    if os.environ.get(CACHE_VARIABLE):
        return pathlib.Path(os.environ[CACHE_VARIABLE])
    base = os.environ.get("XDG_CACHE_HOME") or pathlib.Path.home() / ".cache"
    return pathlib.Path(base) / "ngsgel"


def _compiler() -> str:
    requested = os.environ.get("CXX")
    if requested:
        found = shutil.which(requested)
        if found is None:
            raise KernelsUnavailable(f"the compiler CXX={requested!r} is not an executable on the PATH")
        return found
    for name in ("g++", "c++", "clang++"):
        found = shutil.which(name)
        if found:
            return found
    raise KernelsUnavailable("no C++ compiler found (CXX is unset and none of g++, c++, clang++ is on the PATH)")


def _flags() -> list[str]:
    import netgen.config
    import ngsolve.config

    include = ngsolve.config.get_include_dir()
    definitions = (netgen.config.ngcore_compile_definitions.split(";")
                   + ngsolve.config.NGSOLVE_COMPILE_DEFINITIONS.split(";"))
    return (["-std=c++20", "-O3", "-fPIC", "-shared", "-fcx-limited-range", "-DMAX_SYS_DIM=3"]
            + netgen.config.ngcore_compile_options.split(";")
            + [f"-D{d}" for d in definitions if d]
            + [f"-I{include}", f"-I{include}/include", f"-I{sysconfig.get_path('include')}"])


def _libraries() -> list[str]:
    import ngsolve.config

    libdir = pathlib.Path(ngsolve.config.__file__).parents[2] / ngsolve.config.NGSOLVE_INSTALL_DIR_LIB
    return [f"-L{libdir}", f"-Wl,-rpath,{libdir}"] + [f"-l{name}" for name in _NGSOLVE_LIBRARIES]


def _module_path() -> pathlib.Path:
    import ngsolve.config

    digest = hashlib.sha256(SOURCE.read_bytes() + "\0".join(_flags() + _libraries()).encode()).hexdigest()[:16]
    return (cache_directory() / "kernels" / ngsolve.config.NGSOLVE_VERSION_GIT / digest
            / (MODULE_NAME + sysconfig.get_config_var("EXT_SUFFIX")))


def _check_headers() -> None:
    import ngsolve.config

    python_include = pathlib.Path(sysconfig.get_path("include"))
    if not (python_include / "Python.h").exists():
        raise KernelsUnavailable(f"no Python headers (Python.h) in {python_include}: install the Python "
                                 f"development package (e.g. python3-dev)")
    ngsolve_include = pathlib.Path(ngsolve.config.get_include_dir())
    if not (ngsolve_include / "comp.hpp").exists():
        raise KernelsUnavailable(f"no NGSolve headers (comp.hpp) in {ngsolve_include}")


def _compile(compiler: str, target: pathlib.Path) -> None:
    """Build into a private file next to ``target`` and rename it into place: a process that
    finds ``target`` never sees a partial file."""
    partial = target.with_name(f"{target.name}.{os.getpid()}.partial")
    print(f"ngsgel: compiling the shell kernels for this NGSolve (once, ~30 s) into {target.parent}",
          file=sys.stderr, flush=True)
    start = time.perf_counter()
    try:
        run = subprocess.run([compiler, *_flags(), str(SOURCE), "-o", str(partial), *_libraries()],
                             capture_output=True, text=True)
        if run.returncode != 0:
            lines = run.stderr.strip().splitlines()
            errors = [line for line in lines if "error" in line.lower()] or lines
            message = "\n".join(errors[:20])
            _failed_builds[target] = f"compiling {SOURCE.name} with {compiler} failed:\n{message}"
            raise KernelsUnavailable(_failed_builds[target])
        os.replace(partial, target)
    finally:
        partial.unlink(missing_ok=True)
    print(f"ngsgel: shell kernels compiled in {time.perf_counter() - start:.0f} s", file=sys.stderr, flush=True)


def load_shell_kernels() -> ModuleType:
    """The compiled kernel module (``ShellArea``, ``ShellEdge``), compiled first if the cache
    has no build for this NGSolve and source. Raises ``KernelsUnavailable`` naming the reason
    (no compiler, no headers, the compiler's error message) when it cannot be built."""
    target = _module_path()
    if target in _loaded:
        return _loaded[target]
    if target in _failed_builds:
        raise KernelsUnavailable(_failed_builds[target])
    if not target.exists():
        compiler = _compiler()
        _check_headers()
        try:
            import fcntl
        except ImportError:
            raise KernelsUnavailable("building the kernels needs a POSIX system (fcntl file locks)") from None
        target.parent.mkdir(parents=True, exist_ok=True)
        # two processes starting at once: the second waits for the first's build instead of
        # compiling the same module again
        with open(target.parent / "build.lock", "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            if not target.exists():
                _compile(compiler, target)
    spec = importlib.util.spec_from_file_location(MODULE_NAME, target)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except ImportError as error:
        raise KernelsUnavailable(f"the cached build {target} does not load: {error}") from error
    if module.THICKNESS_POINTS != THICKNESS_POINTS:
        raise KernelsUnavailable(f"{SOURCE.name} has {module.THICKNESS_POINTS} thickness points, "
                                 f"ngsgel.kernels.THICKNESS_POINTS says {THICKNESS_POINTS}")
    _loaded[target] = module
    return module
