"""Redundancy-resolution schemes: one step from task velocity to joint velocity."""

from .augmented import AugmentedJacobianScheme
from .base import (
    Inverse,
    Scheme,
    StepResult,
    make_inverse,
)
from .gradient_projection import GradientProjectionScheme, total_gradient
from .limits import (
    Binding,
    JointLimits,
    braking_velocity,
    run_violation,
    step_violation,
    velocity_bounds,
)
from .priority import METHODS, LevelInfo, PriorityResult, PriorityScheme, prioritized_velocity
from .pseudoinverse import PseudoInverseScheme
from .qp import QPScheme
from .sns import SNSScheme, largest_scale
from .weighted_least_norm import WeightedLeastNormScheme, joint_limit_gradient

__all__ = [
    "METHODS",
    "AugmentedJacobianScheme",
    "Binding",
    "GradientProjectionScheme",
    "Inverse",
    "JointLimits",
    "LevelInfo",
    "PriorityResult",
    "PriorityScheme",
    "PseudoInverseScheme",
    "QPScheme",
    "SNSScheme",
    "Scheme",
    "StepResult",
    "WeightedLeastNormScheme",
    "braking_velocity",
    "joint_limit_gradient",
    "largest_scale",
    "make_inverse",
    "prioritized_velocity",
    "run_violation",
    "step_violation",
    "total_gradient",
    "velocity_bounds",
]
