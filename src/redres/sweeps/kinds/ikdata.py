"""IK datasets: random configurations, their poses, and the distinct IK solutions of each.

For learned inverse kinematics (training and evaluating samplers of the solution set,
as IKFlow: Ames, Morgan, Hermans, "IKFlow: generating diverse inverse kinematics
solutions", IEEE RA-L 7(3), 2022): a unit of the sweep is one pose. Shard ``k`` draws
its configurations ``q_true`` uniformly within the joint limits from
``default_rng([seed, k])``, maps them to poses by forward kinematics
(:func:`redres.batch.fk`), and solves each pose from random first guesses (drawn from
the same generator) with :func:`redres.batch.ik`, collecting up to ``solutions``
converged attempts; each is refined to 1e-11 m and 1e-10 rad (:func:`refine`), then
attempts that end within ``distinct_tol`` (rad, largest joint difference) of an earlier
solution count once. Refining first ties the count to the solution set rather than to
the solver's tolerance (at 1e-4 m two attempts on one solution can lie 1e-2 rad apart).
Stored per pose: ``q_true``, ``pose`` (4x4), ``solutions`` (NaN-padded, in the order
found), ``count`` (distinct solutions) and ``attempts`` (attempts spent).

For training, :func:`training_rows` turns a dataset into rows, one per (pose, solution)
pair, as IKFlow-style samplers read them: ``pose`` ``[x, y, z, qw, qx, qy, qz]`` (m; a
unit quaternion with ``qw >= 0``) and ``q`` (rad), with ``pose_index`` back to the
dataset's pose; :func:`export_rows` writes them to ``.npz`` or ``.csv``
(``redres sweep SPEC --out DIR --rows FILE``).
"""

from __future__ import annotations

import os
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Literal

import numpy as np

from ... import batch
from ...errors import InvalidParameterError, shown_path
from ..kind import Field, Kind, Plan, ShardJob
from ..results import SweepData, load
from .reuleaux import quaternions

if TYPE_CHECKING:
    from ..._toml import Reader
    from ...robot import Robot
    from ..kind import SweepSpec

__all__ = ["IK_DATASET", "IKDatasetParams", "TrainingRows", "distinct", "export_rows",
           "refine", "training_rows"]  # fmt: skip


@dataclass(frozen=True)
class IKDatasetParams:
    """The ``[ik_dataset]`` table.

    Attributes:
        poses: poses in the dataset.
        solutions: converged attempts sought per pose (distinct ones are kept).
        attempts: the attempt budget per pose (first guesses and restarts).
        distinct_tol: two solutions closer than this (rad, max-norm) are one.
        margin: draw ``q_true`` at least this far inside the joint limits, rad.
    """

    poses: int = 10_000
    solutions: int = 8
    attempts: int = 32
    distinct_tol: float = 1e-3
    margin: float = 0.0


def _parse(r: Reader, base: Path) -> IKDatasetParams:
    params = IKDatasetParams(
        poses=r.integer("poses", 10_000, minimum=1),
        solutions=r.integer("solutions", 8, minimum=1),
        attempts=r.integer("attempts", 32, minimum=1),
        distinct_tol=r.positive("distinct_tol", 1e-3),
        margin=r.nonnegative("margin", 0.0),
    )
    r.done()
    return params


def _plan(spec: SweepSpec, robot: Robot) -> Plan:
    p: IKDatasetParams = spec.params
    n, s = robot.n, p.solutions
    fields = {
        "q_true": Field("float64", (n,), "the configuration the pose was made from, rad"),
        "pose": Field("float64", (4, 4), "T_world_frame = fk(q_true)"),
        "solutions": Field("float64", (s, n), "distinct IK solutions, NaN-padded, rad"),
        "count": Field("int64", (), "distinct solutions found"),
        "attempts": Field("int64", (), "attempts spent"),
    }
    return Plan(p.poses, 1, fields)


