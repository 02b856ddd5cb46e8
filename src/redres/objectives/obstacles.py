"""Obstacle avoidance by self-motion with a hat-shaped distance penalty.

Gradient projection (Liégeois 1977; for obstacles Maciejewski & Klein 1985) asks for a
penalty ``D`` of the distance ``d`` between the arm and an object that is largest at
``d = 0`` and reaches zero as ``d`` grows. redres uses, per (link capsule, obstacle) pair,
``D(d) = (1 − d/d₀)²`` for ``d < d₀`` (the influence distance) and 0 beyond: C¹ at
``d₀``, maximal (1) at contact, growing further if the arm penetrates.

``∂d/∂q = n̂ᵀ J_p``: ``p`` is the arm's witness point (the closest point on the link's
segment, held fixed to the link), ``J_p = J_v − [p − p_f]× J_ω`` its position Jacobian
from the link frame's world-aligned Jacobian, and ``n̂`` the unit vector from the
obstacle's witness point to ``p``. Where closest points are unique this is the exact
derivative (the witness points' own motion along the surfaces does not change ``d`` to
first order).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
import pinocchio as pin

from .._validate import MAX_LENGTH, FloatArray, as_scalar, as_vector
from ..errors import InvalidParameterError
from .base import Objective
from .geometry import closest_point_on_segment, closest_points_segments

if TYPE_CHECKING:
    from ..robot import Capsule, Robot


#: Smallest influence distance ``d₀``, m (the penalty divides by it).
MIN_INFLUENCE = 1e-6


def _point(value: Any, name: str) -> FloatArray:
    return as_vector(value, name, 3, limit=MAX_LENGTH)


def _radius(value: Any) -> float:
    return as_scalar(value, "radius", minimum=0.0, maximum=MAX_LENGTH)


@dataclass(frozen=True)
class SphereObstacle:
    """A sphere (a point when ``radius = 0``) in world coordinates, m (within
    ±:data:`MAX_LENGTH`)."""

    center: FloatArray
    radius: float = 0.0
    name: str = "sphere"

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _point(self.center, "center"))
        _radius(self.radius)


def PointObstacle(point: Any, name: str = "point") -> SphereObstacle:  # noqa: N802
    """A point obstacle: a sphere of radius zero."""
    return SphereObstacle(_point(point, "point"), 0.0, name)


@dataclass(frozen=True)
class CapsuleObstacle:
    """A capsule: segment ``[a, b]`` swept by a sphere of ``radius``, world coordinates."""

    a: FloatArray
    b: FloatArray
    radius: float = 0.0
    name: str = "capsule"

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", _point(self.a, "a"))
        object.__setattr__(self, "b", _point(self.b, "b"))
        _radius(self.radius)


Obstacle = SphereObstacle | CapsuleObstacle


@dataclass(frozen=True)
class Proximity:
    """Distance between one link capsule and one obstacle (surfaces), with witnesses."""

    capsule: str
    obstacle: str
    distance: float
    point_on_link: FloatArray
    point_on_obstacle: FloatArray
    frame: str = field(repr=False)


def proximities(
    robot: Robot, q: FloatArray, obstacles: Sequence[Obstacle], capsules: Sequence[Capsule]
) -> list[Proximity]:
    """Surface distances of every (capsule, obstacle) pair at ``q``, m (< 0: penetration)."""
    model, data = robot.model, robot.data
    pin.framesForwardKinematics(model, data, as_vector(q, "q", robot.n))  # one pass, all frames
    out = []
    for cap in capsules:
        placement = data.oMf[robot.frame_id(cap.frame)]
        R, t = placement.rotation, placement.translation
        a = R @ cap.a + t
        b = R @ cap.b + t
        for obs in obstacles:
            if isinstance(obs, SphereObstacle):
                p_obs = obs.center
                p_link = closest_point_on_segment(p_obs, a, b)
            else:
                p_link, p_obs = closest_points_segments(a, b, obs.a, obs.b)
            gap = p_link - p_obs
            d = math.sqrt(float(gap @ gap)) - cap.radius - obs.radius
            out.append(Proximity(cap.name, obs.name, d, p_link, p_obs, cap.frame))
    return out


class ObstacleObjective(Objective):
    """Sum over (link capsule, obstacle) pairs of the hat penalty ``(1 − d/d₀)²``, d < d₀.

    Args:
        obstacles: spheres, points and capsules in world coordinates.
        influence: ``d₀``, m (at least :data:`MIN_INFLUENCE`): pairs farther apart cost
            nothing.
        capsules: link capsules (default: ``robot.capsules`` of the built-in arms).
    """

    name = "obstacles"

    def __init__(
        self,
        obstacles: Sequence[Obstacle],
        influence: float = 0.15,
        capsules: Sequence[Capsule] | None = None,
    ) -> None:
        """The arguments are described in ``help(ObstacleObjective)``."""
        self.obstacles = list(obstacles)
        self.influence = as_scalar(influence, "influence", minimum=MIN_INFLUENCE)
        self.capsules = None if capsules is None else list(capsules)

    def _capsules(self, robot: Robot) -> list[Capsule]:
        caps = robot.capsules if self.capsules is None else self.capsules
        if not caps:
            raise InvalidParameterError(
                f"robot {robot.name!r} has no link capsules: its file has no collision "
                "geometry (add <collision> shapes to its links and they are fitted), or pass "
                "capsules=[Capsule(...)] (redres.robot.capsule_between)"
            )
        return list(caps)

    def proximities(self, robot: Robot, q: FloatArray) -> list[Proximity]:
        """Every (capsule, obstacle) distance at ``q``."""
        return proximities(robot, q, self.obstacles, self._capsules(robot))

    def min_distance(self, robot: Robot, q: FloatArray) -> float:
        """Smallest surface distance between the arm and any obstacle, m."""
        return min(p.distance for p in self.proximities(robot, q))

    def _penalty(self, found: list[Proximity]) -> float:
        d0 = self.influence
        return float(sum((1.0 - p.distance / d0) ** 2 for p in found if p.distance < d0))

    def cost_and_distance(self, robot: Robot, q: FloatArray) -> tuple[float, float]:
        """:meth:`cost` and :meth:`min_distance` from one distance computation."""
        found = self.proximities(robot, q)
        return self._penalty(found), min(p.distance for p in found)

    def cost(self, robot: Robot, q: FloatArray) -> float:
        return self._penalty(self.proximities(robot, q))

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        d0 = self.influence
        grad = np.zeros(robot.n)
        near = [p for p in self.proximities(robot, q) if p.distance < d0]
        if not near:
            return grad
        model, data = robot.model, robot.data
        pin.computeJointJacobians(model, data, q)  # one pass for every frame below
        for p in near:
            offset = p.point_on_link - p.point_on_obstacle
            norm = float(np.linalg.norm(offset))
            if norm < 1e-12:  # segments touch: the direction is undefined
                continue
            fid = robot.frame_id(p.frame)
            origin = pin.updateFramePlacement(model, data, fid).translation
            J = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            n_hat = offset / norm
            # ∂d/∂q = n̂ᵀ J_p, J_p = J_v − [p − p_frame]× J_ω (module docstring)
            dd_dq = n_hat @ (J[:3] - pin.skew(p.point_on_link - origin) @ J[3:])
            grad += -2.0 / d0 * (1.0 - p.distance / d0) * dd_dq
        return grad
