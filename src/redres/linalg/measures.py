"""Kinematic measures of a Jacobian: singular values, manipulability and its gradient.

Singularity is judged from singular values, never from a determinant: ``det`` scales with
the units and the number of rows, while ``sigma_min`` is the smallest task-space speed
reachable per unit joint speed (Maciejewski & Klein 1988; Yoshikawa 1985).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

from ..errors import NonFiniteError, ShapeError
from . import _backend as be
from ._backend import FloatArray
from ._info import condition_from

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
    """
    return np.asarray(np.linalg.svd(be.as_jacobian(J), compute_uv=False), dtype=np.float64)


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
    """
    A = be.as_jacobian(J)
    if A.shape[0] > A.shape[1]:
        return 0.0
    return float(np.prod(np.linalg.svd(A, compute_uv=False)))


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
    A = be.as_jacobian(J)
    m, n = A.shape
    try:
        D = np.asarray(dJ_dq, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"dJ_dq must be an array of numbers; got {dJ_dq!r}") from exc
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
