"""Position inverse kinematics: ``rr.ik(robot, target)`` finds ``q`` with ``fk(q) = target``.

Closed-loop inverse kinematics (CLIK) iterated to convergence (Siciliano, Sciavicco,
Villani, Oriolo, *Robotics*, 2009, §3.7; damping that shrinks with the error as in the
Levenberg–Marquardt method of Sugihara, IEEE Trans. Robot. 27(5), 2011).
Each iteration, from the error ``e = [p_d − p; log(R_d Rᵀ)]`` (docs/conventions.md)::

    dq = J# e − k_null N ∇D(q),     N = I − J# J,     q ← clip(q + s·dq, q_min, q_max)

* ``J#`` is the adaptively damped inverse of :func:`redres.linalg.rate_step`: exact
  (a Newton step, quadratic convergence) while ``σ_min(J) ≥ threshold``, damped near
  singularities (Chiaverini, Siciliano & Egeland 1994). Its damping is further scaled by
  ``min(1, ‖e‖ / 0.1)`` so that it vanishes as the error does: damped least squares with a
  fixed λ converges only linearly, and crawls where ``σ_min`` is small at the solution.
* ``N ∇D`` is the null-space term of the same inverse, ``D`` the joint-limit cost of
  Liégeois (1977), scaled by the same factor so that it fades out near the solution and cannot
  hold the error above the tolerance.
* A preference (``q_preferred``: ``D = ½‖q − q_preferred‖²``; ``arm_angle``: a second
  priority level, :func:`redres.resolution.priority.prioritized_velocity`) starts only
  once the target is met (phase 2, with its own ``max_iterations``), so it never hinders
  convergence: each iteration adds a null-space step toward it (half the linearised
  distance, at most 0.1 rad per joint, halved for good whenever it reverses direction, an
  overshoot on the curved self-motion manifold) while the Newton step keeps the target.
  It ends when the joints move less than ``preference_tol``: a local optimum on the
  solution set (first-order condition ``N (q − q_preferred) = 0`` away from limits);
  joints stopped at a limit stay clamped. If the budget runs out first, the last
  configuration that met the target is returned, converged, with a note in ``message``.
  An ``arm_angle`` missed by more than ``ARM_ANGLE_TOL`` (the branch of the self-motion
  reached may not contain it within the limits) is sought again from random
  configurations while the budget lasts; the result closest to it is returned, with
  ``arm_angle`` (reached) and ``preference_met`` set, and the miss in ``message``.
* ``s ≤ 1`` scales the step so that no joint moves more than ``max_step`` per iteration,
  then joints are clipped into their limits. Before that, joints at a limit that the step
  pushes outward are *clamped*: their Jacobian columns are zeroed and the step recomputed
  (up to three passes), so that the other joints do the work instead of the clip undoing
  part of a Newton step. The result is always within the limits.
* An attempt that stops making progress (the error not halved over ``patience``
  iterations, or not 1 % lower over the last 3: a local minimum, typically with joints
  clamped at their limits) or uses ``max_iterations`` restarts from a configuration drawn
  uniformly within the middle 70 % of each joint range (:data:`~redres.ik.options.RESTART_SPAN`;
  starts near a limit end clamped there more often) by the seeded generator, up to
  ``max_restarts`` times, all within ``timeout_s``. The best configuration found is
  returned with ``converged=False`` when the budget runs out (unreachable targets).

Speed: inputs are validated once. For a frame at the end of a serial chain
(:class:`~redres.robot.SerialChain`) the iteration then runs compiled
(:mod:`redres.ik._kernels`: the chain kernels for the error and Jacobian, the compiled
rate step of :mod:`redres.linalg`, no Pinocchio call, nothing written into
``robot.data``): one kernel call for the first attempt, then calls of as many restarts
as fit in ``max_iterations`` iterations (the call ends after the attempt that reaches
them), the clock read between calls: the time budget is checked at least every
``2 max_iterations`` iterations (well under a millisecond), not every iteration. The
restart configurations come from that module's counter-based generator, keyed by the
integer ``seed`` itself, by the first ``integers(0, 2**62)`` draw of a generator given as
``seed``, or by fresh entropy (``seed=None``); the draws depend on no generator's later
state. The arm-angle preference, frames that are not at the end of a serial chain, and
processes whose kernels are still compiling behind take the reference path
(:mod:`redres.ik.reference`: the same iteration in Python on Pinocchio, writing into
``robot.data``, the clock read every iteration, the restarts the same counter-based draws);
``tests/ik/test_ik_compiled.py`` checks the two against each other.

Determinism: the default budget has a wall-clock part (``timeout_s=0.5``), so when it binds
the result depends on the machine's speed and load. ``timeout_s=None`` leaves only the
iteration budget (``max_iterations`` per attempt, ``max_restarts`` restarts): with an
integer ``seed`` the result is then a function of the inputs alone, bit-identical across
processes on one path (compiled, or the reference path with ``REDRES_DISABLE_JIT=1``;
``tests/ik/test_ik.py::test_iteration_budget_is_deterministic_across_processes``). The two
paths take the same steps: the closed form first where it applies, the same first guess,
the same restart configurations (the counter-based draws). Where the closed form answers
(the default on the Panda, FR3, iiwa14 and srs7 with a full pose) they agree to 1e-11 rad
(300 of 300 random targets on each arm); where they iterate (other arms, ``analytic=False``,
positions, preferences) the kinematics' rounding (Pinocchio's against the compiled
chain's) can take an iteration that starts far from the target to another solution of the
same pose: 53 of 300 random Panda targets with ``analytic=False``, each within the
tolerances. A process whose kernels are still compiling behind takes the reference path
(``redres warmup`` compiles them first).

Bad input: a target containing NaN or infinity returns ``converged=False`` with a
message and no iteration (a sensor glitch should not raise inside a control program); a
target of the wrong shape or a 4x4 that is not a homogeneous transform raises
:class:`~redres.errors.ShapeError` (a programming error), as do bad parameters.
"""

