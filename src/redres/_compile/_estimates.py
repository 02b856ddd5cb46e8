"""How long a first use compiles (internal): what a kernel module's first compilation
compiles (:func:`needs`) and the sum of the figures the kernel groups declare for it
(:func:`cold_seconds`), for the messages of :mod:`redres._compile`."""

from __future__ import annotations

import ast
import importlib.util
from collections.abc import Callable, Mapping

from . import _cache


def needs(name: str) -> tuple[str, ...]:
    """Kernel module ``name`` and every kernel module it imports, directly or not (from
    the sources' ``import`` statements, without importing them): what its first
    compilation compiles."""
    kernels = set(_cache.kernel_modules())
    found: dict[str, None] = {}
    todo = [name]
    while todo:
        module = todo.pop()
        if module in found:
            continue
        found[module] = None
        package = module.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(_cache.module_file(module).read_bytes())):
            if isinstance(node, ast.ImportFrom) and node.module is not None:
                base = importlib.util.resolve_name("." * node.level + node.module, package)
                if base in kernels:
                    todo.append(base)
    return tuple(found)


def cold_seconds(
    figures: Mapping[str, float], names: tuple[str, ...], cached: Callable[[str], bool]
) -> float:
    """Roughly how long the first use of kernel modules ``names`` compiles, s: the
    ``figures`` (seconds by module) of what they :func:`needs` that is not ``cached``
    (a module's callees in another module compile only what it calls of them: the sum
    errs on the long side)."""
    wanted = dict.fromkeys(m for name in names for m in needs(name))
    return sum(figures.get(m, 0.0) for m in wanted if not cached(m))
