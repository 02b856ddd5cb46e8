"""Compiled kernels for the small matrices of robotics (internal).

The public functions of :mod:`redres.linalg` call these within the sizes of
:func:`redres.linalg._backend.use_fast_path`. They are compiled through :mod:`redres._compile`
and imported lazily by :mod:`redres.linalg._backend`: ``import redres`` never pays for numba.

Every kernel works on a *weighted* Jacobian ``Js = J W^{-1/2}`` (``J L^-T`` for a full
``W = L L^T``), divided by its largest entry when that entry is outside ``[1e-100, 1e100]``
so that ``Js Js^T`` can neither overflow nor underflow. The extreme eigenvalues of the Gram
matrix ``A = Js Js^T`` (Householder tridiagonalisation, then Laguerre's method) give
``sigma_min`` and ``sigma_max``, hence the damping law, the rank and the choice of path:

* well conditioned (``sigma_min >= 1e-3 sigma_max``): ``J# = Js^T (A + lam^2 I)^-1`` by a
  Cholesky solve, a few hundred flops, accurate to ``kappa(A) eps <= 2e-10``; the Gram
  eigenvalues give ``sigma`` to about ``kappa(J)^2 eps <= 2e-10`` relative;
* near-singular: a one-sided Jacobi SVD (Hestenes 1958) of ``Js`` (:func:`_core` gives
  the formulas), whose singular values are accurate even when tiny, so the rank and
  ``sigma_min`` reported near a singularity are those of the SVD.

Status codes (returned first by each kernel, turned into errors by the caller) name the
offending argument; the kernels never raise. The small helpers live in
:mod:`~redres.linalg._dense_kernels` (Cholesky, weights, scaling) and
:mod:`~redres.linalg._eigen_kernels` (eigenvalues, Jacobi SVD); calls between them are safe
for numba's disk cache because :mod:`redres._compile` stamps every kernel with all their
sources.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ._codes import (
    EXACT,
    FIXED,
    GRAD_NONFINITE,
    GRAD_SHAPE,
    J_EMPTY,
    J_NONFINITE,
    LAZY,
    MAX_TASK_RATE,
    NO_WEIGHTS,
    OK,
    SCALAR_INVALID,
    XD_NONFINITE,
    XD_SHAPE,
    XD_TOO_LARGE,
)
from ._dense_kernels import (
    _back_project,
    _bounded_1d,
    _cholesky,
    _cholesky_solve,
    _copy_finite_2d,
    _factor_size,
    _factor_view,
    _finite_1d,
    _finite_2d,
    _gram,
    _scale,
    _weigh,
    _weight_down,
    _weight_up,
    _weight_up_row,
)
from ._factor_kernels import _LAZY_MIN_SHIFT, _core


@kernel
def _step_scratch(m, n, wmode):
    """Scratch of :func:`_step_into` for an ``m x n`` Jacobian and the weight mode
    ``wmode``: ``(Js (m, n), mats (3, m, m), Lw, vec (7 m + n))`` (the scaled Jacobian,
    the factors, the weight factor (:func:`_factor_view`), the vectors). Separate arrays
    and rows of a 3-D one, not reshaped slices of one buffer: in the compiled code each
    reshape costs about as much as a 6 x 6 Cholesky factorisation."""
    Lw = _factor_view(np.empty(_factor_size(n, wmode)), n, wmode)
    return np.empty((m, n)), np.empty((3, m, m)), Lw, np.empty(7 * m + n)


@kernel
def _step(J, xd, grad, out, null, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond):
    """``out <- J# xd - k_null (I - J# J) grad``; ``(status, rank, smin, smax, damping)``.

    Any weights (``wmode`` selects ``wdiag`` (n,) or ``W`` (n, n); the other may be empty)
    and damping mode; ``J`` non-empty and the scalars validated by the caller. When
    ``null`` has length n it receives the secondary part ``out - J# xd`` (the null-space
    term), from the same factorisation; pass a length-0 array otherwise. The step is
    :func:`_step_into` with scratch allocated here (a loop over many steps passes its own).
    """
    m, n = J.shape
    if wmode == NO_WEIGHTS and dmode == LAZY:  # the common case, in small scratch
        if _lazy_step(J, xd, grad, out, null, k_null, lam, np.empty((m, m)), np.empty(2 * m + n)):
            return OK, -1, math.nan, math.nan, lam
    scratch = _step_scratch(m, n, wmode)
    return _step_into(
        J, xd, grad, out, null, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond, scratch
    )


@kernel
def _step_into(
    J, xd, grad, out, null, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond, scratch
):
    """:func:`_step` in ``scratch``, the arrays of ``_step_scratch(m, n, wmode)`` (their
    contents are overwritten: one scratch serves any number of steps of that size)."""
    m, n = J.shape
    has_grad = grad.shape[0] > 0
    want_null = null.shape[0] == n
    if xd.shape[0] != m:
        return XD_SHAPE, 0, 0.0, 0.0, 0.0
    if has_grad and grad.shape[0] != n:
        return GRAD_SHAPE, 0, 0.0, 0.0, 0.0
    Js, mats, Lw, vec = scratch
    if (
        wmode == NO_WEIGHTS
        and dmode == LAZY
        and _lazy_step(J, xd, grad, out, null, k_null, lam, mats[0], vec)
    ):
        return OK, -1, math.nan, math.nan, lam
    C = mats[0]
    r = vec[:m]
    dvec = vec[m : 2 * m]
    rt = vec[2 * m : 3 * m]
    work = vec[3 * m : 7 * m]
    g = vec[7 * m : 7 * m + n]
    if not _copy_finite_2d(J, Js):
        return J_NONFINITE, 0, 0.0, 0.0, 0.0
    if not _finite_1d(xd):
        return XD_NONFINITE, 0, 0.0, 0.0, 0.0
    if not _bounded_1d(xd, MAX_TASK_RATE):
        return XD_TOO_LARGE, 0, 0.0, 0.0, 0.0
    bad = 0.0
    for j in range(n):
        x = grad[j] if has_grad else 0.0
        bad += x * 0.0
        g[j] = x
    if bad != 0.0:
        return GRAD_NONFINITE, 0, 0.0, 0.0, 0.0
    status = _weigh(Js, wmode, wdiag, W, Lw)
    if status != OK:
        return status, 0, 0.0, 0.0, 0.0
    if has_grad:  # g = W^{1/2} grad (weighted coordinates)
        _weight_up(g, wmode, Lw)
    scale = _scale(Js)
    if scale == 0.0:  # J = 0: J# = 0, N = I
        lam_used = lam if dmode == FIXED or dmode == LAZY else (lam_max if dmode != EXACT else 0.0)
        for j in range(n):
            out[j] = -k_null * g[j]
        _weight_down(out, wmode, Lw)
        if want_null:
            for j in range(n):
                null[j] = out[j]
        return OK, 0, 0.0, 0.0, lam_used
    use_chol, rank, smin, smax, lam_used = _core(
        Js, scale, dmode, lam, lam_max, eps, rcond, mats, dvec, work
    )
    # Cholesky: qd = Js^T (Js Js^T + lam^2)^-1 (xd / s + k Js g) - k g.
    # SVD (Js now holds B): qd = B^T diag(d) (G xd / s + k B g) - k g.
    inv_scale = 1.0 / scale
    for i in range(m):
        acc = 0.0
        if has_grad:
            for j in range(n):
                acc += Js[i, j] * g[j]
        if use_chol:
            task = xd[i]
        else:
            task = 0.0
            for k in range(m):
                task += C[i, k] * xd[k]
        r[i] = task * inv_scale + k_null * acc
        rt[i] = task * inv_scale
    if use_chol:
        _cholesky_solve(C, r, m)
        if want_null:
            _cholesky_solve(C, rt, m)
    else:
        for i in range(m):
            r[i] *= dvec[i]
            rt[i] *= dvec[i]
    _back_project(Js, m, r, rt, g, k_null, out, null)
    _weight_down(out, wmode, Lw)
    if want_null:
        _weight_down(null, wmode, Lw)
    return OK, rank, smin, smax, lam_used


@kernel
def _lazy_step(J, xd, grad, out, null, k_null, lam, C, vec):
    """:func:`_step_into`'s common case in one pass, on ``J`` itself: no weights,
    ``LAZY`` damping, finite inputs of safe size (no scaling), a shift the Cholesky path
    takes at once (:data:`_LAZY_MIN_SHIFT`). The general path's floating-point operations
    (its ``Js`` is a copy of J here, scaled by 1), hence its bits. Scratch: ``C`` (m x m,
    the Gram matrix factored in place) and ``vec`` (at least ``2 m + n``). Returns False,
    having written nothing but scratch, when a condition fails: then the general path
    decides, and reports why."""
    m, n = J.shape
    has_grad = grad.shape[0] > 0
    if xd.shape[0] != m or (has_grad and grad.shape[0] != n):
        return False
    bad = 0.0
    big = 0.0
    for i in range(m):
        for j in range(n):
            x = J[i, j]
            bad += x * 0.0
            big = max(big, abs(x))
    rate = 0.0
    for i in range(m):
        bad += xd[i] * 0.0
        rate = max(rate, abs(xd[i]))
    if has_grad:
        for j in range(n):
            bad += grad[j] * 0.0
    if bad != 0.0 or not (1e-100 <= big <= 1e100) or rate > MAX_TASK_RATE:
        return False
    _gram(J, m, C)
    trace = 0.0
    for i in range(m):
        trace += C[i, i]
    shift = lam * lam / 1.0  # the general path's lam^2 / scale^2 with scale 1
    # In place: column j of the factor reads only the Gram matrix's column j below the
    # diagonal, not yet overwritten, and the factor's earlier columns.
    if not (shift >= _LAZY_MIN_SHIFT * trace and _cholesky(C, C, m, shift)):
        return False
    want_null = null.shape[0] == n
    r = vec[:m]
    rt = vec[m : 2 * m]
    g = vec[2 * m : 2 * m + n]
    for j in range(n):
        g[j] = grad[j] if has_grad else 0.0
    for i in range(m):
        acc = 0.0
        if has_grad:
            for j in range(n):
                acc += J[i, j] * g[j]
        task = xd[i]
        r[i] = task * 1.0 + k_null * acc
        rt[i] = task * 1.0
    _cholesky_solve(C, r, m)
    if want_null:
        _cholesky_solve(C, rt, m)
    _back_project(J, m, r, rt, g, k_null, out, null)
    return True


@kernel
def finite_inputs(q, J, xd):
    """Which of ``q``, ``J``, ``xd`` is the first to hold a NaN or an infinity (1, 2, 3),
    else 4 if ``xd`` has an entry beyond ``±MAX_TASK_RATE``, else 0:
    :meth:`redres.resolution.Scheme.step`'s check in one call."""
    if not _finite_1d(q):
        return 1
    if not _finite_2d(J):
        return 2
    if not _finite_1d(xd):
        return 3
    if not _bounded_1d(xd, MAX_TASK_RATE):
        return 4
    return 0


