"""Compiled linear program of the hard-limit schemes (internal): the largest task scale of
:mod:`.lp` (formula and references there), in two phases or from a feasible vertex (the
greedy SNS solution). Plain Python written for numba, compiled through :mod:`redres._compile`.
"""

from __future__ import annotations

import math

import numpy as np

from ..._compile import kernel
from ._codes import FAILED, ITERATION_LIMIT, LP_SCALED, NEAREST, OPTIMAL, SINGULAR_BASIS

_CAP = 1e6  # stands in for an infinite velocity bound inside the simplex, rad/s


@kernel
def _solve(B, rhs, out, transpose, W):
    """``B out = rhs`` (or ``Bᵀ out = rhs``) by Gaussian elimination with partial pivoting
    on the workspace ``W`` (m, m+1); False when ``B`` is singular."""
    m = rhs.shape[0]
    for i in range(m):
        for j in range(m):
            W[i, j] = B[j, i] if transpose else B[i, j]
        W[i, m] = rhs[i]
    for c in range(m):
        p = c
        for i in range(c + 1, m):
            if abs(W[i, c]) > abs(W[p, c]):
                p = i
        if abs(W[p, c]) <= 1e-14:
            return False
        if p != c:
            for j in range(c, m + 1):
                W[c, j], W[p, j] = W[p, j], W[c, j]
        for i in range(c + 1, m):
            f = W[i, c] / W[c, c]
            if f != 0.0:
                for j in range(c, m + 1):
                    W[i, j] -= f * W[c, j]
    for i in range(m - 1, -1, -1):
        acc = W[i, m]
        for j in range(i + 1, m):
            acc -= W[i, j] * out[j]
        out[i] = acc / W[i, i]
    return True


@kernel
def _simplex(A, low, up, cost, x, basis, at_upper, is_basic):
    """Bounded-variable primal simplex with Bland's rule: minimise ``cost·x`` subject to
    ``A x = 0``, ``low ≤ x ≤ up``, from the basic feasible solution ``(x, basis)``.
    Returns OPTIMAL, ITERATION_LIMIT or SINGULAR_BASIS; ``x`` is updated."""
    m, N = A.shape
    B, W = np.empty((m, m)), np.empty((m, m + 1))
    rhs, xb, yv, w, cb = np.empty(m), np.empty(m), np.empty(m), np.empty(m), np.empty(m)
    scale = 1.0
    for i in range(m):
        for j in range(N):
            scale = max(scale, abs(A[i, j]))
    eps = 1e-12 * scale
    for _ in range(50 * N):
        for i in range(m):
            acc = 0.0
            for j in range(N):
                if not is_basic[j]:
                    acc -= A[i, j] * x[j]
            rhs[i] = acc
            for k in range(m):
                B[i, k] = A[i, basis[k]]
            cb[i] = cost[basis[i]]
        if not _solve(B, rhs, xb, False, W) or not _solve(B, cb, yv, True, W):
            return SINGULAR_BASIS
        for k in range(m):
            x[basis[k]] = xb[k]
        enter = -1
        for j in range(N):  # Bland: the first improving non-basic variable
            if is_basic[j] or up[j] <= low[j]:
                continue
            d = cost[j]
            for i in range(m):
                d -= A[i, j] * yv[i]
            if (d < -eps and not at_upper[j]) or (d > eps and at_upper[j]):
                enter = j
                break
        if enter < 0:
            return OPTIMAL
        for i in range(m):
            rhs[i] = A[i, enter]
        if not _solve(B, rhs, w, False, W):
            return SINGULAR_BASIS
        sign = -1.0 if at_upper[enter] else 1.0
        step, leave, leave_up = up[enter] - low[enter], -1, False
        for k in range(m):
            g = -sign * w[k]  # rate of change of basic variable k
            v = basis[k]
            if g < -1e-11:
                lim, to_up = (x[v] - low[v]) / -g, False
            elif g > 1e-11:
                lim, to_up = (up[v] - x[v]) / g, True
            else:
                continue
            lim = max(lim, 0.0)
            if lim < step or (lim == step and leave >= 0 and v < basis[leave]):
                step, leave, leave_up = lim, k, to_up
        if step == math.inf:
            return SINGULAR_BASIS
        x[enter] += sign * step
        if leave < 0:
            at_upper[enter] = not at_upper[enter]
            x[enter] = up[enter] if at_upper[enter] else low[enter]
        else:
            v = basis[leave]
            is_basic[v], at_upper[v] = False, leave_up
            x[v] = up[v] if leave_up else low[v]
            basis[leave], is_basic[enter] = enter, True
    return ITERATION_LIMIT


