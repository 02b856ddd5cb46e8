"""Posture cost: stay near a reference configuration."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray, as_vector
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Robot


class PostureObjective(Objective):
    """``D(q) = ½ (q − q_ref)ᵀ diag(weights) (q − q_ref)``, ``∇D = diag(weights)(q − q_ref)``.

    Args:
        q_ref: reference configuration, shape ``(n,)`` (``None``: the robot's ``neutral()``).
        weights: per-joint weights, shape ``(n,)`` or a scalar (default 1).
    """

    name = "posture"

    def __init__(self, q_ref: Any = None, weights: Any = 1.0) -> None:
        self.q_ref = None if q_ref is None else as_vector(q_ref, "q_ref")
        w = np.asarray(weights, dtype=float)
        if not np.all(np.isfinite(w)) or np.any(w < 0):
            raise ValueError(f"weights must be finite and >= 0; got {weights}")
        self.weights = w

    def _q_ref(self, robot: Robot) -> FloatArray:
        return robot.neutral() if self.q_ref is None else self.q_ref

    def cost(self, robot: Robot, q: FloatArray) -> float:
        dq = q - self._q_ref(robot)
        return float(0.5 * np.sum(self.weights * dq * dq))

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        return self.weights * (q - self._q_ref(robot))

    def quadratic_form(self, robot: Robot) -> tuple[FloatArray, FloatArray]:
        """``(weights, q_ref)`` broadcast to ``(n,)``: the gradient is ``w ∘ (q − q_ref)``."""
        w = np.broadcast_to(self.weights, (robot.n,)).astype(float)
        return w, np.array(self._q_ref(robot), float)
