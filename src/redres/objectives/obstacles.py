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

Distances and rows come from the compiled pairs of :mod:`redres.collision` (one call for
every pair at ``q``); ``self_collision=True`` adds the pairs of link capsules with each
other (``∂d/∂q = n̂ᵀ(J_a − J_b)``, both links move).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector
from ..collision import (
    BoxObstacle,
    CapsuleObstacle,
    CollisionModel,
    Obstacle,
    PlaneObstacle,
    PointObstacle,
    SphereObstacle,
)
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Capsule, Robot

__all__ = [
    "BoxObstacle",
    "CapsuleObstacle",
    "Obstacle",
    "ObstacleObjective",
    "PlaneObstacle",
    "PointObstacle",
    "Proximity",
    "SphereObstacle",
    "proximities",
]

#: Smallest influence distance ``d₀``, m (the penalty divides by it).
MIN_INFLUENCE = 1e-6


@dataclass(frozen=True)
class Proximity:
    """Distance between one link capsule and one obstacle (surfaces), with witnesses."""

    capsule: str
    obstacle: str
    distance: float
    point_on_link: FloatArray
    point_on_obstacle: FloatArray
    frame: str = field(repr=False)


def _proximities(model: CollisionModel, q: FloatArray) -> list[Proximity]:
    found = model.compute(q)
    frames = {c.name: c.frame for c in model.capsules}
    return [
        Proximity(p.first, p.second, float(found.distance[k]), found.point_a[k].copy(),
                  found.point_b[k].copy(), frames[p.first])
        for k, p in enumerate(found.pairs) if not p.self_pair
    ]  # fmt: skip


def proximities(
    robot: Robot, q: FloatArray, obstacles: Sequence[Obstacle], capsules: Sequence[Capsule]
) -> list[Proximity]:
    """Surface distances of every (capsule, obstacle) pair at ``q``, m (< 0: penetration);
    the witness on the link is on its centre line (on the obstacle:
    :class:`~redres.collision.PairDistances`)."""
    qv = as_vector(q, "q", robot.n)  # the argument first, as every public entry point
    model = CollisionModel(robot, obstacles, capsules=capsules, self_collision=False,
                           neutral="self")  # fmt: skip
    return _proximities(model, qv)


class ObstacleObjective(Objective):
    """Sum over (link capsule, obstacle) pairs of the hat penalty ``(1 − d/d₀)²``, d < d₀.

    Args:
        obstacles: spheres, points, capsules, boxes and half-spaces in world coordinates.
        influence: ``d₀``, m (at least :data:`MIN_INFLUENCE`): pairs farther apart cost
            nothing.
        capsules: link capsules (default: ``robot.capsules`` of the built-in arms).
        self_collision: also penalise pairs of link capsules (adjacent links and pairs in
            contact at the neutral pose left out: :mod:`redres.collision.pairs`).
    """

    name = "obstacles"

    def __init__(
        self,
        obstacles: Sequence[Obstacle],
        influence: float = 0.15,
        capsules: Sequence[Capsule] | None = None,
        *,
        self_collision: bool = False,
    ) -> None:
        """The arguments are described in ``help(ObstacleObjective)``."""
        self.obstacles = list(obstacles)
        self.influence = as_scalar(influence, "influence", minimum=MIN_INFLUENCE)
        self.capsules = None if capsules is None else list(capsules)
        self.self_collision = bool(self_collision)
        self._model: CollisionModel | None = None

    def collision_model(self, robot: Robot) -> CollisionModel:
        """The pairs of this objective on ``robot`` (built once per robot).

        Raises:
            InvalidParameterError: the robot has no capsules and none were given.
        """
        if self._model is None or self._model.robot is not robot:
            self._model = CollisionModel(
                robot, self.obstacles, capsules=self.capsules,
                self_collision=self.self_collision, neutral="self",
            )  # fmt: skip
        return self._model

    def proximities(self, robot: Robot, q: FloatArray) -> list[Proximity]:
        """Every (capsule, obstacle) distance at ``q``."""
        return _proximities(self.collision_model(robot), as_vector(q, "q", robot.n))

    def min_distance(self, robot: Robot, q: FloatArray) -> float:
        """Smallest surface distance between the arm and any obstacle (or, with
        ``self_collision``, two of its links), m."""
        return float(self.collision_model(robot).compute(q).distance.min(initial=np.inf))

    def _penalty(self, d: FloatArray) -> float:
        near = d[d < self.influence]
        return float(np.sum((1.0 - near / self.influence) ** 2))

    def cost_and_distance(self, robot: Robot, q: FloatArray) -> tuple[float, float]:
        """:meth:`cost` and :meth:`min_distance` from one distance computation."""
        d = self.collision_model(robot).compute(q).distance
        return self._penalty(d), float(d.min(initial=np.inf))

    def cost(self, robot: Robot, q: FloatArray) -> float:
        return self._penalty(self.collision_model(robot).compute(q, self.influence).distance)

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        d0 = self.influence
        found = self.collision_model(robot).compute(q, d0)
        near = found.distance < d0
        if not near.any():
            return np.zeros(robot.n)
        # ∂D/∂q = Σ −(2/d₀)(1 − d/d₀) ∂d/∂q over the pairs within d₀ (module docstring)
        weights = (-2.0 / d0) * (1.0 - found.distance[near] / d0)
        return np.asarray(weights @ found.gradient[near], dtype=float)
