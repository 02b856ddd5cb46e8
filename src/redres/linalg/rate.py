"""One resolved-rate step in one call: the hot path of every rate-control loop.

:func:`rate_step` computes the joint velocity of gradient-projection redundancy resolution
(Liégeois 1977; Chan & Dubey 1995)::

    qd = J# xd - k_null N grad D,     N = I - J# J

with ``J#`` the exact, damped, adaptively damped or weighted inverse selected by the
options, ``N`` the projector *of that same inverse*, and diagnostics of the inverse, all
from one factorisation. ``D(q)`` is a cost to minimise (DESIGN.md convention), so
``-k_null grad D`` is a descent direction; a quantity to maximise is passed as its
negative. Within the kernels' sizes the whole step is one compiled kernel call.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_scalar, real_array
from ..errors import NonFiniteError, ShapeError
from . import _backend as be
from . import _engine as eng
from . import _weights as wt
from ._backend import FloatArray
from ._info import RCOND, AdaptiveDamping, InverseInfo
from ._status import check_rate, check_sigma, raise_status

__all__ = ["RateStep", "rate_step"]

_F64 = np.float64
_contiguous = np.ascontiguousarray
_ndarray = np.ndarray
_INF = float("inf")
_empty = np.empty
_new_tuple = tuple.__new__
_NO_GRAD = wt.EMPTY_1D
_NAMES = {"J": "J", "xd": "xd", "grad": "grad", "W": "weights"}
# InverseInfo.method by damping mode (the codes EXACT, FIXED, ADAPTIVE, SELECTIVE are 0..3).
_LABELS = tuple(eng.method_label(mode, False, "pinv") for mode in range(4))
_WEIGHTED_LABELS = tuple(eng.method_label(mode, True, "") for mode in range(4))

# Native entry point of the compiled step for float64 arrays and float scalars; filled on
# the first call (None until then, False when the kernels are unavailable).
_lane: list[Callable[..., Any] | bool | None] = [None]


def _reset_lane() -> None:
    _lane[0] = None


be._on_switch.append(_reset_lane)


class RateStep(NamedTuple):
    """The result of :func:`rate_step`.

    Attributes:
        qd: joint velocity, shape ``(n,)``, rad/s.
        info: diagnostics of the inverse ``J#`` (rank, ``sigma_min``, ``sigma_max``,
            damping used, method), from the same factorisation.
        null_term: the secondary part ``qd - J# xd = -k_null N grad``, shape ``(n,)``,
            rad/s, with ``return_null=True``; ``None`` otherwise (not computed).
    """

    qd: FloatArray
    info: InverseInfo
    null_term: FloatArray | None


def rate_step(
    J: ArrayLike,
    xd: ArrayLike,
    grad: ArrayLike | None = None,
    *,
    k_null: float = 1.0,
    damping: float | AdaptiveDamping = 0.0,
    weights: ArrayLike | None = None,
    rcond: float = RCOND,
    return_null: bool = False,
) -> RateStep:
    """Joint velocity ``qd = J# xd - k_null N grad`` of one rate-control step.

    ``N = I - J# J`` is built from the same inverse ``J#`` as the task term, so that:

    * exact inverse (default): ``N`` is the orthogonal null-space projector, ``J N = 0``,
      and the secondary term leaves the task untouched (Liégeois 1977);
    * damped (``damping = lambda``): ``qd`` is the exact minimiser of
      ``||J qd - xd||^2 + lambda^2 ||qd + k_null grad||^2``; the secondary term may
      disturb the task by ``||J N|| <= lambda/2`` (see :mod:`redres.linalg.projectors`);
    * adaptive (``damping = AdaptiveDamping(...)``): exact away from singularities,
      damped near them;
    * weighted (``weights = W``): ``J# = J_W^+`` and ``N = I - J_W^+ J``; ``qd`` minimises
      ``(qd + k_null grad)^T W (qd + k_null grad)`` subject to ``J qd = xd`` (Whitney 1969).

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
        return_null: Also compute the secondary part ``qd - J# xd = -k_null N grad`` (the
            null-space term), from the same factorisation.

    Returns:
        A :class:`RateStep` ``(qd, info, null_term)``: joint velocity, shape ``(n,)`` in
        rad/s, the :class:`InverseInfo` of ``J#`` (rank, ``sigma_min``, ``sigma_max``,
        damping used), and the null-space term (``None`` unless ``return_null``).

    Raises:
        ShapeError: an array has the wrong shape.
        NonFiniteError: an input contains NaN or infinity (the message names it).
        InvalidParameterError: negative ``damping`` or ``rcond``; ``xd`` beyond ±1e50
            (``MAX_TASK_RATE``, where ``J# xd`` could overflow).
        NotPositiveDefiniteError: ``weights`` is not positive definite.
    """
    Ja = _contiguous(J) if type(J) is _ndarray and J.dtype == _F64 else _checked(J, "J")
    xa = _contiguous(xd) if type(xd) is _ndarray and xd.dtype == _F64 else _checked(xd, "xd")
    ga = _NO_GRAD if grad is None else _checked(grad, "grad")
    if Ja.ndim != 2 or xa.ndim != 1 or ga.ndim != 1 or (grad is not None and not ga.size):
        _raise_shape(Ja, xa, ga, grad is not None)
    m, n = Ja.shape
    lane = _lane[0]
    if lane is None:
        lane = _lane[0] = be.fast_step() or False
    # The size test of be.use_fast_path, inlined (the hot path): up to 6 rows, or 12 when m <= n.
    if lane and weights is None and (m <= 6 or (m <= 12 and m <= n)) and n <= 50:
        if type(damping) is not AdaptiveDamping:
            qd = _empty(n)
            null = _empty(n) if return_null else _NO_GRAD
            try:
                status, rank, full, smin, smax, used, mode = lane(  # type: ignore[operator]
                    Ja, xa, ga, qd, null, k_null, damping, rcond
                )
            except TypeError:  # a scalar that is not a number
                status = -1
            if not status and smax != _INF:
                info = _new_tuple(InverseInfo, (rank, full, smin, smax, used, _LABELS[mode]))
                return _new_tuple(RateStep, (qd, info, null if return_null else None))
            # else bad input: the general path finds it again and raises the error naming it
    qd, info, null = _general_step(Ja, xa, ga, grad is not None, k_null, damping, weights, rcond)
    return _new_tuple(RateStep, (qd, info, null if return_null else None))


def _checked(value: Any, name: str) -> FloatArray:
    """``value`` as a C-contiguous float64 array; complex refused by name (not made real)."""
    return _contiguous(real_array(value, name))


def _general_step(
    J: FloatArray,
    xd: FloatArray,
    grad: FloatArray,
    has_grad: bool,
    k_null: Any,
    damping: float | AdaptiveDamping,
    weights: Any,
    rcond: Any,
) -> tuple[FloatArray, InverseInfo, FloatArray]:
    """Any options and sizes: the general kernel for small sizes, NumPy beyond; returns
    ``(qd, info, null_term)``."""
    m, n = J.shape
    if J.size == 0 or xd.shape != (m,) or (has_grad and grad.shape != (n,)):
        _raise_shape(J, xd, grad, has_grad)
    k, rc = as_scalar(k_null, "k_null"), eng.as_rcond(rcond)
    mode, lam, lam_max, eps = be.parse_damping(damping)
    wmode, wdiag, wfull = wt.parse_weights(weights, n, "weights")
    labels = _LABELS if weights is None else _WEIGHTED_LABELS
    kern = be.use_fast_path(m, n)
    if kern is not None:
        qd, null = np.empty(n), np.empty(n)
        status, rank, smin, smax, used = kern._step(
            J, xd, grad, qd, null, k, wmode, wdiag, wfull, mode, lam, lam_max, eps, rc
        )
        if status:
            raise_status(status, _NAMES)
        check_sigma(smax)
    else:
        qd, null, (rank, smin, smax, used) = _numpy_step(
            J, xd, grad, k, wmode, wdiag, wfull, (mode, lam, lam_max, eps, rc)
        )
    full = rank == min(m, n)
    return qd, InverseInfo(rank, full, smin, smax, used, labels[mode]), null


def _raise_shape(J: FloatArray, xd: FloatArray, grad: FloatArray, has_grad: bool) -> None:
    if J.ndim != 2 or J.size == 0:
        raise ShapeError(f"J must be a non-empty m x n matrix; got shape {J.shape}")
    m, n = J.shape
    if xd.shape != (m,):
        raise ShapeError(f"xd must have shape ({m},) to match J {J.shape}; got {xd.shape}")
    if has_grad and grad.shape != (n,):
        raise ShapeError(f"grad must have shape ({n},) to match J {J.shape}; got {grad.shape}")
    raise ShapeError(f"grad must be a vector; got shape {grad.shape}")


def _numpy_step(
    J: FloatArray,
    xd: FloatArray,
    grad: FloatArray,
    k: float,
    wmode: int,
    wdiag: FloatArray,
    wfull: FloatArray,
    spec: tuple[int, float, float, float, float],
) -> tuple[FloatArray, FloatArray, eng.Stats]:
    """Reference implementation of the step (any size), same conventions as the kernel:
    ``(qd, null_term, stats)``."""
    for arr, name in ((J, "J"), (xd, "xd"), (grad, "grad")):
        if not np.isfinite(arr).all():
            raise NonFiniteError(f"{name} contains NaN or infinity")
    check_rate(xd)
    mode, lam, lam_max, eps, rcond = spec
    factor = wt.weight_factor(wmode, wdiag, wfull, "weights")
    filt = eng.Filtered(wt.weigh(J, wmode, factor), mode, lam, lam_max, eps, rcond)
    task = filt.apply(xd)
    null = np.zeros_like(task)
    if grad.size:
        null = -k * filt.project(wt.weigh_up(grad, wmode, factor))
    qd = wt.unweigh_rows(task + null, wmode, factor)
    null = wt.unweigh_rows(null, wmode, factor)
    return np.ascontiguousarray(qd), np.ascontiguousarray(null), filt.stats
