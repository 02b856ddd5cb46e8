"""``rr.ik`` on an arm with a closed form: its answer before the iteration.

On the arms :func:`~redres.ik.analytic.analytic_arm` accepts (a spherical shoulder and
axes 5 and 6 meeting: Panda, FR3, iiwa14, srs7), for a full-pose target without a
preference, the closed form answers first, in one compiled call
(:mod:`redres.ik._nearest_kernels`):

1. at ``q0``'s own last joint ``q7 = q0[6]``, every solution
   (:func:`~redres.ik.analytic.at_q7`'s kernel, exact to about 1e-13); of those within
   the joint limits the nearest to ``q0`` (Euclidean, rad) is the answer;
2. if none is within the limits there, the same at :data:`Q7_TRIES` other values of
   ``q7``, evenly spread over its range, nearest to ``q0[6]`` first;
3. if still none, on S-R-S arms (iiwa14, srs7: :mod:`redres.ik.srs`), the arm angle
   (:func:`by_arm_angle`): the within-limits solution nearest ``q0`` among those at
   :data:`ARM_ANGLES` arm angles spread over the circle, else at the middle of each
   exact arc of the self-motion within the limits (Shimizu et al., IEEE T-RO 24(5),
   2008). Where ``q7`` barely moves along the self-motion (a range of a few hundredths
   of a radian within the limits) the values of ``q7`` tried all miss it while most
   arm angles have a solution: 12 of 1,000 random iiwa14 targets from the neutral
   configuration (``benchmarks/ik_compare.py``, seed 7), each answered here in about
   0.1 ms instead of by the iteration (which failed some of them within the
   benchmark's 5 ms);
4. if still none, the iteration from ``q0`` and its random restarts, as without the
   closed form. An answer whose residual (the chain's compiled forward kinematics) is
   above ``tol_position`` (m) or ``tol_orientation`` (rad) is not taken.

What that changes (``benchmarks/ik_compare.py``, docs/priority_and_ik.md): the iteration
from the neutral configuration costs 20-35 µs per target and fails on a few per cent
(joint limits), each failure followed by a restart; the closed form costs a microsecond
per value of ``q7`` tried and answers nearly every random in-limit target. The answer is
a different solution: the nearest to ``q0`` among those at the first value of ``q7``
tried that has one within the limits (``q0[6]`` itself for about half the random
targets from the neutral configuration) — not the one the iteration converges to from
``q0``, which moves joint 7 too; along a path with ``q0`` the previous solution, joint 7
stays where ``q0`` had it while that keeps a solution within the limits.

The answer is clipped into the limits (``within_limits`` allows 1e-12 rad) and returned
with no iteration, no restart, and a message naming the ``q7`` (or the arm angle) used.
``rr.ik(..., analytic=False)`` skips it; preferences (``q_preferred``, ``arm_angle``) and
position-only targets skip it too, as do processes whose analytic kernels are still
compiling behind. On the reference path (kernels disabled) it answers before the
iteration on Pinocchio (milliseconds).
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any
from weakref import WeakKeyDictionary

import numpy as np

from . import _analytic_codes as codes
from . import analytic
from .analytic import KERNELS, AnalyticArm, NotAnalyticError, analytic_arm
from .options import IKResult
from .solutions import _srs

if TYPE_CHECKING:
    from ..robot import Robot
    from .srs import SRSArm

__all__ = ["ARM_ANGLES", "Q7_TRIES", "by_arm_angle", "closed_form_solution", "covered"]

#: Other values of ``q7`` tried when none of the solutions at ``q0[6]`` is within limits
#: (1,000 random in-limit targets from the neutral configuration, seed 7: with 12, the
#: iiwa14 had no answer on 64 and the Panda on 20; with 48, 12 and 0; each value tried
#: costs about half a microsecond).
Q7_TRIES = 48

_Arm = tuple[AnalyticArm, np.ndarray, "SRSArm | None"]
_ARMS: WeakKeyDictionary[Robot, dict[str | None, _Arm | None]] = WeakKeyDictionary()


def _arm(robot: Robot, frame: str | None) -> _Arm | None:
    """The arm's closed form, the ``q7`` values to try after ``q0[6]``, and its S-R-S
    closed form (None: not S-R-S; its kernel loaded here, before any time budget), or
    None."""
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
            srs = _srs(robot, frame, quiet=True)
            if srs is not None:  # load by_arm_angle's compiled calls now (5 ms at first)
                buffer = np.zeros(_BUFFER)
                analytic.solve_srs(srs.constants, np.eye(4), 0.0, buffer)
                analytic._errors(arm.links, arm.axes, arm.kinds, buffer, 0)
            per_robot[frame] = (arm, lo + span * (np.arange(Q7_TRIES) + 0.5), srs)
    return per_robot[frame]


def covered(robot: Robot, frame: str | None) -> bool:
    """Whether the arm has the closed form, its kernels ready (not compiling behind)."""
    if not _READY:  # once ready, ready for good (a fifth of this path's time to ask)
        if KERNELS.compiled("_nearest_kernels") is None:
            return False
        _READY.append(True)
    return _arm(robot, frame) is not None


_READY: list[bool] = []


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
    arm, others, _ = found
    if not (target.flags.c_contiguous and q0.flags.c_contiguous):
        target, q0 = np.ascontiguousarray(target), np.ascontiguousarray(q0)
    out = _empty(_BUFFER)
    status = _nearest(arm.arm, arm.links, arm.axes, arm.kinds, target, q0, others, out)
    if status == _SOLVED:
        row = out[0]
        q, position, rotation = row[:7].copy(), float(row[_POSITION]), float(row[_ROTATION])
        how = f"q7 = {float(row[6]):.6g} rad (redres.ik.analytic)"
    elif status != _NONE:
        return None  # a bad pose (the iteration says why)
    else:  # none within the limits at the values of q7 tried: step 3, the arm angle
        by_angle = by_arm_angle(robot, frame, target, q0)
        if by_angle is None:
            return None
        q, position, rotation, phi = by_angle
        how = f"arm angle = {phi:.6g} rad (redres.ik.srs)"
    if position > tol_position or rotation > tol_orientation:
        return None
    return _result(q, position, rotation, time.perf_counter() - start, how)


def _nearest_first(*args: Any) -> int:
    """``nearest(*args)`` of :mod:`redres.ik._nearest_kernels` (compiled: :func:`covered`
    is true), and :data:`_nearest` its dispatcher from now on."""
    global _nearest
    _nearest = KERNELS.required("rr.ik's closed form", "_nearest_kernels").nearest
    return int(_nearest(*args))


_nearest: Callable[..., int] = _nearest_first


_BUFFER = (codes.N_ROWS, codes.N_VALUES)
_POSITION, _ROTATION, _SOLVED = codes.POSITION_ERROR, codes.ROTATION_ERROR, codes.SOLVED
_NONE = codes.NONE_WITHIN_LIMITS
_empty = np.empty


#: The fields of a converged closed-form :class:`IKResult`, in order, before the five
#: :func:`_result` sets (the strict zip fails at import if the fields change).
_CONVERGED = dict(zip((field.name for field in dataclasses.fields(IKResult)),
                      (None, True, 0, 0, math.inf, math.inf, 0.0, "", None, None),
                      strict=True))  # fmt: skip


def _result(q: np.ndarray, position: float, rotation: float, seconds: float, how: str
            ) -> IKResult:  # fmt: skip
    """The converged :class:`IKResult` (without the frozen dataclass's ``__init__``, a
    fifth of this path's time, nor a zip of its fields, a tenth); ``how``: the parameter
    value used, and by which form."""
    result = object.__new__(IKResult)
    values = result.__dict__
    values.update(_CONVERGED)
    values["q"], values["position_error"], values["orientation_error"] = q, position, rotation
    values["time_s"], values["message"] = seconds, "converged: closed form at " + how
    return result


#: Arm angles tried by :func:`by_arm_angle`, evenly spread over ``[−π, π)`` (the 12 random
#: iiwa14 targets of 1,000, seed 7, that no value of ``q7`` tried answers: every one has
#: an arc of arm angles within the limits wider than 2.5 rad, six times this grid's step;
#: each value tried costs about a microsecond, compiled).
ARM_ANGLES = 16


def by_arm_angle(
    robot: Robot, frame: str | None, target: np.ndarray, q0: np.ndarray
) -> tuple[np.ndarray, float, float, float] | None:
    """Step 3 of the module docstring, on S-R-S arms: the within-limits solution nearest ``q0``
    (Euclidean, rad) among those at :data:`ARM_ANGLES` arm angles evenly spread over the
    circle, by the compiled closed form of :mod:`redres.ik.srs` (Shimizu et al. 2008);
    if none of them has one, the same at the middle of each exact arc of the
    self-motion within the limits (:meth:`redres.ik.srs.SRSPoses.arcs`), so that a
    pose with any arm angle within the limits is answered.

    Args:
        robot, frame: the arm and the frame placed (None: its tip).
        target: the pose, ``(4, 4)`` float64, C-contiguous.
        q0: the first guess, ``(7,)``, rad.

    Returns:
        ``(q (7,) rad clipped into the limits, position error m, rotation error rad, arm
        angle rad)``, or None: not an S-R-S arm, or no arm angle has a solution within
        the limits.
    """
    found = _arm(robot, frame)
    if found is None:
        return None
    arm, _, srs = found
    if srs is None:
        return None
    best = _nearest_at(srs.constants, target, q0, _GRID)
    if best is None:  # every arc within the limits narrower than the grid's step
        arcs = srs.poses(target[None]).arcs()[0]
        middles = [0.5 * (lo + hi) for per_branch in arcs for lo, hi in per_branch]
        best = _nearest_at(srs.constants, target, q0, [math.remainder(x, _TWO_PI)
                                                       for x in middles])  # fmt: skip
    if best is None:
        return None
    phi, row = best
    out = _empty(_BUFFER)
    analytic.solve_srs(srs.constants, target, phi, out)
    out[0] = out[row]
    analytic._errors(arm.links, arm.axes, arm.kinds, out, 1)
    q = np.clip(out[0, :7], robot.q_min, robot.q_max)
    return q, float(out[0, _POSITION]), float(out[0, _ROTATION]), phi


def _nearest_at(constants: np.ndarray, target: np.ndarray, q0: np.ndarray, values: Any
                ) -> tuple[float, int] | None:  # fmt: skip
    """``(arm angle, row)`` of the within-limits solution nearest ``q0`` over the arm
    angles ``values`` (rad), or None when none has one (each value solved by the kernel,
    then all compared at once)."""
    count = len(values)
    out = _empty((count, *_BUFFER))
    found = np.zeros((count, _BUFFER[0]), dtype=bool)
    solve, mask = analytic.solve_srs, codes.COUNT_MASK
    for i, phi in enumerate(values):
        code = solve(constants, target, phi, out[i])
        if code < 0:
            return None
        found[i, : code & mask] = True
    found &= out[:, :, codes.WITHIN] == 1.0
    if not found.any():
        return None
    d = np.full(found.shape, np.inf)  # (rows past each count are not written)
    d[found] = ((out[found][:, :7] - q0) ** 2).sum(axis=1)
    i, row = divmod(int(np.argmin(d)), _BUFFER[0])
    return float(values[i]), row


_TWO_PI = 2.0 * math.pi
_GRID = [float(x) for x in -math.pi + _TWO_PI * (np.arange(ARM_ANGLES) + 0.5) / ARM_ANGLES]
