"""IK datasets: random configurations, their poses, and the distinct IK solutions of each.

For learned inverse kinematics (training and evaluating samplers of the solution set,
as IKFlow: Ames, Morgan, Hermans, "IKFlow: generating diverse inverse kinematics
solutions", IEEE RA-L 7(3), 2022): a unit of the sweep is one pose. Shard ``k`` draws
its configurations ``q_true`` uniformly within the joint limits from
``default_rng([seed, k])``, maps them to poses by forward kinematics
(:func:`redres.batch.fk`), and solves each pose from random first guesses (drawn from
the same generator) with :func:`redres.batch.ik`, collecting up to ``solutions``
converged attempts; attempts that end within ``distinct_tol`` (rad, largest joint
difference) of an earlier solution count once. Stored per pose: ``q_true``, ``pose``
(4x4), ``solutions`` (NaN-padded, in the order found), ``count`` (distinct solutions)
and ``attempts`` (attempts spent).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from ... import batch
from ..kind import Field, Kind, Plan, ShardJob

if TYPE_CHECKING:
    from ..._toml import Reader
    from ...robot import Robot
    from ..kind import SweepSpec

__all__ = ["IK_DATASET", "IKDatasetParams", "distinct"]


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
    unique, found = distinct(result.solutions, result.found, p.distinct_tol)
    return {"q_true": q_true, "pose": T, "solutions": unique, "count": found,
            "attempts": result.restarts + 1}  # fmt: skip


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


IK_DATASET = Kind(
    "ik_dataset",
    "IK dataset: random configurations -> poses -> the distinct IK solutions of each",
    _parse,
    _plan,
    _run,
)
