"""The inverse engine of :mod:`redres.linalg` (internal): one factorisation per call.

Every inverse of :mod:`redres.linalg` is a *filtered SVD inverse* of the weighted Jacobian
``Jw = J W^{-1/2}`` (``W = I`` when unweighted; with ``W = L L^T``, ``Jw = J L^-T``)::

    Jw = U diag(sigma) V^T,   Jw# = V diag(f) U^T,   J# = L^-T Jw#,
    N = I - J# J = L^-T (I - V diag(sigma f) V^T) L^T

with one filter ``f`` per method (damped least squares of Nakamura & Hanafusa 1986 and
Wampler 1986 for ``f = sigma / (sigma^2 + lambda^2)``):

* exact: ``f = 1/sigma`` above ``rcond * sigma_max``, ``0`` below (truncated SVD);
* damped: ``f = sigma / (sigma^2 + lambda^2)`` (equals ``J^T (J J^T + lambda^2 I)^-1``);
* adaptive / selective: the same with ``lambda`` from :class:`AdaptiveDamping`.

Within the sizes of :func:`~redres.linalg._backend.use_fast_path` the compiled kernels of
:mod:`redres.linalg._kernels` compute the same quantities; otherwise NumPy's SVD does
(always with ``REDRES_DISABLE_JIT=1``, read by :mod:`redres._compile`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import (
    TYPE_CHECKING,
    Any,
    Literal,
    NamedTuple,
    Protocol,
    TypedDict,
    cast,
    overload,
)

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_matrix, as_scalar
from ..errors import InvalidParameterError, ShapeError
from . import _codes as codes
from ._backend import FloatArray, parse_damping, use_fast_path
from ._info import AdaptiveDamping, InverseInfo
from ._status import check_sigma, raise_status

if TYPE_CHECKING:
    from typing import Unpack  # Python 3.11; only read by type checkers

from ._weights import (
    EMPTY_1D,
    EMPTY_2D,
    parse_weights,
    times_lt,
    unweigh_rows,
    weigh,
    weight_factor,
)


def method_label(mode: int, weighted: bool, exact_label: str) -> str:
    """The ``InverseInfo.method`` string for a damping mode."""
    if mode == codes.EXACT:
        return "weighted" if weighted else exact_label
    base = {codes.FIXED: "damped", codes.ADAPTIVE: "adaptive", codes.SELECTIVE: "selective"}[mode]
    return f"weighted-{base}" if weighted else base


WithInfo = tuple[FloatArray, InverseInfo]
"""What ``f(J, ..., return_info=True)`` returns: the matrix and its diagnostics."""


class ExactOptions(TypedDict, total=False):
    """Keyword options of the matrix functions, for their typed overloads."""

    rcond: float


class AdaptiveOptions(ExactOptions, total=False):
    selective: bool


class DampedOptions(ExactOptions, total=False):
    damping: float | AdaptiveDamping


class InverseOptions(DampedOptions, total=False):
    weights: ArrayLike | None


Result = FloatArray | WithInfo


class OfJ(Protocol):
    """The type of ``f(J, *, rcond=..., return_info=...)``: the matrix, or with
    ``return_info=True`` the matrix and its diagnostics."""

    @overload
    def __call__(
        self, J: ArrayLike, *, rcond: float = ..., return_info: Literal[False] = ...
    ) -> FloatArray: ...
    @overload
    def __call__(
        self, J: ArrayLike, *, rcond: float = ..., return_info: Literal[True]
    ) -> WithInfo: ...


class OfJM(Protocol):
    """The type of ``f(J, M, *, damping=..., rcond=..., return_info=...)`` (a weight or
    inertia ``M``), as :class:`OfJ`."""

    @overload
    def __call__(
        self,
        J: ArrayLike,
        M: ArrayLike,
        /,
        *,
        return_info: Literal[False] = ...,
        **kw: Unpack[DampedOptions],
    ) -> FloatArray: ...
    @overload
    def __call__(
        self,
        J: ArrayLike,
        M: ArrayLike,
        /,
        *,
        return_info: Literal[True],
        **kw: Unpack[DampedOptions],
    ) -> WithInfo: ...


def of_j(function: Callable[..., Result]) -> OfJ:
    """Decorator: type a matrix function of ``J`` as :class:`OfJ` (its ``return_info``
    overloads, written once for every function of that signature); returns it unchanged."""
    return cast(OfJ, function)


def of_jm(function: Callable[..., Result]) -> OfJM:
    """Decorator: type a matrix function of ``J`` and ``M`` as :class:`OfJM` (as
    :func:`of_j`)."""
    return cast(OfJM, function)


Parts = tuple[FloatArray, "Stats", str]
"""``(matrix, stats, method)`` before packaging."""


def finish(parts: Parts, shape: tuple[int, ...], return_info: bool) -> Result:
    """The matrix of ``parts`` alone, or ``(matrix, InverseInfo)`` built from its statistics."""
    X, stats, method = parts
    if not return_info:
        return X
    rank, smin, smax, used = stats
    return X, InverseInfo(rank, rank == min(shape), smin, smax, used, method)


def as_jacobian(J: Any, *, check_finite: bool = True) -> FloatArray:
    """``J`` as a finite, non-empty float64 matrix (C order), or a clear error.

    ``check_finite=False`` skips the finiteness test for a float64 array passed on to
    :func:`invert` or :func:`task_inertia`, which make it where they read ``J`` (once).
    """
    if check_finite or type(J) is not np.ndarray or J.dtype != np.float64 or J.ndim != 2:
        arr = as_matrix(J, "J")
    else:
        arr = J
    if arr.shape[0] == 0 or arr.shape[1] == 0:
        raise ShapeError(f"J must have at least one row and one column; got {arr.shape}")
    return np.ascontiguousarray(arr)


def check_finite(J: FloatArray) -> None:
    """The kernels' finiteness test of ``J`` for the NumPy paths (same error)."""
    if not np.isfinite(J).all():
        raise_status(codes.J_NONFINITE, {})


