"""``rr.ik`` on an arm with a closed form: its answer before any random restart.

On the arms :func:`~redres.ik.analytic.analytic_arm` accepts (a spherical shoulder and
axes 5 and 6 meeting: Panda, FR3, iiwa14, srs7), when the iteration's first attempt from
``q0`` fails on a full-pose target (no preference), the closed form answers before the
random restarts (each as long as a first attempt, and most of the tail of the solve
time; on the reference path, which iterates on Pinocchio in milliseconds, before the
iteration):

1. at ``q0``'s own last joint ``q7 = q0[6]``, every solution
   (:func:`~redres.ik.analytic.at_q7`, exact to about 1e-13); of those within the joint
   limits the nearest to ``q0`` (Euclidean, rad) is the answer;
2. if none is within the limits there, the same at :data:`Q7_TRIES` other values of
   ``q7``, evenly spread over its range, nearest to ``q0[6]`` first;
3. if still none, the restarts as without the closed form. An answer whose residual
   (the kernel's own forward kinematics) is above ``tol_position`` (m) or
   ``tol_orientation`` (rad) is not taken.

Why not before the first attempt: one :func:`~redres.ik.analytic.at_q7` call costs as
much as most converging first attempts (measured 2026-12-07: 5-9 µs in its kernel,
about as much around it, against 25-35 µs for a whole compiled solve), and half the
random targets have no solution within the limits at ``q0[6]``; so taken first it
raised the median time and lowered none (docs/priority_and_ik.md).

The answer is clipped into the limits (``within_limits`` allows 1e-12 rad) and returned
with ``iterations`` of the first attempt, no restart, and a message naming the ``q7``
used. It is a solution near ``q0`` in ``q7`` and then in joint space — not the one a
restart would have found. ``rr.ik(..., analytic=False)`` skips it; preferences
(``q_preferred``, ``arm_angle``) and position-only targets skip it too, as do processes
whose analytic kernels are still compiling behind.
"""

from __future__ import annotations

import dataclasses
import math
import time
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np

from ..errors import RedresError
from .analytic import KERNELS, AnalyticArm, NotAnalyticError, analytic_arm, at_q7
from .options import IKResult

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["Q7_TRIES", "closed_form_solution", "covered"]

#: Other values of ``q7`` tried when none of the solutions at ``q0[6]`` is within limits.
Q7_TRIES = 12

_ARMS: WeakKeyDictionary[Robot, dict[str | None, tuple[AnalyticArm, np.ndarray] | None]] = (
    WeakKeyDictionary()
)


def _arm(robot: Robot, frame: str | None) -> tuple[AnalyticArm, np.ndarray] | None:
    """The arm's closed form and the ``q7`` values to try after ``q0[6]``, or None."""
    per_robot = _ARMS.get(robot)
    if per_robot is None:
        per_robot = _ARMS[robot] = {}
    if frame not in per_robot:
        try:
            arm = analytic_arm(robot, frame)
        except NotAnalyticError:
            per_robot[frame] = None
        else:
            lo, hi = arm.bounds[:, 6]
            if not (math.isfinite(lo) and math.isfinite(hi)):
                lo, hi = -math.pi, math.pi
            span = (hi - lo) / Q7_TRIES
            per_robot[frame] = (arm, lo + span * (np.arange(Q7_TRIES) + 0.5))
    return per_robot[frame]


def covered(robot: Robot, frame: str | None) -> bool:
    """Whether the arm has the closed form, its kernels ready (not compiling behind)."""
    return _arm(robot, frame) is not None and KERNELS.compiled() is not None


def full_pose(spec: tuple[np.ndarray, np.ndarray | None] | None) -> np.ndarray | None:
    """The 4x4 pose of a parsed full-pose target ``(position, rotation)`` (None: position
    only, or not finite)."""
    if spec is None or spec[1] is None:
        return None
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = spec[1], spec[0]
    return T


def answer(
    robot: Robot, frame: str | None, pose: Any, q0: np.ndarray, options: Any, start: float
) -> IKResult | None:
    """:func:`closed_form_solution` at ``options``' tolerances where the arm is
    :func:`covered` and ``pose`` is a full pose (None otherwise: iterate instead)."""
    if pose is None or not covered(robot, frame):
        return None
    return closed_form_solution(robot, frame, pose, q0, options.tol_position,
                                options.tol_orientation, start)  # fmt: skip


def closed_form_solution(
    robot: Robot,
    frame: str | None,
    target: Any,
    q0: np.ndarray,
    tol_position: float,
    tol_orientation: float,
    start: float,
) -> IKResult | None:
    """The closed-form answer (module docstring), or None to iterate instead.

    Args:
        robot, frame: the arm (:func:`covered`) and the frame placed (None: its tip).
        target: the pose, ``(4, 4)`` float64 (not checked: a bad one gives None).
        q0: the first guess, ``(7,)``, rad.
        tol_position, tol_orientation: the tolerances, m and rad.
        start: ``time.perf_counter()`` at the start of the solve.
    """
    found = _arm(robot, frame)
    if found is None:
        return None
    arm, others = found
    lo, hi = arm.bounds
    q7 = float(q0[6])
    if not math.isfinite(q7):
        return None
    for value in (q7, *others[np.argsort(np.abs(others - q7))].tolist()):
        try:
            solutions = at_q7(robot, target, q7=value, frame=frame)
        except RedresError:  # not a finite homogeneous transform: the iteration says why
            return None
        within = np.flatnonzero(solutions.within_limits)
        if not len(within):
            continue
        q = solutions.q
        best = int(within[0])
        if len(within) > 1:  # the nearest to q0
            best = int(within[((q[within] - q0) ** 2).sum(axis=1).argmin()])
        position = float(solutions.position_error[best])
        rotation = float(solutions.rotation_error[best])
        if position > tol_position or rotation > tol_orientation:
            return None
        answer = q[best].copy()
        np.clip(answer, lo, hi, out=answer)  # within_limits allows 1e-12 rad
        return _result(answer, position, rotation, time.perf_counter() - start, value)
    return None


_FIELDS = tuple(field.name for field in dataclasses.fields(IKResult))


def _result(q: np.ndarray, position: float, rotation: float, seconds: float, q7: float
            ) -> IKResult:  # fmt: skip
    """The converged :class:`IKResult` (without the frozen dataclass's ``__init__``, a
    tenth of this path's time)."""
    result = object.__new__(IKResult)
    message = f"converged: closed form at q7 = {q7:.6g} rad (redres.ik.analytic)"
    values = (q, True, 0, 0, position, rotation, seconds, message, None, None)
    result.__dict__.update(zip(_FIELDS, values, strict=True))
    return result
