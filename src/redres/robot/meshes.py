"""Visual meshes of a file robot (URDF or MJCF), for the report and the live viewer.

Pinocchio's visual geometry model gives each link's shapes with their pose in the link's
joint frame; mesh files (STL, DAE, OBJ, ...) are read by coal, Pinocchio's geometry layer,
scaled as the file says. Each shape becomes a :class:`LinkMesh`: triangles in the joint
frame's coordinates. Primitive shapes (box, cylinder, sphere, capsule) are triangulated
here. Meshes with many triangles are thinned by vertex clustering (vertices snapped to a
grid and merged, collapsed triangles dropped; Rossignac and Borrel, 1993) so that a report
stays a few megabytes.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from .._validate import FloatArray

#: At most this many triangles per mesh after thinning.
MAX_TRIANGLES = 1500


@dataclass(frozen=True)
class LinkMesh:
    """A triangle mesh rigidly attached to a frame.

    Attributes:
        frame: the frame it is fixed to (``None``: the world, for the base's shapes).
        vertices: shape ``(V, 3)``, m, in that frame's coordinates.
        triangles: shape ``(T, 3)``, vertex indices.
        name: the shape's name in the file.
        colour: ``#rrggbb``.
    """

    frame: str | None
    vertices: FloatArray
    triangles: np.ndarray
    name: str = ""
    colour: str = "#b8bec7"


def _lat_long(radius: float, half: float, rings: int = 8, sides: int = 16) -> tuple[Any, Any]:
    """A capsule along z (``half = 0``: a sphere) as latitude rings."""
    lats = np.pi / 2 * np.arange(-rings // 2, rings // 2 + 1) / (rings // 2)
    lon = 2 * np.pi * np.arange(sides) / sides
    pts = []
    for lat in lats:
        for z0 in (-half,) if lat < 0 else (half,) if lat > 0 else (-half, half):
            ring = np.column_stack([np.cos(lat) * np.cos(lon), np.cos(lat) * np.sin(lon),
                                    np.full(sides, np.sin(lat))])  # fmt: skip
            pts.append(radius * ring + [0.0, 0.0, z0])
    return np.concatenate(pts), ring_faces(len(pts), sides)


def ring_faces(count: int, sides: int) -> np.ndarray:
    """Triangles joining ``count`` consecutive rings of ``sides`` vertices."""
    faces = []
    for r in range(count - 1):
        for k in range(sides):
            p, q = r * sides + k, r * sides + (k + 1) % sides
            faces += [(p, q, q + sides), (p, q + sides, p + sides)]
    return np.array(faces, dtype=np.int64)


def _cylinder(radius: float, half: float, sides: int = 20) -> tuple[Any, Any]:
    lon = 2 * np.pi * np.arange(sides) / sides
    ring = np.column_stack([radius * np.cos(lon), radius * np.sin(lon), np.zeros(sides)])
    rings = [np.zeros((sides, 3)) - [0, 0, half], ring - [0, 0, half],
             ring + [0, 0, half], np.zeros((sides, 3)) + [0, 0, half]]  # fmt: skip
    return np.concatenate(rings), ring_faces(4, sides)


def _box(half: Any) -> tuple[Any, Any]:
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]  # fmt: skip
    return corners * np.asarray(half, float), np.array(faces, dtype=np.int64)


def shape_mesh(geometry: Any) -> tuple[FloatArray, np.ndarray] | None:
    """Vertices and triangles of a coal shape in its own frame; ``None`` if unknown."""
    import coal

    if isinstance(geometry, coal.Box):
        return _box(geometry.halfSide)
    if isinstance(geometry, coal.Cylinder):
        return _cylinder(geometry.radius, geometry.halfLength)
    if isinstance(geometry, coal.Sphere):
        return _lat_long(geometry.radius, 0.0)
    if isinstance(geometry, coal.Capsule):
        return _lat_long(geometry.radius, geometry.halfLength)
    if hasattr(geometry, "num_tris") and hasattr(geometry, "vertices"):
        vertices = np.asarray(geometry.vertices(), dtype=float).reshape(-1, 3)
        found = (geometry.tri_indices(i) for i in range(geometry.num_tris))
        tris = np.array([(t[0], t[1], t[2]) for t in found], dtype=np.int64).reshape(-1, 3)
        return vertices, tris
    return None


def decimate(
    vertices: FloatArray, triangles: np.ndarray, max_triangles: int = MAX_TRIANGLES
) -> tuple[FloatArray, np.ndarray]:
    """Thin a mesh to at most ``max_triangles`` by vertex clustering (module docstring).

    Each vertex moves by at most half a grid cell's diagonal; the grid is refined from
    coarse to fine and the finest grid within the budget is kept.
    """
    if len(triangles) <= max_triangles:
        return vertices, triangles
    low, high = vertices.min(axis=0), vertices.max(axis=0)
    size = float(np.max(high - low)) or 1.0
    best = None
    for cells in (4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128):
        h = size / cells
        ijk = np.floor((vertices - low) / h).astype(np.int64)  # 0 … cells, per axis
        keys = (ijk[:, 0] * (cells + 1) + ijk[:, 1]) * (cells + 1) + ijk[:, 2]
        _, cluster, counts = np.unique(keys, return_inverse=True, return_counts=True)
        cluster = cluster.reshape(-1)
        sums = np.zeros((len(counts), 3))
        np.add.at(sums, cluster, vertices)
        merged = sums / counts[:, None]
        tri = cluster[triangles]
        keep = (tri[:, 0] != tri[:, 1]) & (tri[:, 1] != tri[:, 2]) & (tri[:, 0] != tri[:, 2])
        tri = np.unique(np.sort(tri[keep], axis=1), axis=0) if keep.any() else tri[:0]
        if len(tri) > max_triangles:
            break
        best = (merged, tri)
    if best is None:
        return vertices, triangles[:max_triangles]
    return best


def _colour(rgba: Any) -> str:
    c = np.clip(np.asarray(rgba, dtype=float)[:3], 0, 1)
    if not np.all(np.isfinite(c)) or np.allclose(c, 0.0):
        return "#b8bec7"
    return "#{:02x}{:02x}{:02x}".format(*(round(255 * x) for x in c))


def link_meshes(model: pin.Model, visual: Any) -> tuple[LinkMesh, ...]:
    """Every visual shape of ``visual`` (a Pinocchio GeometryModel) as a :class:`LinkMesh`
    in its joint frame's coordinates, thinned to :data:`MAX_TRIANGLES`."""
    from .fitting import _joint_frame

    out = []
    for geom in visual.geometryObjects:
        found = shape_mesh(geom.geometry)
        if found is None:
            continue
        vertices, tris = decimate(*found)
        M = geom.placement
        world = vertices @ M.rotation.T + M.translation
        frame = None if geom.parentJoint == 0 else _joint_frame(model, int(geom.parentJoint))
        out.append(LinkMesh(frame, world, tris, str(geom.name), _colour(geom.meshColor)))
    return tuple(out)
