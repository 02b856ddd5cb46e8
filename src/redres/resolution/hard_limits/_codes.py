"""Integer codes shared by the hard-limit kernels and their Python callers (internal).

Importable without numba: an ``IntEnum`` per family, and its values as plain ints, which
the kernels compile in. Errors are not coded here: the kernels return the statuses of
:class:`redres.linalg._codes.Status` (0 = OK), turned into exceptions by
:func:`redres.linalg._status.raise_status`.
"""

from __future__ import annotations

from enum import IntEnum


class BoundKind(IntEnum):
    """What defines a side of the joint-velocity box (``BOUND_KINDS`` names it)."""

    NONE = 0
    POSITION = 1
    VELOCITY = 2
    ACCELERATION = 3


class Outcome(IntEnum):
    """How an SNS step ended (``METHODS`` names it): a result, not an error."""

    FEASIBLE = 0
    SCALED = 1
    LP_SCALED = 2
    NEAREST = 3
    FAILED = 4


class Simplex(IntEnum):
    """How the bounded-variable simplex ended."""

    OPTIMAL = 0
    ITERATION_LIMIT = 1
    SINGULAR_BASIS = 2


NONE, POSITION, VELOCITY, ACCELERATION = (int(kind) for kind in BoundKind)
BOUND_KINDS: tuple[str, ...] = tuple(kind.name.lower() for kind in BoundKind)

#: Bits of ``VelocityBounds.relaxed``: the limit a non-viable state had to give up.
RELAXED_POSITION = 1
RELAXED_ACCELERATION = 2

FEASIBLE, SCALED, LP_SCALED, NEAREST, FAILED = (int(outcome) for outcome in Outcome)
#: ``SNSDetails.method`` of each :class:`Outcome`.
METHODS: tuple[str, ...] = ("sns", "sns-scaled", "lp", "nearest", "failed")
OPTIMAL, ITERATION_LIMIT, SINGULAR_BASIS = (int(end) for end in Simplex)

#: "The task is met" (``StepResult.feasible`` of SNS and the QP):
#: ``‖J q̇ − ẋ‖ ≤ MET_TOLERANCE ‖ẋ‖ + MET_ROUNDING ‖J‖_F ‖q̇‖`` (the second term is the
#: rounding of ``J q̇`` itself).
MET_TOLERANCE = 1e-9
MET_ROUNDING = 1e-15
