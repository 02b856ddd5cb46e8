"""``rr.run``: drive a :class:`~redres.control.Controller` along a trajectory and record it.

Each control step, at time ``t = k·dt``, the trajectory's sample becomes the frame task's
target (pose and twist), then :meth:`Controller.step` does the whole CLIK step (derived in
:mod:`redres.control.controller`). The loop records what the controller reports after
each step; the measures that need no timing (joint-limit margins, the task Jacobian's
singular values, the objectives' costs) are computed from the recorded configurations
afterwards (:func:`~redres.control.analyse_run`).

With ``viewer=``, the loop also hands its configuration to a live viewer
(:class:`redres.viewer.Viewer`) at most at the viewer's ``rate``, checked on the wall
clock after the timed part of the step: :meth:`~redres.viewer.Viewer.push` only stores the
configuration and returns, and the viewer's own thread sends the latest one, so the run is
not slowed and, when the browser lags, configurations are dropped, never queued. The
last configuration is always pushed.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from .._validate import FloatArray
from ..errors import InvalidParameterError, SimulationError
from ..objectives import Objective
from ..resolution import Scheme
from ..tasks import FrameTask, Task
from .analysis import analyse_run, progress_bar, run_duration, run_steps, start_configuration
from .controller import Controller
from .log import RunLog
from .shaping import CommandShaper
from .trajectories import Trajectory

if TYPE_CHECKING:
    from ..robot import Robot


class LiveView(Protocol):
    """What :func:`run` pushes to: :class:`redres.viewer.Viewer` (``push`` returns at once,
    ``rate`` in Hz bounds how often the run calls it)."""

    rate: float

    def push(self, q: Any, target: Any = None) -> None: ...


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
    shaping: bool | CommandShaper = False,
    log_objectives: Sequence[Objective] = (),
    label: str = "",
    progress: bool | None = None,
    viewer: LiveView | None = None,
) -> RunLog:
    """Run closed-loop rate control and record it.

    Args:
        robot: the robot.
        task: the primary task (e.g. :class:`~redres.tasks.FrameTask`); for a frame task
            the trajectory sets its target each step.
        trajectory: reference for the task frame (``None``: hold the task's target).
        scheme: the redundancy-resolution scheme.
        dt, gain, limit_velocity, shaping: as for :class:`~redres.control.Controller`;
            with ``shaping`` the log's ``qd`` is the shaped command (within the robot's
            velocity, acceleration and jerk limits) and ``log.extra["qd_wanted"]`` the
            controller's before shaping.
        duration: s (default: the trajectory's duration).
        q0: start configuration, inside the limits (default ``robot.neutral()``).
        log_objectives: extra costs to record each step (the scheme's own are recorded
            anyway).
        label: name of the run in tables.
        progress: show a progress bar (default: for long runs on a terminal).
        viewer: a :class:`redres.viewer.Viewer` of this robot (``rr.view(robot)``) to
            show the run in while it computes (module docstring); afterwards
            ``viewer.show_runs([log])`` lets you scrub it. Default: no viewer.

    Returns:
        The :class:`RunLog`.

    Raises:
        InvalidParameterError: non-positive ``dt`` or ``duration``, negative ``gain``, a
            ``duration`` under half a step or over :data:`~redres.control.analysis.MAX_STEPS`
            steps; a ``viewer`` that is not a viewer, or is one of a robot with another
            number of joints.
        JointLimitError: ``q0`` outside the joint limits.
        SimulationError: a non-finite joint velocity (names the step).
    """
    controller = Controller(
        robot, task, scheme, gain=gain, dt=dt, limit_velocity=limit_velocity, shaping=shaping
    )
    controller._eager_info()  # the log records the singular values of every step
    dt = controller.dt
    if trajectory is not None and not isinstance(trajectory, Trajectory):
        raise InvalidParameterError(
            "trajectory must be a redres Trajectory (Circle, Line, ...) or None; "
            f"got {trajectory!r}"
        )
    duration = run_duration(trajectory, duration)
    q = start_configuration(robot, q0)
    steps = run_steps(duration, dt)
    n = robot.n
    objectives = [*(obj for obj, _ in scheme.objectives), *log_objectives]
    live = _live_view(viewer, robot)
    scheme.reset()

    log = RunLog.empty(robot.name, scheme.name, dt, steps, n, label)
    q_log, qd_log, pos_log, target_log = log.q, log.qd, log.position, log.target
    pos_err, rot_err, inv_sigma = log.position_error, log.orientation_error, log.sigma_min
    damping, rank, ratio, scaled = log.damping, log.rank, log.speed_ratio, log.scaled
    step_ns = log.step_time_ns
    algorithmic = np.zeros(steps, dtype=bool)
    wanted = np.zeros((steps, n)) if controller.shaper is not None else None

    frame_task = task if isinstance(task, FrameTask) else None
    follow = trajectory is not None and frame_task is not None
    bar = progress_bar(steps, progress, f"{robot.name} {label or scheme.name}")
    clock = time.perf_counter_ns
    step = controller.step
    push_period = round(1e9 / live.rate) if live is not None else 0
    push_due = 0
    k = 0
    try:
        for k in range(steps):
            t0 = clock()
            if follow:
                sample = trajectory.sample(k * dt)  # type: ignore[union-attr]
                frame_task.set_target(sample.pose, sample.twist, validate=False)  # type: ignore[union-attr]
            q_log[k] = q
            q = step(q)
            step_ns[k] = clock() - t0
            if live is not None and t0 >= push_due:  # at most `rate` pushes a second
                live.push(q, frame_task.target if frame_task is not None else None)
                push_due = t0 + push_period
            qd_log[k] = controller.qd
            if wanted is not None:
                wanted[k] = controller.qd_wanted
            speed = controller.speed_ratio
            ratio[k] = min(speed, 1.0) if limit_velocity else speed
            scaled[k] = controller.scaled
            info = controller.info
            inv_sigma[k], damping[k], rank[k] = info.sigma_min, info.damping, info.rank
            result = controller.result
            algorithmic[k] = result is not None and result.algorithmic_singularity
            e, pose = controller.error, controller.pose
            if pose is not None:
                pos_err[k] = math.sqrt(float(e[:3] @ e[:3]))
                rot_err[k] = math.sqrt(float(e[3:] @ e[3:]))
                pos_log[k] = pose[:3, 3]
                target_log[k] = frame_task.target[:3, 3]  # type: ignore[union-attr, index]
            else:
                pos_err[k] = math.sqrt(float(e @ e))
            if bar is not None:
                bar.update(1)
    except SimulationError as exc:
        raise SimulationError(f"step {k} (t = {k * dt:.4f} s): {exc}") from exc
    finally:
        if bar is not None:
            bar.close()
        if frame_task is not None and controller.path != "composed" and steps:
            frame_task.compute(robot, q_log[k])  # as if it had computed the last step

    log.extra.update(
        inverse_sigma_min=inv_sigma.copy(), algorithmic_singularity=algorithmic, final_q=q
    )
    if wanted is not None:
        log.extra["qd_wanted"] = wanted
    if live is not None and steps:
        live.push(q, frame_task.target if frame_task is not None else None)  # the last one
    frame, rows = (frame_task.frame, frame_task.rows) if frame_task else (None, list(range(6)))
    analyse_run(robot, log, frame=frame, rows=rows, objectives=objectives)
    return log


def _live_view(viewer: LiveView | None, robot: Robot) -> LiveView | None:
    """The viewer :func:`run` pushes to (``None``: none), checked."""
    if viewer is None:
        return None
    if not callable(getattr(viewer, "push", None)) or not hasattr(viewer, "rate"):
        raise InvalidParameterError(
            f"viewer must be a redres.viewer.Viewer (rr.view(robot)) or None; got {viewer!r}"
        )
    shown = getattr(viewer, "robot", None)
    if shown is not None and getattr(shown, "n", robot.n) != robot.n:
        raise InvalidParameterError(
            f"the viewer shows {shown.name!r} with {shown.n} joints; this run's robot "
            f"{robot.name!r} has {robot.n}: open a viewer of it with rr.view(robot)"
        )
    return viewer


def final_configuration(log: RunLog) -> FloatArray:
    """The configuration after the last step of a run."""
    q: FloatArray = log.extra["final_q"]
    return q
