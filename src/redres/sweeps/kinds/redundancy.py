"""Redundancy maps: at each pose of a 7-DOF arm, the arm angles reachable within the
joint limits, as intervals.

A unit of the sweep is one pose of the frame, from one of two sources:

* ``source = "random"``: shard ``k`` draws ``q_true`` uniformly within the joint limits
  (shrunk by ``margin``) from ``default_rng([seed, k])``, its pose by forward kinematics
  (every pose reachable);
* ``source = "grid"``: the poses of a capability map (:mod:`redres.sweeps.kinds.grid`,
  :mod:`redres.sweeps.kinds.orientations`): every tested voxel's centre at every orientation,
  the voxels found by the same forward-kinematics sampling (``resolution``, ``bounds``,
  ``directions``, ``rolls``, ``fk_samples``, ``dilation``).

The arm angle is the library's (:class:`redres.tasks.ArmAngleTask` of the ``points``
frames about ``reference``): the quantity the augmented-Jacobian scheme controls. Three
methods (``method = "auto"`` or ``"closed_form"`` take the first the arm allows; the
stored ``method`` says which):

* ``closed_form`` (:mod:`redres.ik.srs`, Shimizu et al. 2008): for each of the eight
  global configurations (:data:`~redres.ik.srs.BRANCHES`, slot ``b``), the exact arcs
  of arm angles within the limits;
* ``closed_form_q7`` (arms :func:`redres.ik.analytic.analytic_arm` accepts that are not
  S-R-S: the Panda, FR3; :mod:`redres.sweeps.kinds.q7arcs`): the self-motion along
  ``q7`` by the closed form, branch by branch (slot ``b`` the branch of code ``b``,
  table ``branches`` its bits ``(i4, iφ, is)``), its arm angles per stretch within the
  limits;
* ``trace`` (:mod:`redres.sweeps.kinds.selfmotion`): up to ``manifolds`` IK solutions per pose
  (``q_true`` first, then :func:`redres.batch.ik` from random guesses under the
  ``[solver]`` budget, distinct to 1e-3 rad), each traced along its self-motion manifold;
  slot ``b`` holds the arc of the ``b``-th solution whose arc differs from the earlier
  ones. A lower bound: manifolds no solution landed on are missing.

Stored per pose (arcs as pieces in ``[-π, π]``, :mod:`redres.ik.arcs`):
``pose``; ``intervals`` ``(B, K, 2)`` and ``count`` ``(B,)`` (pieces per slot; more than
``K = intervals`` means truncated), ``width`` ``(B,)`` (rad); ``union`` ``(K, 2)``,
``union_count``, ``total_width`` (the set over every slot: the arm angles some
configuration within the limits reaches); ``reachable`` (``total_width > 0``);
``q_true`` with the random source; ``ends`` ``(B, 2)`` with the trace (how each
direction ended, :data:`~redres.sweeps.kinds.selfmotion.LIMIT` ..., -1 for an empty slot).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ... import _compile, batch
from ...ik.analytic import NotAnalyticError, analytic_arm
from ...ik.arcs import Arc, merge, pack, pieces, width
from ...ik.srs import BRANCHES, NotSRSError, SRSArm
from ..kind import Field, Kind, Plan, ShardJob
from .grid import GridSource, grid_bounds, occupancy, read_grid_source, voxel_poses
from .ikdata import distinct
from .orientations import directions, frames
from .q7arcs import q7_arcs
from .selfmotion import trace

if TYPE_CHECKING:
    from ..._toml import Reader
    from ...robot import Robot
    from ..kind import SweepSpec

__all__ = ["REDUNDANCY_MAP", "RedundancyMap", "RedundancyParams", "load_redundancy_map"]

_PLAN_STREAM = 2**40 + 1  # the grid's own generator, default_rng([seed, _PLAN_STREAM])
_SAME_ARC = 1e-6  # rad: traced arcs this close are one manifold's


@dataclass(frozen=True)
class RedundancyParams(GridSource):
    """The ``[redundancy_map]`` table (module docstring; docs/sweeps.md).

    Attributes:
        source: ``"random"`` or ``"grid"``.
        poses: poses of the random source.
        margin: draw ``q_true`` this far inside the limits, rad.
        resolution, bounds, directions, rolls, fk_samples, dilation: the grid source,
            :class:`~redres.sweeps.kinds.grid.GridSource` (a coarser default grid: 0.1 m,
            20 directions, 100,000 samples).
        method: ``"auto"``, ``"closed_form"`` (S-R-S, else the closed form at ``q7``)
            or ``"trace"``.
        intervals: pieces stored per slot and for the union (``K``).
        manifolds: slots of the trace (solutions traced per pose).
        step: the trace's step, rad (joint space); ``max_steps`` its budget per direction.
        points: the shoulder, elbow and wrist frames of the arm angle.
        reference: its reference vector (world).
    """

    # the grid source's defaults for this kind (the fields stay in GridSource's order)
    resolution: float = 0.1
    directions: int = 20
    fk_samples: int = 100_000
    source: str = "random"
    poses: int = 10_000
    margin: float = 0.0
    method: str = "auto"
    intervals: int = 8
    manifolds: int = 4
    step: float = 0.02
    max_steps: int = 4000
    points: tuple[str, str, str] = ("shoulder", "elbow", "wrist")
    reference: tuple[float, float, float] = (0.0, 0.0, 1.0)


def _choice(r: Reader, key: str, default: str, options: tuple[str, ...]) -> str:
    value = r.string(key, default)
    if value not in options:
        raise r.fail(key, f"expected one of {', '.join(map(repr, options))}; got {value!r}")
    return value


def _parse(r: Reader, base: Path) -> RedundancyParams:
    names = tuple(r.string(k, d) for k, d in (("shoulder", "shoulder"), ("elbow", "elbow"),
                                               ("wrist", "wrist")))  # fmt: skip
    reference = r.get("reference", "vector", np.array([0.0, 0.0, 1.0]), size=3)
    if np.linalg.norm(reference) < 1e-9:
        raise r.fail("reference", "must be a non-zero vector")
    params = RedundancyParams(
        source=_choice(r, "source", RedundancyParams.source, ("random", "grid")),
        poses=r.integer("poses", RedundancyParams.poses, minimum=1),
        margin=r.nonnegative("margin", RedundancyParams.margin),
        **read_grid_source(r, RedundancyParams),
        method=_choice(r, "method", RedundancyParams.method, ("auto", "closed_form", "trace")),
        intervals=r.integer("intervals", RedundancyParams.intervals, minimum=1),
        manifolds=r.integer("manifolds", RedundancyParams.manifolds, minimum=1),
        step=r.positive("step", RedundancyParams.step),
        max_steps=r.integer("max_steps", RedundancyParams.max_steps, minimum=1),
        points=(names[0], names[1], names[2]),
        reference=(float(reference[0]), float(reference[1]), float(reference[2])),
    )
    r.done()
    return params


def _closed_form(p: RedundancyParams, robot: Robot, frame: str | None) -> SRSArm | None:
    """The arm's S-R-S closed form, or None when it has none or the trace is asked for."""
    if p.method == "trace":
        return None
    try:
        return SRSArm.from_robot(robot, frame, p.points, np.array(p.reference))
    except NotSRSError:
        return None


