"""How long a first use compiles (internal, for the messages of :mod:`redres._jit` and
:mod:`redres._behind`): what a kernel module's first compilation compiles (:func:`needs`)
and the measured time of each module (:data:`COLD_SECONDS`)."""

from __future__ import annotations

import importlib.util

from . import _jit

#: Cold compile time of each module's own kernels on a 2-core machine, s (for the
#: messages), with the modules it imports already cached. Measured on an empty cache
#: (2026-12, quiet 2-core machine, compiling on the caller's path): a first
#: ``damped_pinv`` 16.6 s, a first fused controller step 15-17 s, a first SNS step 16-18 s,
#: a first ``rr.ik`` 31 s; ``redres warmup --jobs 1`` per group: chain 4.5 s, batch 53.2.
#: What a first use waits for is the sum over what it :func:`needs`: :func:`cold_seconds`
#: (a module's callees in another module compile only what it calls of them: the sum errs
#: on the long side).
COLD_SECONDS: dict[str, float] = {
    "redres.linalg._dense_kernels": 0.0,  # compiled with the callers in linalg._kernels
    "redres.linalg._eigen_kernels": 0.0,
    "redres.linalg._kernels": 16.0,
    "redres.robot._kernels": 0.0,
    "redres.robot._chain_kernels": 4.5,
    "redres.control._kernels": 1.0,  # a first controller: 15-17 s in all, mostly its callees
    "redres._ik_kernels": 10.0,  # a first rr.ik: 31 s in all with linalg and chain (12-06)
    "redres._batch_kernels": 53.0,
    "redres.resolution.hard_limits._kernels": 17.0,  # the SNS step, with _lp_kernels (12-06)
    "redres.resolution.hard_limits._lp_kernels": 0.0,
    "redres.resolution.hard_limits._qp_kernels": 4.0,
}


def needs(name: str) -> tuple[str, ...]:
    """Kernel module ``name`` and every kernel module it imports, directly or not (from
    the sources' ``import`` statements, without importing them): what its first
    compilation compiles."""
    import ast

    found: dict[str, None] = {}
    todo = [name]
    while todo:
        module = todo.pop()
        if module in found:
            continue
        found[module] = None
        package = module.rsplit(".", 1)[0]
        for node in ast.walk(ast.parse(_jit._module_file(module).read_bytes())):
            if isinstance(node, ast.ImportFrom) and node.module is not None:
                base = importlib.util.resolve_name("." * node.level + node.module, package)
                if base in _jit.KERNEL_MODULES:
                    todo.append(base)
    return tuple(found)


def cold_seconds(*names: str) -> float:
    """Roughly how long the first use of kernel modules ``names`` compiles, s: the
    :data:`COLD_SECONDS` of what they :func:`needs` that is not :func:`redres._jit.cached` yet."""
    wanted = dict.fromkeys(m for name in names for m in needs(name))
    return sum(COLD_SECONDS.get(m, 0.0) for m in wanted if not _jit.cached(m))
