"""Task-space inertia and the dynamically consistent inverse (Khatib 1987, 1995).

With ``M`` the joint-space inertia (Khatib writes ``A``)::

    Lambda = (J M^-1 J^T)^-1        task-space (operational-space) inertia
    J_bar  = M^-1 J^T Lambda        dynamically consistent inverse
    tau    = J^T f + (I - J^T J_bar^T) tau_0

where the null-space torque ``(I - J^T J_bar^T) tau_0`` produces no task acceleration:
``J M^-1 (I - J^T J_bar^T) = 0`` (Khatib 1987). ``J_bar`` is the weighted
pseudo-inverse with ``W = M`` (the inverse that minimises kinetic energy), computed as
:func:`~redres.linalg.weighted_pinv` is (in the same kernel), with ``Lambda =
(J L^-T (J L^-T)^T)^+`` from the same factorisation of ``J L^-T`` (``M = L L^T``).

Near a singularity ``J M^-1 J^T`` loses rank and ``Lambda`` grows without bound. With
``damping = lambda`` the functions use ``Lambda_lambda = (J M^-1 J^T + lambda^2 I)^-1``
and ``J_bar_lambda = M^-1 J^T Lambda_lambda``; with no damping, singular values of
``J L^-T`` at or below ``rcond * sigma_max`` are skipped (``info.full_rank`` False).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_matrix
from ..errors import NotPositiveDefiniteError
from . import _backend as be
from . import _codes as codes
from . import _engine as eng
from . import _weights as wt
from ._backend import FloatArray
from ._engine import Result
from ._info import RCOND, AdaptiveDamping

if TYPE_CHECKING:
    pass  # Python 3.11; only read by type checkers

__all__ = [
    "dynamically_consistent_pinv",
    "dynamically_consistent_projector",
    "task_space_inertia",
]


def mass_matrix_factor(M: ArrayLike, n: int) -> FloatArray:
    """Lower Cholesky factor ``L`` of a symmetric positive definite ``M`` (``M = L L^T``).

    Raises:
        ShapeError: ``M`` is not ``(n, n)``.
        NonFiniteError: ``M`` contains NaN or infinity.
        NotPositiveDefiniteError: ``M`` is not symmetric or not positive definite.
    """
    try:
        return wt.weight_factor(codes.FULL, wt.EMPTY_1D, as_matrix(M, "M", (n, n)), "M")
    except NotPositiveDefiniteError as exc:
        raise _not_a_mass_matrix(exc) from exc


def _not_a_mass_matrix(exc: NotPositiveDefiniteError) -> NotPositiveDefiniteError:
    return NotPositiveDefiniteError(f"M must be a symmetric positive definite mass matrix ({exc})")


def _decompose(
    J: ArrayLike,
    M: ArrayLike,
    damping: float | AdaptiveDamping,
    rcond: float,
    want_pinv: bool = True,
) -> tuple[FloatArray, FloatArray, FloatArray, eng.Stats, str]:
    """``(Lambda, J_bar, J, stats, method)``: from the compiled kernel (one factorisation
    of ``J L^-T``) within the kernels' sizes, else from :func:`_decompose_svd`.
    ``J_bar`` is 0 x 0 unless ``want_pinv``."""
    A = eng.as_jacobian(J, check_finite=False)
    n = A.shape[1]
    Mm = as_matrix(M, "M", (n, n))
    rc = eng.as_rcond(rcond)
    try:
        parts = eng.task_inertia(A, Mm, damping=damping, rcond=rc, want_pinv=want_pinv)
    except NotPositiveDefiniteError as exc:
        raise _not_a_mass_matrix(exc) from exc
    if parts is None:
        return _decompose_svd(A, Mm, damping, rc)
    Lam, J_bar, stats, mode = parts
    return Lam, J_bar, A, stats, _method(mode)


def _method(mode: int) -> str:
    """``InverseInfo.method`` of this module for a damping mode."""
    label = "dynamically-consistent"
    return label if mode == codes.EXACT else f"{label}-{eng.method_label(mode, False, '')}"


def _decompose_svd(
    A: FloatArray, M: FloatArray, damping: float | AdaptiveDamping, rcond: float
) -> tuple[FloatArray, FloatArray, FloatArray, eng.Stats, str]:
    """The reference path (any size; also the oracle of the kernel in the tests): one
    LAPACK SVD of ``J L^-T``."""
    eng.check_finite(A)
    m, n = A.shape
    L = mass_matrix_factor(M, n)
    mode, lam, lam_max, eps = be.parse_damping(damping)
    Jw = wt.solve_lower(L, A.T).T  # J L^-T
    U, sigma, Vt = np.linalg.svd(Jw, full_matrices=True)
    k = min(m, n)
    f, lam2, rank, used = eng.filter_factors(sigma, mode, lam, lam_max, eps, rcond)
    # Lambda = U diag(g) U^T with g = 1 / (sigma^2 + lambda^2) (exact: 1/sigma^2 or 0);
    # directions beyond min(m, n) have sigma = 0.
    g = np.zeros(m)
    damped = lam2 > 0.0
    g[:k][damped] = 1.0 / (sigma[damped] ** 2 + lam2[damped])
    exact = ~damped & (f > 0.0)
    g[:k][exact] = f[exact] / sigma[exact]
    if m > k and mode != codes.EXACT:
        tail = lam if mode == codes.FIXED else lam_max
        g[k:] = 1.0 / (tail * tail) if tail > 0.0 else 0.0
    Lam = (U * g) @ U.T
    Lam = 0.5 * (Lam + Lam.T)
    J_bar = wt.solve_lower(L, (Vt[:k].T * f) @ U[:, :k].T, trans="T")
    stats = eng.Stats(rank, float(sigma[-1]), float(sigma[0]), used)
    return Lam, np.asarray(J_bar), A, stats, _method(mode)


@eng.of_jm
def task_space_inertia(
    J: ArrayLike,
    M: ArrayLike,
    *,
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """Task-space inertia ``Lambda = (J M^-1 J^T)^-1`` (Khatib 1987).

    Args:
        J: Task Jacobian, shape ``(m, n)``.
        M: Joint-space inertia, symmetric positive definite, shape ``(n, n)`` (kg m^2, kg).
        damping: ``lambda >= 0`` (units of ``J M^{-1/2}``) or :class:`AdaptiveDamping`:
            ``(J M^-1 J^T + lambda^2 I)^-1``.
        rcond: Relative rank tolerance when undamped.
        return_info: Also return the :class:`InverseInfo` (singular values of ``J L^-T``).

    Returns:
        ``Lambda``, shape ``(m, m)``, symmetric (kg for translational rows).
    """
    Lam, _, A, stats, method = _decompose(J, M, damping, rcond, want_pinv=False)
    return eng.finish((Lam, stats, method), A.shape, return_info)


@eng.of_jm
def dynamically_consistent_pinv(
    J: ArrayLike,
    M: ArrayLike,
    *,
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """Dynamically consistent inverse ``J_bar = M^-1 J^T Lambda`` (Khatib 1987).

    The unique generalised inverse for which null-space torques produce no task
    acceleration; ``J J_bar = I`` when ``J`` has full row rank. Used in
    ``qdd = J_bar (xdd - Jdot qd)``.

    Args:
        J: Task Jacobian, shape ``(m, n)``.
        M: Joint-space inertia, symmetric positive definite, shape ``(n, n)``.
        damping: ``lambda >= 0`` or :class:`AdaptiveDamping`: ``M^-1 J^T Lambda_lambda``.
        rcond: Relative rank tolerance when undamped.
        return_info: Also return the :class:`InverseInfo` (singular values of ``J L^-T``).

    Returns:
        ``J_bar``, shape ``(n, m)``.
    """
    _, J_bar, A, stats, method = _decompose(J, M, damping, rcond)
    return eng.finish((J_bar, stats, method), A.shape, return_info)


def dynamically_consistent_projector(
    J: ArrayLike,
    M: ArrayLike,
    *,
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
) -> FloatArray:
    """Torque null-space projector ``I - J^T J_bar^T`` (Khatib 1987).

    ``tau = J^T f + (I - J^T J_bar^T) tau_0``: the second term produces no task
    acceleration, ``J M^-1 (I - J^T J_bar^T) = 0``. Its transpose ``I - J_bar J`` is the
    matching joint-space (velocity/acceleration) projector.

    Args:
        J: Task Jacobian, shape ``(m, n)``.
        M: Joint-space inertia, symmetric positive definite, shape ``(n, n)``.
        damping: ``lambda >= 0`` or :class:`AdaptiveDamping` (then only approximate).
        rcond: Relative rank tolerance when undamped.

    Returns:
        The projector, shape ``(n, n)``, acting on joint torques (N m, N).
    """
    _, J_bar, A, _, _ = _decompose(J, M, damping, rcond)
    return np.eye(A.shape[1]) - A.T @ J_bar.T
