"""What the 3D view draws besides the arm: obstacles, the robot's meshes and link capsules,
and the closest points.

Spheres and capsules become closed triangle meshes (plotly ``mesh3d``) at their real
centre and radius: a capsule is the surface at distance ``radius`` from its segment
``[a, b]``, built as latitude rings of two hemispheres (centred on ``a`` and ``b``) joined
by the cylinder between their equators. The longitude count is a multiple of four, so a
capsule whose axis is a world axis (and every sphere) touches its bounding box exactly:
the drawn extent is the true extent, which the browser test reads back.
Points (radius 0) are drawn as markers. Every obstacle trace carries
``meta = {"kind": "obstacle", "shape": ..., "name": ...}`` so the page can find it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray
from ..errors import InvalidParameterError
from ..robot.meshes import ring_faces

if TYPE_CHECKING:
    from ..objectives import Obstacle, Proximity
    from ..robot import Robot

#: Latitude steps from pole to pole (even: the equator is a ring) and longitude steps (a
#: multiple of 4: the rings reach ±radius along both axes normal to the segment).
LATITUDES = 12
LONGITUDES = 24
OBSTACLE_COLOUR = "#e07b39"
CAPSULE_COLOUR = "#9aa5b1"
#: Colours of the collision pairs' segments: within the influence distance, and binding.
PAIR_COLOURS = {"free": "#2a9d8f", "bound": "#d62728"}


def _basis(axis: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
    """Unit ``u`` along ``axis`` (z when it is zero) and two unit normals ``e1, e2``."""
    norm = float(np.linalg.norm(axis))
    u = axis / norm if norm > 1e-12 else np.array([0.0, 0.0, 1.0])
    helper = np.eye(3)[int(np.argmin(np.abs(u)))]  # the world axis least aligned with u
    e1 = np.cross(u, helper)
    e1 /= np.linalg.norm(e1)
    return u, e1, np.cross(u, e1)


def capsule_mesh(
    a: Any, b: Any, radius: float, *, latitudes: int = LATITUDES, longitudes: int = LONGITUDES
) -> tuple[FloatArray, np.ndarray]:
    """Vertices and triangles of the surface at distance ``radius`` from segment ``[a, b]``.

    Args:
        a, b: segment end points, shape ``(3,)``, m (equal: a sphere).
        radius: m, > 0.
        latitudes: rings from pole to pole (even), longitudes: vertices per ring.

    Returns:
        ``(vertices (V, 3), triangles (T, 3) of vertex indices)``; every vertex lies at
        distance ``radius`` from the segment.
    """
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    u, e1, e2 = _basis(b - a)
    half = latitudes // 2
    lats = np.pi / 2 * np.arange(-half, half + 1) / half  # -90° … 90°, the equator included
    lon = 2 * np.pi * np.arange(longitudes) / longitudes
    ring = np.outer(np.cos(lon), e1) + np.outer(np.sin(lon), e2)  # (L, 3) unit normals
    rings = []
    for i, lat in enumerate(lats):
        # the equator twice: the lower hemisphere's at a, the upper one's at b
        for centre in (a,) if i < half else (b,) if i > half else (a, b):
            rings.append(centre + radius * (np.cos(lat) * ring + np.sin(lat) * u))
    return np.concatenate(rings), ring_faces(len(rings), longitudes)


def xyz(points: FloatArray, decimals: int) -> dict[str, list[float]]:
    """The columns of ``points`` ``(k, 3)``, rounded to ``decimals``: plotly's ``x, y, z``."""
    p = np.round(np.asarray(points, dtype=float), decimals)
    return {"x": p[:, 0].tolist(), "y": p[:, 1].tolist(), "z": p[:, 2].tolist()}


