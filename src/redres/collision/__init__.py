"""Collision geometry: obstacles, link-capsule pairs, compiled distances and their
Jacobians, and the velocity-damper constraint of the QP scheme.

- :mod:`.shapes`: :class:`SphereObstacle` (:func:`PointObstacle`), :class:`CapsuleObstacle`,
  :class:`BoxObstacle`, :class:`PlaneObstacle`.
- :mod:`.geometry`: closest points of segments and points (NumPy).
- :mod:`.pairs`: which pairs are checked (:class:`Pair`, :func:`read_srdf`).
- :mod:`.distances`: :class:`CollisionModel` → :class:`PairDistances` (compiled).
- :mod:`.constraint`: :class:`Collisions`, the settings of the hard constraint, and
  :class:`DamperRows`, its rows refreshed in place at each step.
"""

from .constraint import DEFAULT_GAIN, CollisionDetails, Collisions, DamperRows
from .distances import CollisionModel, PairDistances
from .pairs import Pair, read_srdf
from .shapes import (
    OBSTACLE_TYPES,
    BoxObstacle,
    CapsuleObstacle,
    Obstacle,
    PlaneObstacle,
    PointObstacle,
    SphereObstacle,
    pack_obstacles,
)

__all__ = [
    "DEFAULT_GAIN",
    "OBSTACLE_TYPES",
    "BoxObstacle",
    "CapsuleObstacle",
    "CollisionDetails",
    "CollisionModel",
    "Collisions",
    "DamperRows",
    "Obstacle",
    "Pair",
    "PairDistances",
    "PlaneObstacle",
    "PointObstacle",
    "SphereObstacle",
    "pack_obstacles",
    "read_srdf",
]
