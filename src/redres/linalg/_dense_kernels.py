"""Small dense kernels shared by the compiled linear algebra (internal): finiteness checks,
Cholesky factorisation and solve, joint weights ``W^{-1/2}`` and the scaling that keeps
``J Jᵀ`` from overflowing. Compiled through :mod:`redres._compile` (see there for the cache);
the algorithms are textbook (Golub & Van Loan, Matrix Computations, 4th ed., §4.2)."""

from __future__ import annotations

import math

from .._compile import kernel
from ._codes import (
    DIAGONAL,
    FULL,
    NO_WEIGHTS,
    OK,
    TINY_SCALE,
    W_ASYMMETRIC,
    W_NONFINITE,
    W_NOT_SPD,
    W_SHAPE,
)

_SYMMETRY_RTOL = 1e-9


@kernel
def _finite_1d(a):
    for i in range(a.shape[0]):
        if not math.isfinite(a[i]):
            return False
    return True


@kernel
def _bounded_1d(a, bound):
    """Whether every entry of the (finite) vector ``a`` lies within ``±bound``."""
    for i in range(a.shape[0]):
        if abs(a[i]) > bound:
            return False
    return True


@kernel
def _finite_2d(a):
    for i in range(a.shape[0]):
        for j in range(a.shape[1]):
            if not math.isfinite(a[i, j]):
                return False
    return True


@kernel(inline=True)
def _gram(J, rows, A):
    """Lower triangle of ``A <- J Jᵀ`` over the first ``rows`` rows of J."""
    n = J.shape[1]
    for a in range(rows):
        for b in range(a + 1):
            acc = 0.0
            for j in range(n):
                acc += J[a, j] * J[b, j]
            A[a, b] = acc


@kernel(inline=True)
def _back_project(J, rows, r, rt, g, k, out, null):
    """``out <- Jᵀ r − k g`` over the first ``rows`` rows of J, and, when ``null`` has
    length n, ``null <- out − Jᵀ rt`` (the two halves of a rate step after its solve)."""
    n = J.shape[1]
    want_null = null.shape[0] == n
    for j in range(n):
        acc = -k * g[j]
        task = 0.0
        for a in range(rows):
            acc += J[a, j] * r[a]
            task += J[a, j] * rt[a]
        out[j] = acc
        if want_null:
            null[j] = acc - task


@kernel(inline=True)
def _copy(dst, src):
    """``dst[:] = src`` for 1-D arrays of one length, as a loop: a slice copy also
    compiles numba's shape-mismatch error path (some 2 s of string formatting, cold)."""
    for k in range(src.shape[0]):
        dst[k] = src[k]


@kernel
def _cholesky(A, L, size, shift):
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


@kernel
def _cholesky_solve(L, b, size):
    """Solve ``L L^T x = b`` in place of ``b``."""
    for i in range(size):
        acc = b[i]
        for k in range(i):
            acc -= L[i, k] * b[k]
        b[i] = acc / L[i, i]
    _solve_lower_transposed(L, b, size)


@kernel
def _solve_lower_transposed(L, b, size):
    """Solve ``L^T x = b`` in place of ``b`` (back substitution, L lower triangular)."""
    for i in range(size - 1, -1, -1):
        acc = b[i]
        for k in range(i + 1, size):
            acc -= L[k, i] * b[k]
        b[i] = acc / L[i, i]


@kernel
def _copy_finite_2d(src, dst):
    """dst <- src; False if src has a NaN or an infinity (x * 0 is NaN exactly then)."""
    bad = 0.0
    for i in range(src.shape[0]):
        for j in range(src.shape[1]):
            x = src[i, j]
            bad += x * 0.0
            dst[i, j] = x
    return bad == 0.0


@kernel
def _weigh(Js, wmode, wdiag, W, Lw):
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


@kernel
def _scale(Js):
    """Largest absolute entry s of Js; Js is divided by s unless s is in [1e-100, 1e100].

    Returns the factor applied (1.0 when the entries are already safe to square and sum,
    0.0 for a zero matrix, and for one whose entries are all below ``TINY_SCALE``: its
    inverse, about ``1/s``, would overflow).
    """
    m, n = Js.shape
    s = 0.0
    for i in range(m):
        for j in range(n):
            s = max(s, abs(Js[i, j]))
    if s < TINY_SCALE:
        return 0.0
    if 1e-100 <= s <= 1e100:
        return 1.0
    inv = 1.0 / s
    for i in range(m):
        for j in range(n):
            Js[i, j] *= inv
    return s


@kernel
def _weight_up(v, wmode, Lw):
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


@kernel
def _weight_down(v, wmode, Lw):
    """v <- L^-T v (diagonal: v / sqrt(w)), in place."""
    n = v.shape[0]
    if wmode == DIAGONAL:
        for j in range(n):
            v[j] /= Lw[j, 0]
    elif wmode == FULL:
        _solve_lower_transposed(Lw, v, n)


@kernel
def _weight_up_row(N, a, wmode, Lw):
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


@kernel
def _factor_size(n, wmode):
    """Floats needed for the weight factor: n x n (full), n (diagonal) or 0."""
    if wmode == FULL:
        return n * n
    if wmode == DIAGONAL:
        return n
    return 0


@kernel
def _factor_view(buffer, n, wmode):
    """The weight factor's storage carved from ``buffer``: (n, n), (n, 1) or (0, 0)."""
    if wmode == FULL:
        return buffer[: n * n].reshape((n, n))
    if wmode == DIAGONAL:
        return buffer[:n].reshape((n, 1))
    return buffer[:0].reshape((0, 0))
