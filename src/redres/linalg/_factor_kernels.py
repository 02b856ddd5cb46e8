"""One factorisation of a weighted Jacobian (internal), the core of every compiled
inverse of :mod:`redres.linalg._kernels`: the extreme eigenvalues of the Gram matrix, then
a Cholesky solve when it is well conditioned or a one-sided Jacobi SVD when it is not
(:func:`_core`, :func:`_svd_core`), with the damping law (:func:`_damping_squared`).
:mod:`redres.linalg._kernels` describes the paths and their accuracy.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ._codes import (
    ADAPTIVE,
    FIXED,
    LAZY,
    SELECTIVE,
)
from ._dense_kernels import (
    _cholesky,
    _gram,
)
from ._eigen_kernels import _EPS, _count_below, _extreme_eigenvalues, _jacobi_rows, _tridiagonalize

# Below this ratio sigma_min / sigma_max, J J^T (kappa > 1e6) is too ill-conditioned for a
# Cholesky solve accurate to 2e-10 and its eigenvalues give sigma_min to less than that:
# switch to the Jacobi SVD of J itself.
_CHOLESKY_MIN_RATIO = 1e-3
# With a damping lambda^2 >= this times trace(J J^T) >= sigma_max^2, kappa(J J^T + lambda^2
# I) <= 1 + 1e6 without any eigenvalue: the same accuracy bound, straight to Cholesky.
_LAZY_MIN_SHIFT = 1e-6


@kernel
def _damping_squared(sigma, dmode, lam, lam_max, eps):
    """Damping lambda^2 for a singular value ``sigma`` (unscaled units): FIXED lam^2,
    ADAPTIVE / SELECTIVE the law of :class:`~redres.linalg.AdaptiveDamping`."""
    if dmode == FIXED:
        return lam * lam
    if dmode == ADAPTIVE or dmode == SELECTIVE:
        if sigma >= eps:
            return 0.0
        ratio = sigma / eps
        return lam_max * lam_max * (1.0 - ratio * ratio)
    return 0.0


@kernel
def _core(Js, scale, dmode, lam, lam_max, eps, rcond, mats, dvec, work):
    """Factor the inverse of the scaled matrix Js (m x n).

    Returns ``(use_cholesky, rank, sigma_min, sigma_max, damping)``:

    * ``use_cholesky``: C holds the lower Cholesky factor of ``Js Js^T + lam'^2 I`` and
      ``J# = Js^T C^-T C^-1 / s``;
    * otherwise Js is overwritten with ``B = G Js`` (orthogonal rows ``sigma_i v_i^T``), C
      with the rotation ``G`` and ``dvec`` with the filter ``d``: ``J# = B^T diag(d) G / s``
      and ``J# J = B^T diag(d) B``, ``d_i = 1 / (sigma_i^2 + lam_i^2)``, or, undamped,
      ``1 / sigma_i^2`` above the rank tolerance and 0 below. Using B itself, not ``G Js``,
      keeps the tiny rows of the near-singular directions accurate to their own size.

    ``C`` is ``mats[0]``; ``mats`` (3, m, m) and ``work`` (at least ``4 m`` floats) are
    scratch space (rows of a 3-D array rather than reshaped slices of one vector: a
    reshape costs more than a 6 x 6 Cholesky factorisation); ``dvec`` has length m.
    Singular values and damping are in the units of the unscaled matrix. ``LAZY``
    damping is ``FIXED`` that may skip the eigenvalues: rank -1 and NaN singular values
    when it does (:data:`_LAZY_MIN_SHIFT`).
    """
    m, n = Js.shape
    kmin = min(m, n)
    C = mats[0]
    A = mats[1]
    T = mats[2]
    mu = work[:m]
    off = work[m : 2 * m]
    v = work[2 * m : 3 * m]
    p = work[3 * m : 4 * m]
    _gram(Js, m, A)
    trace = 0.0
    for i in range(m):
        trace += A[i, i]
    if dmode == LAZY:  # fixed damping, no singular values wanted
        shift = lam * lam / (scale * scale)
        if shift >= _LAZY_MIN_SHIFT * trace and _cholesky(A, C, m, shift):
            return True, -1, math.nan, math.nan, lam
        dmode = FIXED
    for i in range(m):
        for j in range(i + 1):
            T[i, j] = A[i, j]
    _tridiagonalize(T, m, mu, off, v, p)
    lowest, highest = _extreme_eigenvalues(mu, off, m, True)
    smax_s = math.sqrt(max(highest, 0.0))
    smin_s = math.sqrt(max(lowest, 0.0)) if kmin == m else 0.0
    lam2 = _damping_squared(smin_s * scale, dmode, lam, lam_max, eps)
    exact = lam2 == 0.0
    use_cholesky = (
        kmin == m
        and smin_s >= _CHOLESKY_MIN_RATIO * smax_s
        and not (exact and smin_s <= rcond * smax_s)
        and not (dmode == SELECTIVE and not exact)
    )
    if use_cholesky:
        shift = lam2 / (scale * scale)
        if _cholesky(A, C, m, shift):
            rank = m
            if smin_s <= rcond * smax_s:  # only for rcond >= 1e-3: count like the SVD does
                tau = (rcond * smax_s) ** 2
                rank = m - _count_below(mu, off, m, tau * (1.0 + 4.0 * _EPS))
            return True, rank, smin_s * scale, smax_s * scale, math.sqrt(lam2)
    return _svd_core(Js, scale, dmode, lam, lam_max, eps, rcond, C, dvec)


@kernel
def _svd_core(Js, scale, dmode, lam, lam_max, eps, rcond, C, dvec):
    """Near-singular branch of :func:`_core`: one-sided Jacobi SVD of ``[Js | I]``."""
    m, n = Js.shape
    kmin = min(m, n)
    R = np.zeros((m, n + m))
    for i in range(m):
        for j in range(n):
            R[i, j] = Js[i, j]
        R[i, n + i] = 1.0
    _jacobi_rows(R, m, n)
    sig = np.empty(m)
    order = np.empty(m, dtype=np.int64)
    for i in range(m):
        acc = 0.0
        for j in range(n):
            Js[i, j] = R[i, j]
            acc += R[i, j] * R[i, j]
        for j in range(m):
            C[i, j] = R[i, n + j]
        sig[i] = math.sqrt(acc)
        order[i] = i
    for i in range(1, m):  # indices sorted by descending singular value
        key = order[i]
        j = i - 1
        while j >= 0 and sig[order[j]] < sig[key]:
            order[j + 1] = order[j]
            j -= 1
        order[j + 1] = key
    smax_s = sig[order[0]]
    smin_s = sig[order[kmin - 1]]
    used = 0.0
    rank = 0
    for pos in range(m):
        i = order[pos]
        if dmode == SELECTIVE:
            li2 = _damping_squared(sig[i] * scale, dmode, lam, lam_max, eps)
        else:
            li2 = _damping_squared(smin_s * scale, dmode, lam, lam_max, eps)
        used = max(used, li2)
        li2_s = li2 / (scale * scale)
        significant = pos < kmin and sig[i] > rcond * smax_s
        if significant:
            rank += 1
        denom = sig[i] * sig[i] + li2_s
        dvec[i] = 0.0
        if li2 > 0.0 and denom > 0.0:
            dvec[i] = 1.0 / denom
        elif significant:
            dvec[i] = 1.0 / (sig[i] * sig[i])
    return False, rank, smin_s * scale, smax_s * scale, math.sqrt(used)
