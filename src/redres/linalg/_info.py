"""Diagnostics and damping specifications shared by :mod:`redres.linalg`.

:class:`InverseInfo` is the one diagnostics type of the package: every function that
inverts a Jacobian can return one next to its result (``return_info=True``), and
:func:`redres.linalg.rate_step` always does. The numbers come from the factorisation that
produced the result; nothing is recomputed to fill them in.

:class:`AdaptiveDamping` selects damping that is zero away from singularities and grows as
the smallest singular value falls below a threshold. Pass it wherever a ``damping``
argument is accepted.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

from .._validate import as_scalar
from ..errors import InvalidParameterError
from ._codes import RCOND

__all__ = ["RCOND", "AdaptiveDamping", "InverseInfo", "adaptive_damping"]

_EPS = 2.220446049250313e-16


class InverseInfo(NamedTuple):
    """Diagnostics of one (pseudo-)inverse, computed with it.

    Singular values are those of the matrix actually inverted: ``J`` itself, or the weighted
    Jacobian ``J W^{-1/2}`` for a weighted inverse (``J M^{-1/2}`` for the dynamically
    consistent inverse), in the units of ``J`` (times ``W^{-1/2}``).

    Attributes:
        rank: Number of singular values above ``rcond * sigma_max`` (at most ``min(m, n)``).
        full_rank: ``rank == min(m, n)``. For an exact inverse of a rank-deficient matrix this
            is False and the result is the truncated SVD pseudo-inverse (``method`` says so).
        sigma_min: Smallest of the ``min(m, n)`` singular values (0 for a zero matrix).
        sigma_max: Largest singular value.
        damping: Damping ``lambda`` actually applied, in the units of the singular values
            (0 for an exact inverse; for selective damping, the largest one applied).
        method: Which inverse was computed: ``"square"``, ``"right"``, ``"left"``,
            ``"pinv"``, ``"damped"``, ``"adaptive"``, ``"selective"``, prefixed with
            ``"weighted-"`` when weights were used (``"dynamically-consistent"`` and
            ``"dynamically-consistent-damped"`` for :mod:`redres.linalg.dynamics`).
    """

    rank: int
    full_rank: bool
    sigma_min: float
    sigma_max: float
    damping: float
    method: str

    @property
    def condition(self) -> float:
        """``sigma_max / sigma_min``, capped as :func:`redres.linalg.condition_number` is."""
        return condition_from(self.sigma_max, self.sigma_min)


def condition_from(sigma_max: float, sigma_min: float) -> float:
    """``sigma_max / sigma_min`` capped at ``1 / eps`` (:func:`~redres.linalg.condition_number`)."""
    if sigma_min > sigma_max * _EPS:
        return sigma_max / sigma_min
    return 1.0 / _EPS


@dataclass(frozen=True)
class AdaptiveDamping:
    """Damping that vanishes away from singularities (pass as ``damping=``).

    With ``sigma_min`` the smallest singular value, ``eps = threshold`` and
    ``lambda_max = max_damping``::

        lambda^2 = 0                                  if sigma_min >= eps
        lambda^2 = (1 - (sigma_min / eps)^2) lambda_max^2   otherwise

    This is the singular-value-based law of Maciejewski & Klein (1988) in the form of
    Chiaverini, Siciliano & Egeland (1994), refining the damped least-squares inverse of
    Nakamura & Hanafusa (1986) and Wampler (1986). ``lambda`` is continuous in
    ``sigma_min``, zero in the well-conditioned region (so the inverse is exact there) and
    equal to ``lambda_max`` at the singularity.

    With ``selective=True`` each singular value ``sigma_i`` below ``eps`` gets its own
    ``lambda_i`` from the same law and the others are inverted exactly: only the singular
    directions are damped, as in the numerical filtering of Maciejewski & Klein (1988) and
    the singularity-robust task-priority scheme of Chiaverini (1997). The uniform form
    (``selective=False``) damps every direction with the ``lambda`` set by ``sigma_min``.

    Attributes:
        max_damping: ``lambda_max >= 0``, in the units of the Jacobian's entries.
        threshold: ``eps > 0``, size of the singular region, same units.
        selective: Damp only the singular values below ``threshold``.

    References:
        Y. Nakamura, H. Hanafusa, "Inverse kinematic solutions with singularity robustness
        for robot manipulator control", J. Dyn. Sys. Meas. Control 108 (1986) 163-171.
        C. W. Wampler, "Manipulator inverse kinematic solutions based on vector formulations
        and damped least-squares methods", IEEE Trans. SMC 16 (1986) 93-101.
        A. A. Maciejewski, C. A. Klein, "Numerical filtering for the operation of robotic
        manipulators through kinematically singular configurations", J. Robotic Systems 5
        (1988) 527-552.
        S. Chiaverini, B. Siciliano, O. Egeland, "Review of the damped least-squares inverse
        kinematics with experiments on an industrial robot manipulator", IEEE Trans. Control
        Syst. Technol. 2 (1994) 123-134.
        S. Chiaverini, "Singularity-robust task-priority redundancy resolution for real-time
        kinematic control of robot manipulators", IEEE Trans. Robot. Autom. 13 (1997)
        398-410.
    """

    max_damping: float
    threshold: float
    selective: bool = False

    def __post_init__(self) -> None:
        for name in ("max_damping", "threshold"):
            object.__setattr__(self, name, as_scalar(getattr(self, name), name))
        if self.max_damping < 0.0:
            raise InvalidParameterError(
                f"max_damping must be >= 0; got {self.max_damping}. "
                "Use 0 for no damping at singularities."
            )
        if self.threshold <= 0.0:
            raise InvalidParameterError(
                f"threshold must be > 0; got {self.threshold}. "
                "It is the smallest singular value below which damping starts."
            )

    def damping_for(self, sigma_min: float) -> float:
        """Damping ``lambda`` this law applies at a given smallest singular value."""
        return _law(sigma_min, self.max_damping, self.threshold)


def adaptive_damping(sigma_min: float, max_damping: float, threshold: float) -> float:
    """The damping ``lambda`` of the law of :class:`AdaptiveDamping`, as a function.

    Args:
        sigma_min: Smallest singular value (>= 0), units of the Jacobian.
        max_damping: ``lambda_max`` (>= 0), same units.
        threshold: ``eps`` (> 0), same units.

    Raises:
        InvalidParameterError, NonFiniteError: an argument that is not a finite real number
            in its range.
    """
    return _law(
        as_scalar(sigma_min, "sigma_min"),
        as_scalar(max_damping, "max_damping", minimum=0.0),
        as_scalar(threshold, "threshold", minimum=0.0, strict=True),
    )


def _law(sigma_min: float, max_damping: float, threshold: float) -> float:
    """:func:`adaptive_damping` on checked numbers."""
    if sigma_min >= threshold:
        return 0.0
    ratio = max(sigma_min, 0.0) / threshold
    return max_damping * math.sqrt(1.0 - ratio * ratio)
