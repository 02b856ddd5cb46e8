"""Base placement from a capability map (inverse reachability).

Given task poses in the world and a capability map of the robot (in its base frame),
where should the base stand? A candidate base is a floor position ``(x, y)`` (at height
``z``) and a yaw ``ψ`` about the world z axis, ``B = Trans(x, y, z) Rot_z(ψ)``; task pose
``T`` is, seen from it, ``B⁻¹ T``, and counts as reachable when the map marks its voxel
reachable at the nearest tested orientation (:meth:`CapabilityMap.reachable_at`). This
is the scoring of Zacharias, Borst, Hirzinger, "Positioning mobile manipulators to
perform constrained linear trajectories", IROS 2008 (and Reuleaux's base placement by
reachability score), answered from the map without new IK solves: a unit of the sweep is
a candidate base, its queries the task poses.

Stored per candidate: ``reachable`` (one flag per task pose), ``count`` (poses
reachable) and ``score`` (the mean reachability index of the voxels of the reachable
poses, percent); :func:`ranking` orders the candidates by ``count``, then ``score``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..kind import Field, Kind, Plan, ShardJob
from .capability import load_map, lookup

if TYPE_CHECKING:
    from ..._toml import Reader
    from ...robot import Robot
    from ..kind import SweepSpec

__all__ = ["BASE_PLACEMENT", "PlacementParams", "candidates", "ranking"]


@dataclass(frozen=True)
class PlacementParams:
    """The ``[base_placement]`` table.

    Attributes:
        map: the capability map's folder (absolute; relative ones are taken from the
            spec's folder).
        map_sha256: the map's identity (its settings digest and shard checksums).
        poses: task poses ``[x, y, z, qx, qy, qz, qw]`` (m; unit quaternion, scalar last
            as ROS writes it), world frame.
        x, y: ``[min, max, step]`` of the candidate positions, m.
        z: the base height, m.
        yaws: yaw angles ``2πj/yaws``.
    """

    map: str
    map_sha256: str
    poses: tuple[tuple[float, ...], ...]
    x: tuple[float, float, float]
    y: tuple[float, float, float]
    z: float = 0.0
    yaws: int = 8

    def settings(self) -> dict[str, Any]:
        """The identity of the results: the map by content, not by path."""
        return {"map_sha256": self.map_sha256, "poses": self.poses, "x": self.x,
                "y": self.y, "z": self.z, "yaws": self.yaws}  # fmt: skip


def _parse(r: Reader, base: Path) -> PlacementParams:
    from ..folder import HEADER, MANIFEST, read_json

    folder = base / r.string("map")
    header = read_json(folder / HEADER)
    if not isinstance(header, dict) or header.get("kind") != "capability":
        raise r.fail("map", f"{folder} is not a capability map folder (no sweep.json of one)")
    entries = [read_json(p) for p in sorted((folder / MANIFEST).glob("*.json"))]
    if len(entries) != header["shards"]:
        raise r.fail("map", f"the map in {folder} is not finished ({len(entries)} of "
                     f"{header['shards']} shards); resume it first")  # fmt: skip
    import hashlib

    digest = hashlib.sha256(header["settings_sha256"].encode())
    for entry in entries:
        digest.update(str(entry.get("sha256")).encode())
    poses = r.table.get("poses")
    r.used.add("poses")
    if not isinstance(poses, list) or not poses or not all(
        isinstance(p, list) and len(p) == 7 and all(isinstance(v, (int, float)) for v in p)
        for p in poses
    ):  # fmt: skip
        raise r.fail("poses", "expected a list of [x, y, z, qx, qy, qz, qw] task poses")
    for i, p in enumerate(poses):
        if abs(math.sqrt(sum(v * v for v in p[3:])) - 1.0) > 1e-6:
            raise r.fail("poses", f"pose {i}: the quaternion must have norm 1")
    ranges = []
    for key in ("x", "y"):
        v = r.get(key, "vector", size=3)
        if not (v[0] <= v[1] and v[2] > 0):
            raise r.fail(key, "expected [min, max, step] with min <= max and step > 0")
        ranges.append((float(v[0]), float(v[1]), float(v[2])))
    params = PlacementParams(
        str(folder.resolve()), digest.hexdigest(),
        tuple(tuple(float(v) for v in p) for p in poses), ranges[0], ranges[1],
        r.number("z", 0.0), r.integer("yaws", 8, minimum=1),
    )  # fmt: skip
    r.done()
    return params


def candidates(p: PlacementParams) -> np.ndarray:
    """The candidate bases ``(x, y, yaw)``, ``(C, 3)``, x slowest, yaw fastest; positions
    on the grid ``lo + k step``, rounded to 1e-12 m (a base at y = 0 is at 0, not 5.55e-17)."""
    axes = [np.round(np.arange(lo, hi + 0.5 * step, step), 12) + 0.0 for lo, hi, step in (p.x, p.y)]
    yaw = 2.0 * math.pi * np.arange(p.yaws) / p.yaws
    grid = np.meshgrid(axes[0], axes[1], yaw, indexing="ij")
    return np.column_stack([g.ravel() for g in grid])


def task_poses(p: PlacementParams) -> np.ndarray:
    """The task poses as 4x4 transforms, ``(P, 4, 4)``."""
    import pinocchio as pin

    out = np.tile(np.eye(4), (len(p.poses), 1, 1))
    for i, v in enumerate(p.poses):
        quaternion = pin.Quaternion(v[6], v[3], v[4], v[5])  # (w, x, y, z)
        out[i, :3, :3] = quaternion.normalized().toRotationMatrix()
        out[i, :3, 3] = v[:3]
    return out


def _plan(spec: SweepSpec, robot: Robot) -> Plan:
    p: PlacementParams = spec.params
    m = load_map(p.map)
    bases, tasks = candidates(p), task_poses(p)
    fields = {
        "reachable": Field("bool", (len(tasks),), "task pose reachable from this base"),
        "count": Field("int64", (), "task poses reachable"),
        "score": Field("float64", (), "mean reachability index of their voxels, %"),
    }
    constants = {"tasks": tasks, "index": m.index, "rotations": m.rotations,
                 "reachable": m.reachable, "resolution": np.array([m.resolution]),
                 "z": np.array([p.z])}  # fmt: skip
    return Plan(len(bases), len(tasks), fields, {"bases": bases}, constants, {"bases": bases})


def _run(job: ShardJob, robot: Robot) -> dict[str, np.ndarray]:
    c = job.constants
    bases, tasks, reachable = job.inputs["bases"], c["tasks"], c["reachable"]
    index = 100.0 * reachable.mean(axis=1)  # the reachability index of each voxel
    reach = np.zeros((len(bases), len(tasks)), dtype=bool)
    score = np.zeros(len(bases))
    for b, (x, y, yaw) in enumerate(bases):
        local = base_inverse(x, y, float(c["z"][0]), yaw) @ tasks
        rows, orientation = lookup(c["index"], c["rotations"], float(c["resolution"][0]), local)
        ok = rows >= 0
        reach[b, ok] = reachable[rows[ok], orientation[ok]]
        if reach[b].any():
            score[b] = index[rows[reach[b]]].mean()
    return {"reachable": reach, "count": reach.sum(axis=1).astype(np.int64), "score": score}


def base_inverse(x: float, y: float, z: float, yaw: float) -> np.ndarray:
    """``B⁻¹`` of the base ``B = Trans(x, y, z) Rot_z(yaw)``, 4x4."""
    c, s = math.cos(yaw), math.sin(yaw)
    inverse = np.eye(4)
    inverse[:2, :2] = [[c, s], [-s, c]]
    inverse[:3, 3] = -inverse[:3, :3] @ np.array([x, y, z])
    return inverse


def ranking(out: str | Path) -> dict[str, np.ndarray]:
    """The candidates of the base-placement sweep in ``out``, best first: ``bases``
    ``(C, 3)`` (x, y, yaw), ``count`` and ``score``, sorted by count then score."""
    from ..results import load

    data = load(out)
    bases, count, score = data.tables["bases"], data["count"], data["score"]
    order = np.lexsort((-score, -count))
    return {"bases": bases[order], "count": count[order], "score": score[order]}


BASE_PLACEMENT = Kind(
    "base_placement",
    "base placement: floor positions and yaws ranked by the task poses a map reaches",
    _parse,
    _plan,
    _run,
    warmup=(),
)
