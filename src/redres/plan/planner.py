"""The globally optimal joint path along a prescribed tool path, by dynamic programming
over the self-motion: ``rr.plan_path`` (and :func:`solve_grid` over a grid of your own).

Every scheme of :mod:`redres.resolution` is *local*: it picks the joint velocity from the
present state. Along a prescribed path of ``K`` poses the choices form a grid instead
(:mod:`redres.plan.grid`): at sample ``k`` the nodes ``x`` are the IK solutions at ``P``
values of the redundancy parameter on up to 8 branches. :mod:`redres.plan.dp` finds the
best admissible path through it (one feasible node per sample, every step within the
velocity limits) for an objective of :mod:`redres.plan.objectives`, and says where no
path exists and how the feasible region splits.

Obstacles. Given ``obstacles``, a node whose clearance is below ``clearance`` (m,
default 0: no penetration) is infeasible, whatever the objective, as a node outside the
joint limits is (clearance at the samples only: between two of them each joint moves at
most ``q̇_max·dt``).

Execution. :meth:`PathPlan.at` interpolates the plan linearly between samples: within
the joint limits and ``qd_max`` by construction. A :class:`~redres.control.Controller`
tracks it with the path as its frame task and the plan's ``q(t)`` as a posture level
below it (``PriorityScheme([PostureTask(...)])``, ``q_ref`` set each period: see
``examples/18_global_plan.py``).
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector
from ..control.trajectories import Trajectory
from ..errors import InvalidParameterError
from .clearance import KeepOut
from .dp import solve
from .grid import Parameter, PathGrid, build_grid, parameter_values, path_poses
from .objectives import OBJECTIVES, Objective, check_objective
from .path_plan import PathPlan, PlanStats

if TYPE_CHECKING:
    from ..objectives import Obstacle
    from ..robot import Capsule, Robot

__all__ = ["DT", "OBJECTIVES", "PathPlan", "PlanStats", "plan_path", "solve_grid"]

#: The default time between the samples of a trajectory, s.
DT = 0.01
#: How far ``q0`` may be from its node on the grid, rad (it is on the grid by
#: construction: the parameter's values are shifted to its value).
Q0_TOL = 1e-6


def plan_path(
    robot: Robot,
    path: Any,
    *,
    dt: float | None = None,
    parameter: Parameter | None = None,
    resolution: int = 90,
    objective: Objective | Callable[[FloatArray], Any] = "joint_limit_margin",
    qd_max: Any = None,
    qdd_max: Any = None,
    q0: Any = None,
    frame: str | None = None,
    obstacles: Sequence[Obstacle] | None = None,
    clearance: float = 0.0,
    capsules: Sequence[Capsule] | None = None,
) -> PathPlan:
    """The globally optimal joint path of a 7-DOF arm along a tool path (module
    docstring).

    Args:
        robot: a 7R arm with a closed form (:mod:`redres.plan.grid`).
        path: a :class:`~redres.control.trajectories.Trajectory` (sampled at ``t = k·dt``
            up to its duration) or poses of ``frame`` ``(K, 4, 4)`` (``t = k·dt``).
        dt: s between samples (> 0): with ``qd_max`` it bounds each step. Default
            :data:`DT` for a trajectory; required for poses.
        parameter: ``"arm_angle"`` (S-R-S arms; the default there) or ``"q7"`` (the
            default otherwise).
        resolution: parameter values per sample (≥ 2): over the circle for the arm
            angle, over the joint's range for ``q7``.
        objective: ``"joint_limit_margin"`` (max-min, rad), ``"obstacle_clearance"``
            (max-min, m; needs ``obstacles``), ``"manipulability"``
            (largest integral), ``"path_length"`` (shortest, rad), or a function
            ``cost(q (M, n)) -> (M,)`` whose sum over the samples is minimised.
        qd_max: joint velocity limits, rad/s, a scalar or ``(n,)`` (default the
            robot's).
        qdd_max: joint acceleration limits, rad/s², a scalar or ``(n,)`` (default
            None: none). Given, three consecutive samples must also satisfy
            ``|q_{k+1} − 2 q_k + q_{k−1}| ≤ q̈_max·dt²`` joint by joint (the central
            finite-difference acceleration; the velocity at the start and at the end is
            free), and the DP runs over transitions instead of nodes
            (:mod:`redres.plan.dp`). ``robot.qdd_max`` gives the robot's.
        q0: the start configuration (default: free). It must put ``frame`` at the
            path's first pose; the parameter's values are shifted so that ``q0`` is a
            node, and the plan starts there.
        frame: the frame on the path (default the robot's tip).
        obstacles: :class:`~redres.objectives.SphereObstacle` and
            :class:`~redres.objectives.CapsuleObstacle` in world coordinates: a node
            closer to one than ``clearance`` is infeasible.
        clearance: the smallest clearance a node may have, m (default 0: touching).
        capsules: the link capsules measured (default ``robot.capsules``).

    Returns:
        The :class:`PathPlan`; ``feasible`` False (with ``stats.first_infeasible`` or
        ``stats.first_unreachable``) when no admissible path exists.

    Raises:
        NotAnalyticError, NotSRSError: no closed form for ``parameter``.
        InvalidParameterError: a bad ``resolution``, ``objective``, ``qd_max``,
            ``qdd_max``, ``dt``,
            ``obstacles`` or ``clearance``; a ``q0`` that is not on the path's first
            pose; ``"obstacle_clearance"`` without obstacles; no link capsules.
        ShapeError, NonFiniteError: bad poses or ``q0``.
    """
    if parameter is None:
        parameter = _default_parameter(robot, frame)
    if parameter not in ("q7", "arm_angle"):
        raise InvalidParameterError(f"parameter must be 'q7' or 'arm_angle'; got {parameter!r}")
    integer = isinstance(resolution, (int, np.integer)) and not isinstance(resolution, bool)
    if not integer or resolution < 2:
        raise InvalidParameterError(
            f"resolution must be an integer >= 2 (parameter values per sample); got {resolution!r}"
        )
    keep = KeepOut.of(obstacles, clearance, capsules)
    check_objective(objective, keep)
    if dt is None:
        if not isinstance(path, Trajectory):
            raise InvalidParameterError(
                "dt is required for poses (K, 4, 4): the time between them, s, which with "
                "qd_max bounds each step"
            )
        dt = DT
    began = time.perf_counter()
    poses, t = path_poses(path, dt)
    anchor = start = None
    if q0 is not None:
        q0 = as_vector(q0, "q0", robot.n)
        anchor = float(q0[6]) if parameter == "q7" else _arm_angle(robot, q0)
    values = parameter_values(robot, parameter, int(resolution), len(t), anchor)
    grid = build_grid(robot, poses, t, values, parameter, frame)
    if q0 is not None:
        start = _start_node(grid, q0, anchor)  # type: ignore[arg-type]
    return solve(robot, grid, objective, float(dt), qd_max, start, frame, keep,
                  time.perf_counter() - began, qdd_max)  # fmt: skip


def solve_grid(
    robot: Robot,
    grid: PathGrid,
    *,
    dt: float,
    objective: Objective | Callable[[FloatArray], Any] = "joint_limit_margin",
    qd_max: Any = None,
    qdd_max: Any = None,
    start: tuple[int, int] | None = None,
    frame: str | None = None,
    obstacles: Sequence[Obstacle] | None = None,
    clearance: float = 0.0,
    capsules: Sequence[Capsule] | None = None,
) -> PathPlan:
    """:func:`plan_path` over a grid of your own (a planar arm's closed form, another
    parametrisation): the same DP, objectives, limits (``qd_max``, ``qdd_max``), obstacles
    and result. ``start``: the node
    ``(value index, branch)`` of the first sample the plan must start at (default:
    free)."""
    keep = KeepOut.of(obstacles, clearance, capsules)
    check_objective(objective, keep)
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    if start is not None:
        p, b = (int(x) for x in start)
        if not grid.feasible[0, p, b]:
            raise InvalidParameterError(f"start node {start} of the first sample is not feasible")
        start = (p, b)
    return solve(robot, grid, objective, dt, qd_max, start, frame, keep, 0.0, qdd_max)


def _default_parameter(robot: Robot, frame: str | None) -> Parameter:
    from ..ik.srs import NotSRSError, SRSArm

    try:
        SRSArm.from_robot(robot, frame)
    except NotSRSError:
        return "q7"
    return "arm_angle"


def _arm_angle(robot: Robot, q: FloatArray) -> float:
    from ..tasks import ArmAngleTask

    return ArmAngleTask().value(robot, q)


def _start_node(grid: PathGrid, q0: FloatArray, anchor: float) -> tuple[int, int]:
    """The node of the first sample at ``q0``: the value ``anchor`` and the nearest
    branch; refused when it is not ``q0``."""
    p = int(np.argmin(np.abs(np.angle(np.exp(1j * (grid.values[0] - anchor))))))
    gap = np.abs(grid.q[0, p] - q0).max(axis=1)
    gap = np.where(np.isnan(gap), np.inf, gap)
    b = int(np.argmin(gap))
    if not gap[b] <= Q0_TOL:
        raise InvalidParameterError(
            f"q0 is not a configuration at the path's first pose: the nearest solution there "
            f"differs by {gap[b]:.3g} rad (tolerance {Q0_TOL:g}); give a q0 with fk(q0) equal "
            "to the first pose, or q0=None to leave the start free"
        )
    return p, b
