"""What a plan optimises: the objectives of :func:`redres.plan.plan_path` and each
node's value in the dynamic programming (:mod:`redres.plan.dp`).

* ``"joint_limit_margin"``: the largest smallest margin ``m(q) = min_j min(q_j − q_min,j,
  q_max,j − q_j)`` (rad) along the path, a *bottleneck* (max-min) objective;
* ``"obstacle_clearance"``: the largest smallest clearance ``d(q)`` (m) between the link
  capsules and the obstacles (:mod:`redres.plan.clearance`), max-min as the margin;
* ``"manipulability"``: the largest integral ``∫ w(q) dt`` of Yoshikawa's ``w =
  √det(J Jᵀ)`` (trapezoid rule over the samples; node value ``c = −w·h_k``);
* ``"path_length"``: the shortest ``Σ ‖q_{k+1} − q_k‖`` (rad; an edge cost, no node
  value);
* a callable ``cost(q)`` on ``(M, n)`` configurations returning ``(M,)``: the smallest
  ``Σ_k cost(q_k)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Literal

import numpy as np

from .._validate import FloatArray
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from .clearance import KeepOut

if TYPE_CHECKING:
    from numpy.typing import NDArray

    from ..robot import Robot

__all__ = ["BOTTLENECK", "OBJECTIVES", "Objective", "check_objective", "node_values"]

Objective = Literal["joint_limit_margin", "obstacle_clearance", "manipulability", "path_length"]
OBJECTIVES = ("joint_limit_margin", "obstacle_clearance", "manipulability", "path_length")
#: The max-min objectives (the bottleneck recursion).
BOTTLENECK = ("joint_limit_margin", "obstacle_clearance")


def check_objective(objective: Any, keep: KeepOut | None) -> None:
    """Refuse an objective :func:`node_values` does not know, and ``"obstacle_clearance"``
    without obstacles."""
    if objective == "obstacle_clearance" and keep is None:
        raise InvalidParameterError(
            "objective 'obstacle_clearance' needs obstacles=[SphereObstacle(...), "
            "CapsuleObstacle(...)] (redres.objectives)"
        )
    if callable(objective) or objective in OBJECTIVES:
        return
    raise InvalidParameterError(
        f"objective must be one of {list(OBJECTIVES)} or a function cost(q (M, n)) -> (M,); "
        f"got {objective!r}"
    )


def node_values(
    robot: Robot,
    q: FloatArray,
    objective: Objective | Callable[[FloatArray], Any],
    margin: FloatArray,
    clear: FloatArray,
    offsets: NDArray[np.int64],
    dt: float,
    frame: str | None,
) -> tuple[FloatArray, float]:
    """Each node's value for the DP ``(M,)`` and the weight of the step length in the
    edge cost (1 for ``"path_length"``, else 0)."""
    M = len(q)
    if objective == "joint_limit_margin":
        return np.ascontiguousarray(margin), 0.0
    if objective == "obstacle_clearance":
        return clear, 0.0
    if objective == "path_length":
        return np.zeros(M), 1.0
    if objective == "manipulability":
        K = len(offsets) - 1
        h = np.full(K, dt)
        if K > 1:
            h[0] = h[-1] = dt / 2.0
        weight = np.repeat(h, np.diff(offsets))
        return np.ascontiguousarray(-weight * _manipulability(robot, q, frame)), 0.0
    assert callable(objective)
    cost = np.asarray(objective(q.copy()), dtype=np.float64)
    if cost.shape != (M,):
        raise ShapeError(
            f"the cost function must map configurations (M, n) to (M,); got shape "
            f"{cost.shape} for M = {M}"
        )
    if not np.isfinite(cost).all():
        raise NonFiniteError("the cost function returned NaN or infinity")
    return np.ascontiguousarray(cost), 0.0


def _manipulability(robot: Robot, q: FloatArray, frame: str | None) -> FloatArray:
    """Yoshikawa's ``√det(J Jᵀ)`` of each row of ``q`` (the frame's 6-row Jacobian)."""
    from .. import batch

    out = np.empty(len(q))
    for a in range(0, len(q), 65536):
        J = batch.jacobian(robot, q[a : a + 65536], frame=frame)
        JJ = J @ np.swapaxes(J, -1, -2)
        out[a : a + 65536] = np.sqrt(np.maximum(np.linalg.det(JJ), 0.0))
    return out
