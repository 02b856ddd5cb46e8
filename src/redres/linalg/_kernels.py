"""Compiled kernels for the small matrices of robotics (internal).

The public functions of :mod:`redres.linalg` call these for ``m <= 6`` task rows (up to 12
when ``m <= n``) and ``n <= 50`` joints. This module imports numba, so it is imported lazily (by
:mod:`redres.linalg._backend`) on the first call that needs it: ``import redres`` never pays
for numba. The kernels are compiled on first use and cached on disk next to this file (or
in numba's user-wide cache directory); where no cache location is writable, they are
compiled in memory instead.

Every kernel works on a *weighted* Jacobian ``Js = J W^{-1/2}`` (``J L^-T`` for a full
``W = L L^T``), divided by its largest entry when that entry is outside ``[1e-100, 1e100]``
so that ``Js Js^T`` can neither overflow nor underflow. The extreme eigenvalues of the Gram
matrix ``A = Js Js^T`` (Householder tridiagonalisation, then Laguerre's method) give
``sigma_min`` and ``sigma_max``, hence the damping law, the rank and the choice of path:

* well conditioned (``sigma_min >= 1e-3 sigma_max``): ``J# = Js^T (A + lam^2 I)^-1`` by a
  Cholesky solve, a few hundred flops, accurate to ``kappa(A) eps <= 2e-10``; the Gram
  eigenvalues give ``sigma`` to about ``kappa(J)^2 eps <= 2e-10`` relative;
* near-singular: a one-sided Jacobi SVD (Hestenes 1958) of ``Js``, ``B = G Js`` with
  orthogonal rows ``sigma_i v_i^T``: ``J# = B^T diag(d) G`` and ``J# J = B^T diag(d) B``
  with ``d_i = 1 / (sigma_i^2 + lam_i^2)``, or ``1 / sigma_i^2`` above the rank tolerance
  and ``0`` below it when no damping applies. Its singular values are accurate even when
  tiny, so the rank and ``sigma_min`` reported near a singularity are those of the SVD.

Status codes (returned first by each kernel, turned into errors by the caller) name the
offending argument; the kernels never raise. The small helpers are inlined into the entry
kernels (``_inline``): calls between separately compiled numba functions cost more than
the few dozen flops each does. All compiled code lives in this one file on purpose: numba
invalidates its disk cache per source file, so a helper inlined from another file could
leave stale compiled code behind after an edit.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numba
import numpy as np

from ._codes import (
    ADAPTIVE,
    CFG_DAMPING,
    CFG_DT,
    CFG_GAIN,
    CFG_HAS_GRAD,
    CFG_K_NULL,
    CFG_LIMIT,
    CFG_MAX_DAMPING,
    CFG_MODE,
    CFG_POSITION,
    CFG_RCOND,
    CFG_ROTATION,
    CFG_THRESHOLD,
    CFG_TWIST,
    CFG_VECTORS,
    DAMPING_NEGATIVE,
    DAMPING_NONFINITE,
    DIAGONAL,
    EXACT,
    FIXED,
    FULL,
    GRAD_NONFINITE,
    GRAD_SHAPE,
    J_EMPTY,
    J_NONFINITE,
    K_NONFINITE,
    NO_WEIGHTS,
    OK,
    POSE_NONFINITE,
    Q_NONFINITE,
    Q_SHAPE,
    RCOND_NEGATIVE,
    RCOND_NONFINITE,
    SELECTIVE,
    W_ASYMMETRIC,
    W_NONFINITE,
    W_NOT_SPD,
    W_SHAPE,
    XD_NONFINITE,
    XD_SHAPE,
)

# Below this ratio sigma_min / sigma_max, J J^T (kappa > 1e6) is too ill-conditioned for a
# Cholesky solve accurate to 2e-10 and its eigenvalues give sigma_min to less than that:
# switch to the Jacobi SVD of J itself.
_CHOLESKY_MIN_RATIO = 1e-3
_EPS = 2.220446049250313e-16
_SYMMETRY_RTOL = 1e-9


def _jit(func: Callable[..., Any]) -> Any:
    """Compile ``func`` with numba, cached on disk when a cache location is writable."""
    return _compile(func, inline="never")


def _inline(func: Callable[..., Any]) -> Any:
    """Helpers called from several kernels. Numba IR inlining (``inline="always"``) saved
    ~0.35 µs per rate step but compiled every helper once per caller: ~50 s of JIT on a
    cold start instead of ~24 s. Cold start matters more (``redres demo`` < 60 s), so
    helpers are compiled once and called."""
    return _compile(func, inline="never")


def _compile(func: Callable[..., Any], inline: str) -> Any:
    njit: Callable[..., Any] = numba.njit
    options: dict[str, Any] = {"nogil": True, "error_model": "numpy", "inline": inline}
    try:
        return njit(cache=True, **options)(func)
    except RuntimeError:  # no writable cache directory (read-only install)
        return njit(cache=False, **options)(func)


@_inline
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


@_inline
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


@_inline
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


@_inline
def _tridiagonalize(A, size, d, e, v, p):  # type: ignore[no-untyped-def]
    """Householder reduction of the symmetric A (lower triangle, destroyed) to (d, e).

    ``d[i]`` is the diagonal and ``e[i]`` the entry (i+1, i) of ``Q^T A Q`` (Golub &
    Van Loan, Matrix Computations, 4th ed., Alg. 8.3.1). ``v``, ``p``: scratch of ``size``.
    """
    for k in range(size - 2):
        # Householder vector of x = A[k+1:, k], so that H x = alpha e_1. Only the lower
        # triangle of A is read and updated.
        norm2 = 0.0
        for i in range(k + 1, size):
            norm2 += A[i, k] * A[i, k]
        d[k] = A[k, k]
        if norm2 == 0.0:
            e[k] = 0.0
            continue
        x0 = A[k + 1, k]
        alpha = -math.sqrt(norm2) if x0 > 0.0 else math.sqrt(norm2)
        for i in range(k + 1, size):
            v[i] = A[i, k]
        v[k + 1] = x0 - alpha
        beta = 1.0 / (alpha * (alpha - x0))  # 2 / ||v||^2, ||v||^2 = 2 alpha (alpha - x0)
        # Trailing block S <- H S H = S - v w^T - w v^T with p = beta S v,
        # w = p - (beta/2)(p.v) v.
        pv = 0.0
        for i in range(k + 1, size):
            acc = 0.0
            for j in range(k + 1, i + 1):
                acc += A[i, j] * v[j]
            for j in range(i + 1, size):
                acc += A[j, i] * v[j]
            p[i] = beta * acc
            pv += p[i] * v[i]
        half = 0.5 * beta * pv
        for i in range(k + 1, size):
            p[i] -= half * v[i]
        for i in range(k + 1, size):
            vi = v[i]
            pi = p[i]
            for j in range(k + 1, i + 1):
                A[i, j] -= vi * p[j] + pi * v[j]
        e[k] = alpha
    if size >= 2:
        d[size - 2] = A[size - 2, size - 2]
        e[size - 2] = A[size - 1, size - 2]
    d[size - 1] = A[size - 1, size - 1]


@_inline
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


@_inline
def _laguerre_step(d, e, lo, hi, x):  # type: ignore[no-untyped-def]
    """One Laguerre step ``x -> x - step`` on ``det(T - x I)`` of the block; 0 at a root."""
    degree = hi - lo + 1
    p, dp, ddp = _charpoly(d, e, lo, hi, x)
    if p == 0.0:
        return 0.0
    inv_p = 1.0 / p
    G = dp * inv_p
    H = G * G - ddp * inv_p
    disc = (degree - 1) * (degree * H - G * G)
    root = math.sqrt(disc) if disc > 0.0 else 0.0
    den = G - root if G < 0.0 else G + root
    if den == 0.0:
        return 0.0
    return degree / den


@_inline
def _laguerre_pair(d, e, lo, hi, below, above):  # type: ignore[no-untyped-def]
    """Smallest and largest eigenvalue of an unreduced tridiagonal block (Laguerre).

    Started outside the spectrum (``below`` under it, ``above`` over it), Laguerre's
    iteration on a polynomial with real roots moves monotonically to the nearest root,
    cubically for the simple roots of an unreduced block (Wilkinson, The Algebraic
    Eigenvalue Problem, 1965, ch. 7). Both searches run in one loop so that the processor
    can overlap their dependency chains. Each stops when rounding turns its step back or
    when :func:`_converged` says the next step would be below rounding.
    """
    low_done = False
    high_done = False
    low_step = math.inf
    high_step = math.inf
    for _ in range(60):
        if not low_done:
            step = _laguerre_step(d, e, lo, hi, below)
            x = below - step
            if x <= below:
                low_done = True
            else:
                below = x
                low_done = _converged(step, low_step, x)
                low_step = abs(step)
        if not high_done:
            step = _laguerre_step(d, e, lo, hi, above)
            x = above - step
            if x >= above:
                high_done = True
            else:
                above = x
                high_done = _converged(step, high_step, x)
                high_step = abs(step)
        if low_done and high_done:
            break
    return below, above


@_inline
def _converged(step, previous, x):  # type: ignore[no-untyped-def]
    """True once a cubically converging iteration's next step is below rounding.

    A step under ``1e-6 |x|`` that is also under ``1e-3`` of the previous one shows the
    asymptotic (cubic) regime: the error left is about ``(1e-6)^3 |x|``. Slow, linear
    convergence (clustered roots) never passes the second test, so it goes on until
    rounding turns the step back.
    """
    size = abs(step)
    return size <= 1e-6 * abs(x) and size <= 1e-3 * previous


@_inline
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


@_inline
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


@_inline
def _core(Js, scale, dmode, lam, lam_max, eps, rcond, C, dvec, work):  # type: ignore[no-untyped-def]
    """Factor the inverse of the scaled matrix Js (m x n).

    Returns ``(use_cholesky, rank, sigma_min, sigma_max, damping)``:

    * ``use_cholesky``: C holds the lower Cholesky factor of ``Js Js^T + lam'^2 I`` and
      ``J# = Js^T C^-T C^-1 / s``;
    * otherwise Js is overwritten with ``B = G Js`` (orthogonal rows ``sigma_i v_i^T``), C
      with the rotation ``G`` and ``dvec`` with the filter ``d``: ``J# = B^T diag(d) G / s``
      and ``J# J = B^T diag(d) B``. Using B itself, not ``G Js``, keeps the tiny rows of the
      near-singular directions accurate to their own size.

    Singular values and damping are in the units of the unscaled matrix. ``work`` is
    scratch space of at least ``2 m^2 + 4 m`` floats; ``dvec`` has length m.
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
    for i in range(m):
        for j in range(i + 1):
            acc = 0.0
            for k in range(n):
                acc += Js[i, k] * Js[j, k]
            A[i, j] = acc
            T[i, j] = acc
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