@kernel
def _warm_start(J, xd, A, low, up, x, cost, basis, at_upper, is_basic, qd, s):
    """Phase 2 from a feasible point ``(qd, s)`` that is a vertex (the greedy SNS result):
    its variables strictly inside their bounds form the basis. True when the simplex then
    reaches the optimum; False (nothing usable) otherwise."""
    m, n = J.shape
    count = 0
    for j in range(n + 1):
        v = qd[j] if j < n else s
        tol = 1e-12 * (1.0 + abs(v))
        is_basic[j] = low[j] + tol < v < up[j] - tol
        at_upper[j] = not is_basic[j] and v >= up[j] - tol
        x[j] = v if is_basic[j] else (up[j] if at_upper[j] else low[j])
        if is_basic[j]:
            if count == m:
                return False
            basis[count] = j
            count += 1
    if count != m:
        return False
    for i in range(m):
        cost[n + 1 + i], up[n + 1 + i], x[n + 1 + i] = 0.0, 0.0, 0.0
        is_basic[n + 1 + i], at_upper[n + 1 + i] = False, False
    cost[n] = -1.0
    return _simplex(A, low, up, cost, x, basis, at_upper, is_basic) == OPTIMAL


@kernel
def largest_scale(J, xd, lo, hi, qd, warm, s_warm):
    """Exact ``max s`` s.t. ``J q̇ = s ẋ``, ``lo ≤ q̇ ≤ hi``, ``0 ≤ s ≤ 1`` (simplex; from the
    feasible vertex ``(qd, s_warm)`` when ``warm``, else in two phases).

    Returns ``(status, s)``: LP_SCALED with the optimal vertex in ``qd``; NEAREST when no
    ``s`` is feasible (``qd``, ``s``: the phase-1 point nearest, in the 1-norm, to the
    segment ``{s ẋ}``); FAILED on numerical breakdown.
    """
    m, n = J.shape
    N = n + 1 + m
    A = np.zeros((m, N))
    low, up, x, cost = np.empty(N), np.empty(N), np.empty(N), np.zeros(N)
    at_upper, is_basic = np.zeros(N, np.bool_), np.zeros(N, np.bool_)
    basis = np.empty(m, np.int64)
    for i in range(m):
        for k in range(n):
            A[i, k] = J[i, k]
        A[i, n] = -xd[i]
    for k in range(n):
        low[k], up[k] = max(lo[k], -_CAP), min(hi[k], _CAP)
    low[n], up[n] = 0.0, 1.0
    if warm:
        for i in range(m):
            A[i, n + 1 + i], low[n + 1 + i] = 1.0, 0.0
        if _warm_start(J, xd, A, low, up, x, cost, basis, at_upper, is_basic, qd, s_warm):
            for k in range(n):
                qd[k] = min(max(x[k], lo[k]), hi[k])
            return LP_SCALED, min(max(x[n], 0.0), 1.0)
        cost[n] = 0.0
    for k in range(n):
        is_basic[k] = False
        at_upper[k] = abs(up[k]) < abs(low[k])
        x[k] = up[k] if at_upper[k] else low[k]
    x[n], at_upper[n], is_basic[n] = 1.0, True, False
    for i in range(m):
        acc = xd[i]  # residual of J q̇ − s ẋ = 0 at the start point, s = 1
        for k in range(n):
            acc -= J[i, k] * x[k]
        A[i, n + 1 + i] = 1.0 if acc >= 0.0 else -1.0
        low[n + 1 + i], up[n + 1 + i], x[n + 1 + i] = 0.0, math.inf, abs(acc)
        cost[n + 1 + i] = 1.0
        basis[i], is_basic[n + 1 + i] = n + 1 + i, True
    if _simplex(A, low, up, cost, x, basis, at_upper, is_basic) != OPTIMAL:
        return FAILED, 0.0
    size = 1.0
    for i in range(m):
        size += abs(xd[i])
    infeasibility = 0.0
    for i in range(m):
        infeasibility += x[n + 1 + i]
    status = NEAREST
    if infeasibility <= 1e-12 * size:
        for i in range(m):
            cost[n + 1 + i], up[n + 1 + i] = 0.0, 0.0
        cost[n] = -1.0
        if _simplex(A, low, up, cost, x, basis, at_upper, is_basic) != OPTIMAL:
            return FAILED, 0.0
        status = LP_SCALED
    for k in range(n):
        qd[k] = min(max(x[k], lo[k]), hi[k])
    return status, min(max(x[n], 0.0), 1.0)
