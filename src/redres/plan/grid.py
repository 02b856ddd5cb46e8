"""The grid of a path: at each sample, every IK solution at each value of the redundancy
parameter.

A 7-DOF arm reaches each pose of a path in a one-parameter family of configurations (its
self-motion, :mod:`redres.ik.solutions`). Fixing the parameter at ``P`` values per sample
and taking every branch of the closed form there gives up to ``P × 8`` configurations per
sample, the *nodes* of the grid (Ferrentino, Salvioli & Chiacchio, "Globally optimal
redundancy resolution with dynamic programming for robot planning: a ROS
implementation", Robotics 10(1):42, 2021, §2). A node is feasible when the branch has a
solution there and it lies within the joint limits. Two parameters:

* ``"q7"``: the last joint, ``P`` values evenly spaced over its range, solved by
  :func:`redres.ik.analytic.at_q7_batch` (Panda, FR3, iiwa14, srs7); a solution counts
  when its own FK error is below :data:`RESIDUAL_TOL`;
* ``"arm_angle"``: the library's arm angle (:class:`redres.tasks.ArmAngleTask`), ``P``
  values evenly spaced on the circle, solved by the S-R-S closed form
  (:class:`redres.ik.srs.SRSArm`: iiwa14, srs7), branch ``b`` the row of
  :data:`redres.ik.srs.BRANCHES`.

Any other grid (another arm's closed form, a planar arm's) is a :class:`PathGrid` built
by hand: :func:`redres.plan.solve_grid` takes it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Literal

import numpy as np
from numpy.typing import NDArray

from .._validate import FloatArray, as_scalar
from ..control.trajectories import Trajectory
from ..errors import InvalidParameterError, ShapeError
from ..ik.analytic import at_q7_batch
from ..ik.srs import SRSArm
from ..tasks import wrap_angle

if TYPE_CHECKING:
    from ..robot import Robot

__all__ = ["RESIDUAL_TOL", "Parameter", "PathGrid", "build_grid", "path_poses"]

Parameter = Literal["q7", "arm_angle"]
#: Largest FK error (m, rad) of a ``q7`` solution that counts as a node.
RESIDUAL_TOL = 1e-8
#: Poses solved per block (bounds the memory of the IK buffers).
_BLOCK = 64


@dataclass(frozen=True)
class PathGrid:
    """Samples × parameter values × branches of configurations.

    Attributes:
        q: ``(K, P, B, n)`` configurations, rad (NaN where a branch has no solution).
        feasible: ``(K, P, B)``: a solution within the joint limits.
        values: ``(K, P)`` the parameter's values at each sample, rad.
        t: ``(K,)`` the samples' times, s.
        parameter: what ``values`` are (``"q7"``, ``"arm_angle"``, or a name of your own).
    """

    q: FloatArray
    feasible: NDArray[np.bool_]
    values: FloatArray
    t: FloatArray
    parameter: str

    def __post_init__(self) -> None:
        K, P, B, _ = np.shape(self.q)
        if np.shape(self.feasible) != (K, P, B) or np.shape(self.values) != (K, P):
            raise ShapeError(
                f"a PathGrid needs q (K, P, B, n), feasible (K, P, B) and values (K, P); "
                f"got q {np.shape(self.q)}, feasible {np.shape(self.feasible)}, values "
                f"{np.shape(self.values)}"
            )
        if np.shape(self.t) != (K,):
            raise ShapeError(f"a PathGrid's t must have shape ({K},); got {np.shape(self.t)}")
        if not np.isfinite(self.q[self.feasible]).all():
            raise ShapeError("a PathGrid's feasible nodes must have finite configurations")

    @property
    def shape(self) -> tuple[int, int, int]:
        """``(K, P, B)``: samples, parameter values, branches."""
        K, P, B, _ = self.q.shape
        return K, P, B


def path_poses(path: Any, dt: float) -> tuple[FloatArray, FloatArray]:
    """The poses ``(K, 4, 4)`` and times ``(K,)`` of ``path`` at ``t = k·dt``: a
    :class:`~redres.control.trajectories.Trajectory` sampled from 0 to its duration (the
    last sample at or before it), or poses given as an array ``(K, 4, 4)``.

    Raises:
        ShapeError: an array that is not ``(K, 4, 4)`` with ``K ≥ 1``.
        NonFiniteError: NaN or infinite poses; InvalidParameterError: ``dt ≤ 0``.
    """
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    if isinstance(path, Trajectory):
        count = math.floor(path.duration / dt + 1e-9) + 1
        t = np.arange(count, dtype=np.float64) * dt
        poses = np.array([path.sample(float(x)).pose for x in t], dtype=np.float64)
        return poses, t
    poses = np.array(path, dtype=np.float64)
    if poses.ndim != 3 or poses.shape[1:] != (4, 4) or len(poses) == 0:
        raise ShapeError(
            "path must be a redres Trajectory or poses of shape (K, 4, 4) with K >= 1; "
            f"got shape {poses.shape}"
        )
    if not np.isfinite(poses).all():
        from ..errors import NonFiniteError

        raise NonFiniteError("path poses contain NaN or infinity")
    return poses, np.arange(len(poses), dtype=np.float64) * dt


def parameter_values(
    robot: Robot, parameter: Parameter, count: int, samples: int, anchor: float | None
) -> FloatArray:
    """``(samples, count)`` values of the parameter (the same at every sample): on the
    circle from ``anchor`` (default −π) for the arm angle; over the joint's range for
    ``q7``, shifted so that one value is ``anchor`` when given."""
    if parameter == "arm_angle":
        base = -math.pi if anchor is None else anchor
        row = wrap_angle(base + np.arange(count) * (2.0 * math.pi / count))
    else:
        lo, hi = float(robot.q_min[6]), float(robot.q_max[6])
        if not (math.isfinite(lo) and math.isfinite(hi)):
            lo, hi = -math.pi, math.pi
        step = (hi - lo) / max(count - 1, 1)
        if anchor is None:
            row = np.linspace(lo, hi, count)
        else:
            first = math.ceil((lo - anchor) / step - 1e-9)
            row = anchor + (first + np.arange(count)) * step
    return np.ascontiguousarray(np.broadcast_to(np.asarray(row, dtype=np.float64),
                                                (samples, count)))  # fmt: skip


def build_grid(
    robot: Robot,
    poses: FloatArray,
    t: FloatArray,
    values: FloatArray,
    parameter: Parameter,
    frame: str | None = None,
) -> PathGrid:
    """Every branch's solution at ``values`` ``(K, P)`` of the parameter for poses
    ``(K, 4, 4)`` of ``frame`` (module docstring).

    Raises:
        NotAnalyticError, NotSRSError: the arm has no closed form for ``parameter``.
        InvalidParameterError: an unknown ``parameter``.
    """
    K, P = values.shape
    n = robot.n
    q = np.full((K, P, 8, n), np.nan)
    if parameter == "arm_angle":
        arm = SRSArm.from_robot(robot, frame)
        lo, hi = arm.q_min, arm.q_max
        for a in range(0, K, _BLOCK):
            b = min(K, a + _BLOCK)
            solved = arm.poses(np.ascontiguousarray(poses[a:b]))
            for branch in range(8):
                qb = solved.joints(values[a:b], branch)  # (block, P, 7), NaN: no solution
                # each joint moved by 2π into its limits where that fits (as rr.ik_all)
                turn = 2.0 * math.pi
                q[a:b, :, branch] = np.where(qb < lo, qb + turn, np.where(qb > hi, qb - turn, qb))
    elif parameter == "q7":
        for a in range(0, K, _BLOCK):
            b = min(K, a + _BLOCK)
            rows = (b - a) * P
            found = at_q7_batch(
                robot, np.repeat(poses[a:b], P, axis=0), values[a:b].reshape(-1), frame=frame
            )
            good = (found.branch >= 0) & (found.residual <= RESIDUAL_TOL)
            r, s = np.nonzero(good)
            block = np.full((rows, 8, n), np.nan)
            block[r, found.branch[r, s]] = found.q[r, s]
            q[a:b] = block.reshape(b - a, P, 8, n)
    else:
        raise InvalidParameterError(
            f"parameter must be 'q7' or 'arm_angle'; got {parameter!r} (for another "
            "parametrisation build a PathGrid and call redres.plan.solve_grid)"
        )
    with np.errstate(invalid="ignore"):
        feasible = np.all((q >= robot.q_min) & (q <= robot.q_max), axis=-1)
    return PathGrid(q, feasible, values, np.asarray(t, dtype=np.float64), parameter)