def _run(job: ShardJob, robot: Robot) -> dict[str, np.ndarray]:
    p: IKDatasetParams = job.params
    frame, count, n = job.robot.frame, job.stop - job.start, robot.n
    rng = job.rng()
    lo, hi = robot.q_min + p.margin, robot.q_max - p.margin
    q_true = lo + (hi - lo) * rng.random((count, n))
    q0 = robot.q_min + (robot.q_max - robot.q_min) * rng.random((count, n))
    keys = rng.integers(0, 2**62, count)
    T = batch.fk(robot, q_true, frame, threads=job.threads)
    solver = dict(job.solver, max_restarts=p.attempts - 1)
    result = batch.ik(robot, T, frame, q0=q0, keys=keys, solutions=p.solutions,
                      threads=job.threads, **solver)  # fmt: skip
    solutions = refine(robot, T, frame, result.solutions, result.found, job.threads)
    unique, found = distinct(solutions, result.found, p.distinct_tol)
    return {"q_true": q_true, "pose": T, "solutions": unique, "count": found,
            "attempts": result.restarts + 1}  # fmt: skip


#: The tolerances solutions are refined to before de-duplication, m and rad.
REFINE_POSITION, REFINE_ORIENTATION = 1e-11, 1e-10


def refine(
    robot: Robot,
    T: np.ndarray,
    frame: str | None,
    solutions: np.ndarray,
    found: np.ndarray,
    threads: int | None = None,
) -> np.ndarray:
    """The converged solutions ``(N, S, n)`` (the first ``found[i]`` of item ``i``) taken to
    :data:`REFINE_POSITION`, :data:`REFINE_ORIENTATION` by a few iterations of the same IK
    from each (no restart). Accepted at the solver's tolerance (1e-4 m, say), two attempts
    that reached one solution can lie 1e-2 rad apart, above ``distinct_tol``, and counted
    twice (up to 12 "distinct" solutions on a 6-joint arm that has at most 8); refined, they
    coincide to about 1e-9 rad. A solution the refinement does not improve stays as found."""
    slots = solutions.shape[1]
    mask = np.arange(slots)[None, :] < found[:, None]
    if not mask.any():
        return solutions
    start = solutions[mask]
    targets = np.repeat(T, slots, axis=0)[mask.ravel()]
    better = batch.ik(robot, targets, frame, q0=start, keys=np.zeros(len(start), np.int64),
                      max_restarts=0, max_iterations=20, tol_position=REFINE_POSITION,
                      tol_orientation=REFINE_ORIENTATION, threads=threads)  # fmt: skip
    out = solutions.copy()
    out[mask] = np.where(better.converged[:, None], better.q, start)
    return out


def distinct(solutions: np.ndarray, found: np.ndarray, tol: float) -> tuple[np.ndarray, np.ndarray]:
    """The solutions of each item (``solutions`` (N, S, n), the first ``found[i]``
    valid) with those within ``tol`` (max-norm) of an earlier one dropped, moved to the
    front, NaN-padded; and how many remain."""
    count, slots, _ = solutions.shape
    out = np.full_like(solutions, np.nan)
    kept = np.zeros(count, dtype=np.int64)
    for s in range(slots):
        candidate = solutions[:, s]
        fresh = s < found
        for t in range(s):
            near = np.abs(out[:, t] - candidate).max(axis=1) <= tol
            fresh &= ~(near & (t < kept))
        rows = np.flatnonzero(fresh)
        out[rows, kept[rows]] = candidate[rows]
        kept[rows] += 1
    return out, kept


@dataclass(frozen=True)
class TrainingRows:
    """An IK dataset as training rows (module docstring), ``M`` of them.

    Attributes:
        pose: ``(M, 7)``: ``x, y, z`` (m), ``qw, qx, qy, qz`` (``qw >= 0``).
        q: ``(M, n)``, rad: a solution of that pose (or the configuration it was made from).
        pose_index: ``(M,)``: the dataset's pose each row belongs to.
        columns: the names of the ``pose`` and ``q`` columns, in order.
    """

    pose: np.ndarray
    q: np.ndarray
    pose_index: np.ndarray
    columns: tuple[str, ...]


