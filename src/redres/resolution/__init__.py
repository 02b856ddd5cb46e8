"""Redundancy-resolution schemes: one step from task velocity to joint velocity."""

from .augmented import AugmentedJacobianScheme
from .base import (
    INVERSES,
    Inverse,
    InverseChoice,
    InverseKind,
    Scheme,
    StepResult,
    as_inverse,
    make_inverse,
)
from .gradient_projection import GradientProjectionScheme, total_gradient
from .hard_limits import (
    Binding,
    JointLimits,
    QPDetails,
    QPScheme,
    ScaleResult,
    SNSDetails,
    SNSScheme,
    VelocityBounds,
    Violation,
    braking_velocity,
    largest_scale,
    run_violation,
    step_violation,
    velocity_bounds,
)
from .priority import METHODS, LevelInfo, PriorityResult, PriorityScheme, prioritized_velocity
from .pseudoinverse import PseudoInverseScheme
from .weighted_least_norm import WeightedLeastNormScheme, joint_limit_gradient

__all__ = [
    "INVERSES",
    "METHODS",
    "AugmentedJacobianScheme",
    "Binding",
    "GradientProjectionScheme",
    "Inverse",
    "InverseChoice",
    "InverseKind",
    "JointLimits",
    "LevelInfo",
    "PriorityResult",
    "PriorityScheme",
    "PseudoInverseScheme",
    "QPDetails",
    "QPScheme",
    "SNSDetails",
    "SNSScheme",
    "ScaleResult",
    "Scheme",
    "StepResult",
    "VelocityBounds",
    "Violation",
    "WeightedLeastNormScheme",
    "as_inverse",
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