def _method(p: RedundancyParams, robot: Robot, frame: str | None) -> str:
    """``"closed_form"`` (S-R-S), ``"closed_form_q7"`` (the closed form at ``q7``:
    :mod:`redres.sweeps.kinds.q7arcs`) or ``"trace"``, as ``p.method`` asks and the arm
    allows (``closed_form`` on an arm with neither raises why)."""
    if p.method == "trace":
        return "trace"
    if _closed_form(p, robot, frame) is not None:
        return "closed_form"
    try:
        analytic_arm(robot, frame)
    except NotAnalyticError:
        if p.method == "closed_form":
            SRSArm.from_robot(robot, frame, p.points, np.array(p.reference))  # NotSRSError
            raise
        return "trace"
    return "closed_form_q7"


def _plan(spec: SweepSpec, robot: Robot) -> Plan:
    p: RedundancyParams = spec.params
    frame = spec.robot.frame
    if robot.n != 7:
        from ...errors import InvalidParameterError

        raise InvalidParameterError(
            f"a redundancy map is for 7-DOF arms; {robot.name} has {robot.n}"
        )
    for name in p.points:
        robot.frame_id(name)
    method = _method(p, robot, frame)
    closed = method != "trace"
    slots, k = (8 if closed else p.manifolds), p.intervals
    fields = {
        "pose": Field("float64", (4, 4), "T_world_frame"),
        "intervals": Field("float64", (slots, k, 2), "arm-angle pieces per slot, rad, NaN-padded"),
        "count": Field("int64", (slots,), "pieces per slot (> K: truncated)"),
        "width": Field("float64", (slots,), "feasible arm-angle width per slot, rad"),
        "union": Field("float64", (k, 2), "pieces of the union over slots, rad"),
        "union_count": Field("int64", (), "pieces of the union"),
        "total_width": Field("float64", (), "width of the union, rad"),
        "reachable": Field("bool", (), "some arm angle within the limits"),
    }
    if p.source == "random":
        fields["q_true"] = Field("float64", (robot.n,), "the configuration of the pose, rad")
    if not closed:
        fields["ends"] = Field("int64", (slots, 2), "how each trace direction ended; -1 empty")
    inputs: dict[str, np.ndarray] = {}
    tables: dict[str, np.ndarray] = {}
    if method == "closed_form":
        tables["branches"] = BRANCHES
    elif method == "closed_form_q7":  # the bits (i4, iφ, is) of each slot's branch code
        tables["branches"] = (np.arange(8)[:, None] >> np.array([2, 1, 0])) & 1
    units = p.poses
    if p.source == "grid":
        inputs["pose"] = _grid_poses(p, robot, frame, spec.seed)
        units = len(inputs["pose"])
    constants = {"closed_form": np.array([method == "closed_form"])}
    if method == "closed_form_q7":
        constants["q7_form"] = np.array([True])
    meta = {"method": method, "source": p.source}
    return Plan(units, 1, fields, inputs, constants, tables, meta)


