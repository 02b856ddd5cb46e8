"""Manipulability as a cost (seed 001's secondary objective; Yoshikawa 1985).

``w(q) = √det(J Jᵀ) = Πₖ σₖ`` and ``D(q) = −w(q)``. With the SVD ``J = U Σ Vᵀ``,
``∂w/∂qᵢ = Σₖ (Π_{j≠k} σⱼ) uₖᵀ (∂J/∂qᵢ) vₖ``, the usual ``w tr((JJᵀ)⁻¹ ∂J/∂qᵢ Jᵀ)``
written so that it stays finite at singular configurations. The partial derivatives
``∂J/∂qᵢ`` are the Jacobian's time variation along the unit joint velocity ``eᵢ``
(Pinocchio), not finite differences.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray
from .base import Objective

if TYPE_CHECKING:
    from ..robot import Robot


def manipulability_and_gradient(J: FloatArray, dJ: Sequence[FloatArray]) -> tuple[float, FloatArray]:
    """``w = √det(JJᵀ)`` of an ``m x n`` Jacobian (``m ≤ n``) and ``∂w/∂q`` from the
    partials ``dJ[i] = ∂J/∂qᵢ`` (each ``m x n``)."""
    U, s, Vt = np.linalg.svd(J, full_matrices=False)
    w = float(np.prod(s))
    m = s.size
    # Π_{j≠k} σ_j without dividing by σ_k (finite when some σ is zero).
    others = np.array([np.prod(np.delete(s, k)) for k in range(m)])
    grad = np.array([float(np.sum(others * np.einsum("ik,ij,kj->k", U, d, Vt))) for d in dJ])
    return w, grad


class ManipulabilityObjective(Objective):
    """``D(q) = −√det(J Jᵀ)`` of a frame's Jacobian rows (maximises manipulability).

    Args:
        frame: frame name (``None``: tip).
        rows: Jacobian rows to use (default all six; ``(0, 1, 2)`` for translation only).
    """

    name = "manipulability"

    def __init__(self, frame: str | None = None, rows: Sequence[int] | None = None) -> None:
        self.frame = frame
        self.rows = list(range(6)) if rows is None else [int(r) for r in rows]

    def manipulability(self, robot: Robot, q: FloatArray) -> float:
        """``w(q) = √det(J Jᵀ)``."""
        J = robot.jacobian(q, self.frame)[self.rows]
        return float(np.prod(np.linalg.svd(J, compute_uv=False)))

    def cost(self, robot: Robot, q: FloatArray) -> float:
        return -self.manipulability(robot, q)

    def gradient(self, robot: Robot, q: FloatArray) -> FloatArray:
        J = robot.jacobian(q, self.frame)[self.rows]
        eye = np.eye(robot.n)
        dJ = [robot.jacobian_dot(q, eye[i], self.frame)[self.rows] for i in range(robot.n)]
        return -manipulability_and_gradient(J, dJ)[1]
