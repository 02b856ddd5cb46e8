"""What every task gives a redundancy-resolution scheme: an error and a Jacobian."""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, real_array

if TYPE_CHECKING:
    from ..robot import Robot


@dataclass(frozen=True)
class TaskState:
    """A task evaluated at one configuration.

    Attributes:
        error: task error ``e = x_desired ⊖ x``, shape ``(m,)`` (m, rad).
        jacobian: task Jacobian ``J = ∂x/∂q``, shape ``(m, n)``, so that ``ẋ = J q̇``.
        feedforward: desired task velocity ``ẋ_desired``, shape ``(m,)``.
    """

    error: FloatArray
    jacobian: FloatArray
    feedforward: FloatArray

    def command(self, gain: float | FloatArray) -> FloatArray:
        """Closed-loop task velocity ``ẋ_desired + K e`` (CLIK), ``gain`` in 1/s."""
        return self.feedforward + gain * self.error


class Task(ABC):
    """A primary or secondary task: ``dim`` rows of error and Jacobian.

    Subclasses implement :meth:`compute`. Errors follow docs/conventions.md: positions in
    metres, orientations as the world-aligned SO(3) logarithm ``log(R_desired Rᵀ)``.
    """

    #: Number of task rows.
    dim: int
    #: Short name for tables and logs.
    name: str = "task"

    @abstractmethod
    def compute(self, robot: Robot, q: FloatArray) -> TaskState:
        """Error, Jacobian and feedforward velocity at configuration ``q``."""

    def reset(self) -> None:  # noqa: B027 - most tasks keep no state between runs
        """Forget what the task learnt during a run (e.g. a target taken at the first
        call), so that the next run starts as the first did."""

    def __repr__(self) -> str:
        return f"{type(self).__name__}(name={self.name!r}, dim={self.dim})"


def stack(states: list[TaskState]) -> TaskState:
    """Stack several task states into one (rows in order)."""
    return TaskState(
        error=np.concatenate([s.error for s in states]),
        jacobian=np.vstack([s.jacobian for s in states]),
        feedforward=np.concatenate([s.feedforward for s in states]),
    )


def wrap_angle(angle: Any) -> Any:
    """Angle(s) wrapped into ``(-π, π]``."""
    return np.pi - np.mod(np.pi - real_array(angle, "angle"), 2.0 * np.pi)
