"""Closed-loop inverse kinematics (resolved motion rate control with feedback).

Each control step, at time ``t = k·dt``:

1. the trajectory gives the target pose and twist; the task gives ``e`` and ``J``;
2. the scheme turns ``ẋ = ẋ_d + K e`` into ``q̇`` (seed 000 eq. 6 for gradient projection);
3. if any joint would exceed its velocity limit the whole ``q̇`` is scaled down by one
   factor, which keeps its direction (and so the task direction);
4. ``q ← q + q̇ dt`` (seed 003's ``Δq = q̇ Δt``).

``K`` (``gain``, 1/s) makes the task error decay as ``exp(−K t)`` when the scheme tracks
exactly; ``K·dt`` must stay well below 2 for the discrete loop to be stable.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector
from ..errors import InvalidParameterError, JointLimitError, SimulationError
from ..objectives import Objective
from ..resolution import GradientProjectionScheme, Scheme, WeightedLeastNormScheme
from ..tasks import FrameTask, Task
from .analysis import analyse_run, progress_bar
from .controller import ClikController
from .runlog import RunLog
from .trajectories import Trajectory

if TYPE_CHECKING:
    from ..robot import Robot


def run(
    robot: Robot,
    task: Task,
    trajectory: Trajectory | None,
    scheme: Scheme,
    *,
    dt: float = 1e-3,
    duration: float | None = None,
    q0: Any = None,
    gain: float = 50.0,
    limit_velocity: bool = True,
    log_objectives: Sequence[Objective] = (),
    label: str = "",
    progress: bool | None = None,
) -> RunLog:
    """Run closed-loop rate control and record it.

    Args:
        robot: the robot.
        task: the primary task (e.g. :class:`~redres.tasks.FrameTask`); for a frame task
            the trajectory sets its target each step.
        trajectory: reference for the task frame (``None``: hold the task's target).
        scheme: the redundancy-resolution scheme.
        dt: control period, s (> 0).
        duration: s (default: the trajectory's duration).
        q0: start configuration, inside the limits (default ``robot.neutral()``).
        gain: CLIK gain ``K``, 1/s (≥ 0).
        limit_velocity: scale commands down uniformly to the joint velocity limits.
        log_objectives: extra costs to record each step (the scheme's own are recorded
            anyway).
        label: name of the run in tables.
        progress: show a progress bar (default: for long runs on a terminal).

    Returns:
        The :class:`RunLog`.

    Raises:
        InvalidParameterError: non-positive ``dt`` or ``duration``, negative ``gain``.
        JointLimitError: ``q0`` outside the joint limits.
        SimulationError: a non-finite joint velocity (names the step).
    """
    dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
    gain = as_scalar(gain, "gain", minimum=0.0)
    if duration is None:
        if trajectory is None:
            raise InvalidParameterError("give a duration when there is no trajectory")
        duration = trajectory.duration
    duration = as_scalar(duration, "duration", minimum=0.0, strict=True)
    q = robot.neutral() if q0 is None else as_vector(q0, "q0", robot.n).copy()
    margin0 = robot.joint_limit_margin(q)
    if np.any(margin0 < 0):
        j = int(np.argmin(margin0))
        raise JointLimitError(
            f"q0[{j}] = {q[j]:.6g} is outside the limits "
            f"[{robot.q_min[j]:.6g}, {robot.q_max[j]:.6g}] of joint {robot.joint_names[j]!r}"
        )
    steps = round(duration / dt)
    n = robot.n
    qd_max = robot.qd_max
    scheme.reset()

    t_log = np.arange(steps, dtype=np.float64) * dt
    q_log = np.empty((steps, n))
    qd_log = np.empty((steps, n))
    pos_log = np.zeros((steps, 3))
    target_log = np.zeros((steps, 3))
    pos_err = np.zeros(steps)
    rot_err = np.zeros(steps)
    inv_sigma = np.empty(steps)
    damping = np.empty(steps)
    rank = np.empty(steps)
    ratio = np.empty(steps)
    scaled = np.zeros(steps, dtype=bool)
    step_ns = np.empty(steps)
    algorithmic = np.zeros(steps, dtype=bool)

    frame_task = task if isinstance(task, FrameTask) else None
    front = _compiled_front(robot, frame_task, gain, dt)
    bar = progress_bar(steps, progress, f"{robot.name} {label or scheme.name}")
    clock = time.perf_counter_ns
    try:
        for k in range(steps):
            t0 = clock()
            if trajectory is not None and frame_task is not None:
                sample = trajectory.sample(k * dt)
                target = front if front is not None else frame_task
                target.set_target(sample.pose, sample.twist, validate=False)
            if front is not None:  # the frame task through the compiled kernel
                J, xd, frame_error, pose = front.command(q)
            else:
                state = task.compute(robot, q)
                J, xd = state.jacobian, state.command(gain)
            result = scheme.step(robot, q, J, xd)
            qd = result.qd
            speed = float(np.max(np.abs(qd) / qd_max))
            if limit_velocity and speed > 1.0:
                qd = qd / speed
                scaled[k] = True
            if not np.all(np.isfinite(qd)):
                raise SimulationError(
                    f"step {k} (t = {k * dt:.4f} s): the {scheme.name} scheme returned a "
                    f"non-finite joint velocity {qd}"
                )
            q_log[k] = q
            q = q + qd * dt
            step_ns[k] = clock() - t0
            qd_log[k] = qd
            ratio[k] = min(speed, 1.0) if limit_velocity else speed
            inv_sigma[k] = result.info.sigma_min
            damping[k] = result.info.damping
            rank[k] = result.info.rank
            algorithmic[k] = result.algorithmic_singularity
            if front is not None:
                pos_err[k] = math.sqrt(float(frame_error[:3] @ frame_error[:3]))
                rot_err[k] = math.sqrt(float(frame_error[3:] @ frame_error[3:]))
                pos_log[k] = pose[:3, 3]
                target_log[k] = front.target_position
            elif frame_task is not None and frame_task.last_error is not None:
                e = frame_task.last_error
                pos_err[k] = float(np.linalg.norm(e[:3]))
                rot_err[k] = float(np.linalg.norm(e[3:]))
                assert frame_task.last_pose is not None and frame_task.target is not None
                pos_log[k] = frame_task.last_pose.translation
                target_log[k] = frame_task.target[:3, 3]
            else:
                pos_err[k] = float(np.linalg.norm(state.error))
            if bar is not None:
                bar.update(1)
    finally:
        if bar is not None:
            bar.close()
        if front is not None and frame_task is not None and steps:
            _leave_task_as_computed(frame_task, front, q_log[steps - 1])

    log = RunLog(
        robot=robot.name,
        scheme=scheme.name,
        dt=dt,
        t=t_log,
        q=q_log,
        qd=qd_log,
        position=pos_log,
        target=target_log,
        position_error=pos_err,
        orientation_error=rot_err,
        sigma_min=inv_sigma,
        damping=damping,
        rank=rank,
        speed_ratio=ratio,
        scaled=scaled,
        joint_limit_margin=np.zeros(steps),
        manipulability=np.zeros(steps),
        step_time_ns=step_ns,
        label=label,
    )
    log.extra["inverse_sigma_min"] = inv_sigma.copy()
    log.extra["algorithmic_singularity"] = algorithmic
    log.extra["final_q"] = q
    frame = task.frame if isinstance(task, FrameTask) else None
    rows = task.rows if isinstance(task, FrameTask) else list(range(6))
    analyse_run(
        robot,
        log,
        frame=frame,
        rows=rows,
        objectives=[*_scheme_objectives(scheme), *log_objectives],
    )
    return log


def _compiled_front(
    robot: Robot, task: FrameTask | None, gain: float, dt: float
) -> ClikController | None:
    """A controller whose compiled front end evaluates ``task`` (the frame error and
    command ``ẋ_d + K e``) in one kernel call, starting from the task's target; None for
    other tasks, a FrameTask subclass with its own ``compute``, or without the kernels."""
    if task is None or type(task).compute is not FrameTask.compute:
        return None
    front = ClikController(robot, task.frame, task.rows, gain=gain, dt=dt, limit_velocity=False)
    if not front.compiled:
        return None
    if task.target is not None:
        front.set_target(task.target, task.twist, validate=False)
    return front


def _leave_task_as_computed(task: FrameTask, front: ClikController, q: FloatArray) -> None:
    """Leave ``task`` (target, last pose and error) as if it had computed the last step."""
    assert front.target is not None
    task.set_target(front.target, front.twist, validate=False)
    task.compute(front.robot, q)


def _scheme_objectives(scheme: Scheme) -> list[Objective]:
    if isinstance(scheme, (GradientProjectionScheme, WeightedLeastNormScheme)):
        return [obj for obj, _ in scheme.objectives]
    return []


def final_configuration(log: RunLog) -> FloatArray:
    """The configuration after the last step of a run."""
    q: FloatArray = log.extra["final_q"]
    return q