def mesh_trace(
    vertices: FloatArray,
    triangles: np.ndarray,
    *,
    name: str,
    colour: str,
    opacity: float = 0.55,
    meta: dict[str, Any] | None = None,
    decimals: int = 5,
    **style: Any,
) -> dict[str, Any]:
    """A plotly ``mesh3d`` trace of a triangle mesh (vertices in m, rounded)."""
    trace: dict[str, Any] = {
        "type": "mesh3d",
        "name": name,
        **xyz(vertices, decimals),
        "i": triangles[:, 0].tolist(),
        "j": triangles[:, 1].tolist(),
        "k": triangles[:, 2].tolist(),
        "color": colour,
        "opacity": opacity,
        "flatshading": False,
        "hoverinfo": "name",
        "showlegend": True,
        **style,
    }
    if meta is not None:
        trace["meta"] = meta
    return trace


#: Half the side of the square drawn for a half-space (its surface near the robot), m.
PLANE_HALF_SIDE = 1.0
#: The faces of a box of corners ``(±1, ±1, ±1)`` in the order of :func:`box_mesh`
#: (bit 2: x, bit 1: y, bit 0: z), outward.
_BOX_FACES = np.reshape(
    [0, 1, 3, 0, 3, 2, 4, 6, 7, 4, 7, 5, 0, 4, 5, 0, 5, 1]  # x = -1, x = +1, y = -1
    + [2, 3, 7, 2, 7, 6, 0, 2, 6, 0, 6, 4, 1, 5, 7, 1, 7, 3],  # y = +1, z = -1, z = +1
    (12, 3),
)


def box_mesh(center: Any, half_extents: Any, rotation: Any) -> tuple[FloatArray, np.ndarray]:
    """The 8 corners ``center + R (±h)`` of a box, ``(8, 3)`` m, and its 12 triangles."""
    signs = np.array([[(i >> 2) & 1, (i >> 1) & 1, i & 1] for i in range(8)]) * 2.0 - 1.0
    R = np.asarray(rotation, float)
    corners = np.asarray(center, float) + (signs * np.asarray(half_extents, float)) @ R.T
    return corners, _BOX_FACES.copy()


def plane_mesh(normal: Any, offset: float, half_side: float) -> tuple[FloatArray, np.ndarray]:
    """A square of side ``2 half_side`` (m) on the plane ``normal · x = offset``, centred
    on the plane's point closest to the world origin (the robot's base), and its two
    triangles."""
    n = np.asarray(normal, float)
    _, e1, e2 = _basis(n)
    centre = offset * n
    signs = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    corners = centre + half_side * (signs[:, :1] * e1 + signs[:, 1:] * e2)
    return corners, np.array([[0, 1, 2], [0, 2, 3]])


def obstacle_mesh(
    obstacle: Obstacle, *, plane_half_side: float = PLANE_HALF_SIDE, min_radius: float = 0.0
) -> tuple[FloatArray, np.ndarray]:
    """A triangle mesh of an obstacle at its place and size, world coordinates, m: a
    sphere or capsule (radius at least ``min_radius``), a box, or a square patch of a
    half-space's surface (:func:`plane_mesh`)."""
    from ..collision import BoxObstacle, PlaneObstacle, SphereObstacle

    if isinstance(obstacle, BoxObstacle):
        return box_mesh(obstacle.center, obstacle.half_extents, obstacle.rotation)
    if isinstance(obstacle, PlaneObstacle):
        return plane_mesh(obstacle.normal, obstacle.offset, plane_half_side)
    if isinstance(obstacle, SphereObstacle):
        return capsule_mesh(obstacle.center, obstacle.center, max(obstacle.radius, min_radius))
    return capsule_mesh(obstacle.a, obstacle.b, max(obstacle.radius, min_radius))