from __future__ import annotations

import dataclasses
import math
import secrets
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np

from .. import _compile
from .._validate import FloatArray, as_scalar, as_seed, as_vector
from ..errors import InvalidParameterError
from ..linalg import AdaptiveDamping, rate_step
from . import _layout as layout
from .closed import answer, full_pose
from .options import IKResult, _Options, _options, _parse_target, limit_arrays
from .reference import ReferenceSolver, arm_angle_solve

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["IKResult", "ik"]

#: The compiled iteration. Cold: a first ``rr.ik`` 31 s in all with linalg and the chain.
KERNELS = _compile.KernelGroup(
    "ik", ("redres.ik._kernels", "redres.ik._step_kernels"), cold_seconds=10.0
)


def ik(
    robot: Robot,
    target: Any,
    frame: str | None = None,
    *,
    q0: Any = None,
    position_only: bool = False,
    tol_position: float = 1e-6,
    tol_orientation: float = 1e-5,
    max_iterations: int = 100,
    max_restarts: int = 50,
    timeout_s: float | None = 0.5,
    seed: int | np.random.Generator | None = None,
    q_preferred: Any = None,
    arm_angle: float | None = None,
    max_step: float = 0.5,
    k_limits: float = 0.1,
    damping: AdaptiveDamping | None = None,
    patience: int = 10,
    preference_tol: float = 1e-5,
    analytic: bool = True,
) -> IKResult:
    """Joint configuration that puts ``frame`` at ``target`` (see the module docstring).

    Args:
        robot: the robot.
        target: 4x4 pose ``T_world_frame`` (as :meth:`Robot.fk` returns), or a position
            ``(3,)`` in m for a position-only target.
        frame: frame to place (``None``: the robot's tip).
        q0: first guess, shape ``(n,)``, rad (clipped into the limits); default
            ``q_preferred`` if given, else ``robot.neutral()``.
        position_only: ignore the orientation of a 4x4 ``target``.
        tol_position: position tolerance, m (> 0).
        tol_orientation: orientation tolerance (rotation angle), rad (> 0).
        max_iterations: iterations per attempt, and again for a preference (>= 1).
        max_restarts: random restarts after the first attempt (>= 0).
        timeout_s: wall-clock budget of the whole solve, s (> 0), on top of the iteration
            budget (``max_iterations`` per attempt, ``max_restarts`` restarts); whichever
            runs out first ends the solve. ``None``: no wall-clock budget, so the result
            depends only on the inputs and ``seed``: deterministic, bit-identical across
            processes (module docstring, "Determinism"). The default 0.5 s is a wall-clock
            budget: when it binds (a slow or loaded machine, a hard target), results
            differ between runs. (The first call in a process also loads the compiled
            kernels of :mod:`redres.linalg`, before the clock starts.)
        seed: key (a non-negative integer) or generator of the random restarts
            (``None``: fresh entropy; module docstring).
        q_preferred: preferred configuration, shape ``(n,)``: among the solutions, one
            locally closest to it (module docstring).
        arm_angle: preferred arm angle, rad, of a 7-DOF arm with ``shoulder``, ``elbow``
            and ``wrist`` frames (a second priority level; exclusive with ``q_preferred``).
        max_step: largest joint change per iteration, rad (> 0).
        k_limits: gain of the joint-limit null-space term (>= 0).
        damping: adaptive damping of the inverse (default ``AdaptiveDamping(0.05, 0.05)``).
        patience: iterations over which the error must halve before a restart (>= 1).
        preference_tol: with a preference, the joint change (rad, max-norm) below which
            the preference has settled.
        analytic: on an arm with a closed form (:mod:`redres.ik.analytic`: Panda, FR3,
            iiwa14, srs7), for a full-pose target without a preference, take the closed
            form's within-limits solution nearest ``q0`` (at ``q0``'s last joint, or at
            other values of it, or on S-R-S arms at other arm angles) before iterating
            (:mod:`redres.ik.closed`); False: iterate only.

    Returns:
        The :class:`IKResult`.

    Raises:
        ShapeError: ``target`` is neither ``(3,)`` nor a 4x4 homogeneous transform, or
            ``q0``/``q_preferred`` has the wrong shape.
        FrameNotFoundError: unknown ``frame``.
        InvalidParameterError: a tolerance, budget or gain out of range.
    """
    _load_before_the_budget(arm_angle is not None)
    start = time.perf_counter()
    options, packed, timeout = _options_of(
        tol_position, tol_orientation, max_iterations, max_restarts, timeout_s,
        max_step, k_limits, damping, patience, preference_tol,
    )  # fmt: skip
    fid = robot.frame_id(frame)
    compiled = _compiled(robot, fid) if arm_angle is None else None
    # A float64 4x4 pose is checked inside the kernel (as_transform's checks); a failed
    # check comes back here, to _parse_target, for the message.
    raw = compiled is not None and _is_float_pose(target)
    spec = None if raw else _parse_target(target, position_only)
    if q_preferred is not None and arm_angle is not None:
        raise InvalidParameterError("give q_preferred or arm_angle, not both")
    as_seed(seed)
    q_pref = None if q_preferred is None else as_vector(q_preferred, "q_preferred", robot.n)
    if q0 is None:
        q_start = q_pref if q_pref is not None else robot.neutral()
    elif compiled is not None and _is_float_vector(q0, robot.n):
        q_start = q0  # checked in the kernel (finite), for the message below if not
    else:
        q_start = as_vector(q0, "q0", robot.n)
    shortcut: Callable[[], IKResult | None] | None = None
    if analytic and q_pref is None and arm_angle is None and not position_only:
        guess, pose = q_start, target if raw else full_pose(spec)
        if compiled is not None and pose is not None:  # a q0 with NaN gets no answer
            closed = answer(robot, frame, pose, guess, options, start)  # before iterating
            if closed is not None:
                return closed
        else:

            def shortcut() -> IKResult | None:  # before the iteration on Pinocchio
                return answer(robot, frame, pose, guess, options, start)

    if compiled is not None and (raw or spec is not None):
        problem = _problem(target if raw else spec, packed, q_pref)
        rows = 3 if position_only or (spec is not None and spec[1] is None) else 6
        result = _solve_compiled(compiled, problem, rows, q_start, q_pref is not None,
                                 options, start + timeout, seed, start)  # fmt: skip
        if result is not None:
            return result
        if q0 is not None:
            q_start = as_vector(q0, "q0", robot.n)  # raises if the kernel refused q0
        spec = _parse_target(target, position_only)  # raises, or None: not finite
    q_start = np.clip(q_start, robot.q_min, robot.q_max)
    if spec is None:
        return IKResult(
            q_start, False, 0, 0, math.inf, math.inf, time.perf_counter() - start,
            "target contains NaN or infinity: nothing to solve",
        )  # fmt: skip
    if shortcut is not None:  # before the iteration on Pinocchio (milliseconds)
        closed = shortcut()
        if closed is not None:
            return closed
    options = dataclasses.replace(options, timeout_s=timeout)
    if arm_angle is not None:
        rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
        return arm_angle_solve(robot, fid, spec, options, as_scalar(arm_angle, "arm_angle"),
                                q_start, rng, start)  # fmt: skip
    solver = ReferenceSolver(robot, fid, spec, options, q_pref, None)
    return solver.solve(q_start, _restarts(seed, solver.sample_lo, solver.sample_hi), start)