def as_rcond(rcond: Any) -> float:
    """Validated relative rank tolerance (finite, >= 0)."""
    if type(rcond) is float and 0.0 <= rcond < math.inf:  # the common case, valid
        return rcond
    return as_scalar(rcond, "rcond", minimum=0.0)


def filter_factors(
    sigma: FloatArray, mode: int, lam: float, lam_max: float, eps: float, rcond: float
) -> tuple[FloatArray, FloatArray, int, float]:
    """Filter of one inverse for singular values ``sigma`` (descending, at least one).

    Returns ``(f, lam2, rank, damping)``: the inverse is ``V diag(f) U^T`` and ``lam2`` the
    squared damping applied to each singular value.
    """
    sigma_max = float(sigma[0])
    sigma_min = float(sigma[-1])
    significant = sigma > rcond * sigma_max
    if sigma_max == 0.0:
        significant[:] = False
    lam2 = np.zeros_like(sigma)
    if mode == codes.FIXED:
        lam2[:] = lam * lam
    elif mode in (codes.ADAPTIVE, codes.SELECTIVE):
        ref = sigma if mode == codes.SELECTIVE else np.full_like(sigma, sigma_min)
        below = ref < eps
        ratio = ref[below] / eps
        lam2[below] = lam_max * lam_max * (1.0 - ratio * ratio)
    damping = math.sqrt(float(lam2.max()))
    if sigma_max == 0.0 and mode != codes.EXACT:
        damping = lam if mode == codes.FIXED else lam_max
    f = np.zeros_like(sigma)
    damped = lam2 > 0.0
    lam_d = np.sqrt(lam2[damped])
    s_d = sigma[damped]
    top = np.maximum(s_d, lam_d)
    # sigma / (sigma^2 + lambda^2), scaled so that neither square overflows
    f[damped] = (s_d / top) / (top * ((s_d / top) ** 2 + (lam_d / top) ** 2))
    exact = ~damped & significant
    f[exact] = 1.0 / sigma[exact]
    return f, lam2, int(significant.sum()), damping


_FLOAT_MAX = float(np.finfo(np.float64).max)