def obstacle_anchor(obstacle: Obstacle) -> tuple[FloatArray, FloatArray]:
    """Where an obstacle's scene node sits (a sphere's or box's centre, a capsule's end
    ``a``, a half-space's surface point nearest the origin) and the numbers of its shape
    relative to it: ``(b − a, radius)`` for a sphere (``b = a``) or a capsule, ``(half
    extents, rotation)`` for a box, the unit normal for a half-space."""
    from ..collision import BoxObstacle, CapsuleObstacle, PlaneObstacle, SphereObstacle

    if isinstance(obstacle, SphereObstacle):
        return np.asarray(obstacle.center, float), np.array([0.0, 0.0, 0.0, obstacle.radius])
    if not isinstance(obstacle, (BoxObstacle, CapsuleObstacle, PlaneObstacle)):
        raise InvalidParameterError(
            "obstacles must be SphereObstacle, PointObstacle, CapsuleObstacle, BoxObstacle or "
            f"PlaneObstacle; got {obstacle!r}"
        )
    if isinstance(obstacle, BoxObstacle):
        rotation = np.asarray(obstacle.rotation, float)
        return np.asarray(obstacle.center, float), np.concatenate([obstacle.half_extents,
                                                                   rotation.ravel()])  # fmt: skip
    if isinstance(obstacle, PlaneObstacle):
        return obstacle.offset * obstacle.normal, np.array(obstacle.normal, float)
    a = np.asarray(obstacle.a, float)
    return a, np.append(np.asarray(obstacle.b, float) - a, obstacle.radius)


def _shape(obstacle: Obstacle) -> str:
    from ..collision import BoxObstacle, PlaneObstacle, SphereObstacle

    if isinstance(obstacle, SphereObstacle):
        return "point" if obstacle.radius == 0.0 else "sphere"
    return "box" if isinstance(obstacle, BoxObstacle) else (
        "plane" if isinstance(obstacle, PlaneObstacle) else "capsule")  # fmt: skip


def obstacle_points(
    obstacles: Sequence[Obstacle], plane_half_side: float = PLANE_HALF_SIDE
) -> FloatArray:
    """Points that bound every obstacle (for the scene's range), shape ``(k, 3)``, m."""
    out = [np.zeros((0, 3))]
    for obs in obstacles:
        out.append(obstacle_mesh(obs, plane_half_side=plane_half_side)[0])
    return np.concatenate(out)


def obstacle_traces(
    obstacles: Sequence[Obstacle], plane_half_side: float = PLANE_HALF_SIDE
) -> list[dict[str, Any]]:
    """One trace per obstacle: a mesh at its place and size (a half-space: a square of its
    surface, :func:`plane_mesh`), a marker for a point."""
    traces = []
    for obs in obstacles:
        shape = _shape(obs)
        meta = {"kind": "obstacle", "shape": shape, "name": obs.name}
        if shape == "point":
            traces.append({"type": "scatter3d", "mode": "markers", "name": obs.name,
                           **xyz(obs.center[None, :], 6),  # type: ignore[union-attr]
                           "marker": {"size": 5, "color": OBSTACLE_COLOUR, "symbol": "x"},
                           "meta": meta})  # fmt: skip
            continue
        vertices, triangles = obstacle_mesh(obs, plane_half_side=plane_half_side)
        opacity = 0.25 if shape == "plane" else 0.55
        traces.append(mesh_trace(vertices, triangles, name=obs.name, colour=OBSTACLE_COLOUR,
                                 meta=meta, opacity=opacity))  # fmt: skip
    return traces


@dataclass(frozen=True)
class RigidBodies:
    """Triangle meshes whose parts move with their frames, drawn as one trace.

    The page moves them itself (:mod:`.html`): the figure carries the vertices once, in
    their frames' coordinates, and each animation frame's link poses, so a report does
    not repeat every vertex at every frame.

    Attributes:
        name: the trace's name (``"robot meshes"`` or ``"link capsules"``).
        local: vertices in their frames' coordinates, ``(V, 3)``, m.
        triangles: ``(T, 3)`` vertex indices; ``face_colours`` one ``#rrggbb`` each.
        parts: ``(start, count, link)`` vertex ranges and the link index that moves them
            (``-1``: fixed in the world).
        poses: each animation frame's link poses, ``(F, L, 3, 4)`` (rotation, then
            translation).
        hidden: drawn only once its legend entry is clicked (plotly's ``legendonly``).
    """

    name: str
    local: FloatArray
    triangles: np.ndarray
    face_colours: list[str]
    parts: list[tuple[int, int, int]]
    poses: FloatArray
    hidden: bool = False

    def world(self, f: int) -> FloatArray:
        """The vertices in the world at animation frame ``f``, ``(V, 3)``, m."""
        out = self.local.copy()
        for start, count, link in self.parts:
            if link >= 0:
                R, t = self.poses[f, link, :, :3], self.poses[f, link, :, 3]
                out[start : start + count] = self.local[start : start + count] @ R.T + t
        return out