def _restarts(
    seed: int | np.random.Generator | None, lo: FloatArray, hi: FloatArray
) -> Callable[[int], FloatArray]:
    """The configuration of restart ``r >= 1`` within ``[lo, hi]``: the compiled path's
    counter-based draws (``ik._kernels.uniform``, its plain twin) under the same key, so
    that both paths restart from the same configurations."""
    key = _restart_key(seed)
    module = KERNELS.module(plain=True)
    assert module is not None  # the plain twin needs no numba
    uniform = module.uniform
    return lambda r: lo + (hi - lo) * np.array([uniform(key, 0, r, j) for j in range(len(lo))])


_WARM: set[str] = set()


def _load_before_the_budget(priority: bool) -> None:
    """Load the compiled kernels once per process, outside the time budget (the first call
    of a numba kernel loads or compiles it, which takes far longer than a solve)."""
    if not _ENTRY:
        _load_entry()
    if "rate" not in _WARM:
        J = np.eye(3, 4)
        rate_step(J, np.ones(3), np.ones(4), k_null=0.1, damping=0.01)
        _WARM.add("rate")
    if priority and "priority" not in _WARM:
        from ..resolution.priority import prioritized_velocity

        prioritized_velocity(
            [np.eye(2, 4), np.ones((1, 4))], [np.ones(2), np.ones(1)], method="damped"
        )
        _WARM.add("priority")


