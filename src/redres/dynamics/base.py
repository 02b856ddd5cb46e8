"""Torque laws: the interface the simulator runs, task servo gains and simple laws.

A torque law maps the measured state ``(q, q̇)`` and a reference sample to joint torques
``tau`` (N·m). :class:`~redres.dynamics.osc.OperationalSpaceController` and
:class:`~redres.dynamics.acceleration.AccelerationController` are torque laws; so are the
small laws here (:class:`ZeroTorque`, :class:`GravityCompensation`, :class:`TorqueFunction`).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_gains, as_scalar, as_vector
from ..errors import InvalidParameterError, ShapeError
from ..linalg import InverseInfo

if TYPE_CHECKING:
    from ..control import Sample
    from ..robot import Robot


@dataclass(frozen=True)
class ControlStep:
    """What a torque law returns for one control step.

    Attributes:
        tau: commanded joint torques, shape ``(n,)``, N·m (before torque limits).
        info: diagnostics of the inverse used (``None`` for laws without one).
        error: six-row task error ``[p_d − p; log(R_d Rᵀ)]`` of the task frame, ``(6,)``
            (m, rad), or ``None`` for laws without a task.
        pose: 4x4 pose of the task frame, or ``None``.
        target: 4x4 target pose, or ``None``.
        tau_null: the null-space part of ``tau``, ``(n,)`` (zeros if the law has none).
        extra: law-specific diagnostics.
    """

    tau: FloatArray
    info: InverseInfo | None = None
    error: FloatArray | None = None
    pose: FloatArray | None = None
    target: FloatArray | None = None
    tau_null: FloatArray | None = None
    extra: dict[str, Any] = field(default_factory=dict)


class TorqueLaw(ABC):
    """A feedback law ``tau = f(q, q̇, reference)`` run by :func:`~redres.dynamics.simulate`.

    Attributes:
        name: stable identifier used in run logs (``RunLog.scheme``).
    """

    name: str = "torque_law"

    def reset(self) -> None:  # noqa: B027 - optional hook, most laws are stateless
        """Forget any state from a previous run (called once before a simulation)."""

    @abstractmethod
    def step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, sample: Sample | None = None
    ) -> ControlStep:
        """Torques for the state ``q`` (rad), ``qd`` (rad/s) and the reference ``sample``."""

    def task_frame(self) -> tuple[str | None, list[int]] | None:
        """``(frame, rows)`` of the law's task, for post-run measures; ``None``: no task."""
        return None

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r})"


class ZeroTorque(TorqueLaw):
    """``tau = 0``: the robot falls (or, without gravity, coasts)."""

    name = "zero_torque"

    def step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, sample: Sample | None = None
    ) -> ControlStep:
        return ControlStep(np.zeros(robot.n))


class GravityCompensation(TorqueLaw):
    """``tau = g(q) − k_d q̇``: gravity compensation with optional joint damping.

    Args:
        kd: joint damping, N·m·s/rad (≥ 0).
    """

    name = "gravity_compensation"

    def __init__(self, kd: float = 0.0) -> None:
        """The arguments are described in ``help(GravityCompensation)``."""
        self.kd = as_scalar(kd, "kd", minimum=0.0)

    def step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, sample: Sample | None = None
    ) -> ControlStep:
        return ControlStep(robot.gravity(q) - self.kd * as_vector(qd, "qd", robot.n))


class TorqueFunction(TorqueLaw):
    """Wrap a plain function ``fn(robot, q, qd, sample) -> tau`` as a torque law.

    Args:
        fn: the law; must return an array of shape ``(n,)``.
        name: identifier for run logs.
    """

    def __init__(
        self, fn: Callable[[Robot, FloatArray, FloatArray, Sample | None], Any], name: str
    ) -> None:
        """The arguments are described in ``help(TorqueFunction)``."""
        if not callable(fn):
            raise InvalidParameterError(f"fn must be callable; got {fn!r}")
        self.fn = fn
        self.name = name

    def step(
        self, robot: Robot, q: FloatArray, qd: FloatArray, sample: Sample | None = None
    ) -> ControlStep:
        tau = np.asarray(self.fn(robot, q, qd, sample), dtype=float)
        if tau.shape != (robot.n,):
            raise ShapeError(
                f"torque law {self.name!r} returned shape {tau.shape}; expected ({robot.n},)"
            )
        return ControlStep(tau)


@dataclass(frozen=True)
class TaskGains:
    """PD gains of a task servo ``ẍ* = ẍ_d + K_d (ẋ_d − J q̇) + K_p e``.

    With exact model compensation each task row obeys ``ë + K_d ė + K_p e = 0``: natural
    frequency ``√K_p`` (rad/s), damping ratio ``K_d / (2√K_p)``.

    Attributes:
        kp: stiffness ``K_p``, 1/s², shape ``(m,)``.
        kd: damping ``K_d``, 1/s, shape ``(m,)``.
    """

    kp: FloatArray
    kd: FloatArray

    @classmethod
    def make(cls, kp: Any, kd: Any, m: int) -> TaskGains:
        """Validated gains for ``m`` rows; ``kd=None`` gives critical damping ``2√K_p``.

        Raises:
            InvalidParameterError: a negative gain.
            NonFiniteError: a NaN or infinite gain.
            ShapeError: a vector gain of the wrong length.
        """
        kp_v = np.full(m, as_gains(kp, "kp", m))
        kd_v = 2.0 * np.sqrt(kp_v) if kd is None else np.full(m, as_gains(kd, "kd", m))
        return cls(kp_v, kd_v)
