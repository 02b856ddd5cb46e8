"""Compile the kernels ahead of use: ``redres warmup``, :func:`warmup`, and what the
background compiler (:mod:`redres._behind`) compiles.

Each *group* is a short workload through the public API (so that it compiles exactly the
argument types the library's own calls use) and the kernel modules it fills the cache of.
:func:`behind` is the background process :mod:`redres._jit` starts on a cold cache: it
compiles the group of the module asked for first, then the others, and marks each module
as cached as soon as its group is done, so that the process that started it switches to
the compiled path group by group.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable, Sequence

import numpy as np

from . import _behind, _jit

__all__ = ["GROUPS", "warmup"]


def _linalg() -> None:
    from . import linalg
    from .models import panda
    from .resolution import PseudoInverseScheme

    robot = panda()
    q = robot.neutral()
    J, M = robot.jacobian(q), robot.mass_matrix(q)
    xd, g = np.ones(6), np.ones(robot.n)
    linalg.damped_pinv(J, 0.01)
    linalg.pinv(J)
    linalg.weighted_pinv(J, M)
    linalg.adaptive_damped_pinv(J, 0.1, 0.05)
    linalg.nullspace_projector(J)
    linalg.dynamically_consistent_pinv(J, M)
    linalg.manipulability(J)
    for damping in (0.0, 0.01, linalg.AdaptiveDamping(0.1, 0.05)):
        linalg.rate_step(J, xd, g, damping=damping)
        linalg.rate_step(J, xd, g, damping=damping, return_null=True)
        linalg.rate_step(J, xd, damping=damping)
    robot.jacobian_derivatives(q)
    PseudoInverseScheme().step(robot, q, J, xd)  # Scheme.step's input check


def _chain() -> None:
    from .models import panda
    from .robot.chain import log3

    robot = panda()
    q = robot.neutral()
    chain = robot.chain()
    chain.kinematics(q)
    chain.kinematics(q, "local")
    chain.pose_error(q, robot.fk(q))
    log3(np.eye(3))


def _controller() -> None:
    from .control import Controller, _fused
    from .models import panda
    from .objectives import JointLimitObjective
    from .resolution import GradientProjectionScheme, PseudoInverseScheme
    from .tasks import FrameTask

    # The fused step on a serial chain (the common first use) first, from its deepest
    # callee up (the helper compiles its other branches meanwhile); a loop waiting for
    # it switches as soon as it is cached; then the other entry points.
    _jit.precompile(_fused._KERNELS, "_resolve", _f(2), *[_f(1)] * 6)
    robot = panda()
    scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0, damping=0.01)
    Controller(robot, FrameTask(), scheme, dt=1e-3).step(robot.neutral())
    _jit.mark_cached([_fused._KERNELS], part="chain_step")
    for entry in ("integrate", "chain_command", "clik_step", "frame_command"):
        _fused.native(entry)
        _jit.mark_cached([_fused._KERNELS], part=entry)
    Controller(robot, FrameTask(), PseudoInverseScheme(), dt=1e-3).step(robot.neutral())


def _f(ndim: int, dtype: type = float) -> np.ndarray:
    """An array of ``ndim`` dimensions: its type is what a precompiled kernel takes."""
    return np.zeros((1,) * ndim, dtype=dtype)


def _hard_limits() -> None:
    from .models import panda
    from .resolution import QPScheme, SNSScheme

    robot = panda()
    q = robot.neutral()
    J = robot.jacobian(q)
    SNSScheme(dt=1e-3).step(robot, q, J, np.zeros(6))
    # An SNS loop needs no more: it switches now. QPScheme's epilogue (in the same module)
    # compiles next; a QP loop waits for its own module, marked after it (QPScheme._prepare).
    _jit.mark_cached(["redres.resolution.hard_limits._kernels"])
    QPScheme(dt=1e-3).step(robot, q, J, np.zeros(6))


def _ik() -> None:
    from .ik import ik
    from .models import panda

    robot = panda()
    ik(robot, robot.fk(robot.neutral() + 0.2), seed=0)


def _batch() -> None:
    from . import batch, linalg
    from .models import panda

    robot = panda()
    q = np.tile(robot.neutral(), (2, 1))
    batch.fk(robot, q)
    batch.jacobian(robot, q, poses=np.empty((2, 4, 4)))
    batch.jacobian(robot, q, reference="local")
    for damping in (0.0, 0.01, linalg.AdaptiveDamping(0.1, 0.05)):
        batch.rate_step(robot, q, np.ones(6), damping=damping)
        batch.rate_step(robot, q, np.ones((2, 6)), q, damping=damping)
    batch.rate_step(robot, q, np.ones(6), weights=np.ones(robot.n))
    batch.rate_step(robot, q, np.ones(6), weights=np.eye(robot.n))
    batch.ik(robot, batch.fk(robot, q), max_restarts=1)


#: Group name -> (kernel modules it caches, workload).
GROUPS: dict[str, tuple[tuple[str, ...], Callable[[], None]]] = {
    "linalg": (
        ("redres.linalg._kernels", "redres.linalg._dense_kernels",
         "redres.linalg._eigen_kernels", "redres.robot._kernels"),
        _linalg,
    ),
    "chain": (("redres.robot._chain_kernels",), _chain),
    "controller": (("redres.control._kernels",), _controller),
    "hard limits": (
        ("redres.resolution.hard_limits._kernels", "redres.resolution.hard_limits._lp_kernels",
         "redres.resolution.hard_limits._qp_kernels"),
        _hard_limits,
    ),
    "ik": (("redres._ik_kernels",), _ik),
    "batch": (("redres._batch_kernels",), _batch),
}  # fmt: skip


#: What a helper process compiles while the background compiler (:func:`redres._behind.run`)
#: compiles a group, where a second
#: core is free: callees deep in the group's call tree, on branches the group's workload
#: reaches last (module, kernel, arguments of the types its callers pass; checked by
#: ``tests/test_warmup_helper.py``). The two share the work through the cache and its
#: per-kernel locks (:mod:`redres._compile_lock`): whichever comes to a kernel second
#: waits for it and loads it.
HELPERS: dict[str, list[tuple[str, str, Callable[[], tuple[object, ...]]]]] = {
    "controller": [
        ("redres.linalg._kernels", "_core",
         lambda: (_f(2), 0.0, 0, 0.0, 0.0, 0.0, 0.0, _f(3), _f(1), _f(1))),
        ("redres.control._kernels", "chain_command",
         lambda: (_f(1), _f(1), _f(1), _f(2), _f(1))),
    ],
    "hard limits": [
        ("redres.resolution.hard_limits._lp_kernels", "largest_scale",
         lambda: (_f(2), _f(1), _f(1), _f(1), _f(1), False, 0.0)),
        ("redres.resolution.hard_limits._kernels", "epilogue",
         lambda: (_f(2), _f(1), _f(2), _f(3), _f(2), False, False)),
    ],
}  # fmt: skip


def warmup(groups: Sequence[str] | None = None, *, quiet: bool = False, jobs: int = 2) -> float:
    """Compile the kernels now, on this process's path, and cache them for later
    processes; afterwards this process never answers through the reference path.

    Args:
        groups: names of :data:`GROUPS` (``"linalg"``, ``"chain"``, ``"controller"``,
            ``"hard limits"``, ``"ik"``, ``"batch"``); default all.
        quiet: print nothing (else one line per group on standard error: what it
            compiled and how long it took).
        jobs: processes to compile in (``2``: the hard-limit group, the longest, in a
            second process while this one compiles the rest).

    Returns:
        The wall-clock time, s (short when the cache was already warm).
    """
    names = list(GROUPS) if groups is None else list(dict.fromkeys(groups))
    unknown = [g for g in names if g not in GROUPS]
    if unknown:
        from .errors import InvalidParameterError

        raise InvalidParameterError(f"unknown warm-up groups {unknown}; known: {list(GROUPS)}")
    _jit.compile_on_first_use()
    start = time.perf_counter()
    side = _side_process(names) if jobs > 1 and len(names) > 1 else None
    _jit._state["quiet"] = True  # one line per group below instead of one per module
    try:
        _jit.warmup([(name, _marking(name)) for name in names], quiet=quiet)
    finally:
        _jit._state["quiet"] = False
    if side is not None:
        if side.wait() != 0:
            raise RuntimeError(f"redres: the warm-up process failed (status {side.returncode})")
        if not quiet:
            print(f"redres: hard limits: {time.perf_counter() - start:.1f} s (second process)",
                  file=sys.stderr, flush=True)  # fmt: skip
    return time.perf_counter() - start


def _side_process(names: list[str]) -> subprocess.Popen[bytes] | None:
    """Start the hard-limit group in a second process (and drop it from ``names``)."""
    if "hard limits" not in names or all(map(_jit.cached, GROUPS["hard limits"][0])):
        return None
    names.remove("hard limits")
    args = [sys.executable, "-m", "redres", "warmup", "--jobs", "1", "--quiet", "hard limits"]
    return subprocess.Popen(args, stdin=subprocess.DEVNULL, env=_behind.child_env())


def _marking(name: str) -> Callable[[], None]:
    modules, workload = GROUPS[name]

    def call() -> None:
        if modules and all(map(_jit.cached, modules)):
            return  # loaded from the cache on first use
        workload()
        _jit.mark_cached(modules, workload=True)

    return call
