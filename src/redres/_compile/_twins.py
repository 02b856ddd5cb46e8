"""A kernel module in its two forms (internal): compiled, and its plain-Python twin.

While a kernel module compiles behind, its callers answer through the *twin*: a second
module object of the same source, imported with :func:`redres._compile.kernel` as the
identity, so that plain kernels call plain kernels. ``sys.modules`` shows each kernel
module in one form only: during an import it holds only modules of the form asked for,
afterwards the compiled ones where they exist.
"""

from __future__ import annotations

import importlib
import sys
import threading
from types import ModuleType
from typing import Any

from . import _cache

_LOCK = threading.RLock()
#: Imported kernel modules by (name, compiled).
modules: dict[tuple[str, bool], ModuleType] = {}
#: True while a twin is being imported (read by ``kernel``: leave the function plain).
state: dict[str, Any] = {"plain_import": False}


def get(name: str, compiled: bool) -> ModuleType:
    """Kernel module ``name`` compiled or as plain Python (with the kernel modules it
    imports in the same form). Raises ImportError when numba cannot be imported."""
    found = modules.get((name, compiled))
    if found is not None:
        return found
    everyone = _cache.kernel_modules()
    if name not in everyone:
        raise ValueError(f"{name} is not a kernel module of redres (a file named _*kernels.py)")
    with _LOCK:
        if (name, compiled) in modules:
            return modules[(name, compiled)]
        for other in everyone:
            sys.modules.pop(other, None)
            if (other, compiled) in modules:
                sys.modules[other] = modules[(other, compiled)]
        state["plain_import"] = not compiled
        try:
            importlib.import_module(name)
        finally:
            state["plain_import"] = False
            for other in everyone:
                if other in sys.modules:
                    modules.setdefault((other, compiled), sys.modules.pop(other))
                shown = modules.get((other, True)) or modules.get((other, False))
                if shown is not None:
                    sys.modules[other] = shown
        return modules[(name, compiled)]


def is_compiled(module: ModuleType) -> bool:
    """Whether ``module`` is the compiled form of its kernel module."""
    return modules.get((module.__name__, True)) is module
