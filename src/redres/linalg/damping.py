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

import math
from typing import TYPE_CHECKING, Any, Literal, overload

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_scalar
from ..errors import InvalidParameterError
from . import _backend as be
from ._backend import AdaptiveOptions, ExactOptions, FloatArray, Result, WithInfo
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
    A = be.as_jacobian(J, check_finite=False)
    rc = be.as_rcond(rcond)
    parts = be.matrix_inverse(
        A, damping=damping, rcond=rc, exact_label="pinv", lazy=not return_info
    )
    return be.finish(parts, A.shape, return_info)


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
    A = be.as_jacobian(J, check_finite=False)
    parts = be.matrix_inverse(A, damping=spec, rcond=be.as_rcond(rcond))
    return be.finish(parts, A.shape, return_info)


def rescaled_inverse(
    J: FloatArray, weights: Any, weights_name: str, damping: float | AdaptiveDamping,
    rcond: float, want_pinv: bool, want_projector: bool,
) -> be.Factored | None:  # fmt: skip
    """The engine's inverse (:func:`~redres.linalg._backend.invert`) of ``c J`` with the
    damping times ``c``, mapped back: ``J#(J, λ) = c J#(c J, c λ)``, the same projector,
    singular values and damping divided by ``c``. ``c`` is the power of two that brings J's
    largest entry into ``[0.5, 1)``, so the scaling itself is exact; it is used where
    ``λ²`` or ``σ²`` would be subnormal unscaled (the damped inverse of Wampler 1986
    depends on ``λ`` only through ``σ / λ``). None when there is nothing to rescale: J
    already of that size or zero, J or the scaled damping not finite (the engine reports
    it). A damped J below ``TINY_SCALE`` (1e-200, which the kernels count as zero) is
    rescaled too: with ``λ`` as tiny its inverse is not zero (issue 18, item 10).

    Raises:
        InvalidParameterError: the inverse itself overflows float64.
    """
    if not np.isfinite(J).all():
        return None
    top = float(np.abs(J).max()) if J.size else 0.0
    if top == 0.0:
        return None
    e = -math.frexp(top)[1]  # c = 2**e, applied by ldexp (2**1074 itself overflows)
    if e == 0:
        return None
    try:  # overflowing once scaled: J is negligible beside the damping (engine's answer)
        if isinstance(damping, AdaptiveDamping):
            scaled: float | AdaptiveDamping = AdaptiveDamping(
                math.ldexp(damping.max_damping, e), math.ldexp(damping.threshold, e),
                damping.selective,
            )  # fmt: skip
        else:
            scaled = math.ldexp(float(as_scalar(damping, "damping", minimum=0.0)), e)
    except OverflowError:
        return None
    values = (
        (scaled.max_damping, scaled.threshold) if isinstance(scaled, AdaptiveDamping) else (scaled,)
    )
    if not all(math.isfinite(v) for v in values):
        return None
    parts = be.invert(np.ldexp(J, e), weights=weights, weights_name=weights_name,
                      damping=scaled, rcond=rcond, want_pinv=want_pinv,
                      want_projector=want_projector)  # fmt: skip
    with np.errstate(over="ignore"):
        Jp = np.ldexp(parts.first, e) if want_pinv else parts.first
    if want_pinv and not np.isfinite(Jp).all():
        raise InvalidParameterError(
            "the damped inverse of J overflows float64 (J's entries and the damping are "
            "both tiny); rescale J and the damping together"
        )
    st = parts.stats
    stats = be.Stats(st.rank, math.ldexp(st.sigma_min, -e), math.ldexp(st.sigma_max, -e),
                     math.ldexp(st.damping, -e))  # fmt: skip
    return be.Factored(Jp, parts.second, stats, parts.mode)
