"""Augmented (extended) Jacobian: extra task rows until the Jacobian is square (Egeland 1987).

``[ẋ; ẋ_A] = [J; J_A] q̇`` and ``q̇ = J_ext⁻¹ [ẋ; ẋ_A]``, here with ``J_A`` the arm-angle row
of a 7-DOF arm (Kreutz-Delgado et al. 1992; Seraji 1989). ``J_ext`` can be singular where
``J`` is not (an *algorithmic* singularity: the extra row becomes dependent on the task
rows, e.g. the arm stretched, where the arm angle is undefined). The step detects it
from the smallest singular values; the default inverse is adaptively damped, exact away from
singularities and bounded at them.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray, as_scalar, checked_keywords
from ..errors import ShapeError
from ..linalg import AdaptiveDamping, rate_step, sigma_min
from ..tasks import ArmAngleTask, Task
from .base import Inverse, Scheme, StepResult, make_inverse

#: Damping at the singularity of the default inverse, units of ``J_ext``.
DEFAULT_MAX_DAMPING = 0.05

if TYPE_CHECKING:
    from .._toml import ScenarioParams
    from ..robot import Robot


@dataclass(frozen=True)
class AugmentedDetails:
    """What an augmented-Jacobian step adds to its :class:`StepResult`.

    Attributes:
        extra_error: the errors of the extra tasks, shape ``(n - m,)`` (rad for the arm
            angle).
    """

    extra_error: FloatArray


class AugmentedJacobianScheme(Scheme):
    """Square the task with extra rows (default: hold the arm angle) and invert it.

    Args:
        extra_tasks: tasks whose rows complete the Jacobian (default: one
            :class:`~redres.tasks.ArmAngleTask` holding the initial arm angle).
        gain: CLIK gain of the extra tasks, 1/s (≥ 0).
        inverse, damping, rcond: the inverse of ``J_ext``, as for
            :class:`~redres.resolution.PseudoInverseScheme`. Default:
            ``AdaptiveDamping(0.05, threshold)``, exact while ``σ_min(J_ext) ≥ threshold``.
        threshold: smallest singular value of ``J_ext`` below which a step is reported
            an algorithmic singularity (and the default damping starts), units of ``J``.

    Identifier ``augmented``. ``StepResult.algorithmic_singularity`` is true on steps where
    ``J_ext`` is near-singular while ``J`` alone is not; the extra tasks are the scheme's
    :attr:`tasks`.

    Raises:
        InvalidParameterError: a negative gain, a non-positive threshold, a bad inverse.
        UnknownParameterError: a misspelt keyword (the message names the valid ones).
    """

    name = "augmented"

    @checked_keywords
    def __init__(
        self,
        extra_tasks: Sequence[Task] | None = None,
        *,
        gain: float = 10.0,
        inverse: Inverse | None = None,
        damping: float | AdaptiveDamping | None = None,
        rcond: float | None = None,
        threshold: float = 0.02,
    ) -> None:
        """The arguments are described in ``help(AugmentedJacobianScheme)``."""
        self.tasks = tuple(extra_tasks) if extra_tasks is not None else (ArmAngleTask(),)
        self.gain = as_scalar(gain, "gain", minimum=0.0)
        self.threshold = as_scalar(threshold, "threshold", minimum=0.0, strict=True)
        if inverse is None and damping is None and rcond is None:
            damping = AdaptiveDamping(DEFAULT_MAX_DAMPING, self.threshold)
        self.inverse = make_inverse(inverse, damping, rcond)
        self._kwargs = self.inverse.rate_kwargs()

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> AugmentedJacobianScheme:
        """The scheme of a scenario table: the arm-angle row, its ``gain`` and the inverse."""
        return cls(gain=params.nonnegative("gain", 10.0), inverse=params.inverse())

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        states = [task.compute(robot, q) for task in self.tasks]
        rows = J.shape[0] + sum(s.jacobian.shape[0] for s in states)
        if rows != robot.n:
            raise ShapeError(
                f"the augmented Jacobian must be square: {J.shape[0]} task rows + "
                f"{rows - J.shape[0]} extra rows != {robot.n} joints"
            )
        J_ext = np.vstack([J, *(s.jacobian for s in states)])
        x_ext = np.concatenate([xd, *(s.command(self.gain) for s in states)])
        qd, info, _ = rate_step(J_ext, x_ext, **self._kwargs)
        # Classify only near a singularity (one extra SVD there, none elsewhere).
        algorithmic = bool(info.sigma_min < self.threshold and sigma_min(J) >= self.threshold)
        details = AugmentedDetails(np.concatenate([s.error for s in states]))
        return StepResult(
            qd, info, np.zeros_like(qd), algorithmic_singularity=algorithmic, details=details
        )
