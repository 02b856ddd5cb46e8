"""Obstacles in world coordinates: spheres (and points), capsules, boxes and half-spaces.

Each shape packs into one row of :data:`PARAMS` numbers for the distance kernels
(:mod:`redres.collision._kernels`), with its kind code (:data:`SPHERE` … :data:`PLANE`):

============  =====================================================
kind          row
============  =====================================================
sphere        ``center (3), radius``
capsule       ``a (3), b (3), radius``
box           ``center (3), half_extents (3), rotation (9, row-major)``
plane         ``normal (3, unit), offset``
============  =====================================================
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import MAX_LENGTH, FloatArray, as_matrix, as_scalar, as_vector
from ..errors import InvalidParameterError

#: Kind codes of the packed obstacle rows (read by the kernels).
SPHERE, CAPSULE, BOX, PLANE = 0, 1, 2, 3
#: Numbers per packed obstacle row.
PARAMS = 16


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
        object.__setattr__(self, "radius", _radius(self.radius))


def PointObstacle(point: Any, name: str = "point") -> SphereObstacle:  # noqa: N802
    """A point obstacle: a sphere of radius zero."""
    return SphereObstacle(_point(point, "point"), 0.0, name)


@dataclass(frozen=True)
class CapsuleObstacle:
    """A capsule: segment ``[a, b]`` swept by a sphere of ``radius``, world coordinates, m."""

    a: FloatArray
    b: FloatArray
    radius: float = 0.0
    name: str = "capsule"

    def __post_init__(self) -> None:
        object.__setattr__(self, "a", _point(self.a, "a"))
        object.__setattr__(self, "b", _point(self.b, "b"))
        object.__setattr__(self, "radius", _radius(self.radius))


@dataclass(frozen=True)
class BoxObstacle:
    """A solid box: ``{center + R x : |x_i| ≤ half_extents_i}``, world coordinates, m.

    Attributes:
        center: shape ``(3,)``, m.
        half_extents: shape ``(3,)``, m, each ≥ 0.
        rotation: the box axes as columns of a rotation matrix, shape ``(3, 3)``
            (default identity: axis-aligned).
        name: for diagnostics.
    """

    center: FloatArray
    half_extents: FloatArray
    rotation: FloatArray | None = None
    name: str = "box"

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _point(self.center, "center"))
        half = _point(self.half_extents, "half_extents")
        if np.any(half < 0.0):
            raise InvalidParameterError(f"half_extents must be >= 0, m; got {half}")
        object.__setattr__(self, "half_extents", half)
        R = np.eye(3) if self.rotation is None else as_matrix(self.rotation, "rotation", (3, 3))
        if not np.allclose(R.T @ R, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0.0:
            raise InvalidParameterError(
                f"rotation must be a rotation matrix (RᵀR = I, det R = 1); got\n{R}"
            )
        object.__setattr__(self, "rotation", R)


@dataclass(frozen=True)
class PlaneObstacle:
    """A half-space ``{x : normal · x ≤ offset}`` (the solid side; e.g. a table top at
    height ``h`` is ``normal = (0, 0, 1)``, ``offset = h``), world coordinates.

    Attributes:
        normal: outward normal, shape ``(3,)``, normalised on construction.
        offset: m.
        name: for diagnostics.
    """

    normal: FloatArray
    offset: float = 0.0
    name: str = "plane"

    def __post_init__(self) -> None:
        normal = as_vector(self.normal, "normal", 3)
        size = float(np.linalg.norm(normal))
        if not size > 1e-12:
            raise InvalidParameterError(f"normal must be a non-zero vector; got {normal}")
        object.__setattr__(self, "normal", normal / size)
        offset = as_scalar(self.offset, "offset", minimum=-MAX_LENGTH, maximum=MAX_LENGTH)
        object.__setattr__(self, "offset", offset)


Obstacle = SphereObstacle | CapsuleObstacle | BoxObstacle | PlaneObstacle
#: The obstacle classes, for ``isinstance`` checks.
OBSTACLE_TYPES = (SphereObstacle, CapsuleObstacle, BoxObstacle, PlaneObstacle)


def pack_obstacles(obstacles: Any) -> tuple[np.ndarray, FloatArray]:
    """Kind codes ``(O,)`` (int64) and packed rows ``(O, PARAMS)`` of ``obstacles``
    (module docstring).

    Raises:
        InvalidParameterError: an entry is not one of the obstacle classes.
    """
    found = list(obstacles)
    kinds = np.zeros(len(found), np.int64)
    rows = np.zeros((len(found), PARAMS))
    for i, obs in enumerate(found):
        if isinstance(obs, SphereObstacle):
            kinds[i] = SPHERE
            rows[i, :4] = [*obs.center, obs.radius]
        elif isinstance(obs, CapsuleObstacle):
            kinds[i] = CAPSULE
            rows[i, :7] = [*obs.a, *obs.b, obs.radius]
        elif isinstance(obs, BoxObstacle):
            kinds[i] = BOX
            rows[i, :6] = [*obs.center, *obs.half_extents]
            rows[i, 6:15] = np.asarray(obs.rotation).ravel()
        elif isinstance(obs, PlaneObstacle):
            kinds[i] = PLANE
            rows[i, :4] = [*obs.normal, obs.offset]
        else:
            raise InvalidParameterError(
                f"obstacles[{i}] must be a SphereObstacle, CapsuleObstacle, BoxObstacle or "
                f"PlaneObstacle (or PointObstacle(...)); got {obs!r}"
            )
    return kinds, rows