# ---------------------------------------------------------------------- compiled path
#: Validated options by the raw values given (most programs use one set).
_OPTIONS: dict[tuple[Any, ...], tuple[_Options, FloatArray]] = {}
#: Per robot and frame: the kernel's leading arguments, or None (not a serial chain).
_CHAINS: WeakKeyDictionary[Robot, dict[int, tuple[Any, ...] | None]] = WeakKeyDictionary()
_ENTRY: list[Any] = []  # the native entry point of ik._kernels.solve_packed, once loaded


def _options_of(*values: Any) -> tuple[_Options, FloatArray, float]:
    """:func:`redres.ik.options._options` with no time budget (``timeout_s`` infinite), the
    ``options`` array of the kernel, and the budget ``timeout_s`` (``values[4]``), which
    is checked on every call outside the cache: a caller that passes the time left of its
    own budget gives a new float each time, and a full validation costs a third of a
    solve."""
    key = values[:4] + values[5:]
    try:
        found = _OPTIONS.get(key)
    except TypeError:  # an unhashable value: validate (and refuse) it below
        found = None
    if found is None:
        o = _options(*key[:4], None, *key[4:])
        d = o.damping
        settings = {**vars(o), "max_damping": d.max_damping, "threshold": d.threshold}
        packed = np.array([settings[name] for name in layout.OPTION_NAMES], dtype=np.float64)
        found = (o, packed)
        if len(_OPTIONS) < 64:
            _OPTIONS[key] = found
    timeout = values[4]
    if timeout is None:
        timeout = math.inf
    elif not (type(timeout) is float and 0.0 < timeout < math.inf):
        timeout = as_scalar(timeout, "timeout_s", minimum=0.0, strict=True)
    return found[0], found[1], timeout


def _compiled(robot: Robot, fid: int) -> tuple[Any, ...] | None:
    """``(entry point, leading arguments)`` of the compiled solve for this frame, or None
    for the reference path (kernels compiling behind or disabled, not a serial chain)."""
    if not _ENTRY and not _load_entry():
        return None
    per_robot = _CHAINS.get(robot)
    if per_robot is None:
        per_robot = _CHAINS[robot] = {}
    if fid not in per_robot:
        per_robot[fid] = _chain_arguments(robot, fid)
    found = per_robot[fid]
    return None if found is None else (_ENTRY[0], found)


def _load_entry() -> bool:
    """Load the compiled solve if it is ready (:meth:`KERNELS.compiled
    <redres._compile.KernelGroup.compiled>`)."""
    module = KERNELS.compiled() if _compile.enabled() else None
    if module is None:
        return False
    _ENTRY.append(_compile.entry_point(module.solve_packed, _warm_arguments()))
    return True


def _chain_arguments(robot: Robot, fid: int) -> tuple[Any, ...] | None:
    from ..robot import NotSerialChainError

    try:
        chain = robot.chain(robot.model.frames[fid].name)
    except NotSerialChainError:
        return None
    return (*chain.arrays, limit_arrays(robot.q_min, robot.q_max))


def _warm_arguments() -> tuple[Any, ...]:
    """Arguments of the types :func:`_solve_compiled` passes (one revolute joint)."""
    chain = (np.zeros((2, 3, 4)), np.eye(3)[2:], np.array([2], dtype=np.int64))
    for array in chain:  # the types of SerialChain.arrays, read-only
        array.flags.writeable = False
    limits = limit_arrays(np.array([-1.0]), np.array([1.0]))
    problem = np.zeros(16 + 9)
    problem[:16] = np.eye(4).ravel()
    problem[16:19] = 1.0
    io = np.zeros(2 + 6)
    return (*chain, limits, problem, io, 6, False, 0, 0, 1, 1)