def _grid_poses(p: RedundancyParams, robot: Robot, frame: str | None, seed: int) -> np.ndarray:
    """Every tested voxel centre at every orientation, ``(V·O, 4, 4)``, voxel-major."""
    rng = np.random.default_rng([seed, _PLAN_STREAM])
    bounds = grid_bounds(p.bounds, robot, frame)
    occ = occupancy(robot, frame, p.resolution, bounds, p.fk_samples, p.dilation, 0, rng)
    rotations = frames(directions(p.directions), p.rolls)
    return voxel_poses((occ.index + 0.5) * p.resolution, rotations).reshape(-1, 4, 4)


@contextmanager
def _threads(count: int | None) -> Iterator[None]:
    """The compiled kernels launched here on ``count`` threads (None: all)."""
    previous = _compile.threads(count)
    try:
        yield
    finally:
        _compile.threads(previous)


def _run(job: ShardJob, robot: Robot) -> dict[str, np.ndarray]:
    p: RedundancyParams = job.params
    frame, count = job.robot.frame, job.stop - job.start
    rng = job.rng()
    out: dict[str, np.ndarray] = {}
    if p.source == "random":
        lo, hi = robot.q_min + p.margin, robot.q_max - p.margin
        q_true = lo + (hi - lo) * rng.random((count, robot.n))
        T = batch.fk(robot, q_true, frame, threads=job.threads)
        out["q_true"] = q_true
    else:
        T, q_true = job.inputs["pose"], None
    out["pose"] = T
    if bool(job.constants["closed_form"][0]):
        arm = _closed_form(p, robot, frame)
        assert arm is not None
        out.update(arm.poses(T).intervals(p.intervals))
        out["reachable"] = out["total_width"] > 0.0
    elif "q7_form" in job.constants:
        with _threads(job.threads):
            runs = q7_arcs(robot, T, frame=frame, points=p.points,
                           reference=np.array(p.reference))  # fmt: skip
        out.update(runs.stored(p.intervals))
        out["reachable"] = out["total_width"] > 0.0
    else:
        arcs, ends = _traced(p, job, robot, T, q_true, rng)
        out["ends"] = ends
        out.update(_store(arcs, p.intervals))
    return out


