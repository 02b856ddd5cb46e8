"""The hard-limit kernel modules, loaded through :mod:`redres._jit` on first use (internal)."""

from __future__ import annotations

from types import ModuleType

from ... import _jit
from ...errors import MissingDependencyError

_PACKAGE = "redres.resolution.hard_limits."


def kernels(name: str = "_kernels", *, plain: bool = False) -> ModuleType:
    """Kernel module ``name`` of this package (``_kernels``, ``_lp_kernels``, ``_qp_kernels``):
    compiled, or its plain-Python twin while it compiles behind (:func:`redres._jit.load`);
    ``plain``: the twin in any case (a scheme whose other module is still compiling).

    Raises:
        MissingDependencyError: numba cannot be imported (the hard-limit schemes have no
            NumPy path; ``REDRES_DISABLE_JIT=1`` runs their kernels as plain Python).
    """
    module = _jit.load(_PACKAGE + name, plain=plain)
    if module is None:
        raise MissingDependencyError(
            "the hard-limit schemes need numba (a dependency of redres), which cannot be "
            "imported; reinstall it, or set REDRES_DISABLE_JIT=1 to run them as plain Python"
        )
    return module


def pending(*names: str) -> tuple[str, ...]:
    """Those of the kernel modules ``names`` that are still compiling behind: a scheme
    that prepared its entry points on their plain twins prepares again once none is."""
    return tuple(_PACKAGE + n for n in names if not _jit.is_compiled(kernels(n)) and _jit.enabled())
