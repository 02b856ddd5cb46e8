"""Eigenvalue kernels for the compiled inverses (internal): the extreme eigenvalues of a
symmetric matrix by Householder tridiagonalisation and Laguerre's method, eigenvalue counts
by Sylvester inertia, and the one-sided Jacobi SVD (Hestenes 1958) used near singularities.
Compiled through :mod:`redres._compile`; :mod:`redres.linalg._kernels` explains where each is
used and how accurate it is."""

from __future__ import annotations

import math

from .._compile import kernel

_EPS = 2.220446049250313e-16


@kernel
def _tridiagonalize(A, size, d, e, v, p):
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


@kernel
def _charpoly(d, e, lo, hi, x):
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


@kernel
def _laguerre_step(d, e, lo, hi, x):
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


@kernel
def _laguerre_pair(d, e, lo, hi, below, above):
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


@kernel
def _converged(step, previous, x):
    """True once a cubically converging iteration's next step is below rounding.

    A step under ``1e-6 |x|`` that is also under ``1e-3`` of the previous one shows the
    asymptotic (cubic) regime: the error left is about ``(1e-6)^3 |x|``. Slow, linear
    convergence (clustered roots) never passes the second test, so it goes on until
    rounding turns the step back.
    """
    size = abs(step)
    return size <= 1e-6 * abs(x) and size <= 1e-3 * previous


@kernel
def _extreme_eigenvalues(d, e, size, nonnegative):
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


@kernel
def _count_below(d, e, size, tau):
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


@kernel
def _jacobi_rows(R, m, n):
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