@_jit
def _svd_core(Js, scale, dmode, lam, lam_max, eps, rcond, C, dvec):  # type: ignore[no-untyped-def]
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


@_inline
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


@_inline
def _scale(Js):  # type: ignore[no-untyped-def]
    """Largest absolute entry s of Js; Js is divided by s unless s is in [1e-100, 1e100].

    Returns the factor applied (1.0 when the entries are already safe to square and sum,
    0.0 for a zero matrix).
    """
    m, n = Js.shape
    s = 0.0
    for i in range(m):
        for j in range(n):
            s = max(s, abs(Js[i, j]))
    if s == 0.0:
        return 0.0
    if 1e-100 <= s <= 1e100:
        return 1.0
    inv = 1.0 / s
    for i in range(m):
        for j in range(n):
            Js[i, j] *= inv
    return s


@_inline
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


@_inline
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


@_inline
def _factor_size(n, wmode):  # type: ignore[no-untyped-def]
    """Floats needed for the weight factor: n x n (full), n (diagonal) or 0."""
    if wmode == FULL:
        return n * n
    if wmode == DIAGONAL:
        return n
    return 0


@_inline
def _factor_view(buffer, n, wmode):  # type: ignore[no-untyped-def]
    """The weight factor's storage carved from ``buffer``: (n, n), (n, 1) or (0, 0)."""
    if wmode == FULL:
        return buffer[: n * n].reshape((n, n))
    if wmode == DIAGONAL:
        return buffer[:n].reshape((n, 1))
    return buffer[:0].reshape((0, 0))


