"""Kernel status codes and input bounds as errors (internal): the one translation of a
compiled kernel's status into the exception that names the argument, for
:mod:`redres.linalg` and every caller of its kernels."""

from __future__ import annotations

import math

import numpy as np

from .._validate import FloatArray
from ..errors import InvalidParameterError, NonFiniteError, NotPositiveDefiniteError
from . import _codes as codes

_NONFINITE: dict[int, str] = {
    codes.Status.Q_NONFINITE: "q",
    codes.Status.J_NONFINITE: "J",
    codes.Status.XD_NONFINITE: "xd",
    codes.Status.GRAD_NONFINITE: "grad",
    codes.Status.W_NONFINITE: "W",
}


def raise_status(status: int, names: dict[str, str]) -> None:
    """Raise the error a kernel status code stands for, naming the argument."""
    if status in _NONFINITE:
        key = _NONFINITE[status]
        raise NonFiniteError(f"{names.get(key, key)} contains NaN or infinity")
    if status == codes.XD_TOO_LARGE:
        raise too_large(names.get("xd", "xd"))
    w = names.get("W", "W")
    if status == codes.W_NOT_SPD:
        raise NotPositiveDefiniteError(
            f"{w} must be positive definite: diagonal weights all > 0, or a full matrix "
            "with a Cholesky factorisation (check for zero, negative or dependent rows)"
        )
    if status == codes.W_ASYMMETRIC:
        raise NotPositiveDefiniteError(
            f"{w} must be symmetric positive definite; it is not symmetric "
            "(use (W + W.T) / 2 if the asymmetry is rounding)"
        )
    known = status in codes.Status._value2member_map_
    name = codes.Status(status).name if known else "not a status"
    raise RuntimeError(f"unexpected kernel status {status} ({name})")


def too_large(name: str) -> InvalidParameterError:
    """The error for a task velocity beyond ``±MAX_TASK_RATE``."""
    return InvalidParameterError(
        f"{name} must lie within ±{codes.MAX_TASK_RATE:g} (a task velocity, m/s or rad/s); "
        "larger values overflow the joint velocity"
    )


def check_sigma(sigma_max: float) -> None:
    """Refuse a matrix whose largest singular value overflows float64 (the kernels scale
    the matrix, so its inverse is still finite, but its diagnostics would hold inf)."""
    if sigma_max == math.inf:
        raise InvalidParameterError(
            "J's largest singular value overflows float64 (entries near 1.7e308); rescale J"
        )


def check_rate(xd: FloatArray, name: str = "xd") -> None:
    """The kernels' bound on a (finite) task velocity, for the NumPy paths (same error)."""
    if xd.size and np.abs(xd).max() > codes.MAX_TASK_RATE:
        raise too_large(name)