@kernel
def step(J, xd, grad, out, null, k_null, damping, rcond):
    """Unweighted rate step with fixed damping (0: exact) into ``out`` (the fast lane).

    ``qd = J# xd - k_null (I - J# J) grad``; ``grad`` of length 0 means no secondary
    objective; ``null`` of length n receives the secondary part (length 0: not wanted).
    Scalars are checked here (any fault: ``SCALAR_INVALID``). Returns
    ``(status, rank, full_rank, sigma_min, sigma_max, damping, mode)``.
    """
    m, n = J.shape
    if m == 0 or n == 0:
        return J_EMPTY, 0, False, 0.0, 0.0, 0.0, EXACT
    # x * 0 is NaN exactly for NaN or infinity (a sum that overflows is refused too: the
    # caller's general path then accepts it)
    if (k_null + damping + rcond) * 0.0 != 0.0 or not (damping >= 0.0 and rcond >= 0.0):
        return SCALAR_INVALID, 0, False, 0.0, 0.0, 0.0, EXACT
    mode = FIXED if damping > 0.0 else EXACT
    status, rank, smin, smax, used = _step(
        J, xd, grad, out, null, k_null, NO_WEIGHTS, xd[:0], J[:0, :0], mode, damping, 0.0, 1.0,
        rcond,
    )  # fmt: skip
    return status, rank, rank == min(m, n), smin, smax, used, mode


