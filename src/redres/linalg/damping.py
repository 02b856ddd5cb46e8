"""Damped least-squares inverses: fixed damping and adaptive damping near singularities.

The damped least-squares (singularity-robust) inverse of Nakamura & Hanafusa (1986) and
Wampler (1986)::

    J# = J^T (J J^T + lambda^2 I)^-1 = V diag(sigma_i / (sigma_i^2 + lambda^2)) U^T

is the minimiser of ``||J qd - xd||^2 + lambda^2 ||qd||^2``: it trades tracking accuracy
for bounded joint velocities, every gain ``sigma / (sigma^2 + lambda^2)`` being at most
``1 / (2 lambda)``. As ``lambda -> 0`` it tends to the pseudo-inverse of a full-rank ``J``.

:class:`~redres.linalg.AdaptiveDamping` makes ``lambda`` depend on the smallest singular
value so that the inverse is exact away from singularities.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, overload

from numpy.typing import ArrayLike

from . import _engine as eng
from ._backend import FloatArray
from ._engine import AdaptiveOptions, ExactOptions, Result, WithInfo
from ._info import RCOND, AdaptiveDamping

if TYPE_CHECKING:
    from typing import Unpack  # Python 3.11; only read by type checkers

__all__ = ["adaptive_damped_pinv", "damped_pinv"]


@overload
def damped_pinv(
    J: ArrayLike,
    damping: float | AdaptiveDamping,
    *,
    return_info: Literal[False] = ...,
    **kw: Unpack[ExactOptions],
) -> FloatArray: ...
@overload
def damped_pinv(
    J: ArrayLike,
    damping: float | AdaptiveDamping,
    *,
    return_info: Literal[True],
    **kw: Unpack[ExactOptions],
) -> WithInfo: ...
def damped_pinv(
    J: ArrayLike,
    damping: float | AdaptiveDamping,
    *,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """Damped least-squares inverse ``J^T (J J^T + damping^2 I)^-1`` (module docstring).

    Finite for every finite ``J``, including singular ones.

    Args:
        J: Jacobian, shape ``(m, n)``.
        damping: ``lambda >= 0`` in the units of ``J``'s entries (0 gives the exact
            truncated pseudo-inverse of :func:`redres.linalg.pinv`), or an
            :class:`AdaptiveDamping` for damping that depends on the smallest singular value.
        rcond: Relative rank tolerance, used when no damping applies.
        return_info: Also return the :class:`InverseInfo` (``info.damping`` is the
            ``lambda`` applied).

    Returns:
        ``J#``, shape ``(n, m)`` (and the info).

    Raises:
        InvalidParameterError: ``damping`` is negative.
    """
    A = eng.as_jacobian(J, check_finite=False)
    rc = eng.as_rcond(rcond)
    parts = eng.matrix_inverse(
        A, damping=damping, rcond=rc, exact_label="pinv", lazy=not return_info
    )
    return eng.finish(parts, A.shape, return_info)


@overload
def adaptive_damped_pinv(
    J: ArrayLike,
    max_damping: float,
    threshold: float,
    *,
    return_info: Literal[False] = ...,
    **kw: Unpack[AdaptiveOptions],
) -> FloatArray: ...
@overload
def adaptive_damped_pinv(
    J: ArrayLike,
    max_damping: float,
    threshold: float,
    *,
    return_info: Literal[True],
    **kw: Unpack[AdaptiveOptions],
) -> WithInfo: ...
def adaptive_damped_pinv(
    J: ArrayLike,
    max_damping: float,
    threshold: float,
    *,
    selective: bool = False,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """Damped inverse whose damping is zero away from singularities.

    Shorthand for ``damped_pinv(J, AdaptiveDamping(max_damping, threshold, selective))``;
    :class:`AdaptiveDamping` states the law and its references.

    Args:
        J: Jacobian, shape ``(m, n)``.
        max_damping: ``lambda_max >= 0``, units of ``J``'s entries.
        threshold: ``eps > 0``, same units: damping starts when ``sigma_min < eps``.
        selective: Damp each singular value below ``eps`` separately.
        rcond: Relative rank tolerance, used when no damping applies.
        return_info: Also return the :class:`InverseInfo` (``info.damping`` is the
            ``lambda`` applied).

    Returns:
        ``J#``, shape ``(n, m)`` (and the info).
    """
    spec = AdaptiveDamping(max_damping, threshold, selective)
    A = eng.as_jacobian(J, check_finite=False)
    parts = eng.matrix_inverse(A, damping=spec, rcond=eng.as_rcond(rcond))
    return eng.finish(parts, A.shape, return_info)
