"""Shared by the fuzzing and extreme-input tests: every scheme built with its defaults,
and the finiteness check their outputs must pass."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from redres.objectives import JointLimitObjective
from redres.resolution import (
    AugmentedJacobianScheme,
    GradientProjectionScheme,
    PriorityScheme,
    PseudoInverseScheme,
    QPScheme,
    SNSScheme,
    WeightedLeastNormScheme,
)
from redres.tasks import PostureTask

#: Scenario name -> a scheme with its default settings (hard limits at 1 kHz).
SCHEMES: dict[str, Callable[[], Any]] = {
    "pinv": PseudoInverseScheme,
    "dls": lambda: PseudoInverseScheme(damping=0.05),
    "gradient_projection": lambda: GradientProjectionScheme([JointLimitObjective()]),
    "wln": WeightedLeastNormScheme,
    "augmented": AugmentedJacobianScheme,
    "priority": lambda: PriorityScheme([PostureTask()]),
    "sns": lambda: SNSScheme(1e-3),
    "qp": lambda: QPScheme(1e-3),
}


def finite(value: Any) -> bool:
    """Whether every number in ``value`` (an array, a number, a sequence of them) is finite."""
    return bool(np.isfinite(np.asarray(value, dtype=float)).all())
