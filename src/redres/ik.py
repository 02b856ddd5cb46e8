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
  seed 003, scaled by the same factor so that it fades out near the solution and cannot
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
* ``s ≤ 1`` scales the step so that no joint moves more than ``max_step`` per iteration,
  then joints are clipped into their limits. Before that, joints at a limit that the step
  pushes outward are *clamped*: their Jacobian columns are zeroed and the step recomputed
  (up to three passes), so that the other joints do the work instead of the clip undoing
  part of a Newton step. The result is always within the limits.
* An attempt that stops making progress (the error not halved over ``patience``
  iterations) or uses ``max_iterations`` restarts from a configuration drawn uniformly
  within the limits by the seeded generator, up to ``max_restarts`` times, all within
  ``timeout_s``. The best configuration found is returned with ``converged=False`` when
  the budget runs out (unreachable targets).

Speed: inputs are validated once; the loop then calls Pinocchio on ``robot.model`` and
``robot.data`` directly (so, like :class:`~redres.Robot`'s own methods, it writes into
``robot.data``: do not share one ``Robot`` between threads) and
:func:`~redres.linalg.rate_step` once per iteration (twice when clamping).

Bad input: a target containing NaN or infinity returns ``converged=False`` with a
message and no iteration (a sensor glitch should not raise inside a control program); a
target of the wrong shape or a 4x4 that is not a homogeneous transform raises
:class:`~redres.errors.ShapeError` (a programming error), as do bad parameters.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any, cast

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from ._validate import FloatArray, as_scalar, as_vector
from .errors import InvalidParameterError
from .ik_types import IKResult, _Options, _options, _parse_target
from .linalg import AdaptiveDamping, adaptive_damping, rate_step

if TYPE_CHECKING:
    from .robot import Robot
    from .tasks import TaskState

__all__ = ["IKResult", "ik"]

