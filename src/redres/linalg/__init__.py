"""Linear algebra of redundancy resolution on bare arrays (never imports Pinocchio).

Inverses of a Jacobian ``J`` (``m`` task rows, ``n`` joints), the null-space projectors
that go with them, kinematic measures, the dynamically consistent inverse, and
:func:`rate_step`, one whole rate-control step in a single compiled call.

Functions return the ndarray itself; pass ``return_info=True`` to also get an
:class:`InverseInfo` (rank, smallest and largest singular value, damping used, method),
computed with the result. Rank-deficient and near-singular inputs give finite results and
report it in the info; bad input raises an error from :mod:`redres.errors` that names the
argument.

The compiled kernels (numba) are imported on the first call that needs them, so
``import redres`` stays fast. See docs/linalg.md.
"""

from __future__ import annotations

from ._info import RCOND, AdaptiveDamping, InverseInfo, adaptive_damping
from .damping import adaptive_damped_pinv, damped_pinv
from .dynamics import (
    dynamically_consistent_pinv,
    dynamically_consistent_projector,
    task_space_inertia,
)
from .inverses import (
    generalized_inverse,
    left_pinv,
    pinv,
    right_pinv,
    square_inverse,
    weighted_pinv,
)
from .measures import (
    condition_number,
    manipulability,
    manipulability_gradient,
    sigma_min,
    singular_values,
)
from .projectors import (
    MoorePenroseResiduals,
    is_moore_penrose,
    moore_penrose_residuals,
    nullspace_basis,
    nullspace_projector,
)
from .rate import RateStep, rate_step

__all__ = [
    "RCOND",
    "AdaptiveDamping",
    "InverseInfo",
    "MoorePenroseResiduals",
    "RateStep",
    "adaptive_damped_pinv",
    "adaptive_damping",
    "condition_number",
    "damped_pinv",
    "dynamically_consistent_pinv",
    "dynamically_consistent_projector",
    "generalized_inverse",
    "is_moore_penrose",
    "left_pinv",
    "manipulability",
    "manipulability_gradient",
    "moore_penrose_residuals",
    "nullspace_basis",
    "nullspace_projector",
    "pinv",
    "rate_step",
    "right_pinv",
    "sigma_min",
    "singular_values",
    "square_inverse",
    "task_space_inertia",
    "weighted_pinv",
]
