"""Redundancy-resolution schemes: one step from task velocity to joint velocity."""

from .augmented import AugmentedJacobianScheme
from .base import INVERSES, InverseChoice, InverseKind, Scheme, StepResult, as_inverse
from .gradient_projection import GradientProjectionScheme, total_gradient
from .priority import METHODS, LevelInfo, PriorityScheme, prioritized_velocity
from .pseudoinverse import PseudoInverseScheme
from .weighted_least_norm import WeightedLeastNormScheme, joint_limit_gradient

__all__ = [
    "INVERSES",
    "METHODS",
    "AugmentedJacobianScheme",
    "GradientProjectionScheme",
    "InverseChoice",
    "InverseKind",
    "LevelInfo",
    "PriorityScheme",
    "PseudoInverseScheme",
    "Scheme",
    "StepResult",
    "WeightedLeastNormScheme",
    "as_inverse",
    "joint_limit_gradient",
    "prioritized_velocity",
    "total_gradient",
]
