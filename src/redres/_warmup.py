"""Compile the kernels ahead of use: ``redres warmup``, :func:`warmup`, and the background
compiler's process (``python -m redres._warmup --behind MODULE``).

Each warm-up *workload* is a short run through the public API, so that it compiles
exactly the argument types the library's own calls use; it fills the cache of the kernel
group of the same name (:class:`redres._compile.KernelGroup`, declared by its owner).
This module sits at the top of the package: it imports the owners, while
:mod:`redres._compile` imports none of them and starts this module as a process. The
background process compiles the group of the module asked for first (at normal priority,
and with a :func:`helper` process once the machine shows an idle core), then the
serial-chain group, then the others, niced, and marks each group cached as its workload
ends, so that the process that started it switches to the compiled path group by group.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import importlib.util
import os
import shutil
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator, Sequence

import numpy as np

from . import _compile

__all__ = ["WORKLOADS", "warmup"]

#: The helper starts once the machine shows this much of a core idle (the caller's loop
#: and the main compilation running), measured over windows of ``_IDLE_WINDOW`` s; not
#: after ``_IDLE_UNTIL`` s (by then the main compilation is past the helper's kernels).
_IDLE_CORES, _IDLE_WINDOW, _IDLE_UNTIL = 0.5, 0.3, 6.0


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
    PseudoInverseScheme().step(robot, q, J, xd)  # Scheme.step's input check


def _derivatives() -> None:
    from .models import panda

    robot = panda()
    robot.jacobian_derivatives(robot.neutral())


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
    from .resolution import GradientProjectionScheme, PseudoInverseScheme, QPScheme, SNSScheme
    from .tasks import FrameTask

    # The fused step on a serial chain (the common first use) first, from its entry point
    # (its deepest callee first: ready 2 s later); a loop waiting for it switches as soon
    # as it is cached; then the other entry points (some by the helper on an idle core).
    robot = panda()
    scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0, damping=0.01)
    Controller(robot, FrameTask(), scheme, dt=1e-3).step(robot.neutral())
    _compile.groups()["controller"].mark(part="chain_step")
    for entry in ("integrate", "chain_command", "clik_step", "frame_command"):
        _fused.native(entry)
        _compile.groups()["controller"].mark(part=entry)
    Controller(robot, FrameTask(), PseudoInverseScheme(), dt=1e-3).step(robot.neutral())
    # the hard-limit schemes' one-call forms (control._box_kernels; QPScheme: the qp extra)
    for hard in (SNSScheme, QPScheme) if importlib.util.find_spec("qpsolvers") else (SNSScheme,):
        Controller(robot, FrameTask(), hard(dt=1e-3), dt=1e-3).step(robot.neutral())


def _shaping() -> None:
    from .control.shaping import CommandShaper

    CommandShaper(1.0, 10.0, 5000.0, n=2)(np.ones(2))


def _dynamics() -> None:
    from .dynamics import OperationalSpaceController
    from .models import panda

    robot = panda()
    OperationalSpaceController().step(robot, robot.neutral(), np.zeros(robot.n))


def _f(ndim: int, dtype: type = float) -> np.ndarray:
    """An array of ``ndim`` dimensions: its type is what a precompiled kernel takes."""
    return np.zeros((1,) * ndim, dtype=dtype)


def _hard_limits() -> tuple[str, ...] | None:
    from .models import panda
    from .resolution import QPScheme, SNSScheme

    robot = panda()
    q, J = robot.neutral(), robot.jacobian(robot.neutral())
    SNSScheme(dt=1e-3).step(robot, q, J, np.zeros(6))
    # An SNS loop needs no more: it switches now. QPScheme's epilogue (in the same module)
    # compiles next; a QP loop waits for its own module, marked after it (QPScheme._prepare).
    _compile.groups()["hard limits"].mark(modules=["_kernels"])
    if importlib.util.find_spec("qpsolvers") is None:  # said up front, not after minutes
        from .errors import install_hint

        print("redres: hard limits: QPScheme's kernels skipped, the qp extra is not "
              f"installed ({install_hint('qp')}); SNSScheme's are compiled",
              file=sys.stderr, flush=True)  # fmt: skip
        return ("_kernels",)
    QPScheme(dt=1e-3).step(robot, q, J, np.zeros(6))
    return None


def _ik() -> None:
    from .ik.solve import ik
    from .models import panda

    robot = panda()
    ik(robot, robot.fk(robot.neutral() + 0.2), seed=0)


def _analytic_ik() -> None:
    from .ik.analytic import at_q7, at_q7_batch
    from .ik.closed import closed_form_solution
    from .ik.solutions import at_arm_angle
    from .models import iiwa14, panda

    robot = panda()
    q = robot.neutral()
    T = robot.fk(q)
    at_q7(robot, T, q7=float(q[6])).residual  # noqa: B018 - the FK errors' kernel
    at_q7_batch(robot, T[None], q[6:])
    closed_form_solution(robot, None, T, q, 1e-6, 1e-5, 0.0)  # rr.ik's closed form
    srs = iiwa14()
    at_arm_angle(srs, srs.fk(srs.neutral()), arm_angle=0.0)


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


def _plan() -> None:
    from .models import iiwa14
    from .plan import plan_path

    robot = iiwa14()
    T = robot.fk(robot.neutral())
    plan_path(robot, np.stack((T, T)), dt=0.1, resolution=4)
    plan_path(robot, np.stack((T, T, T)), dt=0.1, resolution=4, qdd_max=10.0)  # over edges


def _collision() -> None:
    from .collision import BoxObstacle, CollisionModel, PlaneObstacle, SphereObstacle
    from .models import panda

    robot = panda()
    obstacles = [SphereObstacle(np.array([0.5, 0.0, 0.5]), 0.05),
                 BoxObstacle(np.array([0.5, 0.3, 0.3]), np.full(3, 0.1)),
                 PlaneObstacle(np.array([0.0, 0.0, 1.0]), -0.2)]  # fmt: skip
    CollisionModel(robot, obstacles).compute(robot.neutral(), 0.1)


#: Each kernel group's workload, by the group's name, in the order ``redres warmup`` runs
#: them.
#: A workload returns None, or the modules of its group it compiled when it had to leave
#: some out (a missing extra): only those are marked cached.
WORKLOADS: dict[str, Callable[[], tuple[str, ...] | None]] = {
    "linalg": _linalg,
    "derivatives": _derivatives,
    "chain": _chain,
    "controller": _controller,
    "shaping": _shaping,
    "dynamics": _dynamics,
    "hard limits": _hard_limits,
    "ik": _ik,
    "analytic ik": _analytic_ik,
    "batch": _batch,
    "plan": _plan,
    "collision": _collision,
}


def groups() -> dict[str, _compile.KernelGroup]:
    """Every kernel group, by name (importing their owners declares them)."""
    from . import batch, collision, control, dynamics, ik, linalg, plan  # noqa: F401
    from .ik import analytic  # noqa: F401
    from .resolution import hard_limits  # noqa: F401
    from .robot import chain, derivatives  # noqa: F401

    declared = _compile.groups()
    missing = set(WORKLOADS) ^ set(declared)
    if missing:  # pragma: no cover - a group without a workload, or the reverse
        raise RuntimeError(f"kernel groups and warm-up workloads differ: {sorted(missing)}")
    return {name: declared[name] for name in WORKLOADS}


def _cached(name: str) -> bool:
    """Whether group ``name`` is declared and cached. The background process asks before
    it has imported the other groups' owners (a second of imports before the compilation
    a caller waits for), so an undeclared group counts as not cached: its workload runs
    (loading from the cache, if cached, as fast as the check)."""
    group = _compile.groups().get(name)
    return group is not None and group.cached()


#: What a helper process compiles while the background compiler compiles a group, where
#: a second core is free: callees deep in the group's call tree, on branches the group's
#: workload reaches last (module, kernel, arguments of the types its callers pass; checked
#: by ``tests/compile/test_warmup_helper.py``). The two share the work through the cache
#: and its per-kernel locks: whichever comes to a kernel second waits for it and loads it.
HELPERS: dict[str, list[tuple[str, str, Callable[[], tuple[object, ...]]]]] = {
    "controller": [
        ("redres.linalg._factor_kernels", "_core",
         lambda: (_f(2), 0.0, 0, 0.0, 0.0, 0.0, 0.0, _f(3), _f(1), _f(1))),
        ("redres.control._kernels", "chain_command",
         lambda: (_f(1), _f(1), _f(1), _f(2), _f(1))),
    ],
    "hard limits": [
        ("redres.resolution.hard_limits._lp_kernels", "largest_scale",
         lambda: (_f(2), _f(1), _f(1), _f(1), _f(1), False, 0.0)),
        ("redres.resolution.hard_limits._kernels", "epilogue",
         lambda: (_f(2), _f(1), _f(2), _f(2))),
    ],
}  # fmt: skip


def warmup(groups: Sequence[str] | None = None, *, quiet: bool = False, jobs: int = 2) -> float:
    """Compile the kernels now, on this process's path, and cache them for later
    processes; afterwards this process never answers through the reference path.

    Args:
        groups: names of kernel groups (``"linalg"``, ``"derivatives"``, ``"chain"``,
            ``"controller"``, ``"shaping"``, ``"dynamics"``, ``"hard limits"``, ``"ik"``,
            ``"analytic ik"``, ``"batch"``, ``"plan"``); default all.
        quiet: print nothing (else, for each group that compiles, what it is for, about
            how long it takes, its progress every few seconds and the time it took, on
            standard error; a cached group prints nothing).
        jobs: processes to compile in (``2``: the hard-limit group, the longest, in a
            second process while this one compiles the rest).

    Returns:
        The wall-clock time, s (short when the cache was already warm).
    """
    names = list(WORKLOADS) if groups is None else list(dict.fromkeys(groups))
    unknown = [g for g in names if g not in WORKLOADS]
    if unknown:
        from .errors import InvalidParameterError

        raise InvalidParameterError(f"unknown warm-up groups {unknown}; known: {list(WORKLOADS)}")
    _compile.compile_on_first_use()
    start = time.perf_counter()
    side = _side_process(names) if jobs > 1 and len(names) > 1 else None
    _compile.quiet(True)  # one line per group below instead of one per module
    try:
        timed([(name, _marking(name)) for name in names], quiet=quiet)
    finally:
        _compile.quiet(False)
    if side is not None:
        with _progress("hard limits", quiet) as announced:  # still compiling: say so
            status = side.wait()
        if status != 0:
            raise RuntimeError(f"redres: the warm-up process failed (status {status})")
        if announced:
            print(f"redres: compiled {_words('hard limits')} in a second process, "
                  f"{time.perf_counter() - start:.1f} s", file=sys.stderr, flush=True)  # fmt: skip
    return time.perf_counter() - start


#: What each kernel group computes, in a user's words (the warm-up's progress lines).
GROUP_WORDS = {
    "linalg": "inverses and projectors",
    "derivatives": "Jacobian derivatives",
    "chain": "forward kinematics",
    "controller": "the 1 kHz controller",
    "shaping": "command shaping",
    "dynamics": "the torque-control step",
    "hard limits": "the hard-limit schemes (SNS, QP)",
    "ik": "inverse kinematics",
    "analytic ik": "closed-form inverse kinematics",
    "batch": "batched kinematics and IK",
    "plan": "path planning by dynamic programming",
    "collision": "collision distances",
}

#: Seconds between progress lines while a group compiles (a log without a terminal
#: gets a line at this pace; a terminal sees one line updated in place).
TICK = 5.0


def timed(tasks: Sequence[tuple[str, Callable[[], object]]], *, quiet: bool = False) -> float:
    """Run warm-up calls (``(label, call)`` pairs that compile what they touch); returns the
    total, s. Unless ``quiet``, a call still running after a second (it compiles: a cached
    group loads faster) is announced on standard error with what it is for and about how
    long it takes, followed every :data:`TICK` seconds by how long it has run, and closed
    with the time it took; a cached group prints nothing."""
    total = 0.0
    for label, call in tasks:
        begin = time.perf_counter()
        with _progress(label, quiet) as announced:
            call()
        seconds = time.perf_counter() - begin
        total += seconds
        if announced:
            print(f"redres: compiled {_words(label)} in {seconds:.1f} s (cached for later runs)",
                  file=sys.stderr, flush=True)  # fmt: skip
    return total


def _words(label: str) -> str:
    return f"{GROUP_WORDS[label]} ({label})" if label in GROUP_WORDS else label


@contextlib.contextmanager
def _progress(label: str, quiet: bool) -> Iterator[list[bool]]:
    """While the body runs: after a second, a line saying what compiles and about how
    long; then every :data:`TICK` seconds how long it has run (in place on a terminal,
    new lines in a log). Yields a list that holds True once the line is out."""
    announced: list[bool] = []
    if quiet:
        yield announced
        return
    stop = threading.Event()
    terminal = sys.stderr.isatty() and shutil.get_terminal_size((0, 0)).columns > 0
    start = time.perf_counter()

    def tick() -> None:
        if stop.wait(1.0):
            return
        group = _compile.groups().get(label)  # declared by now: the workload imported it
        estimate = group.cold_estimate() if group is not None else 0.0
        about = f"about {estimate:.0f} s on one core" if estimate >= 1 else ""
        print(f"redres: compiling {_words(label)} for its first use"
              + (f", {about}" if about else "") + "...", file=sys.stderr, flush=True)  # fmt: skip
        announced.append(True)
        while not stop.wait(TICK):
            seconds = time.perf_counter() - start
            more = f" of {about}" if seconds <= estimate else (  # not "12 s of about 5 s"
                f", longer than the {estimate:.0f} s it takes on an idle core")  # fmt: skip
            line = f"redres:   ... {seconds:.0f} s" + (more if about else "")
            print(f"\r{line}" if terminal else line, end="" if terminal else "\n",
                  file=sys.stderr, flush=True)  # fmt: skip

    thread = threading.Thread(target=tick, name="redres-warmup-progress", daemon=True)
    thread.start()
    try:
        yield announced
    finally:
        stop.set()
        thread.join()
        if terminal and time.perf_counter() - start >= 1.0 + TICK:
            print(file=sys.stderr, flush=True)  # end the line updated in place


def _side_process(names: list[str]) -> subprocess.Popen[bytes] | None:
    """Start the hard-limit group in a second process (and drop it from ``names``)."""
    if "hard limits" not in names or _cached("hard limits"):
        return None
    names.remove("hard limits")
    args = [sys.executable, "-m", "redres._warmup", "--jobs", "1", "--quiet", "hard limits"]
    return subprocess.Popen(args, stdin=subprocess.DEVNULL, env=_compile.child_env())


def _marking(name: str) -> Callable[[], None]:
    def call() -> None:
        if _cached(name):
            return  # loaded from the cache on first use
        done = WORKLOADS[name]()  # imports the group's owner, which declares it
        if done is None:
            _compile.groups()[name].mark(workload=True)
        else:
            _compile.groups()[name].mark(modules=done)

    return call


# --------------------------------------------------------------------------- behind


def behind(first: str) -> None:
    """The background process: the group of kernel module ``first``, then the serial-chain
    group (the controller's and IK's readiness needs it; a short one), then the others."""
    importlib.import_module(first.rsplit(".", 1)[0])  # its package declares its group
    declared = _compile.groups()
    lead = next((n for n, g in declared.items() if first in g.modules), "linalg")
    order = sorted(WORKLOADS, key=lambda g: (g != lead, g != "chain"))
    helpers: list[subprocess.Popen[bytes]] = []
    starter = _start_helper(order[0], helpers)
    try:
        warmup(order[:1], quiet=True, jobs=1)  # a caller waits for this one
        if hasattr(os, "nice"):
            os.nice(10)  # the rest: the user's process comes first
        warmup(order[1:], quiet=True, jobs=1)
    finally:
        _compile.release_lock()
        if starter is not None:
            starter.join()
        for proc in helpers:
            proc.wait()


def helper(group: str) -> None:
    """The helper process of :func:`behind`: compile :data:`HELPERS` of ``group``."""
    for module, kernel, arguments in HELPERS.get(group, ()):
        _compile.precompile(module, kernel, *arguments())


def _start_helper(group: str, started: list[subprocess.Popen[bytes]]) -> threading.Thread | None:
    """Start :func:`helper` for ``group`` (into ``started``) from a thread, once the
    machine shows an idle core beside this compilation and the caller's loop. A caller
    that spins on the reference path takes the other core: three processes on two cores
    would only slow the group down."""
    if group not in HELPERS or _compile.cores() < 2 or _cached(group):
        return None

    def start() -> None:
        deadline = time.monotonic() + _IDLE_UNTIL
        # The caller sets up (imports, its own numba) for about a second: its loop shows
        # what it leaves idle only then.
        while _compile.idle_cores(_IDLE_WINDOW) < _IDLE_CORES:
            if time.monotonic() > deadline:
                return
        args = [sys.executable, "-m", "redres._warmup", "--helper", group]
        try:
            started.append(subprocess.Popen(args, stdin=subprocess.DEVNULL,
                                            env=_compile.child_env()))  # fmt: skip
        except OSError:  # the group compiles in this process alone
            pass

    thread = threading.Thread(target=start, name="redres-helper-start", daemon=True)
    thread.start()
    return thread


def main(argv: Sequence[str] | None = None) -> int:
    """``python -m redres._warmup``: the background compiler (``--behind MODULE``), its
    helper (``--helper GROUP``), or a warm-up of the groups named (all by default)."""
    parser = argparse.ArgumentParser(prog="python -m redres._warmup")
    parser.add_argument("groups", nargs="*")
    parser.add_argument("--behind", metavar="MODULE")
    parser.add_argument("--helper", metavar="GROUP")
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--quiet", action="store_true")
    args = parser.parse_args(argv)
    if args.behind:
        behind(args.behind)
    elif args.helper:
        helper(args.helper)
    else:
        warmup(args.groups or None, quiet=args.quiet, jobs=args.jobs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