#: A mesh of a body: its frame (``None``: the world), vertices ``(V, 3)`` in that frame,
#: triangles ``(T, 3)`` and colour.
_Piece = tuple[str | None, FloatArray, np.ndarray, str]


def _capsule_pieces(robot: Robot) -> list[_Piece]:
    """The meshes of the robot's link capsules (``robot.capsules``) in their frames."""
    pieces: list[_Piece] = []
    for cap in robot.capsules:
        v, tri = capsule_mesh(cap.a, cap.b, cap.radius, latitudes=6, longitudes=12)
        pieces.append((cap.frame, v, tri, CAPSULE_COLOUR))
    return pieces


def rigid_bodies(robot: Robot, configurations: FloatArray) -> tuple[RigidBodies, ...]:
    """What moves with the arm, posed at each configuration (rows of ``configurations``).

    The robot's visual meshes (``robot.visuals``) and its link capsules, the capsules
    hidden (a legend click shows them: the clearance is measured to them); a robot
    without visual meshes shows its capsules. Empty when it has neither. All share one
    ``poses`` array, over the frames any of them needs.
    """
    bodies: list[tuple[str, list[_Piece]]] = []
    if robot.visuals:
        pieces = [(m.frame, m.vertices, m.triangles, m.colour) for m in robot.visuals]
        bodies.append(("robot meshes", pieces))
    if robot.capsules:
        bodies.append(("link capsules", _capsule_pieces(robot)))
    frames = sorted({p[0] for _, pieces in bodies for p in pieces if p[0] is not None})
    poses = np.empty((len(configurations), len(frames), 3, 4))
    for f, q in enumerate(configurations):
        for i, frame in enumerate(frames):
            poses[f, i] = robot.fk(q, frame)[:3, :]
    return tuple(_posed(name, pieces, frames, poses, hidden=i > 0)
                 for i, (name, pieces) in enumerate(bodies))  # fmt: skip


def _posed(
    name: str, pieces: list[_Piece], frames: list[str], poses: FloatArray, hidden: bool
) -> RigidBodies:
    """``pieces`` as one :class:`RigidBodies` moved by ``poses`` of ``frames``."""
    parts, tris, colours, offset = [], [], [], 0
    for frame, v, tri, colour in pieces:
        parts.append((offset, len(v), frames.index(frame) if frame is not None else -1))
        tris.append(tri + offset)
        colours += [colour] * len(tri)
        offset += len(v)
    local = np.concatenate([p[1] for p in pieces])
    return RigidBodies(name, local, np.concatenate(tris), colours, parts, poses, hidden)


def rigid_spec(
    bodies: RigidBodies, trace: int, decimals: int, *, poses_of: int | None = None
) -> dict[str, Any]:
    """What the page needs to move ``bodies`` (trace index ``trace``) frame by frame: one
    entry of the figure's ``rigid`` list. ``poses_of``: the index of an earlier entry
    whose poses these are too, written instead of them."""
    poses: Any = poses_of
    if poses_of is None:
        poses = np.round(bodies.poses.reshape(len(bodies.poses), -1, 12), 6).tolist()
    return {
        "trace": trace,
        **xyz(bodies.local, decimals),
        "parts": [list(p) for p in bodies.parts],
        "poses": poses,
        "decimals": decimals,
    }


def closest_pair(found: Sequence[Proximity]) -> tuple[float, FloatArray]:
    """The smallest distance of ``found`` and its two witness points, shape ``(2, 3)``."""
    best = min(found, key=lambda p: p.distance)
    return best.distance, np.vstack([best.point_on_link, best.point_on_obstacle])
