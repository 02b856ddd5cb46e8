"""Joint-limit mid-range cost (seed 003; seed 000 eq. 8–9; seed 002's example).

``D(q) = Σᵢ ((qᵢ − q̄ᵢ) / (q_min,i − q_max,i))²`` with ``q̄ᵢ = (q_min,i + q_max,i)/2``,
``∂D/∂qᵢ = 2 (qᵢ − q̄ᵢ) / (q_max,i − q_min,i)²``.

Note: seeds 000 and 003 print the diagonal ``G`` as ``2 (qᵢ − q̄ᵢ)/(q_min,i − q_max,i)``.
That is not the derivative of their own ``D``: it lacks one factor of the range and, the
denominator being negative, has the opposite sign. Taken literally, their
``Δq = J⁺Δx + [J⁺J − I] G Δt`` would push the joints *away* from mid-range. redres uses the
true derivative above (checked against finite differences), with which the general
formula (seed 000 eq. 6) lowers ``D`` as intended.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Robot


class JointLimitObjective(Objective):
    """Seed 003's normalised squared distance from mid-range (dimensionless)."""

    name = "joint_limits"

    def cost(self, robot: Robot, q: FloatArray) -> float:
        lo, hi = robot.q_min, robot.q_max
        return float(np.sum(((q - (lo + hi) / 2) / (lo - hi)) ** 2))

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        lo, hi = robot.q_min, robot.q_max
        return 2.0 * (q - (lo + hi) / 2) / (hi - lo) ** 2
