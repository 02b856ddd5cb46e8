"""Integer codes shared by the hard-limit kernels and their Python callers (internal).

Plain constants, importable without numba. Errors are not coded here: the kernels return
the status codes of :mod:`redres.linalg._codes` (0 = OK), turned into exceptions by
:func:`redres.linalg._status.raise_status`.
"""

from __future__ import annotations

#: What defines a side of the joint-velocity box (index into ``BOUND_KINDS``).
NONE, POSITION, VELOCITY, ACCELERATION = 0, 1, 2, 3
BOUND_KINDS: tuple[str, ...] = ("none", "position", "velocity", "acceleration")

#: Bits of ``VelocityBounds.relaxed``: the limit a non-viable state had to give up.
RELAXED_POSITION = 1
RELAXED_ACCELERATION = 2

#: Outcome of an SNS step (index into ``METHODS``): a result, not an error.
FEASIBLE, SCALED, LP_SCALED, NEAREST, FAILED = 0, 1, 2, 3, 4
METHODS: tuple[str, ...] = ("sns", "sns-scaled", "lp", "nearest", "failed")

#: Outcome of the bounded-variable simplex.
OPTIMAL, ITERATION_LIMIT, SINGULAR_BASIS = 0, 1, 2

#: "The task is met" (``StepResult.feasible`` of SNS and the QP):
#: ``‖J q̇ − ẋ‖ ≤ MET_TOLERANCE ‖ẋ‖ + MET_ROUNDING ‖J‖_F ‖q̇‖`` (the second term is the
#: rounding of ``J q̇`` itself).
MET_TOLERANCE = 1e-9
MET_ROUNDING = 1e-15
