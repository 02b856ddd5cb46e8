"""Redundancy-resolution schemes: one step from task velocity to joint velocity."""

from .augmented import AugmentedJacobianScheme
from .base import Inverse, Scheme, StepResult, make_inverse
from .gradient_projection import GradientProjectionScheme, total_gradient
from .hard_limits import (
    BOUND_KINDS,
    RELAXED_ACCELERATION,
    RELAXED_POSITION,
    Binding,
    JointLimits,
    QPDetails,
    QPScheme,
    ScaleResult,
    SNSDetails,
    SNSScheme,
    VelocityBounds,
    Violation,
    binding_bounds,
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
    "BOUND_KINDS",
    "METHODS",
    "RELAXED_ACCELERATION",
    "RELAXED_POSITION",
    "AugmentedJacobianScheme",
    "Binding",
    "GradientProjectionScheme",
    "Inverse",
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
    "binding_bounds",
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
