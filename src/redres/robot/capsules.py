"""Capsule models of links, for distances to obstacles.

A capsule is a segment rigidly attached to one frame, swept by a sphere of ``radius``.
Distances between capsules, spheres and points are exact (closest points of segments), so
no collision library is needed for these primitives.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from .._validate import FloatArray, as_scalar


class Posed(Protocol):
    """What the capsule builders read of a :class:`~redres.robot.Robot`: its neutral
    configuration and frame poses (a protocol: the robot module imports this one)."""

    def neutral(self) -> FloatArray: ...

    def fk(self, q: Any, frame: str | None = None) -> FloatArray: ...


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
    robot: Posed, frame: str, start: str, end: str, radius: float, *, name: str = ""
) -> Capsule:
    """A capsule fixed to ``frame`` from the origin of frame ``start`` to that of ``end``.

    Both origins must be fixed relative to ``frame`` (e.g. on the joint axes at either end
    of a link); their local coordinates are read at ``robot.neutral()``.
    """
    r = as_scalar(radius, "radius", minimum=0.0)
    q = robot.neutral()
    T_inv = np.linalg.inv(robot.fk(q, frame))
    a = (T_inv @ robot.fk(q, start)[:, 3])[:3]
    b = (T_inv @ robot.fk(q, end)[:, 3])[:3]
    return Capsule(frame, a, b, r, name or f"{start}-{end}")


def capsule_chain(
    robot: Posed,
    points: Sequence[str],
    links: Sequence[str],
    radii: Sequence[float],
    names: Sequence[str] = (),
) -> list[Capsule]:
    """Capsules along a path of frame origins, one per segment: capsule ``i`` is fixed to
    ``links[i]`` and runs from the origin of ``points[i]`` to that of ``points[i + 1]``
    (:func:`capsule_between`), e.g. base → shoulder → elbow → wrist → tool of an arm.

    Args:
        robot: the model the frames belong to.
        points: ``k + 1`` frame names, the segments' end points in order.
        links: ``k`` frames the segments are fixed to.
        radii: ``k`` radii, m.
        names: ``k`` capsule names (default ``"start-end"``).

    Raises:
        ShapeError: the sequences' lengths do not match.
    """
    k = len(points) - 1
    if k < 1 or len(links) != k or len(radii) != k or (names and len(names) != k):
        from ..errors import ShapeError

        raise ShapeError(
            f"capsule_chain needs k + 1 points and k links, radii (and names); got "
            f"{len(points)} points, {len(links)} links, {len(radii)} radii, {len(names)} names"
        )
    return [
        capsule_between(robot, links[i], points[i], points[i + 1], radii[i],
                        name=names[i] if names else "")
        for i in range(k)
    ]  # fmt: skip
