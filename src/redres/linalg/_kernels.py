"""Compiled kernels for the small matrices of robotics (internal).

The public functions of :mod:`redres.linalg` call these for ``m <= 6`` task rows and
``n <= 50`` joints. This module imports numba, so it is imported lazily (by
:mod:`redres.linalg._backend`) on the first call that needs it: ``import redres`` never pays
for numba. The kernels are compiled on first use and cached on disk next to this file (or
in numba's user-wide cache directory); where no cache location is writable, they are
compiled in memory instead.

Every kernel works on a *scaled, weighted* Jacobian ``Js = J W^{-1/2} / s`` with ``s`` its
largest absolute entry, so that ``Js Js^T`` neither overflows nor underflows. Whatever the
inverse (exact, damped, adaptively damped, weighted), it is written
``J# = W^{-1/2} Js^T S / s`` with an ``m x m`` symmetric *core* ``S``:

* well-conditioned case (``sigma_min >= 1e-4 sigma_max``), ``S = (Js Js^T + lam'^2 I)^-1``,
  used through its Cholesky factor — a few hundred flops;
* near-singular case, ``S = G^T diag(d) G`` from a one-sided Jacobi SVD of ``Js``
  (Hestenes 1958), whose singular values are accurate even when tiny. ``d_i`` is
  ``1 / (sigma_i^2 + lam_i^2)``, or ``1 / sigma_i^2`` above the rank tolerance and ``0``
  below it when no damping applies.

Status codes (returned first by each kernel, turned into errors by the caller) name the
offending argument; the kernels never raise.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

from ._codes import (
    ADAPTIVE,
    DIAGONAL,
    EXACT,
    FIXED,
    FULL,
    GRAD_NONFINITE,
    GRAD_SHAPE,
    J_NONFINITE,
    NO_WEIGHTS,
    OK,
    SELECTIVE,
    W_ASYMMETRIC,
    W_NONFINITE,
    W_NOT_SPD,
    W_SHAPE,
    XD_NONFINITE,
    XD_SHAPE,
)

# Below this ratio sigma_min / sigma_max the Gram matrix J J^T is too ill-conditioned for a
# Cholesky solve (kappa(J J^T) > 1e8) and its eigenvalues give sigma_min to less than
# ~1e-8 relative accuracy: switch to the Jacobi SVD of J itself.
_CHOLESKY_MIN_RATIO = 1e-4
_EPS = 2.220446049250313e-16
_SYMMETRY_RTOL = 1e-9


def _jit(func: Callable[..., Any]) -> Any:
    """Compile ``func`` with numba, cached on disk when a cache location is writable."""
    try:
        return numba.njit(cache=True, nogil=True, error_model="numpy")(func)
    except RuntimeError:  # no writable cache directory (read-only install)
        return numba.njit(cache=False, nogil=True, error_model="numpy")(func)


@_jit
def _finite_1d(a):  # type: ignore[no-untyped-def]
    for i in range(a.shape[0]):
        if not math.isfinite(a[i]):
            return False
    return True


@_jit
def _finite_2d(a):  # type: ignore[no-untyped-def]
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not math.isfinite(a[i, j]):
                return False
    return True


@_jit
def _cholesky(A, L, size, shift):  # type: ignore[no-untyped-def]
    """Lower Cholesky factor of ``A + shift I`` (lower triangle of A read) into L.

    Returns False if a pivot is not positive (the matrix is not positive definite).
    """
    for j in range(size):
        acc = A[j, j] + shift
        for k in range(j):
            acc -= L[j, k] * L[j, k]
        if not acc > 0.0:
            return False
        ljj = math.sqrt(acc)
        L[j, j] = ljj
        for i in range(j + 1, size):
            acc = A[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            L[i, j] = acc / ljj
        for i in range(j):
            L[i, j] = 0.0
    return True


@_jit
def _cholesky_solve(L, b, size):  # type: ignore[no-untyped-def]
    """Solve ``L L^T x = b`` in place of ``b``."""
    for i in range(size):
        acc = b[i]
        for k in range(i):
            acc -= L[i, k] * b[k]
        b[i] = acc / L[i, i]
    for i in range(size - 1, -1, -1):
        acc = b[i]
        for k in range(i + 1, size):
            acc -= L[k, i] * b[k]
        b[i] = acc / L[i, i]


@_jit
def _tridiagonalize(A, size, d, e, v, p):  # type: ignore[no-untyped-def]
    """Householder reduction of the symmetric A (destroyed) to tridiagonal (d, e).

    ``d[i]`` is the diagonal and ``e[i]`` the entry (i+1, i) of ``Q^T A Q`` (Golub &
    Van Loan, Matrix Computations, 4th ed., Alg. 8.3.1). ``v``, ``p``: scratch of ``size``.
    """
    for k in range(size - 2):
        # Householder vector of x = A[k+1:, k], so that H x = alpha e_1.
        norm2 = 0.0
        for i in range(k + 1, size):
            norm2 += A[i, k] * A[i, k]
        d[k] = A[k, k]
        if norm2 == 0.0:
            e[k] = 0.0
            continue
        alpha = math.sqrt(norm2)
        if A[k + 1, k] > 0.0:
            alpha = -alpha
        vnorm2 = 0.0
        for i in range(k + 1, size):
            v[i] = A[i, k]
        v[k + 1] -= alpha
        for i in range(k + 1, size):
            vnorm2 += v[i] * v[i]
        beta = 2.0 / vnorm2
        # Trailing block S <- H S H = S - v w^T - w v^T with p = beta S v,
        # w = p - (beta/2)(p.v) v.
        pv = 0.0
        for i in range(k + 1, size):
            acc = 0.0
            for j in range(k + 1, size):
                acc += A[i, j] * v[j]
            p[i] = beta * acc
            pv += p[i] * v[i]
        half = 0.5 * beta * pv
        for i in range(k + 1, size):
            p[i] -= half * v[i]
        for i in range(k + 1, size):
            for j in range(k + 1, size):
                A[i, j] -= v[i] * p[j] + p[i] * v[j]
        e[k] = alpha
    if size >= 2:
        d[size - 2] = A[size - 2, size - 2]
        e[size - 2] = A[size - 1, size - 2]
    d[size - 1] = A[size - 1, size - 1]



@_jit
def _charpoly(d, e, lo, hi, x):  # type: ignore[no-untyped-def]
    """``p(x), p'(x), p''(x)`` for ``p = det(T - x I)`` of the block ``lo..hi`` of (d, e).

    Three-term recurrence of the leading principal minors (the Sturm sequence).
    """
    p0 = 1.0
    d0 = 0.0
    dd0 = 0.0
    p1 = d[lo] - x
    d1 = -1.0
    dd1 = 0.0
    for k in range(lo + 1, hi + 1):
        t = d[k] - x
        b2 = e[k - 1] * e[k - 1]
        p2 = t * p1 - b2 * p0
        d2 = t * d1 - p1 - b2 * d0
        dd2 = t * dd1 - 2.0 * d1 - b2 * dd0
        p0, d0, dd0 = p1, d1, dd1
        p1, d1, dd1 = p2, d2, dd2
    return p1, d1, dd1


@_jit
def _laguerre_step(d, e, lo, hi, x):  # type: ignore[no-untyped-def]
    """One Laguerre step ``x -> x - step`` on ``det(T - x I)`` of the block; 0 at a root."""
    degree = hi - lo + 1
    p, dp, ddp = _charpoly(d, e, lo, hi, x)
    if p == 0.0:
        return 0.0
    G = dp / p
    H = G * G - ddp / p
    disc = (degree - 1) * (degree * H - G * G)
    root = math.sqrt(disc) if disc > 0.0 else 0.0
    den = G - root if G < 0.0 else G + root
    if den == 0.0:
        return 0.0
    return degree / den


@_jit
def _laguerre_pair(d, e, lo, hi, below, above):  # type: ignore[no-untyped-def]
    """Smallest and largest eigenvalue of an unreduced tridiagonal block (Laguerre).

    Started outside the spectrum (``below`` under it, ``above`` over it), Laguerre's
    iteration on a polynomial with real roots moves monotonically to the nearest root,
    cubically for the simple roots of an unreduced block (Wilkinson, The Algebraic
    Eigenvalue Problem, 1965, ch. 7). Both searches run in one loop so that the processor
    can overlap their dependency chains. Each stops when rounding turns its step back.
    """
    low_done = False
    high_done = False
    for _ in range(60):
        if not low_done:
            x = below - _laguerre_step(d, e, lo, hi, below)
            if x <= below:
                low_done = True
            else:
                below = x
        if not high_done:
            x = above - _laguerre_step(d, e, lo, hi, above)
            if x >= above:
                high_done = True
            else:
                above = x
        if low_done and high_done:
            break
    return below, above


@_jit
def _extreme_eigenvalues(d, e, size, nonnegative):  # type: ignore[no-untyped-def]
    """Smallest and largest eigenvalue of the symmetric tridiagonal (d, e).

    The matrix is split where an off-diagonal entry is negligible; each unreduced block is
    started from its Gershgorin bounds, tightened to ``[-1e-12, 1] ||T||_F`` when the
    caller knows the matrix is positive semi-definite up to rounding (a Gram matrix, whose
    eigenvalues are perturbed by far less than ``1e-12 ||T||``).
    """
    frobenius2 = 0.0
    for i in range(size):
        frobenius2 += d[i] * d[i]
        if i < size - 1:
            frobenius2 += 2.0 * e[i] * e[i]
    frobenius = math.sqrt(frobenius2)
    lo = 0
    smallest = math.inf
    largest = -math.inf
    while lo < size:
        hi = lo
        while hi < size - 1 and abs(e[hi]) > _EPS * (abs(d[hi]) + abs(d[hi + 1])):
            hi += 1
        if hi == lo:
            smallest = min(smallest, d[lo])
            largest = max(largest, d[lo])
        else:
            below = math.inf
            above = -math.inf
            for i in range(lo, hi + 1):
                radius = 0.0
                if i > lo:
                    radius += abs(e[i - 1])
                if i < hi:
                    radius += abs(e[i])
                below = min(below, d[i] - radius)
                above = max(above, d[i] + radius)
            if nonnegative:  # a Gram matrix: the spectrum lies in [-rounding, ||T||_F]
                below = max(below, -1e-12 * frobenius)
                above = min(above, frobenius * (1.0 + 1e-12))
            low, high = _laguerre_pair(d, e, lo, hi, below, above)
            smallest = min(smallest, low)
            largest = max(largest, high)
        lo = hi + 1
    return smallest, largest


@_jit
def _count_below(d, e, size, tau):  # type: ignore[no-untyped-def]
    """Number of eigenvalues of the tridiagonal (d, e) below ``tau`` (Sylvester inertia)."""
    count = 0
    q = 1.0
    for k in range(size):
        b2 = e[k - 1] * e[k - 1] if k > 0 else 0.0
        q = d[k] - tau - (b2 / q if k > 0 else 0.0)
        if q == 0.0:
            q = -_EPS * (abs(d[k]) + abs(tau) + 1e-300)
        if q < 0.0:
            count += 1
    return count


@_jit
def _jacobi_rows(R, m, n):  # type: ignore[no-untyped-def]
    """One-sided Jacobi (Hestenes): rotate the rows of R until R[:, :n] has orthogonal rows.

    Every column of R is rotated, so extra columns carry the accumulated rotation G.
    """
    width = R.shape[1]
    for _sweep in range(60):
        rotated = False
        for p in range(m - 1):
            for q in range(p + 1, m):
                a = 0.0
                b = 0.0
                c = 0.0
                for j in range(n):
                    x = R[p, j]
                    y = R[q, j]
                    a += x * x
                    b += y * y
                    c += x * y
                if c == 0.0 or abs(c) <= 1e-15 * math.sqrt(a * b):
                    continue
                rotated = True
                zeta = (b - a) / (2.0 * c)
                t = 1.0 / (abs(zeta) + math.sqrt(1.0 + zeta * zeta))
                if zeta < 0.0:
                    t = -t
                cs = 1.0 / math.sqrt(1.0 + t * t)
                sn = cs * t
                for j in range(width):
                    x = R[p, j]
                    y = R[q, j]
                    R[p, j] = cs * x - sn * y
                    R[q, j] = sn * x + cs * y
        if not rotated:
            break


@_jit
def _damping_squared(sigma, dmode, lam, lam_max, eps):  # type: ignore[no-untyped-def]
    """Damping lambda^2 for a singular value ``sigma`` (unscaled units).

    FIXED: lam^2. ADAPTIVE / SELECTIVE: lam_max^2 (1 - (sigma/eps)^2) below eps, else 0
    (Chiaverini, Siciliano & Egeland 1994; Maciejewski & Klein 1988).
    """
    if dmode == FIXED:
        return lam * lam
    if dmode == ADAPTIVE or dmode == SELECTIVE:
        if sigma >= eps:
            return 0.0
        ratio = sigma / eps
        return lam_max * lam_max * (1.0 - ratio * ratio)
    return 0.0


@_jit
def _core(Js, scale, dmode, lam, lam_max, eps, rcond, C, work):  # type: ignore[no-untyped-def]
    """Build the core of the inverse of the scaled matrix Js (m x n) into C (m x m).

    Returns ``(use_cholesky, rank, sigma_min, sigma_max, damping)``: with ``use_cholesky``
    C holds the lower Cholesky factor of ``Js Js^T + lam'^2 I``, else C holds S itself.
    Singular values and damping are in the units of the unscaled matrix. ``work`` is
    scratch space of at least ``2 m^2 + 4 m`` floats.
    """
    m, n = Js.shape
    kmin = min(m, n)
    A = work[: m * m].reshape((m, m))
    T = work[m * m : 2 * m * m].reshape((m, m))
    base = 2 * m * m
    mu = work[base : base + m]
    off = work[base + m : base + 2 * m]
    v = work[base + 2 * m : base + 3 * m]
    p = work[base + 3 * m : base + 4 * m]
    # Gram matrix, lower triangle; the innermost loop runs over independent entries.
    for i in range(m):
        for j in range(i + 1):
            A[i, j] = 0.0
        for k in range(n):
            a = Js[i, k]
            for j in range(i + 1):
                A[i, j] += a * Js[j, k]
        for j in range(i + 1):
            T[i, j] = A[i, j]
            T[j, i] = A[i, j]
            A[j, i] = A[i, j]
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
            if smin_s <= rcond * smax_s:  # only for rcond >= 1e-4: count like the SVD does
                tau = (rcond * smax_s) ** 2
                rank = m - _count_below(mu, off, m, tau * (1.0 + 4.0 * _EPS))
            return True, rank, smin_s * scale, smax_s * scale, math.sqrt(lam2)
    return _svd_core(Js, scale, dmode, lam, lam_max, eps, rcond, C)


@_jit
def _svd_core(Js, scale, dmode, lam, lam_max, eps, rcond, C):  # type: ignore[no-untyped-def]
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
    dvec = np.zeros(m)
    order = np.empty(m, dtype=np.int64)
    for i in range(m):
        acc = 0.0
        for j in range(n):
            acc += R[i, j] * R[i, j]
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
        if li2 > 0.0 and denom > 0.0:
            dvec[i] = 1.0 / denom
        elif significant:
            dvec[i] = 1.0 / (sig[i] * sig[i])
    # S = G^T diag(d) G with G = R[:, n:].
    for a in range(m):
        for b in range(a + 1):
            acc = 0.0
            for i in range(m):
                acc += R[i, n + a] * dvec[i] * R[i, n + b]
            C[a, b] = acc
            C[b, a] = acc
    return False, rank, smin_s * scale, smax_s * scale, math.sqrt(used)


@_jit
def _copy_finite_2d(src, dst):  # type: ignore[no-untyped-def]
    """dst <- src; False if src has a NaN or an infinity (x * 0 is NaN exactly then)."""
    bad = 0.0
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            x = src[i, j]
            bad += x * 0.0
            dst[i, j] = x
    return bad == 0.0


@_jit
def _weigh(Js, wmode, wdiag, W, Lw):  # type: ignore[no-untyped-def]
    """Js <- Js W^{-1/2} (diagonal) or Js L^-T (full, W = L L^T into Lw), in place; status."""
    m, n = Js.shape
    if wmode == NO_WEIGHTS:
        return OK
    if wmode == DIAGONAL:
        if wdiag.shape[0] != n:
            return W_SHAPE
        if not _finite_1d(wdiag):
            return W_NONFINITE
        for j in range(n):
            if not wdiag[j] > 0.0:
                return W_NOT_SPD
            Lw[j, 0] = math.sqrt(wdiag[j])
        for i in range(m):
            for j in range(n):
                Js[i, j] /= Lw[j, 0]
        return OK
    if W.shape[0] != n or W.shape[1] != n:
        return W_SHAPE
    if not _finite_2d(W):
        return W_NONFINITE
    biggest = 0.0
    for i in range(n):
        for j in range(n):
            biggest = max(biggest, abs(W[i, j]))
    for i in range(n):
        for j in range(i):
            if abs(W[i, j] - W[j, i]) > _SYMMETRY_RTOL * biggest:
                return W_ASYMMETRIC
    if not _cholesky(W, Lw, n, 0.0):
        return W_NOT_SPD
    for i in range(m):  # row i of J L^-T is L^-1 (row i of J)^T: forward substitution
        for j in range(n):
            acc = Js[i, j]
            for k in range(j):
                acc -= Lw[j, k] * Js[i, k]
            Js[i, j] = acc / Lw[j, j]
    return OK


@_jit
def _scale(Js):  # type: ignore[no-untyped-def]
    m, n = Js.shape
    s = 0.0
    for i in range(m):
        for j in range(n):
            s = max(s, abs(Js[i, j]))
    if s > 0.0:
        inv = 1.0 / s
        for i in range(m):
            for j in range(n):
                Js[i, j] *= inv
    return s


@_jit
def _weight_up(v, wmode, Lw):  # type: ignore[no-untyped-def]
    """v <- W^{1/2}-side map L^T v (diagonal: sqrt(w) v), in place."""
    n = v.shape[0]
    if wmode == DIAGONAL:
        for j in range(n):
            v[j] *= Lw[j, 0]
    elif wmode == FULL:
        for j in range(n):
            acc = 0.0
            for k in range(j, n):
                acc += Lw[k, j] * v[k]
            v[j] = acc


@_jit
def _weight_down(v, wmode, Lw):  # type: ignore[no-untyped-def]
    """v <- L^-T v (diagonal: v / sqrt(w)), in place."""
    n = v.shape[0]
    if wmode == DIAGONAL:
        for j in range(n):
            v[j] /= Lw[j, 0]
    elif wmode == FULL:
        for j in range(n - 1, -1, -1):
            acc = v[j]
            for k in range(j + 1, n):
                acc -= Lw[k, j] * v[k]
            v[j] = acc / Lw[j, j]


@_jit
def _factor_storage(n, wmode):  # type: ignore[no-untyped-def]
    """Storage for the weight factor: n x n (full), n x 1 (diagonal) or 0 x 0."""
    if wmode == FULL:
        return np.empty((n, n))
    if wmode == DIAGONAL:
        return np.empty((n, 1))
    return np.empty((0, 0))


@_jit
def _step(J, xd, grad, out, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    m, n = J.shape
    has_grad = grad.shape[0] > 0
    if xd.shape[0] != m:
        return XD_SHAPE, 0, 0.0, 0.0, 0.0
    if has_grad and grad.shape[0] != n:
        return GRAD_SHAPE, 0, 0.0, 0.0, 0.0
    work = np.empty(m * n + 3 * m * m + 6 * m + n)
    Js = work[: m * n].reshape((m, n))
    C = work[m * n : m * n + m * m].reshape((m, m))
    base = m * n + m * m
    r = work[base : base + m]
    g = work[base + m : base + m + n]
    scratch = work[base + m + n :]
    if not _copy_finite_2d(J, Js):
        return J_NONFINITE, 0, 0.0, 0.0, 0.0
    if not _finite_1d(xd):
        return XD_NONFINITE, 0, 0.0, 0.0, 0.0
    bad = 0.0
    for j in range(n):
        x = grad[j] if has_grad else 0.0
        bad += x * 0.0
        g[j] = x
    if bad != 0.0:
        return GRAD_NONFINITE, 0, 0.0, 0.0, 0.0
    Lw = _factor_storage(n, wmode)
    status = _weigh(Js, wmode, wdiag, W, Lw)
    if status != OK:
        return status, 0, 0.0, 0.0, 0.0
    if has_grad:  # g = W^{1/2} grad (weighted coordinates)
        _weight_up(g, wmode, Lw)
    scale = _scale(Js)
    if scale == 0.0:  # J = 0: J# = 0, N = I
        lam_used = lam if dmode == FIXED else (lam_max if dmode != EXACT else 0.0)
        for j in range(n):
            out[j] = -k_null * g[j]
        _weight_down(out, wmode, Lw)
        return OK, 0, 0.0, 0.0, lam_used
    use_chol, rank, smin, smax, lam_used = _core(
        Js, scale, dmode, lam, lam_max, eps, rcond, C, scratch
    )
    # qd = Js^T S (xd / s + k Js g) - k g, then back to joint coordinates.
    inv_scale = 1.0 / scale
    for i in range(m):
        r[i] = 0.0
    if has_grad:
        for j in range(n):
            gj = g[j]
            for i in range(m):
                r[i] += Js[i, j] * gj
    for i in range(m):
        r[i] = xd[i] * inv_scale + k_null * r[i]
    if use_chol:
        _cholesky_solve(C, r, m)
    else:
        y = np.empty(m)
        for i in range(m):
            acc = 0.0
            for k in range(m):
                acc += C[i, k] * r[k]
            y[i] = acc
        for i in range(m):
            r[i] = y[i]
    for j in range(n):
        out[j] = -k_null * g[j]
    for i in range(m):
        ri = r[i]
        for j in range(n):
            out[j] += Js[i, j] * ri
    _weight_down(out, wmode, Lw)
    return OK, rank, smin, smax, lam_used


@_jit
def step(J, xd, grad, out, k_null, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """Unweighted rate step into ``out``: ``qd = J# xd - k_null (I - J# J) grad``.

    ``grad`` of length 0 means no secondary objective. Returns
    ``(status, rank, sigma_min, sigma_max, damping)``.
    """
    return _step(
        J, xd, grad, out, k_null, NO_WEIGHTS, xd[:0], J[:0, :0], dmode, lam, lam_max, eps, rcond
    )


@_jit
def step_diagonal(J, xd, grad, w, out, k_null, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """:func:`step` with diagonal joint weights ``w`` (n,)."""
    return _step(
        J, xd, grad, out, k_null, DIAGONAL, w, J[:0, :0], dmode, lam, lam_max, eps, rcond
    )


@_jit
def step_full(J, xd, grad, W, out, k_null, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """:func:`step` with a full SPD joint weight matrix ``W`` (n, n)."""
    return _step(J, xd, grad, out, k_null, FULL, xd[:0], W, dmode, lam, lam_max, eps, rcond)


@_jit
def inverse(J, wdiag, W, Jp, N, wmode, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """Fill ``Jp`` (n x m) with J# and ``N`` (n x n) with I - J# J; either may be 0 x 0.

    Returns ``(status, rank, sigma_min, sigma_max, damping)``.
    """
    m, n = J.shape
    want_pinv = Jp.shape[0] > 0
    want_projector = N.shape[0] > 0
    work = np.empty(2 * m * n + 3 * m * m + 5 * m)
    Js = work[: m * n].reshape((m, n))
    X = work[m * n : 2 * m * n].reshape((m, n))
    C = work[2 * m * n : 2 * m * n + m * m].reshape((m, m))
    col = work[2 * m * n + m * m : 2 * m * n + m * m + m]
    scratch = work[2 * m * n + m * m + m :]
    if not _copy_finite_2d(J, Js):
        return J_NONFINITE, 0, 0.0, 0.0, 0.0
    Lw = _factor_storage(n, wmode)
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
        lam_used = lam if dmode == FIXED else (lam_max if dmode != EXACT else 0.0)
        return OK, 0, 0.0, 0.0, lam_used
    use_chol, rank, smin, smax, lam_used = _core(
        Js, scale, dmode, lam, lam_max, eps, rcond, C, scratch
    )
    # X = S Js (m x n): the scaled inverse is Js^T S = X^T.
    for j in range(n):
        for i in range(m):
            col[i] = Js[i, j]
        if use_chol:
            _cholesky_solve(C, col, m)
            for i in range(m):
                X[i, j] = col[i]
        else:
            for i in range(m):
                acc = 0.0
                for k in range(m):
                    acc += C[i, k] * col[k]
                X[i, j] = acc
    inv_scale = 1.0 / scale
    if want_pinv:
        for j in range(n):
            for i in range(m):
                Jp[j, i] = X[i, j] * inv_scale
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


@_jit
def _weight_up_row(N, a, wmode, Lw):  # type: ignore[no-untyped-def]
    """Row a of N <- row a of (N L^T)."""
    n = N.shape[1]
    if wmode == DIAGONAL:
        for j in range(n):
            N[a, j] *= Lw[j, 0]
    elif wmode == FULL:
        # (N L^T)[a, j] = sum_k N[a, k] L[j, k], k <= j
        for j in range(n - 1, -1, -1):
            acc = 0.0
            for k in range(j + 1):
                acc += N[a, k] * Lw[j, k]
            N[a, j] = acc