def _traced(
    p: RedundancyParams, job: ShardJob, robot: Robot, T: np.ndarray, q_true: np.ndarray | None,
    rng: np.random.Generator,
) -> tuple[list[list[list[Arc]]], np.ndarray]:  # fmt: skip
    """Per pose and slot, the traced arc (module docstring), and the slots' ends."""
    count, n, slots = len(T), robot.n, p.manifolds
    wanted = slots - (q_true is not None)
    starts = np.full((count, slots, n), np.nan)
    found = np.zeros(count, dtype=np.int64)
    if q_true is not None:
        starts[:, 0], found[:] = q_true, 1
    if wanted > 0:
        q0 = robot.q_min + (robot.q_max - robot.q_min) * rng.random((count, n))
        keys = rng.integers(0, 2**62, count)
        result = batch.ik(robot, T, job.robot.frame, q0=q0, keys=keys, solutions=wanted,
                          threads=job.threads, **job.solver)  # fmt: skip
        for s in range(wanted):
            ok = s < result.found
            starts[ok, found[ok]] = result.solutions[ok, s]
            found[ok] += 1
    starts, found = distinct(starts, found, 1e-3)
    rows, cols = np.nonzero(np.arange(slots)[None, :] < found[:, None])
    traced = trace(robot, T[rows], starts[rows, cols], frame=job.robot.frame, points=p.points,
                   reference=np.array(p.reference), step=p.step, max_steps=p.max_steps,
                   threads=job.threads)  # fmt: skip
    arcs: list[list[list[Arc]]] = [[[] for _ in range(slots)] for _ in range(count)]
    ends = np.full((count, slots, 2), -1, dtype=np.int64)
    kept = np.zeros(count, dtype=np.int64)
    for item, (i, _) in enumerate(zip(rows, cols)):
        arc = traced.arc(item)
        if any(abs(arc[0] - a[0][0]) < _SAME_ARC and abs(arc[1] - a[0][1]) < _SAME_ARC
               for a in arcs[i][: kept[i]]):  # fmt: skip
            continue
        arcs[i][kept[i]] = [arc]
        ends[i, kept[i]] = traced.ends[item]
        kept[i] += 1
    return arcs, ends


def _store(arcs: list[list[list[Arc]]], k: int) -> dict[str, np.ndarray]:
    """The stored fields of per-pose, per-slot arcs."""
    count, slots = len(arcs), len(arcs[0]) if arcs else 0
    out = {
        "intervals": np.full((count, slots, k, 2), np.nan),
        "count": np.zeros((count, slots), dtype=np.int64),
        "width": np.zeros((count, slots)),
        "union": np.full((count, k, 2), np.nan),
        "union_count": np.zeros(count, dtype=np.int64),
        "total_width": np.zeros(count),
    }
    for i, per_pose in enumerate(arcs):
        every: list[Arc] = []
        for b, slot in enumerate(per_pose):
            parts = pieces(slot)
            out["intervals"][i, b], out["count"][i, b] = pack(parts, k)
            out["width"][i, b] = width(parts)
            every += parts
        union = merge(every)
        out["union"][i], out["union_count"][i] = pack(union, k)
        out["total_width"][i] = width(union)
    out["reachable"] = out["total_width"] > 0.0
    return out


@dataclass(frozen=True)
class RedundancyMap:
    """A redundancy map as :func:`load_redundancy_map` returns it (``N`` poses, ``B``
    slots, ``K`` pieces; fields as the module docstring).

    Attributes:
        method: ``"closed_form"``, ``"closed_form_q7"`` or ``"trace"``; ``branches``:
            the ``(g₂, g₄, g₆)`` of each slot of the S-R-S closed form, or the bits
            ``(i4, iφ, is)`` of each slot's branch code at ``q7`` (``(8, 3)``; empty
            for the trace).
        done: whether every shard is finished.
    """

    method: str
    pose: np.ndarray
    intervals: np.ndarray
    count: np.ndarray
    width: np.ndarray
    union: np.ndarray
    total_width: np.ndarray
    reachable: np.ndarray
    branches: np.ndarray
    extra: dict[str, Any]
    done: bool

    def feasible(self, phi: np.ndarray) -> np.ndarray:
        """Whether arm angle ``phi[i]`` (rad) is reachable at pose ``i`` (in the union)."""
        from ...ik.arcs import contains

        return contains(self.union, np.asarray(phi, dtype=np.float64))


def load_redundancy_map(out: str | Path) -> RedundancyMap:
    """The redundancy map in the sweep folder ``out``."""
    from ..results import load

    data = load(out)
    if data.kind != "redundancy_map":
        from ..folder import SweepFolderError

        raise SweepFolderError(f"{out} holds a {data.kind} sweep, not a redundancy map")
    extra = {k: data[k] for k in ("q_true", "ends") if k in data}
    return RedundancyMap(
        str(data.meta.get("method", "")), data["pose"], data["intervals"], data["count"],
        data["width"], data["union"], data["total_width"], data["reachable"],
        data.tables.get("branches", np.zeros((0, 3), dtype=np.int64)), extra, data.done,
    )  # fmt: skip


REDUNDANCY_MAP = Kind(
    "redundancy_map",
    "redundancy map: per pose of a 7-DOF arm, the arm-angle intervals within the limits",
    _parse,
    _plan,
    _run,
    warmup=("linalg", "batch", "analytic ik"),
)