_WORLD = pin.LOCAL_WORLD_ALIGNED
_ERROR_SCALE = 0.1  # m or rad: damping and the joint-limit term fade out below this error
_PREFERENCE_GAIN = 0.5  # fraction of the distance to the preference covered per iteration
_PREFERENCE_STEP = 0.1  # rad: largest joint motion per iteration toward the preference
_STICKY_ERROR = 1e-3  # m + rad: above this error in phase 2, clamped joints are released


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
    timeout_s: float = 0.5,
    seed: int | np.random.Generator | None = None,
    q_preferred: Any = None,
    arm_angle: float | None = None,
    max_step: float = 0.5,
    k_limits: float = 0.1,
    damping: AdaptiveDamping | None = None,
    patience: int = 10,
    preference_tol: float = 1e-5,
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
        timeout_s: wall-clock budget of the whole solve, s (> 0); checked every iteration.
            (The first call in a process also loads the compiled kernels of
            :mod:`redres.linalg`, before the clock starts.)
        seed: seed or generator of the random restarts (``None``: fresh entropy).
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

    Returns:
        The :class:`IKResult`.

    Raises:
        ShapeError: ``target`` is neither ``(3,)`` nor a 4x4 homogeneous transform, or
            ``q0``/``q_preferred`` has the wrong shape.
        FrameNotFoundError: unknown ``frame``.
        InvalidParameterError: a tolerance, budget or gain out of range.
    """
    _warm_up(arm_angle is not None)
    start = time.perf_counter()
    options = _options(
        tol_position, tol_orientation, max_iterations, max_restarts, timeout_s,
        max_step, k_limits, damping, patience, preference_tol,
    )  # fmt: skip
    fid = robot.frame_id(frame)
    spec = _parse_target(target, position_only)
    if q_preferred is not None and arm_angle is not None:
        raise InvalidParameterError("give q_preferred or arm_angle, not both")
    q_pref = None if q_preferred is None else as_vector(q_preferred, "q_preferred", robot.n)
    if q0 is not None:
        q_start = as_vector(q0, "q0", robot.n)
    else:
        q_start = q_pref if q_pref is not None else robot.neutral()
    q_start = np.clip(q_start, robot.q_min, robot.q_max)
    if spec is None:
        return IKResult(
            q_start, False, 0, 0, math.inf, math.inf, time.perf_counter() - start,
            "target contains NaN or infinity: nothing to solve",
        )  # fmt: skip
    if arm_angle is not None:
        arm_angle = as_scalar(arm_angle, "arm_angle")
    rng = seed if isinstance(seed, np.random.Generator) else np.random.default_rng(seed)
    solver = _Solver(robot, fid, spec, options, q_pref, arm_angle)
    return solver.solve(q_start, rng, start)


_WARM: set[str] = set()


def _warm_up(priority: bool) -> None:
    """Load the compiled kernels once per process, outside the time budget (the first call
    of a numba kernel loads or compiles it, which takes far longer than a solve)."""
    if "rate" not in _WARM:
        J = np.eye(3, 4)
        rate_step(J, np.ones(3), np.ones(4), k_null=0.1, damping=0.01)
        _WARM.add("rate")
    if priority and "priority" not in _WARM:
        from .resolution.priority import prioritized_velocity

        prioritized_velocity(
            [np.eye(2, 4), np.ones((1, 4))], [np.ones(2), np.ones(1)], method="damped"
        )
        _WARM.add("priority")


_CONVERGED, _STALLED, _BUDGET, _TIMEOUT = range(4)
#: ``(task part, preference part)`` of a step; :meth:`_Solver.direction` at one ``q``.
_Parts = tuple[FloatArray, FloatArray | None]
_Direction = Callable[[NDArray[np.bool_] | None], _Parts]


class _Solver:
    """The iteration, with everything validated and preallocated once (internal)."""

    def __init__(
        self,
        robot: Robot,
        fid: int,
        spec: tuple[FloatArray, FloatArray | None],
        options: _Options,
        q_pref: FloatArray | None,
        arm_angle: float | None,
    ) -> None:
        self.robot, self.model, self.data, self.fid = robot, robot.model, robot.data, fid
        self.p_d, self.R_d = spec
        self.o = options
        self.lo, self.hi = robot.q_min, robot.q_max
        finite = np.isfinite(self.lo) & np.isfinite(self.hi)
        span = np.where(finite, self.hi - self.lo, 1.0)
        self.sample_lo = np.where(finite, self.lo, np.maximum(self.lo, -math.pi))
        self.sample_hi = np.where(finite, self.hi, np.minimum(self.hi, math.pi))
        self.mid = np.where(finite, (self.lo + self.hi) / 2.0, 0.0)
        self.limit_weight = np.where(finite & (span > 0), 2.0 / (span * span), 0.0)
        self.q_pref = q_pref
        self.arm_task = None
        if arm_angle is not None:
            from .tasks import ArmAngleTask

            self.arm_task = ArmAngleTask(target=arm_angle)
        self.rows = 3 if self.R_d is None else 6
        self.has_preference = q_pref is not None or arm_angle is not None
        self.e = np.zeros(self.rows)
        self.sigma = 0.0
        self.best_q = np.zeros(robot.n)
        self.best_score = math.inf
        self.best_errors = (math.inf, math.inf)
        self.candidate: FloatArray | None = None
        self.prefer = False
        self.note = ""
        self.at_limit = True  # some joint may be at a limit: check before stepping
        self.sticky = np.zeros(robot.n, dtype=bool)
        self.preference_scale = 1.0
        self.last_preference: FloatArray | None = None

    # ------------------------------------------------------------------ outer loop
    def solve(self, q: FloatArray, rng: np.random.Generator, start: float) -> IKResult:
        deadline = start + self.o.timeout_s
        iterations = restarts = 0
        while True:
            q, status, used = self.attempt(q, deadline)
            iterations += used
            if status == _CONVERGED:
                return self.result(q, True, iterations, restarts, start, "converged" + self.note)
            if status == _TIMEOUT or restarts >= self.o.max_restarts:
                break
            restarts += 1
            q = rng.uniform(self.sample_lo, self.sample_hi)
        why = "time budget" if status == _TIMEOUT else "iteration and restart budget"
        message = f"not converged: {why} exhausted; returning the best configuration found"
        return self.result(self.best_q, False, iterations, restarts, start, message)

    def result(
        self, q: FloatArray, ok: bool, iterations: int, restarts: int, start: float, msg: str
    ) -> IKResult:
        errors = self.evaluate(q)[1:] if ok else self.best_errors
        return IKResult(
            q.copy(), ok, iterations, restarts, errors[0], errors[1],
            time.perf_counter() - start, msg,
        )  # fmt: skip

    # ------------------------------------------------------------------ one attempt
    def attempt(self, q: FloatArray, deadline: float) -> tuple[FloatArray, int, int]:
        """Iterate from ``q``; returns ``(q, status, iterations used)``.

        Phase 1 drives the error within tolerance; with a preference, phase 2 then adds
        the preference step (keeping the task) until the joints move less than
        ``preference_tol`` per iteration. The preference thus never hinders convergence.
        """
        o = self.o
        self.sigma, self.candidate, self.prefer, self.note = 0.0, None, False, ""
        self.at_limit = True
        moved = math.inf
        check_error, check_at = math.inf, 0
        clock = time.perf_counter
        it, limit = 0, o.max_iterations
        while it < limit:
            J, ep, eo = self.evaluate(q)
            self.track(q, ep, eo)
            if ep <= o.tol_position and eo <= o.tol_orientation:
                if not self.has_preference or (self.prefer and moved <= o.preference_tol):
                    return q, _CONVERGED, it
                self.candidate = q
                if not self.prefer:  # phase 2, with a budget of its own
                    self.prefer, moved, limit = True, math.inf, it + o.max_iterations
                    self.sticky = np.zeros(q.size, dtype=bool)
                    self.preference_scale, self.last_preference = 1.0, None
            elif self.candidate is None:
                if it - check_at >= o.patience:
                    if ep + eo > 0.5 * check_error:
                        return (*self.end(q, _STALLED), it)
                    check_error, check_at = ep + eo, it
                elif it == 0:
                    check_error = ep + eo
            if clock() > deadline:
                return (*self.end(q, _TIMEOUT), it)
            q_new = self.step(q, J, ep + eo)
            moved = float(abs(q_new - q).max())
            q, it = q_new, it + 1
        return (*self.end(q, _BUDGET), it)

    def end(self, q: FloatArray, status: int) -> tuple[FloatArray, int]:
        """End of an attempt: converged if the task was met on the way (the preference
        had not settled), else ``status``."""
        if self.candidate is not None:
            self.note = " (the preference had not settled when the budget ran out)"
            return self.candidate, _CONVERGED
        return q, status

    # ------------------------------------------------------------------ kinematics
    def evaluate(self, q: FloatArray) -> tuple[FloatArray, float, float]:
        """Jacobian rows of the task, position and orientation errors; fills ``self.e``."""
        model, data = self.model, self.data
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacement(model, data, self.fid)
        pose = data.oMf[self.fid]
        e = self.e
        e[:3] = self.p_d - pose.translation
        ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
        J = pin.getFrameJacobian(model, data, self.fid, _WORLD)
        if self.R_d is None:
            return J[:3], ep, 0.0
        e[3:] = pin.log3(self.R_d @ pose.rotation.T)
        eo = math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
        return J, ep, eo

    def track(self, q: FloatArray, ep: float, eo: float) -> None:
        """Remember the best configuration so far (largest error relative to tolerance)."""
        score = max(ep / self.o.tol_position, eo / self.o.tol_orientation)
        if score < self.best_score:
            self.best_score, self.best_errors = score, (ep, eo)
            self.best_q[:] = q

    # ------------------------------------------------------------------ one step
    def step(self, q: FloatArray, J: FloatArray, error: float) -> FloatArray:
        """Next configuration: damped CLIK step plus null-space term, clamped (:meth:`clamp`),
        scaled and clipped."""
        o = self.o
        fade = min(1.0, error / _ERROR_SCALE)
        damping = o.damping
        lam = adaptive_damping(self.sigma, damping.max_damping, damping.threshold) * fade
        arm = None
        if self.prefer and self.arm_task is not None:
            arm = self.arm_task.compute(self.robot, q)
        parts = self.direction(q, J, lam, fade, arm, None)
        if self.at_limit:
            parts = self.clamp(q, partial(self.direction, q, J, lam, fade, arm), parts, error)
        task, pref = parts
        dq = task if pref is None else task + self.preference_part(pref)
        q_new = q + _cap(dq, o.max_step)
        self.at_limit = bool((q_new <= self.lo).any() or (q_new >= self.hi).any())
        if self.at_limit:
            q_new = np.minimum(np.maximum(q_new, self.lo), self.hi)
        return q_new

    def clamp(self, q: FloatArray, redo: _Direction, parts: _Parts, error: float) -> _Parts:
        """Recompute the step (``redo``: :meth:`direction` at this ``q``) without the
        joints it pushes against their limits, until none is (at most three passes). In
        phase 2 a clamped joint stays clamped while the task holds (no chattering against
        the limit)."""
        task, pref = parts
        blocked = np.zeros(q.size, dtype=bool)
        if self.prefer:
            if error > _STICKY_ERROR:
                self.sticky[:] = False
            blocked |= self.sticky
        recompute = bool(blocked.any())
        for _ in range(3):
            if recompute:
                task, pref = redo(blocked)
            dq = task if pref is None else task + pref
            out = (((q <= self.lo) & (dq < 0.0)) | ((q >= self.hi) & (dq > 0.0))) & ~blocked
            if not out.any():
                break
            blocked |= out
            recompute = True
        if self.prefer:
            self.sticky = blocked
        return task, pref

    def direction(
        self,
        q: FloatArray,
        J: FloatArray,
        lam: float,
        fade: float,
        arm: TaskState | None,
        blocked: NDArray[np.bool_] | None,
    ) -> _Parts:
        """``(task part, preference part)`` of the step, the ``blocked`` joints' columns
        removed (in phase 1 the joint-limit term is in the task part, preference None)."""
        if blocked is not None:
            J = J.copy()
            J[:, blocked] = 0.0
        if arm is not None:
            return self.arm_angle_step(J, arm, lam, blocked)
        if self.prefer and self.q_pref is not None:
            grad, k = q - self.q_pref, _PREFERENCE_GAIN
        else:
            grad, k = self.limit_weight * (q - self.mid), self.o.k_limits * fade
        if blocked is not None:
            grad = np.where(blocked, 0.0, grad)
        step = rate_step(J, self.e, grad, k_null=k, damping=lam, return_null=True)
        self.sigma = step.info.sigma_min
        if not self.prefer:
            return step.qd, None
        null = cast("FloatArray", step.null_term)  # computed: return_null=True
        return step.qd - null, null

    def arm_angle_step(
        self, J: FloatArray, arm: TaskState, lam: float, blocked: NDArray[np.bool_] | None
    ) -> tuple[FloatArray, FloatArray]:
        """Pose first, arm angle second: the priority recursion, the arm-angle level with
        the adaptive damping of ``options.damping`` so that its step stays bounded where the
        self-motion barely changes the arm angle (an algorithmic singularity)."""
        from .resolution.priority import prioritized_velocity

        J_arm = arm.jacobian
        if blocked is not None:
            J_arm = np.where(blocked, 0.0, J_arm)
        levels = prioritized_velocity(
            [J, J_arm],
            [self.e, _PREFERENCE_GAIN * arm.error],
            method="damped",
            damping=[lam, self.o.damping],
        ).levels
        self.sigma = levels[0].sigma_min
        return levels[0].contribution, levels[1].contribution

    def preference_part(self, pref: FloatArray) -> FloatArray:
        """The preference step, capped to ``_PREFERENCE_STEP`` and halved for good each
        time it reverses direction (an overshoot on the curved self-motion manifold,
        where the linearised step ignores the curvature)."""
        step = _cap(pref, _PREFERENCE_STEP) * self.preference_scale
        if self.last_preference is not None and float(step @ self.last_preference) < 0.0:
            self.preference_scale *= 0.5
            step *= 0.5
        self.last_preference = step
        return step


def _cap(dq: FloatArray, largest: float) -> FloatArray:
    """``dq`` scaled down so that no entry exceeds ``largest`` in magnitude."""
    peak = float(abs(dq).max())
    return dq * (largest / peak) if peak > largest else dq
