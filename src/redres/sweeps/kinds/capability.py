"""Capability maps: which orientations the frame reaches at each voxel of the workspace.

Zacharias, Borst, Hirzinger, "Capturing robot workspace structure: representing robot
capabilities", IROS 2007: the workspace is cut into voxels; at each, poses of many
orientations are tested by inverse kinematics; the *reachability index* of a voxel is
``D = 100 · R / N`` (percent), ``R`` of its ``N`` orientations reachable. ROS Reuleaux
(Makhal & Goins, 2018) builds the same maps in HDF5 (:mod:`redres.sweeps.kinds.reuleaux`
writes that layout).

Here a unit of the sweep is a voxel (:mod:`redres.sweeps.kinds.grid`: which voxels are tested,
and why the others are empty), its queries the ``directions × rolls`` orientations of
:mod:`redres.sweeps.kinds.orientations` at the voxel's centre. Each query is one item of
:func:`redres.batch.ik` under the ``[solver]`` budget: the first attempt starts at the
forward-kinematics sample of that voxel whose orientation is nearest the query's (the
robot's neutral configuration when no sample reached the voxel), then up to
``max_restarts`` random restarts; then ``refine`` passes retry each unsolved query with
one attempt from the solution of its voxel at the nearest solved orientation, then one
from the solution at its orientation in each face-neighbour voxel of the shard
(neighbouring poses have neighbouring solutions: this finds many that random restarts
miss, at one attempt per unsolved query and neighbour). For each (voxel, orientation) the map stores
``reachable`` (a solution within the joint limits and the tolerances), the best
``manipulability`` ``√det(J Jᵀ)`` (Yoshikawa 1985) and the best joint-limit ``margin``
(the smallest distance of a joint to its nearer limit, rad) over the ``solutions``
solutions sought, NaN when unreachable.

Cost: unreachable orientations dominate a map (most orientations at the edge of the
workspace are out of reach), and an unreachable query spends the whole budget; the
defaults (``max_restarts = 2``, ``max_iterations = 60``, ``patience = 8``: at most 3
attempts of 60 iterations, most stopped by the stall test long before) bound that cost
to a few hundred microseconds. The price is that a reachable orientation that needs
more restarts is recorded as unreachable: a map is a lower bound of the reachable set;
docs/sweeps.md gives the rate measured against a solve with 50 restarts.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ... import batch
from ..kind import Field, Kind, Plan, ShardJob
from .grid import GridSource, grid_bounds, occupancy, read_grid_source, voxel_poses
from .orientations import directions, frames, nearest

if TYPE_CHECKING:
    from ..._toml import Reader
    from ...robot import Robot
    from ..kind import SweepSpec

__all__ = [
    "CAPABILITY",
    "CapabilityMap",
    "CapabilityParams",
    "load_map",
    "lookup",
    "manipulability_and_margin",
]

#: The entropy word of the plan's own generator, ``default_rng([seed, PLAN_STREAM])``
#: (shard ``k`` uses ``[seed, k]``, ``k < 2**32``).
PLAN_STREAM = 2**40


@dataclass(frozen=True)
class CapabilityParams(GridSource):
    """The ``[capability]`` table (docs/sweeps.md).

    Attributes:
        resolution, bounds, directions, rolls, fk_samples, dilation: the voxels and
            orientations of the map, :class:`~redres.sweeps.kinds.grid.GridSource`.
        seeds_per_voxel: samples kept per voxel to start its queries from.
        solutions: solutions sought per query (the best manipulability and margin of
            those found are kept).
        refine: passes that retry the unsolved queries from the solutions of their
            neighbours (nearest orientation in the voxel, same orientation in the
            neighbour voxels).
        keep_configurations: also store the solution ``q`` of each query.
    """

    seeds_per_voxel: int = 4
    solutions: int = 1
    refine: int = 2
    keep_configurations: bool = False


def _parse(r: Reader, base: Path) -> CapabilityParams:
    params = CapabilityParams(
        **read_grid_source(r, CapabilityParams),
        seeds_per_voxel=r.integer(
            "seeds_per_voxel", CapabilityParams.seeds_per_voxel, minimum=0, maximum=64
        ),
        solutions=r.integer("solutions", CapabilityParams.solutions, minimum=1, maximum=1024),
        refine=r.integer("refine", CapabilityParams.refine, minimum=0, maximum=1000),
        keep_configurations=r.boolean("keep_configurations", CapabilityParams.keep_configurations),
    )
    r.done()
    return params


def _plan(spec: SweepSpec, robot: Robot) -> Plan:
    p: CapabilityParams = spec.params
    frame = spec.robot.frame
    rng = np.random.default_rng([spec.seed, PLAN_STREAM])
    occ = occupancy(robot, frame, p.resolution, grid_bounds(p.bounds, robot, frame), p.fk_samples,
                    p.dilation, p.seeds_per_voxel, rng)  # fmt: skip
    axes = directions(p.directions)
    rotations = frames(axes, p.rolls)
    count = len(rotations)
    fields = {
        "reachable": Field("bool", (count,), "a solution within the limits and tolerances"),
        "manipulability": Field("float64", (count,), "best sqrt(det(J J^T)); NaN: unreachable"),
        "margin": Field("float64", (count,), "best smallest distance to a joint limit, rad"),
    }
    if p.keep_configurations:
        fields["q"] = Field("float64", (count, robot.n), "a solution (the first found), rad")
    centres = (occ.index + 0.5) * p.resolution
    tables = {
        "index": occ.index, "centres": centres, "hits": occ.hits, "directions": axes,
        "rolls": 2.0 * np.pi * np.arange(p.rolls) / p.rolls, "rotations": rotations,
        "resolution": np.array([p.resolution]), "grid_low": occ.low,
        "grid_shape": np.array(occ.shape), "in_reach": np.array([occ.in_reach]),
    }  # fmt: skip
    inputs = {"centres": centres, "seeds": occ.seeds, "index": occ.index}
    constants = {"rotations": rotations, "neutral": robot.neutral()}
    return Plan(len(centres), count, fields, inputs, constants, tables)


def _run(job: ShardJob, robot: Robot) -> dict[str, np.ndarray]:
    p: CapabilityParams = job.params
    frame = job.robot.frame
    centres, seeds = job.inputs["centres"], job.inputs["seeds"]
    rotations = job.constants["rotations"]
    voxels, count = len(centres), len(rotations)
    T = voxel_poses(centres, rotations)
    q0 = _starts(robot, frame, seeds, rotations, job.constants["neutral"], job.threads)
    queries = voxels * count
    keys = job.rng().integers(0, 2**62, queries)
    targets = T.reshape(queries, 4, 4)
    result = batch.ik(robot, targets, frame, q0=q0.reshape(queries, -1), keys=keys,
                      solutions=p.solutions, threads=job.threads, **job.solver)  # fmt: skip
    solutions, found = result.solutions.copy(), result.found.copy()
    _refine(robot, frame, targets, rotations, job.inputs["index"], solutions, found, p.refine,
            job)  # fmt: skip
    manip, margin = manipulability_and_margin(robot, frame, solutions, found, job.threads)
    out = {
        "reachable": (found > 0).reshape(voxels, count),
        "manipulability": manip.reshape(voxels, count),
        "margin": margin.reshape(voxels, count),
    }
    if p.keep_configurations:
        out["q"] = np.where((found > 0)[:, None], solutions[:, 0], result.q).reshape(
            voxels, count, robot.n
        )
    return out


def _refine(
    robot: Robot,
    frame: str | None,
    targets: np.ndarray,
    rotations: np.ndarray,
    index: np.ndarray,
    solutions: np.ndarray,
    found: np.ndarray,
    passes: int,
    job: ShardJob,
) -> None:
    """Passes over the unsolved queries: one attempt each from the solution of the same
    voxel at the nearest solved orientation (largest ``tr(R_oᵀ R_p)``), then one from the
    solution at the same orientation in each of the six face-neighbour voxels of the
    shard that has one (``index``: the shard's grid indices); ``solutions`` (slot 0) and
    ``found`` are updated in place."""
    count = len(rotations)
    voxels = len(index)
    similarity = np.einsum("oab,pab->op", rotations, rotations)
    np.fill_diagonal(similarity, -np.inf)
    solver = dict(job.solver, max_restarts=0)
    steps = np.vstack((np.eye(3, dtype=np.int64), -np.eye(3, dtype=np.int64)))
    neighbours = [_rows_of(index, index + step) for step in steps]

    def attempt(rows: np.ndarray, seeds: np.ndarray) -> int:
        if not len(rows):
            return 0
        again = batch.ik(robot, targets[rows], frame, q0=solutions[seeds, 0], solutions=1,
                         threads=job.threads, **solver)  # fmt: skip
        ok = again.converged
        solutions[rows[ok], 0], found[rows[ok]] = again.q[ok], 1
        return int(ok.sum())

    for _ in range(passes):
        solved = (found > 0).reshape(voxels, count)
        v, o = np.nonzero(~solved & solved.any(axis=1, keepdims=True))
        score = np.where(solved[v], similarity[o], -np.inf)
        new = attempt(v * count + o, v * count + np.argmax(score, axis=1))
        for near in neighbours:
            solved = (found > 0).reshape(voxels, count)
            v, o = np.nonzero(~solved)
            n = near[v]
            ok = n >= 0
            v, o, n = v[ok], o[ok], n[ok]
            ok = solved[n, o]
            new += attempt(v[ok] * count + o[ok], n[ok] * count + o[ok])
        if not new:
            return


def _starts(
    robot: Robot,
    frame: str | None,
    seeds: np.ndarray,
    rotations: np.ndarray,
    neutral: np.ndarray,
    threads: int | None,
) -> np.ndarray:
    """The first guess of each (voxel, orientation): the voxel's sample whose frame
    orientation is nearest (largest ``tr(R_oᵀ R)``), else ``neutral``; ``(V, O, n)``."""
    voxels, k, n = seeds.shape
    q0 = np.broadcast_to(neutral, (voxels, len(rotations), n)).copy()
    if k == 0:
        return q0
    valid = np.isfinite(seeds[..., 0])
    flat = np.where(valid[..., None], seeds, neutral).reshape(-1, n)
    R = batch.fk(robot, flat, frame, threads=threads)[:, :3, :3].reshape(voxels, k, 3, 3)
    score = np.einsum("oab,vkab->vok", rotations, R)
    score[~np.broadcast_to(valid[:, None, :], score.shape)] = -np.inf
    best = np.argmax(score, axis=2)
    has = valid.any(axis=1)
    q0[has] = np.take_along_axis(seeds[has], best[has][..., None], axis=1)
    return q0


def manipulability_and_margin(
    robot: Robot, frame: str | None, solutions: np.ndarray, found: np.ndarray,
    threads: int | None = None,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """The best ``√det(J Jᵀ)`` and the best smallest distance to a joint limit (rad)
    over the ``found[i]`` first of ``solutions[i]`` (N, S, n); NaN where none."""
    count, slots, _ = solutions.shape
    used = np.arange(slots)[None, :] < found[:, None]
    q = solutions[used]
    manip = np.full((count, slots), -np.inf)
    margin = np.full((count, slots), -np.inf)
    if len(q):
        J = batch.jacobian(robot, q, frame, threads=threads)
        gram = J @ np.swapaxes(J, 1, 2)
        manip[used] = np.sqrt(np.maximum(np.linalg.det(gram), 0.0))
        margin[used] = np.minimum(q - robot.q_min, robot.q_max - q).min(axis=1)
    best_manip, best_margin = manip.max(axis=1), margin.max(axis=1)
    none = found == 0
    best_manip[none] = np.nan
    best_margin[none] = np.nan
    return best_manip, best_margin


@dataclass(frozen=True)
class CapabilityMap:
    """A capability map as :func:`load_map` returns it (arrays by voxel ``V`` and
    orientation ``O``).

    Attributes:
        resolution: voxel edge, m.
        index: grid indices of the tested voxels, ``(V, 3)``; ``centres`` their centres,
            m, ``(V, 3)``.
        rotations: the tested orientations, ``(O, 3, 3)``; ``directions`` their z axes
            (``(D, 3)``), ``rolls`` the roll angles (``(R,)``, rad).
        reachable, manipulability, margin: ``(V, O)`` (see the module docstring).
        hits: forward-kinematics samples that reached each voxel, ``(V,)``.
        done: whether every shard is finished (unfinished voxels read as unreachable).
    """

    resolution: float
    index: np.ndarray
    centres: np.ndarray
    rotations: np.ndarray
    directions: np.ndarray
    rolls: np.ndarray
    reachable: np.ndarray
    manipulability: np.ndarray
    margin: np.ndarray
    hits: np.ndarray
    done: bool

    @property
    def reachability_index(self) -> np.ndarray:
        """``D = 100 · R / N`` per voxel (Zacharias et al. 2007), percent, ``(V,)``."""
        return 100.0 * self.reachable.mean(axis=1) if self.reachable.size else np.zeros(0)

    def lookup(self, T: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(voxel row, orientation)`` of each pose of ``T`` (N, 4, 4): the tested voxel
        holding its position (-1 when the voxel is outside the map or untested) and the
        nearest tested orientation."""
        return lookup(self.index, self.rotations, self.resolution, T)

    def reachable_at(self, T: np.ndarray) -> np.ndarray:
        """Whether each pose of ``T`` (N, 4, 4) is reachable in the map (its voxel at its
        nearest orientation), ``(N,)``."""
        rows, orientation = self.lookup(T)
        out = np.zeros(len(rows), dtype=bool)
        ok = rows >= 0
        out[ok] = self.reachable[rows[ok], orientation[ok]]
        return out


def lookup(
    index: np.ndarray, rotations: np.ndarray, resolution: float, T: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """:meth:`CapabilityMap.lookup` on the map's arrays: the row of ``index`` (V, 3)
    holding each position of ``T`` (N, 4, 4), or -1, and the nearest of ``rotations``."""
    T = np.asarray(T, dtype=np.float64)
    ijk = np.floor(T[:, :3, 3] / resolution).astype(np.int64)
    return _rows_of(index, ijk), nearest(rotations, T[:, :3, :3])


def _rows_of(index: np.ndarray, ijk: np.ndarray) -> np.ndarray:
    """Row of ``index`` (V, 3, sorted lexicographically) equal to each of ``ijk``, or -1."""
    if not len(index):
        return np.full(len(ijk), -1, dtype=np.int64)
    keys, probe = _records(index), _records(ijk)
    at = np.searchsorted(keys, probe)
    at = np.minimum(at, len(keys) - 1)
    return np.where(keys[at] == probe, at, -1)


def _records(ijk: np.ndarray) -> np.ndarray:
    """Rows of ``ijk`` (N, 3) as records of three int64, ordered lexicographically."""
    layout = np.dtype([("i", np.int64), ("j", np.int64), ("k", np.int64)])
    return np.ascontiguousarray(ijk, dtype=np.int64).view(layout).ravel()


def load_map(out: str | Path) -> CapabilityMap:
    """The capability map in the sweep folder ``out``."""
    from ..results import load

    data = load(out)
    if data.kind != "capability":
        from ..folder import SweepFolderError

        raise SweepFolderError(f"{out} holds a {data.kind} sweep, not a capability map")
    t = data.tables
    return CapabilityMap(
        float(t["resolution"][0]), t["index"], t["centres"], t["rotations"], t["directions"],
        t["rolls"], data["reachable"], data["manipulability"], data["margin"], t["hits"],
        data.done,
    )  # fmt: skip


CAPABILITY = Kind(
    "capability",
    "capability map: per voxel and orientation, reachable? best manipulability, margin",
    _parse,
    _plan,
    _run,
)
