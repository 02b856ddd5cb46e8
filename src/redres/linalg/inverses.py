"""Exact and weighted (pseudo-)inverses of a Jacobian, and a dispatcher.

All functions take ``J`` of shape ``(m, n)`` (``m`` task rows, ``n`` joints; units of the
task velocity per joint velocity, e.g. m/rad and rad/rad for a geometric Jacobian) and
return the ``(n, m)`` inverse as an ndarray. With ``return_info=True`` they return
``(matrix, InverseInfo)``, the diagnostics computed with the matrix.

Rank deficiency is never an error and never produces NaN: an exact inverse of a
rank-deficient ``J`` is the truncated SVD pseudo-inverse (Golub & Kahan 1965: singular values at or
below ``rcond * sigma_max`` are skipped), reported as ``info.full_rank == False`` and
``info.method == "pinv"``. For the damped inverses see :mod:`redres.linalg.damping`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, overload

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ShapeError
from . import _backend as be
from . import _engine as eng
from ._backend import FloatArray
from ._engine import InverseOptions, Result, WithInfo
from ._info import RCOND, AdaptiveDamping

if TYPE_CHECKING:
    from typing import Unpack  # Python 3.11; only read by type checkers

__all__ = [
    "generalized_inverse",
    "left_pinv",
    "pinv",
    "right_pinv",
    "square_inverse",
    "weighted_pinv",
]


def _left(J: FloatArray, rcond: float) -> eng.Parts:
    """Left pseudo-inverse as the transpose of the right one of ``J^T``."""
    J_t = np.ascontiguousarray(J.T)
    Jp_t, stats, method = eng.matrix_inverse(J_t, rcond=rcond, exact_label="left")
    return np.ascontiguousarray(Jp_t.T), stats, method


@overload
def pinv(J: ArrayLike, rcond: float = ..., *, return_info: Literal[False] = ...) -> FloatArray: ...
@overload
def pinv(J: ArrayLike, rcond: float = ..., *, return_info: Literal[True]) -> WithInfo: ...
def pinv(J: ArrayLike, rcond: float = RCOND, *, return_info: bool = False) -> Result:
    """Moore–Penrose pseudo-inverse from the SVD, skipping small singular values.

    ``J = U diag(sigma) V^T``, ``J^+ = V diag(sigma^+) U^T`` with ``sigma_i^+ = 1/sigma_i``
    if ``sigma_i > rcond * sigma_max`` and 0 otherwise (Golub & Kahan 1965;
    Siciliano et al. 2009, §3.5). Defined for every shape and rank; it is the minimum-norm
    least-squares inverse.

    Args:
        J: Jacobian, shape ``(m, n)``.
        rcond: Relative tolerance below which singular values are treated as zero.
        return_info: Also return the :class:`InverseInfo`.

    Returns:
        ``J^+``, shape ``(n, m)`` (and the info).
    """
    A = eng.as_jacobian(J)
    filt = eng.Filtered(A, 0, 0.0, 0.0, 1.0, eng.as_rcond(rcond))
    return eng.finish((filt.pinv(), filt.stats, "pinv"), A.shape, return_info)


@eng.of_j
def right_pinv(J: ArrayLike, *, rcond: float = RCOND, return_info: bool = False) -> Result:
    """Right pseudo-inverse ``J^T (J J^T)^-1`` of a wide Jacobian (``m <= n``).

    The minimum-norm solution of ``J qd = xd`` (Whitney 1969), with ``J J_r^+ = I``.
    Computed by a Cholesky solve when ``J`` is well conditioned and from the SVD otherwise
    (the same matrix, without squaring the condition number); a rank-deficient ``J``
    gives the truncated SVD pseudo-inverse (module docstring).

    Args:
        J: Jacobian, shape ``(m, n)`` with ``m <= n``.
        rcond: Relative rank tolerance (see :func:`pinv`).
        return_info: Also return the :class:`InverseInfo`.

    Returns:
        ``J_r^+``, shape ``(n, m)`` (and the info).

    Raises:
        ShapeError: if ``m > n`` (use :func:`left_pinv` or :func:`pinv`).
    """
    A = eng.as_jacobian(J, check_finite=False)
    if A.shape[0] > A.shape[1]:
        raise ShapeError(
            f"right_pinv needs a wide J (m <= n); got shape {A.shape}. "
            "Use left_pinv for tall J, or pinv for any shape."
        )
    parts = eng.matrix_inverse(A, rcond=eng.as_rcond(rcond), exact_label="right")
    return eng.finish(parts, A.shape, return_info)


@eng.of_j
def left_pinv(J: ArrayLike, *, rcond: float = RCOND, return_info: bool = False) -> Result:
    """Left pseudo-inverse ``(J^T J)^-1 J^T`` of a tall Jacobian (``m >= n``).

    The least-squares solution of an over-constrained ``J qd = xd``: it minimises
    ``||xd - J qd||^2`` and ``J_l^+ J = I`` (Penrose 1955, least squares). Computed as
    the transpose of the right pseudo-inverse of ``J^T`` (so rank-deficient alike).

    Args:
        J: Jacobian, shape ``(m, n)`` with ``m >= n``.
        rcond: Relative rank tolerance (see :func:`pinv`).
        return_info: Also return the :class:`InverseInfo`.

    Returns:
        ``J_l^+``, shape ``(n, m)`` (and the info).

    Raises:
        ShapeError: if ``m < n`` (use :func:`right_pinv` or :func:`pinv`).
    """
    A = eng.as_jacobian(J, check_finite=False)
    if A.shape[0] < A.shape[1]:
        raise ShapeError(
            f"left_pinv needs a tall J (m >= n); got shape {A.shape}. "
            "Use right_pinv for wide J, or pinv for any shape."
        )
    return eng.finish(_left(A, eng.as_rcond(rcond)), A.shape, return_info)


@eng.of_j
def square_inverse(J: ArrayLike, *, rcond: float = RCOND, return_info: bool = False) -> Result:
    """Inverse ``J^-1`` of a square Jacobian (Siciliano et al. 2009, §3.5); a singular
    ``J`` gives the truncated SVD pseudo-inverse (module docstring).

    Args:
        J: Jacobian, shape ``(n, n)``.
        rcond: Relative rank tolerance (see :func:`pinv`).
        return_info: Also return the :class:`InverseInfo`.

    Returns:
        ``J^-1``, shape ``(n, n)`` (and the info).

    Raises:
        ShapeError: if ``J`` is not square.
    """
    A = eng.as_jacobian(J, check_finite=False)
    if A.shape[0] != A.shape[1]:
        raise ShapeError(f"square_inverse needs a square J; got shape {A.shape}. Use pinv.")
    parts = eng.matrix_inverse(A, rcond=eng.as_rcond(rcond), exact_label="square")
    return eng.finish(parts, A.shape, return_info)


@eng.of_jm
def weighted_pinv(
    J: ArrayLike,
    W: ArrayLike,
    *,
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """Weighted least-norm inverse ``J_W^+ = W^-1 J^T (J W^-1 J^T)^-1`` (Whitney 1969).

    ``qd = J_W^+ xd`` minimises ``qd^T W qd / 2`` subject to ``J qd = xd`` (Whitney 1969,
    Lagrange multipliers); a larger weight slows that joint down. When ``J`` is square and
    invertible ``J_W^+ = J^-1`` whatever ``W`` (Whitney 1969). With ``damping`` it is the
    weighted damped least-squares inverse ``W^-1 J^T (J W^-1 J^T + lambda^2 I)^-1``.

    Computed as ``L^-T (J L^-T)^+`` with ``W = L L^T`` (``L = diag(sqrt(w))`` for
    diagonal weights): triangular solves, never an explicit ``W^-1``. If ``J W^-1 J^T`` is
    singular the truncated pseudo-inverse of ``J L^-T`` is used (``info.full_rank`` False).

    Args:
        J: Jacobian, shape ``(m, n)``.
        W: Joint weights: shape ``(n,)`` diagonal weights, all > 0, or a symmetric
            positive definite ``(n, n)`` matrix. Units: cost per (joint velocity)^2.
        damping: ``lambda >= 0`` (units of ``J W^{-1/2}``) or an :class:`AdaptiveDamping`.
        rcond: Relative rank tolerance for the exact case.
        return_info: Also return the :class:`InverseInfo` (singular values of ``J L^-T``).

    Returns:
        ``J_W^+``, shape ``(n, m)`` (and the info).

    Raises:
        ShapeError: ``W`` is neither ``(n,)`` nor ``(n, n)``.
        NotPositiveDefiniteError: ``W`` is not symmetric positive definite.
        NonFiniteError: ``J`` or ``W`` contains NaN or infinity.
    """
    A = eng.as_jacobian(J, check_finite=False)
    parts = eng.matrix_inverse(A, weights=W, damping=damping, rcond=eng.as_rcond(rcond))
    return eng.finish(parts, A.shape, return_info)


@overload
def generalized_inverse(
    J: ArrayLike, *, return_info: Literal[False] = ..., **kw: Unpack[InverseOptions]
) -> FloatArray: ...
@overload
def generalized_inverse(
    J: ArrayLike, *, return_info: Literal[True], **kw: Unpack[InverseOptions]
) -> WithInfo: ...
def generalized_inverse(
    J: ArrayLike,
    *,
    weights: ArrayLike | None = None,
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """The inverse that fits ``J``: one entry point that picks by shape, rank and options.

    * ``weights`` given: :func:`weighted_pinv` (damped if ``damping`` is set);
    * ``damping`` set: :func:`redres.linalg.damped_pinv` / ``adaptive_damped_pinv``;
    * otherwise square -> :func:`square_inverse`, wide -> :func:`right_pinv`,
      tall -> :func:`left_pinv`.

    ``info.method`` (with ``return_info=True``) says which one was used.

    Args:
        J: Jacobian, shape ``(m, n)``.
        weights: ``None``, ``(n,)`` diagonal weights or an ``(n, n)`` SPD matrix.
        damping: ``lambda >= 0`` or an :class:`AdaptiveDamping`.
        rcond: Relative rank tolerance.
        return_info: Also return the :class:`InverseInfo`.

    Returns:
        The inverse, shape ``(n, m)`` (and the info).
    """
    A = eng.as_jacobian(J, check_finite=False)
    m, n = A.shape
    rc = eng.as_rcond(rcond)
    if weights is not None or be.parse_damping(damping)[0] != 0:
        parts = eng.matrix_inverse(
            A, weights=weights, weights_name="weights", damping=damping, rcond=rc
        )
    elif m <= n:
        parts = eng.matrix_inverse(A, rcond=rc, exact_label="square" if m == n else "right")
    else:
        parts = _left(A, rc)
    return eng.finish(parts, A.shape, return_info)
