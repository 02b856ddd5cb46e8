"""Posture cost: stay near a reference configuration."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_gains, as_vector
from ..errors import ShapeError
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Robot


class PostureObjective(Objective):
    """``D(q) = ½ (q − q_ref)ᵀ diag(weights) (q − q_ref)``, ``∇D = diag(weights)(q − q_ref)``.

    Args:
        q_ref: reference configuration, shape ``(n,)`` (``None``: the robot's ``neutral()``).
        weights: per-joint weights, shape ``(n,)`` or a scalar (default 1), each >= 0.

    Raises:
        InvalidParameterError: a negative weight; ShapeError, NonFiniteError: weights or
            ``q_ref`` that are not finite numbers, or (when used) not of the robot's size.
    """

    name = "posture"

    def __init__(self, q_ref: Any = None, weights: Any = 1.0) -> None:
        """The arguments are described in ``help(PostureObjective)``."""
        self.q_ref = None if q_ref is None else as_vector(q_ref, "q_ref")
        self.weights: float | FloatArray = as_gains(weights, "weights")

    def _q_ref(self, robot: Robot) -> FloatArray:
        q_ref = robot.neutral() if self.q_ref is None else self.q_ref
        for name, value in (("q_ref", q_ref), ("weights", self.weights)):
            if np.ndim(value) and np.shape(value)[0] != robot.n:
                raise ShapeError(
                    f"PostureObjective {name} has {np.shape(value)[0]} entries but robot "
                    f"{robot.name!r} has {robot.n} joints"
                )
        return q_ref

    def cost(self, robot: Robot, q: FloatArray) -> float:
        dq = as_vector(q, "q", robot.n) - self._q_ref(robot)
        return float(0.5 * np.sum(self.weights * dq * dq))

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        return self._gradient(robot, as_vector(q, "q", robot.n))

    def _gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        return self.weights * (q - self._q_ref(robot))

    def quadratic_form(self, robot: Robot) -> tuple[FloatArray, FloatArray]:
        """``(weights, q_ref)`` broadcast to ``(n,)``: the gradient is ``w ∘ (q − q_ref)``."""
        w = np.broadcast_to(self.weights, (robot.n,)).astype(float)
        return w, np.array(self._q_ref(robot), float)