@kernel
def inverse(J, wdiag, W, Jp, N, Lam, wmode, dmode, lam, lam_max, eps, rcond):
    """Fill ``Jp`` (n x m) with J#, ``N`` (n x n) with I - J# J and ``Lam`` (m x m) with
    ``(J W^-1 J^T + lam^2 I)^-1`` (the task-space inertia for ``W = M``; its filtered
    pseudo-inverse when J W^-1/2 is rank-deficient and undamped); any may be 0 x 0.

    Returns ``(status, rank, sigma_min, sigma_max, damping)``.
    """
    m, n = J.shape
    want_pinv = Jp.shape[0] > 0
    want_projector = N.shape[0] > 0
    want_inertia = Lam.shape[0] > 0
    Js, mats, Lw, vec = _step_scratch(m, n, wmode)
    X = np.empty((m, n))
    C = mats[0]
    col = vec[:m]
    dvec = vec[m : 2 * m]
    scratch = vec[3 * m : 7 * m]
    if not _copy_finite_2d(J, Js):
        return J_NONFINITE, 0, 0.0, 0.0, 0.0
    status = _weigh(Js, wmode, wdiag, W, Lw)
    if status != OK:
        return status, 0, 0.0, 0.0, 0.0
    scale = _scale(Js)
    if scale == 0.0:
        for a in range(Jp.shape[0]):
            for b in range(Jp.shape[1]):
                Jp[a, b] = 0.0
        for a in range(N.shape[0]):
            for b in range(n):
                N[a, b] = 1.0 if a == b else 0.0
        lam_used = lam if dmode == FIXED or dmode == LAZY else (lam_max if dmode != EXACT else 0.0)
        for a in range(Lam.shape[0]):  # (0 + lam^2 I)^-1, or the pseudo-inverse 0
            for b in range(m):
                Lam[a, b] = 1.0 / (lam_used * lam_used) if a == b and lam_used > 0.0 else 0.0
        return OK, 0, 0.0, 0.0, lam_used
    use_chol, rank, smin, smax, lam_used = _core(
        Js, scale, dmode, lam, lam_max, eps, rcond, mats, dvec, scratch
    )
    if want_inertia:
        _inertia(C, dvec, use_chol, scale, Lam)
    # X = (Js Js^T + lam^2)^-1 Js (Cholesky) or diag(d) B (SVD, Js holds B), so that
    # J# J = Js^T X and J# = X^T / s (Cholesky) or X^T G / s (SVD).
    for j in range(n):
        if use_chol:
            for i in range(m):
                col[i] = Js[i, j]
            _cholesky_solve(C, col, m)
            for i in range(m):
                X[i, j] = col[i]
        else:
            for i in range(m):
                X[i, j] = dvec[i] * Js[i, j]
    inv_scale = 1.0 / scale
    if want_pinv:
        for j in range(n):
            for i in range(m):
                if use_chol:
                    Jp[j, i] = X[i, j] * inv_scale
                else:
                    acc = 0.0
                    for p in range(m):
                        acc += X[p, j] * C[p, i]
                    Jp[j, i] = acc * inv_scale
        if wmode != NO_WEIGHTS:
            for i in range(m):
                _weight_down(Jp[:, i], wmode, Lw)
    if want_projector:
        for a in range(n):
            for b in range(n):
                acc = 0.0
                for i in range(m):
                    acc += Js[i, a] * X[i, b]
                N[a, b] = -acc
            N[a, a] += 1.0
        if wmode != NO_WEIGHTS:
            # N_W = L^-T N L^T: columns through L^-T, then each row times L^T.
            for b in range(n):
                _weight_down(N[:, b], wmode, Lw)
            for a in range(n):
                _weight_up_row(N, a, wmode, Lw)
    return OK, rank, smin, smax, lam_used


@kernel
def _inertia(C, dvec, use_chol, scale, Lam):
    """``Lam <- (Js Js^T + lam^2)^-1 / s^2`` from :func:`_core`'s factors: ``C^-T C^-1``
    with C the Cholesky factor, or ``G^T diag(d) G`` with G the rotation of the SVD path
    (``Js Js^T = G^T diag(sigma^2) G``)."""
    m = C.shape[0]
    inv2 = 1.0 / (scale * scale)
    if use_chol:
        Linv = np.zeros((m, m))  # C^-1, lower triangular, by forward substitution
        for b in range(m):
            for i in range(b, m):
                acc = 1.0 if i == b else 0.0
                for k in range(b, i):
                    acc -= C[i, k] * Linv[k, b]
                Linv[i, b] = acc / C[i, i]
        for a in range(m):
            for b in range(a + 1):
                acc = 0.0
                for k in range(max(a, b), m):
                    acc += Linv[k, a] * Linv[k, b]
                Lam[a, b] = Lam[b, a] = acc * inv2
        return
    for a in range(m):
        for b in range(a + 1):
            acc = 0.0
            for k in range(m):
                acc += C[k, a] * dvec[k] * C[k, b]
            Lam[a, b] = Lam[b, a] = acc * inv2
