"""Weighted least-norm resolution with joint-limit weights (Chan & Dubey 1995).

``q̇ = W⁻¹Jᵀ(JW⁻¹Jᵀ)⁻¹ ẋ`` minimises ``q̇ᵀWq̇`` subject to ``Jq̇ = ẋ``. The diagonal weights
grow as a joint moves toward a limit and relax when it moves away:

    h(qᵢ) = (q_max,i − q_min,i)(2qᵢ − q_max,i − q_min,i) / (cᵢ (q_max,i − qᵢ)² (qᵢ − q_min,i)²)
    wᵢ = 1 + |h(qᵢ)|   if |h(qᵢ)| grew since the previous step (moving toward a limit)
    wᵢ = 1             otherwise

``h`` is (up to the tuning constant ``cᵢ``) the gradient of Chan and Dubey's performance
criterion ``H(q) = Σ (q_max − q_min)² / (4 (q_max − q)(q − q_min))``, which is infinite at the
limits, so ``q̇ᵢ → 0`` as a joint approaches its limit. ``cᵢ = 4/(q_max,i − q_min,i)``
reproduces Chan and Dubey's weights exactly. T. F. Chan, R. V. Dubey, "A weighted
least-norm solution based scheme for avoiding joint limits for redundant joint
manipulators", IEEE Trans. Robotics and Automation 11(2), 1995.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from .._validate import FloatArray, as_scalar, checked_keywords, real_array
from ..errors import InvalidParameterError, ShapeError
from ..linalg import AdaptiveDamping, rate_step
from .base import Inverse, Scheme, StepResult, make_inverse
from .gradient_projection import WeightedObjective, total_gradient, weighted_objectives

if TYPE_CHECKING:
    from .._toml import ScenarioParams
    from ..robot import Robot

_MAX_WEIGHT = 1e12


def joint_limit_gradient(q: FloatArray, q_min: FloatArray, q_max: FloatArray, c: Any) -> FloatArray:
    """Chan & Dubey's ``h(q)`` per joint (finite: distances to the limits floored at 1e-12).

    With ``a = q_max − q`` and ``b = q − q_min`` (so ``q_max − q_min = a + b`` and
    ``2q − q_max − q_min = b − a``), ``h = (a + b)(b − a)/(c a² b²) = (1/a² − 1/b²)/c``:
    the same number, and for an unbounded side (``a`` or ``b`` infinite) its limit, 0.
    """
    q, c = real_array(q, "q"), real_array(c, "c")  # complex refused by name, not made real
    to_max = np.maximum(q_max - q, 1e-12)
    to_min = np.maximum(q - q_min, 1e-12)
    return (1.0 / to_max**2 - 1.0 / to_min**2) / c


@dataclass(frozen=True)
class WeightDetails:
    """What a weighted least-norm step adds to its :class:`StepResult`.

    Attributes:
        weights: the diagonal joint weights ``wᵢ`` used, shape ``(n,)``.
    """

    weights: FloatArray


class WeightedLeastNormScheme(Scheme):
    """Weighted least-norm rate control with Chan & Dubey's joint-limit weights.

    Args:
        c: tuning constant ``cᵢ`` (scalar or shape ``(n,)``, > 0); larger is gentler.
        objectives: optional secondary costs projected with the weighted projector
            ``I − J_W⁺ J``.
        k_null: null-space gain ``k`` of the secondary term (≥ 0).
        inverse, damping, rcond: the inverse of the weighted Jacobian (default exact), as
            for :class:`~redres.resolution.PseudoInverseScheme`.

    Identifier ``wln``. The scheme keeps ``|h|`` of the previous step; :meth:`reset`
    forgets it (the first step of a run uses unit weights for joints not yet moving).

    Raises:
        InvalidParameterError: a non-positive ``c``, a negative ``k_null``, a bad inverse.
        UnknownParameterError: a misspelt keyword (the message names the valid ones).
    """

    name = "wln"

    @checked_keywords
    def __init__(
        self,
        c: float | Sequence[float] = 1.0,
        objectives: Sequence[WeightedObjective] = (),
        *,
        k_null: float = 1.0,
        inverse: Inverse | None = None,
        damping: float | AdaptiveDamping | None = None,
        rcond: float | None = None,
    ) -> None:
        """The arguments are described in ``help(WeightedLeastNormScheme)``."""
        try:
            c_arr = real_array(c, "c")
        except ShapeError:
            raise InvalidParameterError(
                f"c must be a positive number or one per joint; got {c!r}"
            ) from None
        if not np.all(np.isfinite(c_arr)) or np.any(c_arr <= 0):
            raise InvalidParameterError(f"c must be positive; got {c}")
        self.c = c_arr
        self.objectives = tuple(weighted_objectives(objectives))
        self.k_null = as_scalar(k_null, "k_null", minimum=0.0)
        self.inverse = make_inverse(inverse, damping, rcond)
        self._kwargs = self.inverse.rate_kwargs()
        self._previous: FloatArray | None = None

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> WeightedLeastNormScheme:
        """The scheme of a scenario table: ``c``, ``objectives``, ``k_null``, the inverse."""
        c, objectives = params.positive("c", 1.0), params.objectives()
        k_null = params.nonnegative("k_null", 1.0)
        return cls(c, objectives, k_null=k_null, inverse=params.inverse())

    def _reset(self) -> None:
        self._previous = None

    def weights(self, robot: Robot, q: FloatArray) -> FloatArray:
        """Joint weights at ``q`` (updates the remembered ``|h|``)."""
        h = np.abs(joint_limit_gradient(q, robot.q_min, robot.q_max, self.c))
        growing = np.zeros(h.shape, dtype=bool) if self._previous is None else h > self._previous
        self._previous = h
        return np.where(growing, np.minimum(1.0 + h, _MAX_WEIGHT), 1.0)

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        w = self.weights(robot, q)
        grad = total_gradient(robot, q, self.objectives) if self.objectives else None
        step = rate_step(
            J, xd, grad, k_null=self.k_null, weights=w, return_null=True, **self._kwargs
        )
        null_term = cast("FloatArray", step.null_term)  # computed: return_null=True
        return StepResult(step.qd, step.info, null_term, details=WeightDetails(w))
