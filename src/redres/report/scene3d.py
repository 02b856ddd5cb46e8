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


def obstacle_points(obstacles: Sequence[Obstacle]) -> FloatArray:
    """Points that bound every obstacle (for the scene's range), shape ``(k, 3)``, m."""
    from ..objectives import CapsuleObstacle, SphereObstacle

    out = [np.zeros((0, 3))]
    for obs in obstacles:
        if not isinstance(obs, (SphereObstacle, CapsuleObstacle)):
            continue  # boxes and half-spaces are not drawn yet
        ends = [obs.center] if isinstance(obs, SphereObstacle) else [obs.a, obs.b]
        for p in ends:
            out.append(p + obs.radius * np.vstack([np.eye(3), -np.eye(3)]))
    return np.concatenate(out)


def obstacle_traces(obstacles: Sequence[Obstacle]) -> list[dict[str, Any]]:
    """One trace per obstacle: a mesh at its place and size, a marker for a point (boxes
    and half-spaces are not drawn yet)."""
    from ..objectives import CapsuleObstacle, SphereObstacle

    traces = []
    for obs in obstacles:
        if not isinstance(obs, (SphereObstacle, CapsuleObstacle)):
            continue
        sphere = isinstance(obs, SphereObstacle)
        meta = {"kind": "obstacle", "shape": "sphere" if sphere else "capsule", "name": obs.name}
        a, b = (obs.center, obs.center) if isinstance(obs, SphereObstacle) else (obs.a, obs.b)
        if sphere and obs.radius == 0.0:
            meta["shape"] = "point"
            traces.append(
                {
                    "type": "scatter3d",
                    "mode": "markers",
                    "name": obs.name,
                    "x": [float(a[0])],
                    "y": [float(a[1])],
                    "z": [float(a[2])],
                    "marker": {"size": 5, "color": OBSTACLE_COLOUR, "symbol": "x"},
                    "meta": meta,
                }
            )
            continue
        vertices, triangles = capsule_mesh(a, b, obs.radius)
        traces.append(
            mesh_trace(vertices, triangles, name=obs.name, colour=OBSTACLE_COLOUR, meta=meta)
        )
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
