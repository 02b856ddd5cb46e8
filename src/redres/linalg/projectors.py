"""Null-space projectors, null-space bases and the Moore–Penrose conditions.

A joint velocity ``N z`` with ``N = I - J# J`` does not move the task when ``J N = 0``
(Liégeois 1977: the homogeneous solution / self-motion). The projector must come
from the same inverse as the task solution ``J# xd`` (DESIGN.md, section 2):

* exact pseudo-inverse: ``N = I - J^+ J``, symmetric, idempotent, ``J N = 0``;
* weighted ``J_W^+``: ``N_W = I - J_W^+ J``, idempotent, ``J N_W = 0``, self-adjoint in
  the ``W`` inner product (``W N_W`` symmetric) rather than symmetric;
* damped ``J#_lambda``: ``N = I - J#_lambda J`` is *not* an exact projector: ``J N =
  lambda^2 (J J^T + lambda^2 I)^-1 J`` with ``||J N||_2 <= lambda / 2``. It is still the
  right one: ``J#_lambda xd + N z`` is the exact minimiser of
  ``||J qd - xd||^2 + lambda^2 ||qd - z||^2``, so a secondary motion ``z`` is damped in
  the same way as the task, and ``N`` tends to the exact projector as ``lambda -> 0``.
  Pairing a damped inverse with the exact projector ``I - J^+ J`` (the pitfall STYLE.md
  recalls) makes the sum jump wherever the rank changes.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Literal, NamedTuple, overload

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_matrix
from ..errors import InvalidParameterError
from . import _engine as eng
from ._backend import FloatArray
from ._engine import InverseOptions, Result, WithInfo
from ._info import RCOND, AdaptiveDamping

if TYPE_CHECKING:
    from typing import Unpack  # Python 3.11; only read by type checkers

__all__ = [
    "MoorePenroseResiduals",
    "is_moore_penrose",
    "moore_penrose_residuals",
    "nullspace_basis",
    "nullspace_projector",
]


@overload
def nullspace_projector(
    J: ArrayLike,
    J_pinv: ArrayLike | None = ...,
    *,
    return_info: Literal[False] = ...,
    **kw: Unpack[InverseOptions],
) -> FloatArray: ...
@overload
def nullspace_projector(
    J: ArrayLike, J_pinv: None = ..., *, return_info: Literal[True], **kw: Unpack[InverseOptions]
) -> WithInfo: ...
def nullspace_projector(
    J: ArrayLike,
    J_pinv: ArrayLike | None = None,
    *,
    weights: ArrayLike | None = None,
    damping: float | AdaptiveDamping = 0.0,
    rcond: float = RCOND,
    return_info: bool = False,
) -> Result:
    """Null-space projector ``N = I - J# J`` consistent with an inverse ``J#``.

    Either pass the inverse you use (``J_pinv``), or let the function build it from the
    same options as :func:`redres.linalg.generalized_inverse` (``weights``, ``damping``,
    ``rcond``) in one pass; by default ``J#`` is the SVD pseudo-inverse and ``N`` the
    orthogonal projector onto the null space of ``J`` (Liégeois 1977: ``J N = 0``).

    Args:
        J: Jacobian, shape ``(m, n)``.
        J_pinv: An inverse of ``J``, shape ``(n, m)``; exclusive with the other options.
        weights: ``(n,)`` diagonal weights or ``(n, n)`` SPD matrix: ``N = I - J_W^+ J``.
        damping: ``lambda >= 0`` or :class:`AdaptiveDamping`: ``N = I - J#_lambda J``
            (see the module docstring for why this, not ``I - J^+ J``, goes with it).
        rcond: Relative rank tolerance for the exact inverse.
        return_info: Also return the :class:`InverseInfo` of the inverse (not available
            with ``J_pinv``, which this function did not compute).

    Returns:
        ``N``, shape ``(n, n)`` (and the info).
    """
    A = eng.as_jacobian(J, check_finite=False)
    m, n = A.shape
    if J_pinv is not None:
        if weights is not None or isinstance(damping, AdaptiveDamping) or damping != 0.0:
            raise InvalidParameterError(
                "pass either J_pinv or the options (weights, damping) that build it, not both"
            )
        if return_info:
            raise InvalidParameterError(
                "return_info=True needs J_pinv=None: the diagnostics belong to the inverse "
                "this function computes"
            )
        eng.check_finite(A)
        return np.eye(n) - as_matrix(J_pinv, "J_pinv", (n, m)) @ A
    _, N, stats, mode = eng.invert(
        A,
        weights=weights,
        weights_name="weights",
        damping=damping,
        rcond=eng.as_rcond(rcond),
        want_pinv=False,
        want_projector=True,
    )
    method = eng.method_label(mode, weights is not None, "pinv")
    return eng.finish((N, stats, method), A.shape, return_info)


def nullspace_basis(J: ArrayLike, rcond: float = RCOND) -> FloatArray:
    """Orthonormal basis ``Z`` of the null space of ``J``, from its SVD.

    ``J Z = 0``, ``Z^T Z = I`` and ``Z Z^T = I - J^+ J``. Its ``n - rank`` columns are the
    right singular vectors whose singular values are at or below ``rcond * sigma_max`` (or
    beyond ``m``); every self-motion is ``qd = Z a`` (Siciliano et al. 2009, §3.5).

    Args:
        J: Jacobian, shape ``(m, n)``.
        rcond: Relative rank tolerance.

    Returns:
        ``Z``, shape ``(n, n - rank)`` (``(n, 0)`` when ``J`` has full column rank).
    """
    A = eng.as_jacobian(J)
    tol = eng.as_rcond(rcond)
    _, sigma, Vt = np.linalg.svd(A, full_matrices=True)
    rank = int((sigma > tol * sigma[0]).sum()) if sigma[0] > 0.0 else 0
    return np.ascontiguousarray(Vt[rank:].T)


class MoorePenroseResiduals(NamedTuple):
    """Relative Frobenius residuals of the four Moore–Penrose conditions (Penrose 1955).

    Each is ``||lhs - rhs||_F / max(||rhs||_F, tiny)``; all four are ~1e-15 for the
    pseudo-inverse, and only the first (``J X J = J``) is small for a general inverse.
    """

    jxj: float  # J X J = J
    xjx: float  # X J X = X
    jx_symmetric: float  # (J X)^T = J X
    xj_symmetric: float  # (X J)^T = X J

    def max(self) -> float:
        """Largest of the four residuals."""
        return max(self)


def _relative(residual: FloatArray, reference: FloatArray) -> float:
    scale = float(np.linalg.norm(reference))
    return float(np.linalg.norm(residual)) / max(scale, np.finfo(float).tiny)


def moore_penrose_residuals(J: ArrayLike, J_pinv: ArrayLike) -> MoorePenroseResiduals:
    """How far ``J_pinv`` is from satisfying each Moore–Penrose condition.

    Args:
        J: Matrix, shape ``(m, n)``.
        J_pinv: Candidate pseudo-inverse ``X``, shape ``(n, m)``.

    Returns:
        The four relative residuals (see :class:`MoorePenroseResiduals`).
    """
    A = eng.as_jacobian(J)
    m, n = A.shape
    X = as_matrix(J_pinv, "J_pinv", (n, m))
    JX = A @ X
    XJ = X @ A
    return MoorePenroseResiduals(
        _relative(JX @ A - A, A),
        _relative(XJ @ X - X, X),
        _relative(JX.T - JX, JX),
        _relative(XJ.T - XJ, XJ),
    )


def is_moore_penrose(J: ArrayLike, J_pinv: ArrayLike, *, tol: float = 1e-8) -> bool:
    """True if ``J_pinv`` satisfies the four Moore–Penrose conditions to ``tol``.

    Args:
        J: Matrix, shape ``(m, n)``.
        J_pinv: Candidate pseudo-inverse, shape ``(n, m)``.
        tol: Largest accepted relative residual (see :func:`moore_penrose_residuals`).
    """
    return moore_penrose_residuals(J, J_pinv).max() <= tol
