"""Kinematic measures of a Jacobian: singular values, manipulability and its gradient.

Singularity is judged from singular values, never from a determinant: ``det`` scales with
the units and the number of rows, while ``sigma_min`` is the smallest task-space speed
reachable per unit joint speed (Maciejewski & Klein 1988; Yoshikawa 1985).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike

from .._validate import real_array
from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from . import _engine as eng
from ._backend import FloatArray
from ._info import condition_from

_FLOAT_MAX = float(np.finfo(np.float64).max)

__all__ = [
    "condition_number",
    "manipulability",
    "manipulability_gradient",
    "sigma_min",
    "singular_values",
]


def singular_values(J: ArrayLike) -> FloatArray:
    """Singular values of ``J``, descending.

    Args:
        J: Matrix, shape ``(m, n)``.

    Returns:
        ``sigma``, shape ``(min(m, n),)``, in the units of ``J``'s entries.

    Raises:
        InvalidParameterError: the largest singular value overflows float64 (entries near
            1.7e308); the SVD runs on ``J`` scaled to unit size, so any smaller ``J`` works.
    """
    A = eng.as_jacobian(J)
    top = float(np.abs(A).max())
    if top == 0.0 or 1e-100 <= top <= 1e100:
        return np.asarray(np.linalg.svd(A, compute_uv=False), dtype=np.float64)
    sigma = np.linalg.svd(A / top, compute_uv=False)
    if sigma[0] > _FLOAT_MAX / top:
        raise InvalidParameterError(
            f"J's largest singular value overflows float64 (largest entry {top:g}); rescale J"
        )
    return np.asarray(sigma * top, dtype=np.float64)


def sigma_min(J: ArrayLike) -> float:
    """Smallest singular value of ``J`` (0 at a singularity), units of ``J``.

    Args:
        J: Matrix, shape ``(m, n)``; the smallest of its ``min(m, n)`` singular values.
    """
    return float(singular_values(J)[-1])


def condition_number(J: ArrayLike) -> float:
    """Condition number ``sigma_max / sigma_min`` of ``J`` (dimensionless, >= 1).

    Capped at ``1 / eps`` (about 4.5e15, ``eps`` the float64 machine epsilon): a ratio
    beyond it means ``J`` is numerically singular, and an exactly singular ``J`` (or
    ``J = 0``) returns the cap rather than infinity, so the result is always finite.
    Compare :func:`sigma_min` with a threshold for a measure in the units of ``J``.

    Args:
        J: Matrix, shape ``(m, n)``.
    """
    sigma = singular_values(J)
    return condition_from(float(sigma[0]), float(sigma[-1]))


def manipulability(J: ArrayLike) -> float:
    """Yoshikawa's manipulability ``w = sqrt(det(J J^T))`` (Yoshikawa 1985).

    Computed as the product of the singular values (no determinant of a possibly
    ill-conditioned ``J J^T``). It is zero at a singularity, and zero for ``m > n`` where
    ``J J^T`` (``m x m``) has rank at most ``n``; for a tall ``J`` use
    ``manipulability(J.T)`` (``sqrt(det(J^T J))``).

    Args:
        J: Jacobian, shape ``(m, n)``.

    Returns:
        ``w >= 0``, in units of the product of the ``m`` rows' units.

    Raises:
        InvalidParameterError: ``w`` overflows float64 (``J``'s entries about
            ``1e308 ** (1 / m)`` or larger).
    """
    A = eng.as_jacobian(J)
    if A.shape[0] > A.shape[1]:
        return 0.0
    sigma = singular_values(A)
    if sigma[-1] == 0.0:  # exactly singular: w = 0 (and 0 * inf is no product)
        return 0.0
    with np.errstate(over="ignore", under="ignore"):
        w = float(np.prod(sigma))
    if not math.isfinite(w):
        raise InvalidParameterError(
            "the manipulability of J (the product of its singular values) overflows "
            "float64; rescale J"
        )
    return w


def manipulability_gradient(J: ArrayLike, dJ_dq: ArrayLike) -> FloatArray:
    """Gradient of the manipulability ``w(q) = sqrt(det(J J^T))`` with respect to ``q``.

    ``dw/dq_k = w trace(J^+ dJ/dq_k)`` (Yoshikawa 1985, by Jacobi's formula
    ``d det(A) = det(A) trace(A^-1 dA)`` with ``A = J J^T``), evaluated
    as ``trace(C dJ/dq_k)`` with ``C = V diag(prod_{j != i} sigma_j) U^T`` — the same
    quantity where ``J`` has full rank, and finite at singularities, where ``w`` itself is
    not differentiable (its value there is the derivative of ``prod sigma_i``).

    For a cost to minimise (DESIGN.md convention), use ``-manipulability_gradient(...)``.

    Args:
        J: Jacobian, shape ``(m, n)``.
        dJ_dq: Partial derivatives of ``J``, shape ``(n, m, n)``: ``dJ_dq[k]`` is
            ``dJ/dq_k`` (per rad), e.g. from Pinocchio's kinematic Hessian.

    Returns:
        ``dw/dq``, shape ``(n,)``, units of ``w`` per rad. Zero for ``m > n``.
    """
    A = eng.as_jacobian(J)
    m, n = A.shape
    D = real_array(dJ_dq, "dJ_dq")
    if D.shape != (n, m, n):
        raise ShapeError(
            f"dJ_dq must have shape (n, m, n) = ({n}, {m}, {n}) with dJ_dq[k] = dJ/dq_k; "
            f"got {D.shape}"
        )
    if not np.isfinite(D).all():
        raise NonFiniteError("dJ_dq contains NaN or infinity")
    if m > n:
        return np.zeros(n)
    U, sigma, Vt = np.linalg.svd(A, full_matrices=False)
    # cof_i = prod_{j != i} sigma_j from prefix and suffix products (no division: exact
    # at singular values of zero).
    before = np.ones(m)
    after = np.ones(m)
    before[1:] = np.cumprod(sigma[:-1])
    after[:-1] = np.cumprod(sigma[:0:-1])[::-1]
    C = (Vt.T * (before * after)) @ U.T  # (n, m)
    # trace(C dJ/dq_k) = sum_ab C[b, a] dJ_k[a, b]: one product over the flattened (m, n)
    return np.ascontiguousarray(D.reshape(n, m * n) @ C.T.reshape(m * n))
