"""Routing of :mod:`redres.linalg` between its compiled kernels and NumPy (internal).

linalg's kernel group (:data:`KERNELS`), whether callers route to compiled code
(:func:`routed`, :func:`set_jit_enabled`), which sizes take the kernels
(:func:`use_fast_path`) and their entry points. The inverse engine that uses them is
:mod:`._engine`. Other packages' compiled paths (the controller, batches, the scheme
input check, the Jacobian derivatives) route through here too.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .. import _compile
from .._validate import as_scalar
from . import _codes as codes
from ._info import AdaptiveDamping

FloatArray = NDArray[np.float64]

FAST_MAX_ROWS = 6  # any shape up to this many rows ...
FAST_MAX_SQUARE_ROWS = 12  # ... and wide or square Jacobians (m <= n) up to this many
FAST_MAX_COLS = 50


_state: dict[str, Any] = {"enabled": _compile.enabled()}

#: linalg's kernels (the first answers the library's calls; the others hold the one
#: factorisation, the dense helpers and the eigenvalue kernels it calls). Cold: a first
#: ``damped_pinv`` 16 s.
KERNELS = _compile.KernelGroup(
    "linalg",
    (
        "redres.linalg._kernels",
        "redres.linalg._factor_kernels",
        "redres.linalg._dense_kernels",
        "redres.linalg._eigen_kernels",
    ),
    cold_seconds=16.0,
)
loaded: ModuleType | None = None
"""The kernel module once imported and enabled."""


def kernels() -> ModuleType | None:
    """The compiled kernel module; None if disabled, unavailable, or compiling behind
    (NumPy answers meanwhile; the switch, for good, runs the :data:`_on_switch` hooks)."""
    global loaded
    if loaded is not None or not _state["enabled"] or _state.get("failed"):
        return loaded
    loaded = KERNELS.compiled()
    if loaded is None and not KERNELS.pending():
        # it became ready between the two questions (a background compile that failed
        # at once: compiled on first use now); None again means numba is not there
        loaded = KERNELS.compiled()
    if loaded is not None:
        for hook in _on_switch:
            hook()
    elif not KERNELS.pending():  # numba missing or broken: keep working on NumPy
        _state["failed"] = True
        warnings.warn(
            "redres.linalg: compiled kernels unavailable (numba cannot be imported); using NumPy",
            UserWarning,
            stacklevel=3,
        )
    return loaded


def routed() -> bool:
    """Whether callers route to compiled kernels: linalg's switch
    (:func:`set_jit_enabled`) is on and numba is there. The controller, the Jacobian
    derivatives and the scheme input check follow it."""
    return bool(_state["enabled"]) and not _state.get("failed")


def entry(
    group: _compile.KernelGroup, name: str, warm: tuple[Any, ...]
) -> Callable[..., Any] | None:
    """The native entry point of kernel ``name`` of ``group``'s first module for the types
    of ``warm`` (:meth:`~redres._compile.KernelGroup.entry`; plain Python while it
    compiles behind); None when the kernels are off (:func:`routed`) or unavailable."""
    return group.entry(name, warm) if routed() else None


def fast_step() -> Callable[..., Any] | None:
    """Native entry point of ``_kernels.step`` (no per-call type dispatch): callers must
    pass float64 C-contiguous arrays (``J`` 2-D, the rest 1-D) and Python floats."""
    if kernels() is None:
        return None
    warm = (np.zeros((1, 1)), np.zeros(1), np.zeros(1), np.zeros(1), np.zeros(1), 0.0, 0.0, 0.0)
    return entry(KERNELS, "step", warm)


def set_jit_enabled(enabled: bool) -> bool:
    """Route :mod:`redres.linalg` and the controller to the kernels or to NumPy (tests,
    comparisons; a no-op under ``REDRES_DISABLE_JIT=1``); returns the old value."""
    global loaded
    previous = bool(_state["enabled"])
    _state["enabled"] = bool(enabled) and _compile.enabled()
    if not enabled:
        loaded = None
    for hook in _on_switch:
        hook()
    return previous


_on_switch: list[Callable[[], None]] = []  # run when the routing changes (cached entries)


@contextmanager
def jit_enabled(enabled: bool) -> Iterator[None]:
    """A block with the kernels on or off (:func:`set_jit_enabled`), then as before."""
    previous = set_jit_enabled(enabled)
    try:
        yield
    finally:
        set_jit_enabled(previous)


def use_fast_path(m: int, n: int) -> ModuleType | None:
    """Kernels if ``m x n`` is small enough for them and they are available: up to 6 rows,
    or up to 12 rows when ``m <= n`` (stacked and augmented Jacobians); at most 50 columns."""
    if m <= 0 or n <= 0 or n > FAST_MAX_COLS:
        return None
    if m <= FAST_MAX_ROWS or (m <= FAST_MAX_SQUARE_ROWS and m <= n):
        return kernels()
    return None


def parse_damping(damping: float | AdaptiveDamping) -> tuple[int, float, float, float]:
    """``(mode, lambda, lambda_max, eps)`` for the kernels from a ``damping`` argument."""
    if type(damping) is float and 0.0 < damping < math.inf:  # the common case, valid
        return codes.FIXED, damping, 0.0, 1.0
    if isinstance(damping, AdaptiveDamping):
        mode = codes.SELECTIVE if damping.selective else codes.ADAPTIVE
        return mode, 0.0, damping.max_damping, damping.threshold
    lam = as_scalar(damping, "damping", minimum=0.0)
    return (codes.FIXED if lam > 0.0 else codes.EXACT), lam, 0.0, 1.0