def training_rows(
    source: SweepData | str | Path, *, which: Literal["solutions", "true"] = "solutions"
) -> TrainingRows:
    """The rows of the IK dataset ``source`` (loaded, or its sweep folder): one per
    distinct solution of each pose (``which="solutions"``), or one per pose with the
    configuration it was made from (``"true"``). Only finished shards give rows.

    Raises:
        InvalidParameterError: ``source`` is not an IK dataset, or an unknown ``which``.
    """
    data = source if isinstance(source, SweepData) else load(source)
    if data.kind != IK_DATASET.name:
        raise InvalidParameterError(
            f"{shown_path(data.folder)} holds a {data.kind} sweep; training rows come "
            f"from an {IK_DATASET.name} sweep"
        )
    if which not in ("solutions", "true"):
        raise InvalidParameterError(f"which must be 'solutions' or 'true'; got {which!r}")
    shard = int(data.header["shard_units"])
    units = int(data.header["units"])
    done = np.zeros(units, dtype=bool)
    for k in data.finished:
        done[k * shard : (k + 1) * shard] = True
    poses = data["pose"]
    if which == "true":
        index = np.flatnonzero(done)
        q = data["q_true"][index]
    else:
        solutions, count = data["solutions"], data["count"]
        slot = np.arange(solutions.shape[1])
        keep = (slot[None, :] < count[:, None]) & done[:, None]
        index, s = np.nonzero(keep)
        q = solutions[index, s]
    T = poses[index]
    xyzw = quaternions(T[:, :3, :3]) if len(T) else np.empty((0, 4))
    pose = np.column_stack((T[:, :3, 3], xyzw[:, 3], xyzw[:, :3]))
    columns = ("x", "y", "z", "qw", "qx", "qy", "qz", *(f"q{j + 1}" for j in range(q.shape[1])))
    return TrainingRows(pose, q, index.astype(np.int64), columns)


def export_rows(
    source: SweepData | str | Path,
    path: str | Path,
    *,
    which: Literal["solutions", "true"] = "solutions",
) -> Path:
    """Write :func:`training_rows` of ``source`` to ``path``: ``.npz`` (arrays ``pose``,
    ``q``, ``pose_index``, ``columns``) or ``.csv`` (a header of the column names and
    ``pose_index``, then one row per line, every float to 17 significant digits). Written
    to a temporary file and renamed, so a reader never sees half a file. Returns the path.

    Raises:
        InvalidParameterError: another suffix (or as :func:`training_rows`).
    """
    target = Path(path)
    suffix = target.suffix.lower()
    if suffix not in (".npz", ".csv"):
        raise InvalidParameterError(
            f"training rows are written as .npz or .csv; got {shown_path(target)}"
        )
    rows = training_rows(source, which=which)
    handle, temp = tempfile.mkstemp(suffix=suffix, dir=target.parent or None,
                                    prefix=f".{target.name}.")  # fmt: skip
    try:
        with os.fdopen(handle, "wb") as f:
            if suffix == ".npz":
                np.savez(f, pose=rows.pose, q=rows.q, pose_index=rows.pose_index,
                         columns=np.array(rows.columns))  # fmt: skip
            else:
                table = np.column_stack((rows.pose, rows.q, rows.pose_index))
                np.savetxt(f, table, fmt=["%.17g"] * len(rows.columns) + ["%d"], delimiter=",",
                           header=",".join((*rows.columns, "pose_index")), comments="")  # fmt: skip
        os.replace(temp, target)
    except BaseException:
        os.unlink(temp)
        raise
    return target


IK_DATASET = Kind(
    "ik_dataset",
    "IK dataset: random configurations -> poses -> the distinct IK solutions of each",
    _parse,
    _plan,
    _run,
)