class Filtered:
    """SVD of a (weighted) matrix and the filter of one inverse (NumPy reference path)."""

    __slots__ = ("U", "Vt", "f", "p", "stats")

    def __init__(
        self, Jw: FloatArray, mode: int, lam: float, lam_max: float, eps: float, rcond: float
    ) -> None:
        # The kernels' scaling (_dense_kernels._scale): an SVD of entries near 1.7e308
        # overflows (inf - inf), and a matrix of entries below TINY_SCALE counts as zero.
        top = float(np.abs(Jw).max())
        if top < codes.TINY_SCALE:
            Jw, top = np.zeros_like(Jw), 1.0
        elif 1e-100 <= top <= 1e100:
            top = 1.0
        self.U, sigma, self.Vt = np.linalg.svd(Jw / top if top != 1.0 else Jw, full_matrices=False)
        if top != 1.0:
            if sigma[0] > _FLOAT_MAX / top:
                raise InvalidParameterError(
                    f"J's largest singular value overflows float64 (largest entry {top:g}); "
                    "rescale J"
                )
            sigma = sigma * top
        self.f, _, rank, damping = filter_factors(sigma, mode, lam, lam_max, eps, rcond)
        self.p = sigma * self.f  # weights of the row-space projector J# J in the V basis
        self.stats = Stats(rank, float(sigma[-1]), float(sigma[0]), damping)

    def pinv(self) -> FloatArray:
        """``V diag(f) U^T`` (n x m)."""
        return np.asarray((self.Vt.T * self.f) @ self.U.T)

    def projector(self) -> FloatArray:
        """``I - V diag(sigma f) V^T`` (n x n)."""
        n = self.Vt.shape[1]
        return np.asarray(np.eye(n) - (self.Vt.T * self.p) @ self.Vt)

    def apply(self, xd: FloatArray) -> FloatArray:
        """``J# xd``."""
        return np.asarray(self.Vt.T @ (self.f * (self.U.T @ xd)))

    def project(self, g: FloatArray) -> FloatArray:
        """``N g``."""
        return np.asarray(g - self.Vt.T @ (self.p * (self.Vt @ g)))


class Stats(NamedTuple):
    """What a factorisation says about the matrix it inverted."""

    rank: int
    sigma_min: float
    sigma_max: float
    damping: float


class Factored(NamedTuple):
    """Outputs of the shared engine: the matrices (0 x 0 when not wanted), the statistics
    of the factorisation and the damping mode used."""

    first: FloatArray  # J# (invert) or Lambda (task_inertia)
    second: FloatArray  # N (invert) or J_bar (task_inertia)
    stats: Stats
    mode: int


#: Below this, a damping (or a singular value) squared is subnormal or zero in float64:
#: :func:`rescaled_inverse` takes over.
SMALL_DAMPING = 1e-150


def invert(
    J: FloatArray,
    *,
    weights: Any,
    weights_name: str,
    damping: float | AdaptiveDamping,
    rcond: float,
    want_pinv: bool,
    want_projector: bool,
    lazy: bool = False,
) -> Factored:
    """Shared engine of the matrix functions: ``Factored(J#, N, stats, mode)``.

    ``J`` must be a float64 matrix from :func:`as_jacobian`. Outputs not wanted are 0 x 0.
    ``lazy``: the statistics are not read (fixed damping may skip them: rank -1, NaN).
    """
    m, n = J.shape
    mode, lam, lam_max, eps = parse_damping(damping)
    rescale = (J, weights, weights_name, damping, rcond, want_pinv, want_projector)
    if mode != codes.EXACT and (lam if mode == codes.FIXED else min(lam_max, eps)) < SMALL_DAMPING:
        rescaled = rescaled_inverse(*rescale)
        if rescaled is not None:
            return rescaled
    kmode = codes.LAZY if lazy and mode == codes.FIXED else mode
    wmode, wdiag, wfull = parse_weights(weights, n, weights_name)
    kern = use_fast_path(m, n)
    if kern is not None:
        Jp = np.empty((n, m)) if want_pinv else EMPTY_2D
        N = np.empty((n, n)) if want_projector else EMPTY_2D
        status, rank, smin, smax, used = kern.inverse(
            np.ascontiguousarray(J), wdiag, wfull, Jp, N, EMPTY_2D, wmode, kmode, lam, lam_max,
            eps, rcond,
        )  # fmt: skip
        if status:
            raise_status(status, {"J": "J", "W": weights_name})
        check_sigma(smax)
        if mode != codes.EXACT and smax < SMALL_DAMPING:
            # the kernels square the scale of so tiny a J: subnormal, digits lost (below
            # TINY_SCALE they count it as zero, smax = 0, while J^T / λ² need not be)
            rescaled = rescaled_inverse(*rescale)
            if rescaled is not None:
                return rescaled
        return Factored(Jp, N, Stats(rank, smin, smax, used), mode)
    check_finite(J)
    factor = weight_factor(wmode, wdiag, wfull, weights_name)
    filt = Filtered(weigh(J, wmode, factor), mode, lam, lam_max, eps, rcond)
    Jp = unweigh_rows(filt.pinv(), wmode, factor) if want_pinv else EMPTY_2D
    N = EMPTY_2D
    if want_projector:
        N = times_lt(unweigh_rows(filt.projector(), wmode, factor), wmode, factor)
    return Factored(Jp, N, filt.stats, mode)


