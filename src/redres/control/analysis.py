"""Shared by the kinematic loop and the dynamic simulator: the checks of a run's start,
progress bars and the post-run measures of a :class:`~redres.control.RunLog` (computed
after the timed loop)."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector
from ..collision import Collisions, Pair
from ..collision.constraint import BINDING_TOLERANCE
from ..errors import InvalidParameterError, JointLimitError
from ..objectives import Objective, ObstacleObjective
from .log import RunLog

if TYPE_CHECKING:
    from ..robot import Robot
    from .trajectories import Trajectory


def start_configuration(robot: Robot, q0: Any) -> FloatArray:
    """A copy of ``q0`` (default ``robot.neutral()``), checked to be inside the limits.

    Raises:
        JointLimitError: a joint outside its limits (the message names it and them).
    """
    q = robot.neutral() if q0 is None else as_vector(q0, "q0", robot.n).copy()
    margin = robot.joint_limit_margin(q)
    if np.any(margin < 0):
        j = int(np.argmin(margin))
        raise JointLimitError(
            f"q0[{j}] = {q[j]:.6g} is outside the limits "
            f"[{robot.q_min[j]:.6g}, {robot.q_max[j]:.6g}] of joint {robot.joint_names[j]!r}"
        )
    return q


def run_duration(trajectory: Trajectory | None, duration: float | None) -> float:
    """``duration`` (default: the trajectory's), s, > 0."""
    if duration is None:
        if trajectory is None:
            raise InvalidParameterError("give a duration when there is no trajectory")
        duration = trajectory.duration
    return as_scalar(duration, "duration", minimum=0.0, strict=True)


#: The most steps one run records: its log is held in memory (about 250 bytes per step
#: on a 7-joint arm, and some 1.3 kB per step while the run is analysed), so 10⁷ steps,
#: 10⁴ s at 1 kHz, already take gigabytes.
MAX_STEPS = 10_000_000


def run_steps(duration: float, dt: float) -> int:
    """The number of steps ``round(duration / dt)``, from 1 to :data:`MAX_STEPS`.

    Raises:
        InvalidParameterError: ``duration`` is under half a step, or the run would take
            more than :data:`MAX_STEPS` steps (the message gives the count and the fix).
    """
    ratio = duration / dt
    if not ratio >= 0.5:
        raise InvalidParameterError(
            f"duration = {duration} s is under half a step of dt = {dt} s, so the run has no "
            "steps; make duration at least dt"
        )
    if not ratio <= MAX_STEPS:
        raise InvalidParameterError(
            f"duration / dt = {duration} / {dt} = {ratio:.3g} steps; a run takes at most "
            f"{MAX_STEPS:,} steps (its log is kept in memory): raise dt or shorten duration"
        )
    return round(ratio)


def progress_bar(total: int, enabled: bool | None, desc: str) -> Any:
    """A tqdm bar over ``total`` steps, or ``None``.

    ``enabled=None`` shows it for long runs (≥ 5,000 steps) on a terminal only.
    """
    show = enabled if enabled is not None else (total >= 5000 and sys.stderr.isatty())
    if not show:
        return None
    from tqdm import tqdm  # a dependency; imported only when a bar is shown

    return tqdm(total=total, desc=desc, unit="step", leave=False, mininterval=0.25)


def analyse_run(
    robot: Robot,
    log: RunLog,
    *,
    frame: str | None,
    rows: Sequence[int],
    objectives: Sequence[Objective] = (),
) -> np.ndarray:
    """Fill the post-run measures of ``log`` from its configurations ``log.q``.

    The robot's joint names and position limits (recorded in the log, for its
    :attr:`~redres.control.RunLog.warnings`); joint-limit margins; smallest singular value
    and manipulability of the task Jacobian (``rows`` of ``frame``'s world-aligned
    Jacobian); the value of each objective
    at every step; and the smallest arm–obstacle distance when an
    :class:`~redres.objectives.ObstacleObjective` is among them.

    Returns:
        The singular values of the task Jacobian at every step, shape ``(K, min(m, n))``.
    """
    rows = list(rows)
    log.joint_names = tuple(robot.joint_names)
    log.q_min, log.q_max = robot.q_min.copy(), robot.q_max.copy()  # what the warnings use
    log.joint_limit_margin[:] = np.minimum(log.q - robot.q_min, robot.q_max - log.q).min(axis=1)
    fid = robot.frame_id(frame)
    s: np.ndarray = np.zeros((0, min(len(rows), robot.n)))
    if log.steps:
        jacobians = np.stack([robot.placement_jacobian(q, fid)[1][rows] for q in log.q])
        s = np.linalg.svd(jacobians, compute_uv=False)
        log.sigma_min[:] = s[:, -1]
        log.manipulability[:] = np.prod(s, axis=1)
    by_name = {obj.name: obj for obj in objectives}
    obstacle = next((o for o in by_name.values() if isinstance(o, ObstacleObjective)), None)
    log.objectives = {
        name: np.array([obj.cost(robot, q) for q in log.q])
        for name, obj in by_name.items()
        if obj is not obstacle
    }
    if obstacle is not None:
        pairs = np.array([obstacle.cost_and_distance(robot, q) for q in log.q]).reshape(-1, 2)
        log.objectives[obstacle.name] = pairs[:, 0]
        log.objectives["obstacle_distance_m"] = pairs[:, 1]
        if log.steps and pairs[:, 1].min() < 0.0:  # which link went into which obstacle
            deepest = min(obstacle.proximities(robot, log.q[int(np.argmin(pairs[:, 1]))]),
                          key=lambda p: p.distance)  # fmt: skip
            log.extra["deepest_contact"] = {"obstacle": deepest.obstacle, "link": deepest.capsule}
    return s


@dataclass(frozen=True)
class CollisionRecord:
    """The collision pairs closer than the influence distance ``d_i`` at every step of a
    run, with their witness points, and whether the velocity damper's row (Faverjon &
    Tournassoud 1987; ``redres.collision.constraint``) bound the applied velocity.

    One row per (step, pair within ``d_i``), in step order; :meth:`at` gives a step's rows.

    Attributes:
        pairs: every pair of the collision model (:class:`~redres.collision.Pair`).
        influence, safety, gain: ``d_i`` (m), ``d_s`` (m) and ``ξ`` (m/s) of the damper.
        constrained: whether the run was under the constraint (without it no row binds:
            ``binding`` is all False, and the rows are those a constraint would have had).
        step: each row's step, ``(R,)``.
        pair: each row's index in ``pairs``, ``(R,)``.
        distance: the pair's signed distance, ``(R,)``, m.
        point_a, point_b: the witness points on the link capsule and on the other shape,
            ``(R, 3)``, m (:class:`~redres.collision.PairDistances`).
        binding: ``ḋ = n̂ᵀ(J_a − J_b) q̇`` of the logged ``q̇`` within ``1e-7`` m/s of
            the damper's bound ``−ξ (d − d_s)/(d_i − d_s)``, ``(R,)``.
    """

    pairs: list[Pair]
    influence: float
    safety: float
    gain: float
    constrained: bool
    step: np.ndarray
    pair: np.ndarray
    distance: FloatArray
    point_a: FloatArray
    point_b: FloatArray
    binding: np.ndarray

    def at(self, k: int) -> slice:
        """The rows of step ``k``."""
        lo, hi = np.searchsorted(self.step, [k, k + 1])
        return slice(int(lo), int(hi))

    @property
    def binding_steps(self) -> int:
        """How many steps had a binding pair."""
        return int(np.unique(self.step[self.binding]).size)


def collision_clearance(
    log: RunLog, robot: Robot, collisions: Collisions, *, constrained: bool = True
) -> CollisionRecord:
    """Log the clearances of a run under collision avoidance (or, ``constrained=False``,
    of a run to compare with one): at every step of ``log.q`` the smallest distance of the
    constraint's environment pairs (``obstacle_distance_m``, when it has any) and of its
    self pairs (``self_distance_m``, when it has any), m; the pairs are the constraint's
    (adjacent links, contacts at the neutral pose and allowed pairs left out:
    :class:`~redres.collision.CollisionModel`). The pairs within ``d_i`` at each step
    are kept in ``log.extra["collision_pairs"]``, the returned :class:`CollisionRecord`."""
    model = collisions.model(robot)
    mask = model.self_mask()
    d_i, d_s, gain = collisions.influence, collisions.safety, collisions.gain
    d = np.full((log.steps, len(mask)), np.inf)
    parts: dict[str, list[np.ndarray]] = {k: [] for k in ("step", "pair", "d", "a", "b", "bind")}
    for k, q in enumerate(log.q):
        found = model.compute(q)
        d[k] = found.distance
        near = np.flatnonzero(found.distance < d_i)
        if not len(near):
            continue
        dn = found.distance[near]
        binding = found.gradient[near] @ log.qd[k] - collisions.bound(dn) <= BINDING_TOLERANCE
        for key, value in (("step", np.full(len(near), k)), ("pair", near), ("d", dn),
                           ("a", found.point_a[near]), ("b", found.point_b[near]),
                           ("bind", binding & constrained)):  # fmt: skip
            parts[key].append(value)
    if len(mask) and log.steps:
        for key, contact, kept in (("obstacle_distance_m", "deepest_contact", ~mask),
                                   ("self_distance_m", "deepest_self_contact", mask)):  # fmt: skip
            if not kept.any():
                continue
            log.objectives[key] = d[:, kept].min(axis=1)
            k = int(np.argmin(log.objectives[key]))
            if log.objectives[key][k] < 0.0:  # which shapes went into each other
                pair = model.pairs[int(np.flatnonzero(kept)[np.argmin(d[k, kept])])]
                log.extra[contact] = {"obstacle": pair.second, "link": pair.first}

    def joined(key: str, shape: tuple[int, ...], dtype: Any = float) -> np.ndarray:
        return np.concatenate(parts[key]).astype(dtype) if parts[key] else np.zeros(shape, dtype)

    record = CollisionRecord(
        list(model.pairs), d_i, d_s, gain, constrained, joined("step", (0,), np.int64),
        joined("pair", (0,), np.int64), joined("d", (0,)), joined("a", (0, 3)),
        joined("b", (0, 3)), joined("bind", (0,), bool),
    )  # fmt: skip
    log.extra["collision_pairs"] = record
    return record
