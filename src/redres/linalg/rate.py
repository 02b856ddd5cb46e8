"""One resolved-rate step in one call: the hot path of every rate-control loop.

:func:`rate_step` computes the joint velocity of gradient-projection redundancy resolution
(seed 000 eq. 6, seed 001, seed 003)::

    qd = J# xd - k_null N grad D,     N = I - J# J

with ``J#`` the exact, damped, adaptively damped or weighted inverse selected by the
options, ``N`` the projector *of that same inverse*, and diagnostics of the inverse, all
from one factorisation. ``D(q)`` is a cost to minimise (DESIGN.md convention), so
``-k_null grad D`` is a descent direction; a quantity to maximise is passed as its
negative. For ``m <= 6`` task rows and ``n <= 50`` joints the whole step is one compiled
kernel call.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import InvalidParameterError, NonFiniteError, ShapeError
from . import _backend as be
from . import _codes as codes
from ._backend import FloatArray
from ._info import RCOND, AdaptiveDamping, InverseInfo

__all__ = ["rate_step"]

_F64 = np.float64
_contiguous = np.ascontiguousarray
_new_info = tuple.__new__
_NO_GRAD = be.EMPTY_1D
_empty = np.empty
_INF = math.inf
_MAX_ROWS = be.FAST_MAX_ROWS
_MAX_COLS = be.FAST_MAX_COLS
_EXACT = codes.EXACT
_FIXED = codes.FIXED
_NAMES = {"J": "J", "xd": "xd", "grad": "grad", "W": "weights"}
# InverseInfo.method by damping mode (EXACT, FIXED, ADAPTIVE, SELECTIVE).
_LABELS = ("pinv", "damped", "adaptive", "selective")
_WEIGHTED_LABELS = ("weighted", "weighted-damped", "weighted-adaptive", "weighted-selective")


def rate_step(
    J: ArrayLike,
    xd: ArrayLike,
    grad: ArrayLike | None = None,
    *,
    k_null: float = 1.0,
    damping: float | AdaptiveDamping = 0.0,
    weights: ArrayLike | None = None,
    rcond: float = RCOND,
) -> tuple[FloatArray, InverseInfo]:
    """Joint velocity ``qd = J# xd - k_null N grad`` of one rate-control step.

    ``N = I - J# J`` is built from the same inverse ``J#`` as the task term, so that:

    * exact inverse (default): ``N`` is the orthogonal null-space projector, ``J N = 0``,
      and the secondary term leaves the task untouched (seed 000 eq. 6);
    * damped (``damping = lambda``): ``qd`` is the exact minimiser of
      ``||J qd - xd||^2 + lambda^2 ||qd + k_null grad||^2``; ``||J N|| <= lambda/2``, so the
      secondary term may disturb the task by at most that much, and nothing jumps where
      the rank changes (see :mod:`redres.linalg.projectors`);
    * adaptive (``damping = AdaptiveDamping(...)``): exact away from singularities,
      damped near them;
    * weighted (``weights = W``): ``J# = J_W^+`` and ``N = I - J_W^+ J``; ``qd`` minimises
      ``(qd + k_null grad)^T W (qd + k_null grad)`` subject to ``J qd = xd`` (seed 001).

    To project an arbitrary joint velocity ``z`` instead of a gradient, pass
    ``grad=z, k_null=-1``.

    Args:
        J: Task Jacobian, shape ``(m, n)``, e.g. m/rad and rad/rad.
        xd: Desired task velocity, shape ``(m,)`` (m/s, rad/s), or the CLIK command
            ``xd_ref + K e``.
        grad: Gradient of the secondary cost ``D(q)``, shape ``(n,)`` (cost per rad);
            ``None`` for no secondary objective.
        k_null: Gain on the secondary term (rad^2/s per cost unit), any finite value.
        damping: ``lambda >= 0`` (units of ``J``) or an :class:`AdaptiveDamping`.
        weights: ``None``, ``(n,)`` diagonal joint weights (> 0), or an ``(n, n)`` SPD
            matrix.
        rcond: Relative rank tolerance used when no damping applies.

    Returns:
        ``(qd, info)``: joint velocity, shape ``(n,)`` in rad/s, and the
        :class:`InverseInfo` of ``J#`` (rank, ``sigma_min``, ``sigma_max``, damping used).

    Raises:
        ShapeError: an array has the wrong shape.
        NonFiniteError: an input contains NaN or infinity (the message names it).
        InvalidParameterError: negative ``damping`` or ``rcond``.
        NotPositiveDefiniteError: ``weights`` is not positive definite.
    """
    try:
        Ja = _contiguous(J, _F64)
        xa = _contiguous(xd, _F64)
        ga = _NO_GRAD if grad is None else _contiguous(grad, _F64)
    except (TypeError, ValueError) as exc:
        raise ShapeError(f"J, xd and grad must be arrays of numbers: {exc}") from exc
    if Ja.ndim != 2 or xa.ndim != 1 or ga.ndim != 1 or Ja.size == 0:
        _raise_shape(Ja, xa, ga, grad is not None)
    m, n = Ja.shape
    # Scalars: x - x is 0.0 for finite floats, NaN for NaN and +-inf.
    k = k_null if type(k_null) is float else _number(k_null, "k_null")
    rc = rcond if type(rcond) is float else _number(rcond, "rcond")
    if k - k != 0.0 or rc - rc != 0.0:
        raise NonFiniteError(f"k_null and rcond must be finite; got {k_null!r}, {rcond!r}")
    if rc < 0.0:
        raise InvalidParameterError(f"rcond must be >= 0; got {rc}")
    if type(damping) is float:
        lam = damping
        if not 0.0 <= lam < _INF:
            raise InvalidParameterError(f"damping must be finite and >= 0; got {damping}")
        mode = _FIXED if lam > 0.0 else _EXACT
        lam_max = 0.0
        eps = 1.0
    else:
        mode, lam, lam_max, eps = be.parse_damping(damping)

    kern = be.loaded
    small = m <= _MAX_ROWS and n <= _MAX_COLS
    if kern is None and small:
        kern = be.kernels()
    if kern is not None and small:
        qd = _empty(n)
        if weights is None:
            status, rank, smin, smax, used = kern.step(
                Ja, xa, ga, qd, k, mode, lam, lam_max, eps, rc
            )
            labels = _LABELS
        else:
            wmode, wdiag, wfull = be.parse_weights(weights, n, "weights")
            if wmode == codes.DIAGONAL:
                status, rank, smin, smax, used = kern.step_diagonal(
                    Ja, xa, ga, wdiag, qd, k, mode, lam, lam_max, eps, rc
                )
            else:
                status, rank, smin, smax, used = kern.step_full(
                    Ja, xa, ga, wfull, qd, k, mode, lam, lam_max, eps, rc
                )
            labels = _WEIGHTED_LABELS
        if status:
            if status == codes.XD_SHAPE or status == codes.GRAD_SHAPE:
                _raise_shape(Ja, xa, ga, grad is not None)
            be.raise_status(status, _NAMES)
    else:
        if xa.shape != (m,) or (grad is not None and ga.shape != (n,)):
            _raise_shape(Ja, xa, ga, grad is not None)
        wmode, wdiag, wfull = be.parse_weights(weights, n, "weights")
        qd, rank, smin, smax, used = _numpy_step(
            Ja, xa, ga, k, wmode, wdiag, wfull, (mode, lam, lam_max, eps, rc)
        )
        labels = _LABELS if weights is None else _WEIGHTED_LABELS
    full = rank == (m if m < n else n)
    return qd, _new_info(InverseInfo, (rank, full, smin, smax, used, labels[mode]))


def _raise_shape(J: FloatArray, xd: FloatArray, grad: FloatArray, has_grad: bool) -> None:
    if J.ndim != 2 or J.size == 0:
        raise ShapeError(f"J must be a non-empty m x n matrix; got shape {J.shape}")
    m, n = J.shape
    if xd.shape != (m,):
        raise ShapeError(f"xd must have shape ({m},) to match J {J.shape}; got {xd.shape}")
    if has_grad and grad.shape != (n,):
        raise ShapeError(f"grad must have shape ({n},) to match J {J.shape}; got {grad.shape}")
    raise ShapeError("inconsistent shapes")  # pragma: no cover


def _number(value: Any, name: str) -> float:
    try:
        return float(value)
    except (TypeError, ValueError) as exc:
        raise InvalidParameterError(f"{name} must be a number; got {value!r}") from exc


def _numpy_step(
    J: FloatArray,
    xd: FloatArray,
    grad: FloatArray,
    k: float,
    wmode: int,
    wdiag: FloatArray,
    wfull: FloatArray,
    spec: tuple[int, float, float, float, float],
) -> tuple[FloatArray, int, float, float, float]:
    """Reference implementation of the step (any size), same conventions as the kernel."""
    for arr, name in ((J, "J"), (xd, "xd"), (grad, "grad")):
        if not np.isfinite(arr).all():
            raise NonFiniteError(f"{name} contains NaN or infinity")
    mode, lam, lam_max, eps, rcond = spec
    factor = be.EMPTY_2D
    if wmode != codes.NO_WEIGHTS:
        factor = be.weight_factor(wmode, wdiag, wfull, "weights")
    filt = be.Filtered(be.weigh(J, wmode, factor), mode, lam, lam_max, eps, rcond)
    qd = filt.apply(xd)
    if grad.size:
        qd = qd - k * filt.project(be.weigh_up(grad, wmode, factor))
    qd = be.unweigh_rows(qd, wmode, factor)
    return np.ascontiguousarray(qd), filt.rank, filt.sigma_min, filt.sigma_max, filt.damping
