"""Shared parts of the torque-level controllers (internal): the task servo, the
null-space acceleration law and :class:`ServoLaw`, the base that holds both."""

from __future__ import annotations

from abc import abstractmethod
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NamedTuple, TypedDict

import numpy as np

from .._validate import FloatArray, as_scalar, as_vector
from ..errors import InvalidParameterError
from ..linalg import RCOND, AdaptiveDamping
from ..linalg._backend import parse_damping
from ..resolution.gradient_projection import WeightedObjective, total_gradient, weighted_objectives
from ..tasks import FrameTask
from .base import ControlStep, TaskGains, TorqueLaw

if TYPE_CHECKING:
    from ..control import Sample
    from ..robot import Robot


class ServoState(NamedTuple):
    """One evaluation of the task servo.

    Attributes:
        pose: 4x4 pose of the task frame.
        error: six-row error ``[p_d − p; log(R_d Rᵀ)]``, (6,), m and rad.
        jacobian: task rows of the world-aligned Jacobian, (m, n).
        command: ``ẍ* − J̇ q̇`` with ``ẍ* = ẍ_d + K_d (ẋ_d − J q̇) + K_p e``, (m,).
    """

    pose: FloatArray
    error: FloatArray
    jacobian: FloatArray
    command: FloatArray


class TaskServo:
    """PD tracking of a frame task's reference at the acceleration level.

    ``ẍ* = ẍ_d + K_d (ẋ_d − J q̇) + K_p e`` (Khatib 1987, eq. for the servo of the unit-mass
    system), with ``e`` the task error of :class:`~redres.tasks.FrameTask` and ``ẋ_d − J q̇``
    the velocity error in the same world-aligned coordinates.
    """

    def __init__(self, task: FrameTask, kp: Any, kd: Any) -> None:
        if not isinstance(task, FrameTask):
            raise InvalidParameterError(
                f"task must be a FrameTask (or PositionTask, OrientationTask, PlanarTask): "
                f"the operational-space law needs its frame for J̇ q̇; got {task!r}"
            )
        self.task = task
        self.rows = list(task.rows)
        # A slice when all six rows are used: no fancy-indexing copies in the hot path.
        self._sel: slice | np.ndarray = (
            slice(None) if self.rows == list(range(6)) else np.array(self.rows)
        )
        self.gains = TaskGains.make(kp, kd, len(self.rows))
        self.reset()

    def reset(self) -> None:
        """Hold the task's own target (if set) with zero feed-forward until a sample comes."""
        self._twist = np.zeros(6)
        self._accel = np.zeros(6)
        self._has_target = self.task.target is not None

    def update(self, sample: Sample | None) -> None:
        """Take the reference pose, twist and acceleration of a trajectory sample."""
        if sample is None:
            return
        self._twist = np.asarray(sample.twist, dtype=float)
        self._accel = np.asarray(sample.acceleration, dtype=float)
        self.task.set_target(sample.pose, self._twist, validate=False)
        self._has_target = True

    @property
    def has_target(self) -> bool:
        """Whether the task has a target (else :meth:`evaluate` holds the current pose)."""
        return self._has_target

    def hold(self, pose: FloatArray) -> None:
        """Hold ``pose`` (4x4) with zero feed-forward (the target when none was given)."""
        self.task.set_target(pose, np.zeros(6), validate=False)
        self._has_target = True

    @property
    def twist(self) -> FloatArray:
        """The reference twist ``ẋ_d`` (6,) (the array itself: do not modify)."""
        return self._twist

    @property
    def acceleration(self) -> FloatArray:
        """The reference acceleration ``ẍ_d`` (6,) (the array itself: do not modify)."""
        return self._accel

    def evaluate(self, robot: Robot, q: FloatArray, qd: FloatArray) -> ServoState:
        """Error, Jacobian and the commanded ``ẍ* − J̇ q̇`` at ``(q, q̇)``."""
        frame, rows = self.task.frame, self._sel
        T, J6 = robot.kinematics(q, frame)
        if not self._has_target:
            self.hold(T)
        e6 = self.task.full_error(T)
        jdot_qd = robot.jacobian_dot(q, qd, frame)[rows] @ qd
        J = J6[rows]
        g = self.gains
        cmd = self._accel[rows] + g.kd * (self._twist[rows] - J @ qd) + g.kp * e6[rows]
        return ServoState(T, e6, J, cmd - jdot_qd)


