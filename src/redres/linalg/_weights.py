"""The weights of the weighted inverses (internal): ``W = L Lᵀ`` as a diagonal ``(n,)`` or
a full symmetric positive definite ``(n, n)`` matrix, and the maps between joint and
weighted coordinates (``Jw = J W^{-1/2}``, :mod:`redres.linalg._backend`) on the NumPy
path; the compiled kernels apply the same factor inside."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._validate import real_array
from ..errors import ShapeError
from . import _codes as codes

FloatArray = NDArray[np.float64]

# Zero-size placeholders passed to the kernels for absent arguments (never written to;
# kept writable so that they have the same numba type as user arrays).
EMPTY_1D: FloatArray = np.zeros(0)
EMPTY_2D: FloatArray = np.zeros((0, 0))


def parse_weights(weights: Any, n: int, name: str) -> tuple[int, FloatArray, FloatArray]:
    """``(mode, diagonal, full)`` from a weights argument: None, ``(n,)`` or ``(n, n)``.

    Only shapes are checked here; values are checked by :func:`weight_factor` or the kernels.
    """
    if weights is None:
        return codes.NO_WEIGHTS, EMPTY_1D, EMPTY_2D
    w = np.ascontiguousarray(real_array(weights, name))
    if w.shape == (n,):
        return codes.DIAGONAL, w, EMPTY_2D
    if w.shape == (n, n):
        return codes.FULL, EMPTY_1D, w
    raise ShapeError(
        f"{name} must be a vector of {n} diagonal weights, shape ({n},), or a symmetric "
        f"positive definite matrix, shape ({n}, {n}); got shape {w.shape}"
    )


def weight_factor(mode: int, diag: FloatArray, full: FloatArray, name: str) -> FloatArray:
    """Validated factor of W for the NumPy path: ``sqrt(w)`` (diagonal), lower ``L`` (full)
    or an empty placeholder (no weights)."""
    if mode == codes.NO_WEIGHTS:
        return EMPTY_2D
    if mode == codes.DIAGONAL:
        if not np.isfinite(diag).all():
            _raise(codes.W_NONFINITE, {"W": name})
        if not (diag > 0.0).all():
            _raise(codes.W_NOT_SPD, {"W": name})
        return np.sqrt(diag)
    if not np.isfinite(full).all():
        _raise(codes.W_NONFINITE, {"W": name})
    if np.abs(full - full.T).max() > 1e-9 * np.abs(full).max():
        _raise(codes.W_ASYMMETRIC, {"W": name})
    try:
        L = np.linalg.cholesky(full)
    except np.linalg.LinAlgError:
        _raise(codes.W_NOT_SPD, {"W": name})
    return np.asarray(L, dtype=np.float64)


def solve_lower(L: FloatArray, B: FloatArray, *, trans: str = "N") -> FloatArray:
    """``L⁻¹ B`` (``trans="T"``: ``L⁻ᵀ B``) for a lower-triangular ``L``: SciPy's
    triangular solve, imported on first use (``scipy.linalg`` costs 0.2 s of
    ``import redres``; the compiled paths never need it)."""
    from scipy.linalg import solve_triangular

    return np.asarray(solve_triangular(L, B, lower=True, trans=trans))


def weigh(J: FloatArray, mode: int, factor: FloatArray) -> FloatArray:
    """``J W^{-1/2}``: ``J / sqrt(w)`` or ``J L^-T``."""
    if mode == codes.NO_WEIGHTS:
        return J
    if mode == codes.DIAGONAL:
        return J / factor
    return solve_lower(factor, J.T).T


def unweigh_rows(X: FloatArray, mode: int, factor: FloatArray) -> FloatArray:
    """``L^-T X`` (X with n rows): map a result from weighted to joint coordinates."""
    if mode == codes.NO_WEIGHTS:
        return X
    if mode == codes.DIAGONAL:
        return X / (factor if X.ndim == 1 else factor[:, None])
    return solve_lower(factor, X, trans="T")


def weigh_up(v: FloatArray, mode: int, factor: FloatArray) -> FloatArray:
    """``L^T v`` (diagonal: ``sqrt(w) v``): map a joint-space gradient to weighted coordinates."""
    if mode == codes.NO_WEIGHTS:
        return v
    if mode == codes.DIAGONAL:
        return factor * v
    return np.asarray(factor.T @ v)


def times_lt(X: FloatArray, mode: int, factor: FloatArray) -> FloatArray:
    """``X L^T`` (diagonal: ``X diag(sqrt(w))``)."""
    if mode == codes.NO_WEIGHTS:
        return X
    if mode == codes.DIAGONAL:
        return X * factor[None, :]
    return np.asarray(X @ factor.T)


def _raise(status: int, names: dict[str, str]) -> None:
    from ._status import raise_status  # the one translation of status codes

    raise_status(status, names)
