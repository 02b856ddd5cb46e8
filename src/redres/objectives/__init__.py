"""Secondary objectives: costs D(q) with analytic gradients (docs/conventions.md)."""

from .base import Objective, quadratic_coefficients
from .joint_limits import JointLimitObjective
from .manipulability import ManipulabilityObjective
from .obstacles import (
    BoxObstacle,
    CapsuleObstacle,
    Obstacle,
    ObstacleObjective,
    PlaneObstacle,
    PointObstacle,
    Proximity,
    SphereObstacle,
    proximities,
)
from .posture import PostureObjective

__all__ = [
    "BoxObstacle",
    "CapsuleObstacle",
    "JointLimitObjective",
    "ManipulabilityObjective",
    "Objective",
    "Obstacle",
    "ObstacleObjective",
    "PlaneObstacle",
    "PointObstacle",
    "PostureObjective",
    "Proximity",
    "SphereObstacle",
    "proximities",
    "quadratic_coefficients",
]
