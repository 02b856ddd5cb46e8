"""Capsule models of links, for distances to obstacles.

A capsule is a segment rigidly attached to one frame, swept by a sphere of ``radius``.
Distances between capsules, spheres and points are exact (closest points of segments), so
no collision library is needed for these primitives.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray

if TYPE_CHECKING:
    from .robot import Robot


@dataclass(frozen=True)
class Capsule:
    """A link capsule.

    Attributes:
        frame: the frame the segment is fixed to.
        a, b: segment end points in that frame's coordinates, m, shape ``(3,)``.
        radius: m.
        name: for diagnostics.
    """

    frame: str
    a: FloatArray
    b: FloatArray
    radius: float
    name: str = ""


def capsule_between(
    robot: Robot, frame: str, start: str, end: str, radius: float, *, name: str = ""
) -> Capsule:
    """A capsule fixed to ``frame`` from the origin of frame ``start`` to that of ``end``.

    Both origins must be fixed relative to ``frame`` (e.g. on the joint axes at either end
    of a link); their local coordinates are read at ``robot.neutral()``.
    """
    q = robot.neutral()
    T_inv = np.linalg.inv(robot.fk(q, frame))
    a = (T_inv @ robot.fk(q, start)[:, 3])[:3]
    b = (T_inv @ robot.fk(q, end)[:, 3])[:3]
    return Capsule(frame, a, b, float(radius), name or f"{start}-{end}")
