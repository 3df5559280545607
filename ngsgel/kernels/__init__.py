"""Compiled C++ kernels: the shell energy's residual and tangent (``GelShell(kernels=...)``).

The source ships with the package and is compiled at first use into a per-user cache
(``$NGSGEL_CACHE``, else ``$XDG_CACHE_HOME/ngsgel`` or ``~/.cache/ngsgel``); see ``loader``.
"""

from .loader import THICKNESS_POINTS, KernelsUnavailable, cache_directory, load_shell_kernels

__all__ = ["THICKNESS_POINTS", "KernelsUnavailable", "cache_directory", "load_shell_kernels"]