def _is_float_vector(value: Any, n: int) -> bool:
    return type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (n,)


def _is_float_pose(target: Any) -> bool:
    return type(target) is np.ndarray and target.dtype == np.float64 and target.shape == (4, 4)


def _problem(target: Any, packed: FloatArray, q_pref: FloatArray | None) -> FloatArray:
    """The ``problem`` array of :func:`redres.ik._kernels.solve_packed`: the 4x4 target
    (a float64 array, or ``(p_d, R_d)`` parsed), the options, ``q_pref``."""
    n_pref = 0 if q_pref is None else q_pref.shape[0]
    problem = np.empty(16 + packed.shape[0] + n_pref)
    if type(target) is tuple:
        T = problem[:16].reshape(4, 4)
        T[:] = _EYE4
        T[:3, 3] = target[0]
        if target[1] is not None:
            T[:3, :3] = target[1]
    else:
        problem[:16] = target.ravel()
    problem[16 : 16 + packed.shape[0]] = packed
    if q_pref is not None:
        problem[16 + packed.shape[0] :] = q_pref
    return problem


_EYE4 = np.eye(4)


def _restart_key(seed: int | np.random.Generator | None) -> int:
    """The key of the restart configurations (:mod:`redres.ik._kernels`): an integer seed
    itself (modulo ``2**62``; the generator hashes it), the first ``integers(0, 2**62)``
    draw of a generator, fresh entropy for None. (``np.random.default_rng(seed)`` costs
    30 µs, a third of a solve.)"""
    if seed is None:
        return secrets.randbits(62)
    if isinstance(seed, np.random.Generator):
        return int(seed.integers(0, _KEYS))
    return int(seed) % _KEYS  # checked by ik(): as_seed


_KEYS = 2**62


def _solve_compiled(
    compiled: tuple[Any, ...],
    problem: FloatArray,
    rows: int,
    q: FloatArray,
    has_pref: bool,
    options: _Options,
    deadline: float,
    seed: int | np.random.Generator | None,
    start: float,
) -> IKResult | None:
    """The attempts in the kernel, the clock read between calls; None when
    the kernel refuses the start (not finite) or the target (not a finite homogeneous
    transform)."""
    entry, arguments = compiled
    n = q.shape[0]
    io = np.empty(2 * n + layout.N_STATE)
    io[:n] = q
    state = io[2 * n :]
    state[[layout.BEST_SCORE, layout.BEST_POSITION, layout.BEST_ORIENTATION]] = math.inf
    clock = time.perf_counter
    # Attempt 0 draws nothing: the key is made only when a restart is needed.
    key, made, iterations, stop, spend = 0, 0, 0, 1, options.max_iterations
    while True:
        status, attempts, used = entry(*arguments, problem, io, rows, has_pref, key, made,
                                       stop, spend)  # fmt: skip
        made += attempts
        iterations += used
        if status == layout.CONVERGED:
            note = _UNSETTLED if state[layout.UNSETTLED] else ""
            return _result(io[:n].copy(), True, iterations, made - 1,
                           float(state[layout.ERR_POSITION]), float(state[layout.ERR_ORIENTATION]),
                           clock() - start, "converged" + note)  # fmt: skip
        if status < 0:
            return None
        timeout = clock() > deadline
        if timeout or made > options.max_restarts:
            break
        if made == 1:
            key, stop = _restart_key(seed), options.max_restarts + 1
    why = "time budget" if timeout else "iteration and restart budget"
    return _result(
        io[n : 2 * n].copy(), False, iterations, made - 1,
        float(state[layout.BEST_POSITION]), float(state[layout.BEST_ORIENTATION]), clock() - start,
        f"not converged: {why} exhausted; returning the best configuration found",
    )  # fmt: skip


_UNSETTLED = " (the preference had not settled when the budget ran out)"
_FIELDS = tuple(field.name for field in dataclasses.fields(IKResult))
_DEFAULTS = {f.name: f.default for f in dataclasses.fields(IKResult)
             if f.default is not dataclasses.MISSING}  # fmt: skip


def _result(*values: Any) -> IKResult:
    """``IKResult(*values)`` without the frozen dataclass's ``__init__`` (one
    ``object.__setattr__`` per field, a fifth of a solve's Python overhead): the same
    object, its remaining fields at their defaults."""
    result = object.__new__(IKResult)
    result.__dict__.update(_DEFAULTS, **dict(zip(_FIELDS, values, strict=False)))
    return result
