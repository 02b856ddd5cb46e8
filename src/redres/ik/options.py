"""The problem and the answer of :func:`redres.ik.ik`: :class:`IKResult`, and the solver's
options and target, validated once before the iteration (see :mod:`redres.ik`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import FloatArray, as_scalar, as_transform, real_array, short_repr
from ..errors import InvalidParameterError, ShapeError
from ..linalg import AdaptiveDamping

__all__ = ["IKResult"]


@dataclass(frozen=True)
class IKResult:
    """Outcome of :func:`~redres.ik.ik`.

    Attributes:
        q: configuration, shape ``(n,)``, rad, always within the joint limits (the best
            one found when not converged).
        converged: both errors are within their tolerances (and the preference, if any,
            has settled).
        iterations: CLIK iterations over all attempts.
        restarts: random restarts used.
        position_error: ``‖p_d − p(q)‖``, m (``inf`` for a non-finite target).
        orientation_error: rotation angle of ``R_d R(q)ᵀ``, rad (0 for position-only
            targets; ``inf`` for a non-finite target).
        time_s: wall-clock time of the solve, s.
        message: what happened, in words.
        arm_angle: with an ``arm_angle`` preference, the arm angle reached, rad (else
            None).
        preference_met: with an ``arm_angle`` preference, whether it was reached within
            :data:`ARM_ANGLE_TOL` (else None); when it was not, ``message`` says so.
    """

    q: FloatArray
    converged: bool
    iterations: int
    restarts: int
    position_error: float
    orientation_error: float
    time_s: float
    message: str
    arm_angle: float | None = None
    preference_met: bool | None = None


#: rad: an arm-angle preference counts as met within this distance (wrapped).
ARM_ANGLE_TOL = 1e-4
#: Restarts are drawn within the middle part of each finite joint range: this fraction
#: of the range, about its middle (configurations near a limit start more attempts that
#: end clamped there at a local minimum).
RESTART_SPAN = 0.7


def limit_arrays(lo: FloatArray, hi: FloatArray) -> FloatArray:
    """The IK's view of the joint limits, ``[lo, hi, sample_lo, sample_hi, mid, weight]``
    (6, n), for the compiled solver and the reference one alike: the restart box
    (:data:`RESTART_SPAN` of each finite range about its middle, ``[max(lo, −π), min(hi,
    π)]`` where a limit is infinite), the middle of each range and the weight
    ``2 / span²`` of the joint-limit cost (0 for an infinite range)."""
    finite = np.isfinite(lo) & np.isfinite(hi)
    a, b = np.where(finite, lo, 0.0), np.where(finite, hi, 0.0)  # no inf - inf
    mid, span = (a + b) / 2.0, b - a
    half = RESTART_SPAN * span / 2.0
    return np.array(
        (
            lo, hi, np.where(finite, mid - half, np.maximum(lo, -math.pi)),
            np.where(finite, mid + half, np.minimum(hi, math.pi)), mid,
            np.where(finite & (span > 0), 2.0 / np.where(span > 0, span * span, 1.0), 0.0),
        ),
        dtype=np.float64,
    )  # fmt: skip


@dataclass(frozen=True)
class _Options:
    tol_position: float
    tol_orientation: float
    max_iterations: int
    max_restarts: int
    timeout_s: float
    max_step: float
    k_limits: float
    damping: AdaptiveDamping
    patience: int
    preference_tol: float


#: The largest ``max_iterations``, ``max_restarts`` and ``patience`` (the counts are int64
#: in the compiled kernel; a budget beyond this would run for days anyway).
MAX_COUNT = 10**7


def _count(value: Any, name: str, minimum: int) -> int:
    """A budget count: an integer from ``minimum`` to :data:`MAX_COUNT`."""
    if (
        isinstance(value, bool)
        or not isinstance(value, (int, np.integer))
        or not minimum <= value <= MAX_COUNT
    ):
        raise InvalidParameterError(
            f"{name} must be an integer from {minimum} to {MAX_COUNT:,}; got {short_repr(value)}"
        )
    return int(value)


def _options(*values: Any) -> _Options:
    (tol_p, tol_o, iters, restarts, timeout, max_step, k_lim, damping, patience, pref) = values
    iters, patience = _count(iters, "max_iterations", 1), _count(patience, "patience", 1)
    restarts = _count(restarts, "max_restarts", 0)
    if damping is not None and not isinstance(damping, AdaptiveDamping):
        raise InvalidParameterError(f"damping must be an AdaptiveDamping; got {damping!r}")
    return _Options(
        as_scalar(tol_p, "tol_position", minimum=0.0, strict=True),
        as_scalar(tol_o, "tol_orientation", minimum=0.0, strict=True),
        int(iters),
        int(restarts),
        math.inf if timeout is None else as_scalar(timeout, "timeout_s", minimum=0.0, strict=True),
        as_scalar(max_step, "max_step", minimum=0.0, strict=True),
        as_scalar(k_lim, "k_limits", minimum=0.0),
        damping if damping is not None else AdaptiveDamping(0.05, 0.05),
        int(patience),
        as_scalar(pref, "preference_tol", minimum=0.0, strict=True),
    )


def _parse_target(target: Any, position_only: bool) -> tuple[FloatArray, FloatArray | None] | None:
    """``(p_d, R_d)`` (``R_d`` None for position only), or None if the target is not finite."""
    arr = real_array(target, "target", "a 4x4 pose or a 3-vector")
    if arr.shape not in ((3,), (4, 4)):
        raise ShapeError(
            f"target must be a 4x4 homogeneous transform or a position of shape (3,); "
            f"got shape {arr.shape}"
        )
    if not np.isfinite(arr).all():
        return None
    if arr.shape == (3,):
        return arr.copy(), None
    T = as_transform(arr, "target")
    return T[:3, 3].copy(), (None if position_only else T[:3, :3].copy())
