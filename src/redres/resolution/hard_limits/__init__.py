"""Hard joint limits: position, velocity and acceleration limits that are never broken.

* :mod:`.box` — the joint-velocity box of one control step (:func:`velocity_bounds`, the
  exact discrete braking bound) and the checks of a step or a run against the limits;
* :mod:`.lp` — the largest task scale inside a box (:func:`largest_scale`);
* :mod:`.sns` — :class:`SNSScheme`, saturation in the null space (Flacco et al. 2015);
* :mod:`.qp` — :class:`QPScheme`, a sequence of QPs (DAQP or any qpsolvers backend).

Both schemes share :class:`~.base.BoxScheme` (period, limits, previous velocity) and run
one compiled kernel per step (:mod:`._kernels`, through :mod:`redres._compile`).
"""

from ._codes import BOUND_KINDS, RELAXED_ACCELERATION, RELAXED_POSITION
from .box import (
    Binding,
    JointLimits,
    VelocityBounds,
    Violation,
    binding_bounds,
    braking_velocity,
    run_violation,
    step_violation,
    velocity_bounds,
)
from .lp import ScaleResult, largest_scale
from .qp import QPDetails, QPScheme
from .sns import SNSDetails, SNSScheme

__all__ = [
    "BOUND_KINDS",
    "RELAXED_ACCELERATION",
    "RELAXED_POSITION",
    "Binding",
    "JointLimits",
    "QPDetails",
    "QPScheme",
    "SNSDetails",
    "SNSScheme",
    "ScaleResult",
    "VelocityBounds",
    "Violation",
    "binding_bounds",
    "braking_velocity",
    "largest_scale",
    "run_violation",
    "step_violation",
    "velocity_bounds",
]
