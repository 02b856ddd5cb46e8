"""Joint-limit mid-range cost (Liégeois 1977; the example of Hanai 2010, p. 12).

``D(q) = Σᵢ ((qᵢ − q̄ᵢ) / (q_min,i − q_max,i))²`` with ``q̄ᵢ = (q_min,i + q_max,i)/2``,
``∂D/∂qᵢ = 2 (qᵢ − q̄ᵢ) / (q_max,i − q_min,i)²``.

Note: lecture notes that work this example print the diagonal ``G`` as
``2 (qᵢ − q̄ᵢ)/(q_min,i − q_max,i)``. That is not the derivative of their own ``D``: it
lacks one factor of the range and, the denominator being negative, has the opposite sign.
Taken literally, their ``Δq = J⁺Δx + [J⁺J − I] G Δt`` would push the joints *away* from
mid-range. redres uses the true derivative above (checked against finite differences),
with which the general formula (Liégeois 1977) lowers ``D`` as intended.

A joint without a finite range (a limit of ``±inf``) has no mid-range: its term is 0 (the
limit of the normalised cost as the range grows).
"""

from __future__ import annotations

import weakref
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray, as_vector
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Robot


class JointLimitObjective(Objective):
    """Liégeois' normalised squared distance from mid-range (dimensionless)."""

    name = "joint_limits"

    def __init__(self) -> None:
        """No parameters: the limits are the robot's ``q_min`` and ``q_max``."""
        self._cache: tuple[weakref.ref[Robot], FloatArray, FloatArray] | None = None

    def _mid_scale(self, robot: Robot) -> tuple[FloatArray, FloatArray]:
        # Limits are fixed per robot: compute q̄ and 2/(q_max − q_min)² once.
        if self._cache is None or self._cache[0]() is not robot:
            lo, hi = robot.q_min, robot.q_max
            bounded = np.isfinite(lo) & np.isfinite(hi)
            lo, hi = np.where(bounded, lo, -1.0), np.where(bounded, hi, 1.0)
            scale = np.where(bounded, 2.0 / (hi - lo) ** 2, 0.0)
            self._cache = (weakref.ref(robot), np.where(bounded, (lo + hi) / 2, 0.0), scale)
        return self._cache[1], self._cache[2]

    def cost(self, robot: Robot, q: FloatArray) -> float:
        mid, scale = self._mid_scale(robot)
        return float(np.sum(0.5 * scale * (as_vector(q, "q", robot.n) - mid) ** 2))

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        return self._gradient(robot, as_vector(q, "q", robot.n))

    def _gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        mid, scale = self._mid_scale(robot)
        return scale * (q - mid)

    def quadratic_form(self, robot: Robot) -> tuple[FloatArray, FloatArray]:
        """``(2/(q_max − q_min)², q̄)``: the gradient is ``a ∘ (q − q̄)``."""
        mid, scale = self._mid_scale(robot)
        return scale.copy(), mid.copy()
