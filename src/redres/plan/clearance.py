"""The clearance of many configurations at once: the smallest surface distance between
the arm's link capsules and the obstacles, the quantity of
:func:`redres.objectives.proximities` and :meth:`ObstacleObjective.min_distance
<redres.objectives.ObstacleObjective.min_distance>` (``< 0``: penetration), for every
node of a path's grid.

Each capsule's segment is placed by :func:`redres.batch.fk` of its frame (compiled, all
rows per call), then measured against each obstacle by the row-wise closest points of
:mod:`redres.collision.geometry` (Ericson, *Real-Time Collision Detection*, 2005,
§5.1.9): for a sphere the distance from its centre to the segment, for a capsule the
distance between the two segments, less both radii.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar
from ..collision.geometry import segment_point_distances, segment_segment_distances
from ..errors import InvalidParameterError
from ..objectives import CapsuleObstacle, SphereObstacle
from .grid import PathGrid

if TYPE_CHECKING:
    from ..objectives.obstacles import Obstacle
    from ..robot import Capsule, Robot

__all__ = ["KeepOut", "clearances", "link_capsules", "screen"]

#: Configurations per call of the batched FK (bounds the memory of the poses).
_BLOCK = 65536


def link_capsules(robot: Robot, capsules: Sequence[Capsule] | None) -> list[Capsule]:
    """``capsules``, or the robot's own; refused when there are none."""
    caps = list(robot.capsules if capsules is None else capsules)
    if not caps:
        raise InvalidParameterError(
            f"robot {robot.name!r} has no link capsules to measure the clearance with: pass "
            "capsules=[Capsule(...)] (redres.robot.capsule_between)"
        )
    return caps


def clearances(
    robot: Robot, q: Any, obstacles: Sequence[Any], capsules: Sequence[Capsule] | None = None
) -> FloatArray:
    """The clearance ``(M,)`` (m) of each row of ``q`` ``(M, n)``: the smallest surface
    distance over (link capsule, obstacle) pairs; ``+inf`` without obstacles.

    Args:
        robot: a serial chain up to each capsule's frame.
        q: configurations ``(M, n)``, rad.
        obstacles: :class:`~redres.objectives.SphereObstacle` and
            :class:`~redres.objectives.CapsuleObstacle` in world coordinates.
        capsules: the link capsules (default ``robot.capsules``).
    """
    from .. import batch

    q = np.asarray(q, dtype=np.float64)
    out = np.full(len(q), np.inf)
    if not obstacles or len(q) == 0:
        return out
    for cap in link_capsules(robot, capsules):
        for lo in range(0, len(q), _BLOCK):
            T = batch.fk(robot, q[lo : lo + _BLOCK], frame=cap.frame)
            R, t = T[:, :3, :3], T[:, :3, 3]
            a, b = R @ cap.a + t, R @ cap.b + t
            part = out[lo : lo + _BLOCK]
            for obs in obstacles:
                if isinstance(obs, SphereObstacle):
                    d = segment_point_distances(a, b, obs.center)
                elif isinstance(obs, CapsuleObstacle):
                    d = segment_segment_distances(a, b, obs.a, obs.b)
                else:
                    raise InvalidParameterError(
                        "obstacles must be SphereObstacle or CapsuleObstacle (redres."
                        f"objectives); got {type(obs).__name__}"
                    )
                np.minimum(part, d - cap.radius - obs.radius, out=part)
    return out


@dataclass(frozen=True)
class KeepOut:
    """The obstacles a plan keeps clear of: ``obstacles``, the smallest clearance a node
    may have (``margin``, m) and the link ``capsules`` (None: the robot's)."""

    obstacles: tuple[Obstacle, ...]
    margin: float
    capsules: tuple[Capsule, ...] | None

    @classmethod
    def of(cls, obstacles: Any, margin: Any, capsules: Any) -> KeepOut | None:
        """Checked arguments of :func:`~redres.plan.plan_path` (None: no obstacles)."""
        margin = as_scalar(margin, "clearance")
        if obstacles is None or len(obstacles) == 0:
            return None
        for obs in obstacles:
            if not isinstance(obs, (SphereObstacle, CapsuleObstacle)):
                raise InvalidParameterError(
                    "obstacles must be SphereObstacle or CapsuleObstacle (redres.objectives); "
                    f"got {type(obs).__name__}"
                )
        return cls(tuple(obstacles), margin, None if capsules is None else tuple(capsules))


def screen(robot: Robot, grid: PathGrid, keep: KeepOut) -> tuple[PathGrid, FloatArray, int]:
    """The grid with its nodes closer than ``keep.margin`` to an obstacle made infeasible;
    the clearance ``(K, P, B)`` of the nodes that were feasible (NaN elsewhere), m; how
    many were made infeasible."""
    shape = grid.feasible.shape
    index = np.flatnonzero(grid.feasible.reshape(-1))
    flat = np.full(grid.feasible.size, np.nan)
    flat[index] = clearances(robot, grid.q.reshape(-1, grid.q.shape[-1])[index],
                             keep.obstacles, keep.capsules)  # fmt: skip
    dense: FloatArray = flat.reshape(shape)
    with np.errstate(invalid="ignore"):
        feasible = grid.feasible & (dense >= keep.margin)
    colliding = int(grid.feasible.sum() - feasible.sum())
    return dataclasses.replace(grid, feasible=feasible), dense, colliding
