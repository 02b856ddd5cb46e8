"""The reference path of :func:`redres.ik.ik` (internal): the iteration in Python, on
Pinocchio and :func:`redres.linalg.rate_step`.

It is the path of the arm-angle preference, of frames whose model is not a serial chain
(:class:`~redres.robot.NotSerialChainError`) and of processes whose kernels are not
compiled yet (compiling behind) or disabled; :mod:`redres.ik._kernels` transcribes it
for the rest, and ``tests/ik/test_ik_compiled.py`` checks the two against each other. The
algorithm is in the :mod:`redres.ik` docstring.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, cast

import numpy as np
import pinocchio as pin
from numpy.typing import NDArray

from .._validate import FloatArray
from ..linalg import adaptive_damping, rate_step
from ._layout import (
    ERROR_SCALE,
    FLAT_GAIN,
    FLAT_ITERATIONS,
    PREFERENCE_GAIN,
    PREFERENCE_STEP,
    STICKY_ERROR,
)
from .options import ARM_ANGLE_TOL, IKResult, _Options, limit_arrays

if TYPE_CHECKING:
    from ..robot import Robot
    from ..tasks import TaskState

_WORLD = pin.LOCAL_WORLD_ALIGNED


_CONVERGED, _STALLED, _BUDGET, _TIMEOUT = range(4)
#: ``(task part, preference part)`` of a step; :meth:`ReferenceSolver.direction` at one ``q``.
_Parts = tuple[FloatArray, FloatArray | None]
_Direction = Callable[[NDArray[np.bool_] | None], _Parts]


class ReferenceSolver:
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
        _, _, self.sample_lo, self.sample_hi, self.mid, self.limit_weight = limit_arrays(
            self.lo, self.hi
        )
        self.q_pref = q_pref
        self.arm_task = None
        if arm_angle is not None:
            from ..tasks import ArmAngleTask

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
    def solve(self, q: FloatArray, draw: Callable[[int], FloatArray], start: float) -> IKResult:
        """Attempts from ``q``, then from ``draw(r)`` for restart ``r = 1, 2, ...``, until
        one converges or the budget is spent."""
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
            q = draw(restarts)
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
        flat_error, flat_at = math.inf, 0
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
                if ep + eo < (1.0 - FLAT_GAIN) * flat_error:
                    flat_error, flat_at = ep + eo, it
                elif it - flat_at >= FLAT_ITERATIONS:
                    return (*self.end(q, _STALLED), it)
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
        # Pinocchio's logarithm, as before: this path's restarts depend on the last bit of
        # the error, and its results are the reference the compiled path is checked on.
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
        fade = min(1.0, error / ERROR_SCALE)
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
            if error > STICKY_ERROR:
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
            grad, k = q - self.q_pref, PREFERENCE_GAIN
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
        from ..resolution.priority import prioritized_velocity

        J_arm = arm.jacobian
        if blocked is not None:
            J_arm = np.where(blocked, 0.0, J_arm)
        levels = prioritized_velocity(
            [J, J_arm],
            [self.e, PREFERENCE_GAIN * arm.error],
            method="damped",
            damping=[lam, self.o.damping],
        ).levels
        self.sigma = levels[0].sigma_min
        return levels[0].contribution, levels[1].contribution

    def preference_part(self, pref: FloatArray) -> FloatArray:
        """The preference step, capped to ``PREFERENCE_STEP`` and halved for good each
        time it reverses direction (an overshoot on the curved self-motion manifold,
        where the linearised step ignores the curvature)."""
        step = _cap(pref, PREFERENCE_STEP) * self.preference_scale
        if self.last_preference is not None and float(step @ self.last_preference) < 0.0:
            self.preference_scale *= 0.5
            step *= 0.5
        self.last_preference = step
        return step


def _cap(dq: FloatArray, largest: float) -> FloatArray:
    """``dq`` scaled down so that no entry exceeds ``largest`` in magnitude."""
    peak = float(abs(dq).max())
    return dq * (largest / peak) if peak > largest else dq


def arm_angle_solve(
    robot: Robot,
    fid: int,
    spec: tuple[FloatArray, FloatArray | None],
    options: _Options,
    phi: float,
    q_start: FloatArray,
    rng: np.random.Generator,
    start: float,
) -> IKResult:
    """The reference path with the arm-angle preference, re-solved from random
    configurations (other branches of the self-motion) while the preference is missed
    and the budget lasts (``max_restarts`` solves, ``timeout_s``): the result closest
    to ``phi`` is returned, with the angle reached and whether it is met."""
    from ..tasks import ArmAngleTask, wrap_angle

    arm, best, best_miss = ArmAngleTask(), None, math.inf
    q, deadline = q_start, start + options.timeout_s
    for _ in range(options.max_restarts + 1):
        solver = ReferenceSolver(robot, fid, spec, options, None, phi)
        result = solver.solve(q, partial(_uniform, rng, solver.sample_lo, solver.sample_hi), start)
        if result.converged:
            reached = float(arm.value(robot, result.q))
            miss = abs(wrap_angle(reached - phi))
            if miss < best_miss:
                best, best_miss = dataclasses.replace(result, arm_angle=reached), miss
        elif best is None:
            best = result
        if best_miss <= ARM_ANGLE_TOL or time.perf_counter() > deadline:
            break
        q = rng.uniform(solver.sample_lo, solver.sample_hi)
    assert best is not None
    if not best.converged:
        return best
    met = best_miss <= ARM_ANGLE_TOL
    note = "" if met else (
        f"; arm-angle preference not met: reached {best.arm_angle:.4f} rad, wanted "
        f"{phi:.4f} rad (the closest of the solutions found)"
    )  # fmt: skip
    return dataclasses.replace(best, preference_met=met, message=best.message + note,
                               time_s=time.perf_counter() - start)  # fmt: skip


def _uniform(rng: np.random.Generator, lo: FloatArray, hi: FloatArray, _: int) -> FloatArray:
    """A configuration drawn by ``rng`` within ``[lo, hi]`` (restarts of the arm-angle
    preference)."""
    return np.asarray(rng.uniform(lo, hi))