def task_inertia(
    J: FloatArray,
    M: FloatArray,
    *,
    damping: float | AdaptiveDamping,
    rcond: float,
    want_pinv: bool,
) -> Factored | None:
    """``Factored(Lambda, J_bar, stats, mode)`` from one compiled factorisation
    of ``J L^-T`` (``J`` from :func:`as_jacobian`, ``M = L L^T`` a validated ``(n, n)``
    matrix), or None when the kernels do not cover this size.

    ``Lambda = (J M^-1 J^T + lambda^2 I)^-1`` and ``J_bar = M^-1 J^T Lambda`` (the inverse
    weighted by ``M``); ``J_bar`` is 0 x 0 unless ``want_pinv``. Errors name ``M``.
    """
    m, n = J.shape
    kern = use_fast_path(m, n)
    if kern is None:
        return None
    mode, lam, lam_max, eps = parse_damping(damping)
    Lam = np.empty((m, m))
    Jp = np.empty((n, m)) if want_pinv else EMPTY_2D
    status, rank, smin, smax, used = kern.inverse(
        np.ascontiguousarray(J), EMPTY_1D, np.ascontiguousarray(M), Jp, EMPTY_2D, Lam,
        codes.FULL, mode, lam, lam_max, eps, rcond,
    )  # fmt: skip
    if status:
        raise_status(status, {"J": "J", "W": "M"})
    check_sigma(smax)
    return Factored(Lam, Jp, Stats(rank, smin, smax, used), mode)


def matrix_inverse(
    J: FloatArray,
    *,
    weights: Any = None,
    weights_name: str = "W",
    damping: float | AdaptiveDamping = 0.0,
    rcond: float,
    exact_label: str = "",
    lazy: bool = False,
) -> Parts:
    """``(J#, stats, method)`` for the matrix functions (``rcond`` already validated;
    ``lazy`` as for :func:`invert`: nobody reads the statistics, nor the method, left
    ``""``). An exact unweighted inverse of a rank-deficient ``J`` is labelled ``"pinv"``
    (the truncated SVD pseudo-inverse it falls back to) instead of ``exact_label``."""
    Jp, _, stats, mode = invert(
        J, weights=weights, weights_name=weights_name, damping=damping, rcond=rcond,
        want_pinv=True, want_projector=False, lazy=lazy,
    )  # fmt: skip
    if lazy:
        return Jp, stats, ""
    method = method_label(mode, weights is not None, exact_label)
    if weights is None and mode == codes.EXACT and stats.rank < min(J.shape):
        method = "pinv"
    return Jp, stats, method


def rescaled_inverse(
    J: FloatArray, weights: Any, weights_name: str, damping: float | AdaptiveDamping,
    rcond: float, want_pinv: bool, want_projector: bool,
) -> Factored | None:  # fmt: skip
    """The engine's inverse (:func:`invert`) of ``c J`` with the
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
    parts = invert(np.ldexp(J, e), weights=weights, weights_name=weights_name,
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
    stats = Stats(st.rank, math.ldexp(st.sigma_min, -e), math.ldexp(st.sigma_max, -e),
                     math.ldexp(st.damping, -e))  # fmt: skip
    return Factored(Jp, parts.second, stats, parts.mode)
