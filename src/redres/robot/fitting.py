"""Link capsules fitted to a robot's collision geometry (URDF or MJCF).

Each collision shape becomes a set of *balls* ``(centre, radius)`` whose convex hull
contains it: a sphere is one ball; a capsule its two end balls; a box its eight corners; a
cylinder (or cone) the vertices of the polygons *circumscribed* about its end circles
(``N`` sides at radius ``r / cos(π/N)``, so the circles lie inside); a mesh or convex
shape its vertices. A capsule is convex, so it holds a shape as soon as it holds those
balls: ball ``(c, R)`` is inside the capsule of segment ``[a, b]`` and radius ``r`` iff
``dist(c, [a, b]) + R ≤ r``.

For an axis ``u`` through a point ``p``, a ball at axial coordinate ``t`` and distance
``ρ`` from the axis needs ``r ≥ ρ + R`` and, with ``s = √((r − R)² − ρ²)``, a segment
``[A, B]`` with ``A ≤ t + s`` and ``B ≥ t − s``: the shortest one is
``A = min(t + s)``, ``B = max(t − s)`` (a point when ``A > B``). The volume
``π r² (B − A) + 4/3 π r³`` is then a function of ``r`` alone, minimised on a grid and
refined. The axis is chosen among the principal axes of the ball centres, through their
centroid or the middle of their extent across the axis, whichever gives the smallest
volume.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from .._validate import FloatArray
from .capsules import Capsule

#: Sides of the polygons circumscribed about circles (cylinders, cones).
POLYGON_SIDES = 24


@dataclass(frozen=True)
class Balls:
    """Balls whose convex hull holds a shape: centres ``(k, 3)`` m, radii ``(k,)`` m."""

    centres: FloatArray
    radii: FloatArray


def _circle(radius: float, z: float) -> FloatArray:
    """Vertices of the polygon circumscribed about a circle of ``radius`` at height z."""
    angle = 2 * np.pi * np.arange(POLYGON_SIDES) / POLYGON_SIDES
    rho = radius / np.cos(np.pi / POLYGON_SIDES)
    return np.column_stack([rho * np.cos(angle), rho * np.sin(angle), np.full_like(angle, z)])


def shape_balls(geometry: Any) -> Balls | None:
    """The balls of one coal shape in its own frame (module docstring); ``None`` for a
    shape this does not know (a plane, a height field)."""
    import coal

    if isinstance(geometry, coal.Sphere):
        return Balls(np.zeros((1, 3)), np.array([geometry.radius]))
    if isinstance(geometry, coal.Capsule):
        h = geometry.halfLength
        return Balls(np.array([[0, 0, -h], [0, 0, h]], float), np.full(2, geometry.radius))
    if isinstance(geometry, coal.Box):
        corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        return Balls(corners * np.asarray(geometry.halfSide), np.zeros(8))
    if isinstance(geometry, coal.Cylinder):
        h = geometry.halfLength
        points = np.vstack([_circle(geometry.radius, -h), _circle(geometry.radius, h)])
        return Balls(points, np.zeros(len(points)))
    if isinstance(geometry, coal.Cone):
        h = geometry.halfLength
        points = np.vstack([_circle(geometry.radius, -h), [[0.0, 0.0, h]]])
        return Balls(points, np.zeros(len(points)))
    if isinstance(geometry, coal.Ellipsoid):
        corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T
        return Balls(corners * np.asarray(geometry.radii), np.zeros(8))
    vertices = getattr(geometry, "vertices", None) or getattr(geometry, "points", None)
    if callable(vertices):
        points = np.asarray(vertices(), dtype=float).reshape(-1, 3)
        if len(points):
            points = _hull(points)
            return Balls(points, np.zeros(len(points)))
    return None


def _hull(points: FloatArray) -> FloatArray:
    """The vertices of the convex hull of ``points`` (a capsule holding them holds the
    whole hull); ``points`` unchanged when they are few or flat."""
    if len(points) <= 64:
        return points
    from scipy.spatial import ConvexHull, QhullError

    try:
        return points[ConvexHull(points).vertices]
    except (QhullError, ValueError):  # flat or degenerate: keep them all
        return points


def _volume_for_axis(
    centres: FloatArray, radii: FloatArray, u: FloatArray, p: FloatArray
) -> tuple[float, float, float, float]:
    """The smallest capsule on the axis ``p + t u``: (volume, A, B, r)."""
    d = centres - p
    t = d @ u
    rho = np.linalg.norm(d - np.outer(t, u), axis=1)
    r_min = float(np.max(rho + radii))
    span = float(np.ptp(t)) + 2 * float(radii.max()) + 1e-12

    def shape(r: float) -> tuple[float, float, float]:
        s = np.sqrt(np.maximum((r - radii) ** 2 - rho**2, 0.0))
        A, B = float(np.min(t + s)), float(np.max(t - s))
        if A > B:
            A = B = 0.5 * (A + B)
        return np.pi * r * r * (B - A) + 4.0 / 3.0 * np.pi * r**3, A, B

    grid = r_min + span * np.linspace(0.0, 1.0, 101) ** 2
    volumes = [shape(r)[0] for r in grid]
    i = int(np.argmin(volumes))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, len(grid) - 1)]
    fine = np.linspace(lo, hi, 41)
    best = min(fine, key=lambda r: shape(r)[0])
    V, A, B = shape(float(best))
    return V, A, B, float(best)


def fit_capsule(balls: Balls) -> tuple[FloatArray, FloatArray, float]:
    """The capsule ``(a, b, radius)`` that holds ``balls`` (module docstring), m."""
    centres, radii = balls.centres, balls.radii
    centroid = centres.mean(axis=0)
    if len(centres) > 1:
        _, _, vt = np.linalg.svd(centres - centroid)
        axes = list(vt)
    else:
        axes = list(np.eye(3))
    best: tuple[float, FloatArray, FloatArray, float] | None = None
    for u in axes:
        u = u / np.linalg.norm(u)
        across = centres - np.outer(centres @ u, u)
        middle = 0.5 * (across.min(axis=0) + across.max(axis=0))
        for p in (centroid, middle):
            V, A, B, r = _volume_for_axis(centres, radii, u, p)
            if best is None or V < best[0]:
                best = (V, p + A * u, p + B * u, r)
    assert best is not None
    _, a, b, r = best
    return a, b, r * (1 + 1e-9) + 1e-12  # rounding must not leave a point outside


def link_capsules(model: pin.Model, collision: Any) -> list[Capsule]:
    """One capsule per moving link holding all its collision shapes, on the frame of its
    joint (the base's shapes do not move and are left out)."""
    per_joint: dict[int, list[Balls]] = {}
    for geom in collision.geometryObjects:
        if geom.parentJoint == 0:
            continue
        balls = shape_balls(geom.geometry)
        if balls is None:
            continue
        M = geom.placement  # the shape's pose in its joint's frame (mesh vertices scaled)
        centres = balls.centres @ M.rotation.T + M.translation
        per_joint.setdefault(int(geom.parentJoint), []).append(Balls(centres, balls.radii))
    out = []
    for j, found in sorted(per_joint.items()):
        joined = Balls(np.vstack([b.centres for b in found]), np.hstack([b.radii for b in found]))
        a, b, r = fit_capsule(joined)
        frame = _joint_frame(model, j)
        body = _body_name(model, j)
        out.append(Capsule(frame, a, b, r, body))
    return out


def _joint_frame(model: pin.Model, joint: int) -> str:
    """The frame placed at joint ``joint`` (its ``JOINT`` frame)."""
    for f in model.frames:
        if f.parentJoint == joint and f.type == pin.FrameType.JOINT:
            return str(f.name)
    return str(model.names[joint])


def _body_name(model: pin.Model, joint: int) -> str:
    for f in model.frames:
        if f.parentJoint == joint and f.type == pin.FrameType.BODY:
            return str(f.name)
    return str(model.names[joint])