@_inline
def _step(J, xd, grad, out, null, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """``out <- J# xd - k_null (I - J# J) grad``; ``(status, rank, smin, smax, damping)``.

    When ``null`` has length n it receives the secondary part ``out - J# xd`` (the
    null-space term), from the same factorisation; pass a length-0 array otherwise.
    """
    m, n = J.shape
    has_grad = grad.shape[0] > 0
    want_null = null.shape[0] == n
    if xd.shape[0] != m:
        return XD_SHAPE, 0, 0.0, 0.0, 0.0
    if has_grad and grad.shape[0] != n:
        return GRAD_SHAPE, 0, 0.0, 0.0, 0.0
    fsize = _factor_size(n, wmode)
    work = np.empty(m * n + 3 * m * m + 8 * m + n + fsize)
    Lw = _factor_view(work[work.shape[0] - fsize :], n, wmode)
    Js = work[: m * n].reshape((m, n))
    C = work[m * n : m * n + m * m].reshape((m, m))
    base = m * n + m * m
    r = work[base : base + m]
    dvec = work[base + m : base + 2 * m]
    g = work[base + 2 * m : base + 2 * m + n]
    rt = work[base + 2 * m + n : base + 3 * m + n]
    scratch = work[base + 3 * m + n : work.shape[0] - fsize]
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
        if want_null:
            for j in range(n):
                null[j] = out[j]
        return OK, 0, 0.0, 0.0, lam_used
    use_chol, rank, smin, smax, lam_used = _core(
        Js, scale, dmode, lam, lam_max, eps, rcond, C, dvec, scratch
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
    for j in range(n):
        acc = -k_null * g[j]
        task = 0.0
        for i in range(m):
            acc += Js[i, j] * r[i]
            task += Js[i, j] * rt[i]
        out[j] = acc
        if want_null:
            null[j] = acc - task
    _weight_down(out, wmode, Lw)
    if want_null:
        _weight_down(null, wmode, Lw)
    return OK, rank, smin, smax, lam_used


@_jit
def step(J, xd, grad, out, null, k_null, damping, rcond):  # type: ignore[no-untyped-def]
    """Unweighted rate step with fixed damping (0: exact) into ``out`` (the fast lane).

    ``qd = J# xd - k_null (I - J# J) grad``; ``grad`` of length 0 means no secondary
    objective; ``null`` of length n receives the secondary part (length 0: not wanted).
    Scalars are validated here. Returns
    ``(status, rank, full_rank, sigma_min, sigma_max, damping, mode)``.
    """
    m, n = J.shape
    if m == 0 or n == 0:
        return J_EMPTY, 0, False, 0.0, 0.0, 0.0, EXACT
    if k_null * 0.0 != 0.0:
        return K_NONFINITE, 0, False, 0.0, 0.0, 0.0, EXACT
    if damping * 0.0 != 0.0:
        return DAMPING_NONFINITE, 0, False, 0.0, 0.0, 0.0, EXACT
    if damping < 0.0:
        return DAMPING_NEGATIVE, 0, False, 0.0, 0.0, 0.0, EXACT
    if rcond * 0.0 != 0.0:
        return RCOND_NONFINITE, 0, False, 0.0, 0.0, 0.0, EXACT
    if rcond < 0.0:
        return RCOND_NEGATIVE, 0, False, 0.0, 0.0, 0.0, EXACT
    mode = FIXED if damping > 0.0 else EXACT
    status, rank, smin, smax, used = _step(
        J, xd, grad, out, null, k_null, NO_WEIGHTS, xd[:0], J[:0, :0], mode, damping, 0.0, 1.0,
        rcond,
    )  # fmt: skip
    return status, rank, rank == min(m, n), smin, smax, used, mode


@_jit
def step_general(J, xd, grad, wdiag, W, out, null, k_null, wmode, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """Rate step with any weights and damping mode (scalars validated by the caller).

    ``wmode`` selects ``wdiag`` (n,) or ``W`` (n, n); the other may be empty; ``null`` as
    for :func:`step`. Returns ``(status, rank, sigma_min, sigma_max, damping)``.
    """
    m, n = J.shape
    if m == 0 or n == 0:
        return J_EMPTY, 0, 0.0, 0.0, 0.0
    return _step(J, xd, grad, out, null, k_null, wmode, wdiag, W, dmode, lam, lam_max, eps, rcond)


@_jit
def inverse(J, wdiag, W, Jp, N, Lam, wmode, dmode, lam, lam_max, eps, rcond):  # type: ignore[no-untyped-def]
    """Fill ``Jp`` (n x m) with J#, ``N`` (n x n) with I - J# J and ``Lam`` (m x m) with
    ``(J W^-1 J^T + lam^2 I)^-1`` (the task-space inertia for ``W = M``; its filtered
    pseudo-inverse when J W^-1/2 is rank-deficient and undamped); any may be 0 x 0.

    Returns ``(status, rank, sigma_min, sigma_max, damping)``.
    """
    m, n = J.shape
    want_pinv = Jp.shape[0] > 0
    want_projector = N.shape[0] > 0
    want_inertia = Lam.shape[0] > 0
    fsize = _factor_size(n, wmode)
    work = np.empty(2 * m * n + 3 * m * m + 6 * m + fsize)
    Lw = _factor_view(work[work.shape[0] - fsize :], n, wmode)
    Js = work[: m * n].reshape((m, n))
    X = work[m * n : 2 * m * n].reshape((m, n))
    C = work[2 * m * n : 2 * m * n + m * m].reshape((m, m))
    col = work[2 * m * n + m * m : 2 * m * n + m * m + m]
    dvec = work[2 * m * n + m * m + m : 2 * m * n + m * m + 2 * m]
    scratch = work[2 * m * n + m * m + 2 * m : work.shape[0] - fsize]
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
        lam_used = lam if dmode == FIXED else (lam_max if dmode != EXACT else 0.0)
        for a in range(Lam.shape[0]):  # (0 + lam^2 I)^-1, or the pseudo-inverse 0
            for b in range(m):
                Lam[a, b] = 1.0 / (lam_used * lam_used) if a == b and lam_used > 0.0 else 0.0
        return OK, 0, 0.0, 0.0, lam_used
    use_chol, rank, smin, smax, lam_used = _core(
        Js, scale, dmode, lam, lam_max, eps, rcond, C, dvec, scratch
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


@_jit
def _inertia(C, dvec, use_chol, scale, Lam):  # type: ignore[no-untyped-def]
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


@_inline
def _so3_log(M, out):  # type: ignore[no-untyped-def]
    """``out[:3] <- log(M)`` for a rotation matrix M: the rotation vector ``theta u``.

    ``theta = atan2(sin, cos)`` from the skew and trace parts, accurate at every angle;
    below ``cos = -0.9`` (``theta > 2.69``) the axis comes from the symmetric part
    ``(M + M^T)/2 - cos I = (1 - cos) u u^T`` (its largest diagonal entry), with the sign
    of the skew part, since ``sin`` alone loses the axis near ``pi``.
    """
    wx = M[2, 1] - M[1, 2]
    wy = M[0, 2] - M[2, 0]
    wz = M[1, 0] - M[0, 1]
    s = 0.5 * math.sqrt(wx * wx + wy * wy + wz * wz)
    c = 0.5 * (M[0, 0] + M[1, 1] + M[2, 2] - 1.0)
    theta = math.atan2(s, c)
    if c > -0.9:
        # theta / (2 sin theta), by its series where sin theta is tiny (theta < 1e-4).
        f = 0.5 * theta / s if s > 1e-4 else 0.5 + theta * theta / 12.0
        out[0] = f * wx
        out[1] = f * wy
        out[2] = f * wz
        return
    one_minus_c = 1.0 - c
    k = 0
    for i in range(1, 3):
        if M[i, i] > M[k, k]:
            k = i
    bkk = M[k, k] - c
    norm = math.sqrt(bkk * one_minus_c)
    skew = (wx, wy, wz)
    sign = 0.0
    for i in range(3):
        u = (0.5 * (M[i, k] + M[k, i]) - (c if i == k else 0.0)) / norm
        out[i] = u
        sign += u * skew[i]
    f = -theta if sign < 0.0 else theta
    for i in range(3):
        out[i] *= f


@_inline
def _frame_command(J, H, q, rows, config, Jm, xd, e):  # type: ignore[no-untyped-def]
    """Frame-task error and command of :func:`clik_step` into ``e`` (6), ``Jm`` (m x n)
    and ``xd`` (m); returns a status."""
    n = q.shape[0]
    if J.shape[0] != 6 or J.shape[1] != n or H.shape[0] != 4 or H.shape[1] != 4:
        return Q_SHAPE
    if config.shape[0] != CFG_VECTORS + 3 * n or e.shape[0] != 6:
        return Q_SHAPE
    m = rows.shape[0]
    if Jm.shape[0] != m or Jm.shape[1] != n or xd.shape[0] != m:
        return Q_SHAPE
    if not _finite_1d(q):
        return Q_NONFINITE
    bad = 0.0
    for i in range(3):
        for j in range(4):
            bad += H[i, j] * 0.0
    if bad != 0.0:
        return POSE_NONFINITE
    M = np.empty((3, 3))
    for i in range(3):
        e[i] = config[CFG_POSITION + i] - H[i, 3]
        for j in range(3):
            acc = 0.0
            for k in range(3):
                acc += config[CFG_ROTATION + 3 * i + k] * H[j, k]
            M[i, j] = acc
    _so3_log(M, e[3:])
    for i in range(m):
        r = rows[i]
        xd[i] = config[CFG_TWIST + r] + config[CFG_GAIN + r] * e[r]
        for j in range(n):
            Jm[i, j] = J[r, j]
    return OK


@_jit
def frame_command(J, H, q, rows, config, Jm, xd, e):  # type: ignore[no-untyped-def]
    """The frame-task part of :func:`clik_step` alone (for schemes with their own step):
    ``e = [p_d - p; log(R_d R^T)]`` into ``e``, the task rows of ``J`` into ``Jm`` and
    ``xd = twist_d + gain * e`` into ``xd``. Returns a status."""
    return _frame_command(J, H, q, rows, config, Jm, xd, e)


@_jit
def clik_step(J, H, q, rows, config, out):  # type: ignore[no-untyped-def]
    """One fused CLIK step on a frame task: pose error, rate step, limits, integration.

    Inputs: ``J`` the frame's 6 x n world-aligned Jacobian, ``H`` its 4 x 4 placement,
    ``q`` (n,), ``rows`` the task rows (indices into ``[x, y, z, rx, ry, rz]``) and
    ``config`` laid out as the ``CFG_*`` offsets say, with ``a, r, qd_max`` (n each) from
    ``CFG_VECTORS`` on. Computes::

        e  = [p_d - p; log(R_d R^T)]                      (six rows)
        xd = twist_d + gain * e                          (the selected rows)
        qd = J# xd - k_null (I - J# J) (a * (q - r))     (damping mode CFG_MODE)
        qd <- qd / max(1, max_j |qd_j| / qd_max_j)        (when CFG_LIMIT is 1)
        q+ = q + qd dt

    with the same floating-point operations as the composed step (the quadratic cost's
    gradient ``a * (q - r)``, the division by the speed ratio), so that both give the same
    bits where the inverse does.

    and writes ``out[:n] = q+``, ``out[n:2n] = qd``, ``out[2n:2n+6] = e``. Returns
    ``(status, rank, sigma_min, sigma_max, damping, speed)`` where ``speed`` is
    ``max_j |qd_j| / qd_max_j`` before scaling (0 when limits are off).
    """
    n = q.shape[0]
    m = rows.shape[0]
    if out.shape[0] != 2 * n + 6:
        return Q_SHAPE, 0, 0.0, 0.0, 0.0, 0.0
    Jm = np.empty((m, n))
    xd = np.empty(m)
    status = _frame_command(J, H, q, rows, config, Jm, xd, out[2 * n : 2 * n + 6])
    if status != OK:
        return status, 0, 0.0, 0.0, 0.0, 0.0
    has_grad = config[CFG_HAS_GRAD] != 0.0
    grad = np.empty(n if has_grad else 0)
    if has_grad:
        for j in range(n):
            grad[j] = config[CFG_VECTORS + j] * (q[j] - config[CFG_VECTORS + n + j])
    qd = out[n : 2 * n]
    status, rank, smin, smax, used = _step(
        Jm, xd, grad, qd, xd[:0], config[CFG_K_NULL], NO_WEIGHTS, xd[:0], Jm[:0, :0],
        int(config[CFG_MODE]), config[CFG_DAMPING], config[CFG_MAX_DAMPING],
        config[CFG_THRESHOLD], config[CFG_RCOND],
    )  # fmt: skip
    if status != OK:
        return status, rank, smin, smax, used, 0.0
    speed = 0.0
    if config[CFG_LIMIT] != 0.0:
        limits = config[CFG_VECTORS + 2 * n : CFG_VECTORS + 3 * n]
        for j in range(n):
            speed = max(speed, abs(qd[j]) / limits[j])
        if speed > 1.0:
            for j in range(n):
                qd[j] /= speed
    dt = config[CFG_DT]
    for j in range(n):
        out[j] = q[j] + qd[j] * dt
    return OK, rank, smin, smax, used, speed


@_jit
def integrate(q, qd, dt, out):  # type: ignore[no-untyped-def]
    """``out <- q + qd dt`` (one compiled call instead of two NumPy temporaries); returns
    whether every ``out[j]`` is finite."""
    finite = True
    for j in range(q.shape[0]):
        x = q[j] + qd[j] * dt
        out[j] = x
        if not math.isfinite(x):
            finite = False
    return finite


@_jit
def revolute_jacobian_derivatives(J, out):  # type: ignore[no-untyped-def]
    """``out[i] = ∂J/∂qᵢ`` (n x 6 x n) of a serial chain of revolute joints from its
    world-aligned Jacobian ``J = [Jᵥ; J_ω]`` (6 x n): column j of ``∂J/∂qᵢ`` is
    ``[zᵢ × Jᵥ,ⱼ; zᵢ × zⱼ]`` for ``i < j`` and ``[zⱼ × Jᵥ,ᵢ; 0]`` for ``i ≥ j``
    (Bruyninckx and De Schutter; zⱼ = J_ω,ⱼ)."""
    n = J.shape[1]
    for i in range(n):
        zi0, zi1, zi2 = J[3, i], J[4, i], J[5, i]
        for j in range(n):
            if i < j:
                a0, a1, a2 = zi0, zi1, zi2
                v0, v1, v2 = J[0, j], J[1, j], J[2, j]
                w0, w1, w2 = J[3, j], J[4, j], J[5, j]
                out[i, 3, j] = a1 * w2 - a2 * w1
                out[i, 4, j] = a2 * w0 - a0 * w2
                out[i, 5, j] = a0 * w1 - a1 * w0
            else:
                a0, a1, a2 = J[3, j], J[4, j], J[5, j]
                v0, v1, v2 = J[0, i], J[1, i], J[2, i]
                out[i, 3, j] = 0.0
                out[i, 4, j] = 0.0
                out[i, 5, j] = 0.0
            out[i, 0, j] = a1 * v2 - a2 * v1
            out[i, 1, j] = a2 * v0 - a0 * v2
            out[i, 2, j] = a0 * v1 - a1 * v0