class NullSpaceLaw:
    """Secondary motion as a joint acceleration ``q̈₀ = −k_p Σ wᵢ ∇Dᵢ(q) − k_d q̇``.

    With ``D`` a posture cost ``½ (q − q_ref)ᵀ W (q − q_ref)`` this is a joint PD law
    pulling towards ``q_ref``; ``k_d`` also damps the self-motion when there is no
    objective.

    Args:
        objectives: costs ``Dᵢ`` (docs/conventions.md), optionally ``(objective, weight)``.
        kp: 1/s² per unit of gradient (rad/s² per rad for a unit-weight posture), ≥ 0.
        kd: 1/s, ≥ 0.
    """

    def __init__(self, objectives: Sequence[WeightedObjective], kp: float, kd: float) -> None:
        self.objectives = weighted_objectives(objectives)
        self.kp = as_scalar(kp, "null_kp", minimum=0.0)
        self.kd = as_scalar(kd, "null_kd", minimum=0.0)

    def acceleration(self, robot: Robot, q: FloatArray, qd: FloatArray) -> FloatArray:
        """``q̈₀``, shape ``(n,)``, rad/s²."""
        qdd0 = -self.kd * qd
        if self.objectives and self.kp > 0.0:
            qdd0 = qdd0 - self.kp * total_gradient(robot, q, self.objectives)
        return qdd0


class ServoSettings(TypedDict, total=False):
    """The keywords every :class:`ServoLaw` takes (its constructor holds their defaults):
    a subclass adds its own and passes these on as ``**settings``."""

    kp: Any
    kd: Any
    objectives: Sequence[WeightedObjective]
    null_kp: float
    null_kd: float
    damping: float | AdaptiveDamping
    rcond: float
    name: str | None


class ServoLaw(TorqueLaw):
    """A torque law built on a :class:`TaskServo` and a :class:`NullSpaceLaw`: the settings,
    validation and task plumbing that the operational-space and acceleration-level
    controllers share (arguments as for :class:`~redres.dynamics.OperationalSpaceController`;
    ``name``: the identifier in run logs, else the subclass's default).
    Subclasses give the torque of one evaluated servo state in :meth:`_step`.
    """

    def __init__(
        self,
        task: FrameTask | None = None,
        *,
        kp: Any = 400.0,
        kd: Any = None,
        objectives: Sequence[WeightedObjective] = (),
        null_kp: float = 25.0,
        null_kd: float = 10.0,
        damping: float | AdaptiveDamping = 0.0,
        rcond: float = RCOND,
        name: str | None = None,
    ) -> None:
        self.servo = TaskServo(FrameTask() if task is None else task, kp, kd)
        self.null_law = NullSpaceLaw(objectives, null_kp, null_kd)
        parse_damping(damping)  # validates it early (without loading the kernels)
        self.damping = damping
        self.rcond = rcond
        if name:
            self.name = name

    @property
    def task(self) -> FrameTask:
        """The controlled frame task."""
        return self.servo.task

    def reset(self) -> None:
        self.servo.reset()

    def task_frame(self) -> tuple[str | None, list[int]]:
        return self.servo.task.frame, self.servo.rows

    def step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, sample: Sample | None = None
    ) -> ControlStep:
        """Torques for state ``(q, q̇)`` tracking ``sample`` (``None``: hold the target)."""
        q = as_vector(q, "q", robot.n)
        qd = as_vector(qd, "qd", robot.n)
        self.servo.update(sample)
        s = self.servo.evaluate(robot, q, qd)
        return self._step(robot, q, qd, s, robot.mass_matrix(q))

    @abstractmethod
    def _step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, s: ServoState, M: FloatArray
    ) -> ControlStep:
        """The torque at validated ``(q, q̇)``, servo state ``s`` and joint inertia ``M``."""
