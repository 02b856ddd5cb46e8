"""Manipulability as a cost (a classic secondary objective; Yoshikawa 1985).

``w(q) = √det(J Jᵀ)`` and ``D(q) = −w(q)``; the gradient is
:func:`redres.linalg.manipulability_gradient` (finite at singular configurations) fed
with the partial derivatives ``∂J/∂qᵢ``, which are the Jacobian's time variation along
the unit joint velocity ``eᵢ`` (:meth:`redres.Robot.jacobian_derivatives`), not finite
differences.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from .._validate import FloatArray
from ..linalg import manipulability, manipulability_gradient
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Robot


class ManipulabilityObjective(Objective):
    """``D(q) = −√det(J Jᵀ)`` of a frame's Jacobian rows (maximises manipulability).

    Args:
        frame: frame name (``None``: tip).
        rows: Jacobian rows to use (default all six; ``(0, 1, 2)`` for translation only).
    """

    name = "manipulability"

    def __init__(self, frame: str | None = None, rows: Sequence[int] | None = None) -> None:
        """The arguments are described in ``help(ManipulabilityObjective)``."""
        self.frame = frame
        self.rows = list(range(6)) if rows is None else [int(r) for r in rows]

    def manipulability(self, robot: Robot, q: FloatArray) -> float:
        """``w(q) = √det(J Jᵀ)``."""
        return manipulability(robot.jacobian(q, self.frame)[self.rows])

    def cost(self, robot: Robot, q: FloatArray) -> float:
        return -self.manipulability(robot, q)

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        J = robot.jacobian(q, self.frame)[self.rows]
        dJ = robot.jacobian_derivatives(q, self.frame)[:, self.rows, :]
        return -manipulability_gradient(J, dJ)
