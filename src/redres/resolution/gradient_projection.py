"""Gradient projection: ``q̇ = J# ẋ − k (I − J# J) ∇D`` (Liégeois 1977).

``D`` is a weighted sum of secondary costs; the projector is built from the same inverse
as the task term (exact: ``J N = 0``, the task is untouched; damped: the secondary term
can leak into the task by at most ``λ/2`` per unit, see :mod:`redres.linalg.rate`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, cast

import numpy as np

from .._validate import FloatArray, as_scalar, checked_keywords
from ..errors import InvalidParameterError, ShapeError
from ..linalg import AdaptiveDamping, rate_step
from ..objectives import Objective
from .base import Inverse, Scheme, StepResult, make_inverse

if TYPE_CHECKING:
    from .._toml import ScenarioParams
    from ..robot import Robot

WeightedObjective = Objective | tuple[Objective, float]


def weighted_objectives(objectives: Sequence[WeightedObjective]) -> list[tuple[Objective, float]]:
    """Normalise ``[obj, (obj, weight), ...]`` to ``[(obj, weight), ...]``."""
    out = []
    for item in objectives:
        obj, weight = item if isinstance(item, tuple) else (item, 1.0)
        if not isinstance(obj, Objective):
            raise InvalidParameterError(
                f"objectives must be Objective instances or (objective, weight) pairs; got {item!r}"
            )
        out.append((obj, as_scalar(weight, f"weight of {obj.name}")))
    return out


def total_gradient(
    robot: Robot, q: FloatArray, objectives: Sequence[tuple[Objective, float]]
) -> FloatArray:
    """``Σ wᵢ ∇Dᵢ(q)`` at a checked ``q`` (:meth:`Scheme.step` checked it), checked to have
    shape ``(n,)`` (a new array)."""
    n = robot.n
    grad: FloatArray | None = None
    for obj, weight in objectives:
        g = np.asarray(obj._gradient(robot, q), dtype=np.float64)
        if g.shape != (n,):
            raise ShapeError(f"gradient of {obj.name} has shape {g.shape}; expected ({n},)")
        grad = weight * g if grad is None else grad + weight * g
    return np.zeros(n) if grad is None else grad


@dataclass(frozen=True)
class GradientDetails:
    """What a gradient-projection step adds to its :class:`StepResult`.

    Attributes:
        gradient: ``Σ wᵢ ∇Dᵢ(q)``, shape ``(n,)``, cost per rad.
    """

    gradient: FloatArray


class GradientProjectionScheme(Scheme):
    """Task by the inverse, secondary costs descended in its null space.

    Args:
        objectives: costs, each optionally with a weight: ``[JointLimitObjective(),
            (ManipulabilityObjective(), 10.0)]``.
        k_null: null-space gain ``k`` of ``−k N ∇D`` (≥ 0; rad²/s per unit of cost when
            ``D`` is dimensionless).
        inverse, damping, rcond: the inverse, as for
            :class:`~redres.resolution.PseudoInverseScheme`; ``N`` is its projector.

    Identifier ``gradient_projection``.

    Raises:
        InvalidParameterError: no objective, a negative ``k_null``, or a bad inverse.
        UnknownParameterError: a misspelt keyword (the message names the valid ones).
    """

    name = "gradient_projection"

    @checked_keywords
    def __init__(
        self,
        objectives: Sequence[WeightedObjective],
        *,
        k_null: float = 1.0,
        inverse: Inverse | None = None,
        damping: float | AdaptiveDamping | None = None,
        rcond: float | None = None,
    ) -> None:
        """The arguments are described in ``help(GradientProjectionScheme)``."""
        self.objectives = tuple(weighted_objectives(objectives))
        if not self.objectives:
            raise InvalidParameterError("gradient projection needs at least one objective")
        self.k_null = as_scalar(k_null, "k_null", minimum=0.0)
        self.inverse = make_inverse(inverse, damping, rcond)
        self._kwargs = self.inverse.rate_kwargs()

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> GradientProjectionScheme:
        """The scheme of a scenario table: ``objectives``, ``k_null`` and the inverse."""
        k_null = params.nonnegative("k_null", 1.0)
        return cls(params.objectives(), k_null=k_null, inverse=params.inverse())

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        grad = total_gradient(robot, q, self.objectives)
        step = rate_step(J, xd, grad, k_null=self.k_null, return_null=True, **self._kwargs)
        null_term = cast("FloatArray", step.null_term)  # computed: return_null=True
        return StepResult(step.qd, step.info, null_term, details=GradientDetails(grad))
