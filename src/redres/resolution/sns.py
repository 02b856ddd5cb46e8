"""Saturation in the null space (SNS): hard joint limits without a QP solver.

Flacco, De Luca and Khatib (2015, Algorithm 1) solve ``J q̇ = ẋ`` inside the joint-velocity
box ``lower ≤ q̇ ≤ upper`` of :mod:`~redres.resolution.limits` as follows. Start with every
joint free (``W = I``) and the null-space velocity ``q̇_N`` equal to the secondary velocity
``q̇_0`` (zero without objectives); repeat:

1. ``q̇ = q̇_N + (J W)⁺ (ẋ − J q̇_N)`` — the task solved with the free joints only (``W``
   selects them; ``(J W)⁺ = W Jᵀ (J W Jᵀ)⁻¹``, computed by a Cholesky solve with one step
   of iterative refinement). If ``q̇`` is inside the box, stop: the task is met exactly.
2. Otherwise write ``q̇(s) = s a + b`` with ``a = (J W)⁺ ẋ``, ``b = q̇ − a`` and find the
   largest ``s ∈ [0, 1]`` that keeps the free joints in the box (Algorithm 2, the task
   scaling factor); remember the best ``(s, W, q̇_N)`` seen.
3. Saturate the *most critical joint* (the first to reach its bound as ``s`` grows; the
   worst violator if none limits ``s``): ``W_jj = 0``, ``q̇_N,j`` = the bound it crosses.
4. When ``J W`` loses rank, the task cannot be met: return the best remembered solution
   with the task scaled by ``s`` (``J q̇ = s ẋ``, same direction).

The greedy choice of saturated joints does not always find the largest feasible scale
(nor a feasible solution whenever one exists; on random boxes it misses in about one
case in four). So when step 4 is reached, this implementation also solves the linear
program ``max s  s.t.  J q̇ = s ẋ, lower ≤ q̇ ≤ upper, 0 ≤ s ≤ 1`` exactly (a bounded-
variable primal simplex with Bland's rule, Dantzig 1963 ch. 18; Chvátal 1983 ch. 8) and
keeps the SNS solution if its scale is that maximum, the simplex vertex otherwise. The
returned scale is therefore the largest feasible one (tests check it against a brute-
force line search). If no scale in ``[0, 1]`` is feasible (the joints cannot change their
velocities fast enough to move along ``ẋ`` at all), the result is the velocity in the box
whose task velocity is nearest, in the 1-norm, to the segment ``{s ẋ : 0 ≤ s ≤ 1}``
(phase 1 of the same simplex), reported as infeasible.

With objectives the secondary velocity is ``q̇_0 = −k Σ wᵢ ∇Dᵢ(q)`` (DESIGN.md convention);
on the free joints SNS then gives the gradient projection ``q̇_0 + (J W)⁺(ẋ − J q̇_N)``. If
the task cannot be met with ``q̇_0``, SNS is rerun without it (the secondary goal gives way
first).

References:
    F. Flacco, A. De Luca, O. Khatib, "Control of redundant robots under hard joint
    constraints: saturation in the null space", IEEE Trans. Robotics 31(3) (2015) 637–654.
    G. B. Dantzig, Linear Programming and Extensions, Princeton, 1963.
    V. Chvátal, Linear Programming, Freeman, 1983.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import FloatArray, as_matrix, as_scalar, as_vector
from ..errors import NonFiniteError, ShapeError
from ..linalg import InverseInfo
from .base import Scheme, StepResult
from .gradient_projection import WeightedObjective, total_gradient, weighted_objectives
from .limits import (
    BOUND_KINDS,
    Binding,
    JointLimits,
    _bounds,
    fast_entry,
    kernel,
    register_kernels,
)

if TYPE_CHECKING:
    from ..robot import Robot

#: Status codes of a step (``SNSDetails.method`` gives the name).
FEASIBLE, SCALED, LP_SCALED, NEAREST, FAILED = 0, 1, 2, 3, 4
METHODS: tuple[str, ...] = ("sns", "sns-scaled", "lp", "nearest", "failed")
_CAP = 1e6  # stands in for an infinite velocity bound inside the simplex, rad/s
_RANK_TOL = 1e-12  # Cholesky pivot / largest Gram diagonal below which J W is rank-deficient

# --------------------------------------------------------------------------- kernels
# Plain Python written for numba (compiled on first use, see limits.register_kernels).
# Workspaces: wm (3, m) and wn (6, n) floats, wb (3, n) booleans, G, L, E (m, m).


@kernel
def _factor(J, free, G, L):  # type: ignore[no-untyped-def]
    """``G = J W Jᵀ`` (free columns) and ``L Lᵀ = G``; False when ``J W`` is rank-deficient."""
    m, n = J.shape
    top = 0.0
    for i in range(m):
        for j in range(i + 1):
            acc = 0.0
            for k in range(n):
                if free[k]:
                    acc += J[i, k] * J[j, k]
            G[i, j] = acc
            G[j, i] = acc
        top = max(top, G[i, i])
    if top <= 0.0:
        return False
    for j in range(m):
        d = G[j, j]
        for k in range(j):
            d -= L[j, k] * L[j, k]
        if d <= _RANK_TOL * top:
            return False
        d = math.sqrt(d)
        L[j, j] = d
        for i in range(j + 1, m):
            acc = G[i, j]
            for k in range(j):
                acc -= L[i, k] * L[j, k]
            L[i, j] = acc / d
    return True


@kernel
def _min_norm(J, free, L, r, y, res, out):  # type: ignore[no-untyped-def]
    """``out = (J W)⁺ r = W Jᵀ (J W Jᵀ)⁻¹ r``, refined once against the residual."""
    m, n = J.shape
    for k in range(n):
        out[k] = 0.0
    for i in range(m):
        res[i] = r[i]
    for _ in range(2):
        for i in range(m):  # L z = res, then Lᵀ y = z
            acc = res[i]
            for k in range(i):
                acc -= L[i, k] * y[k]
            y[i] = acc / L[i, i]
        for i in range(m - 1, -1, -1):
            acc = y[i]
            for k in range(i + 1, m):
                acc -= L[k, i] * y[k]
            y[i] = acc / L[i, i]
        for k in range(n):
            if free[k]:
                acc = 0.0
                for i in range(m):
                    acc += J[i, k] * y[i]
                out[k] += acc
        for i in range(m):
            acc = r[i]
            for k in range(n):
                acc -= J[i, k] * out[k]
            res[i] = acc


@kernel
def _solved(r, res):  # type: ignore[no-untyped-def]
    """Whether the residual ``res`` of a solve for ``r`` is at rounding level."""
    size, err = 1.0, 0.0
    for i in range(r.shape[0]):
        size = max(size, abs(r[i]))
        err = max(err, abs(res[i]))
    return err <= 1e-12 * size


@kernel
def _scale_interval(a, b, lo, hi, free, tol):  # type: ignore[no-untyped-def]
    """``(s_min, s_max, j)``: free joints of ``s a + b`` stay in the box for ``s`` in
    ``[s_min, s_max]``; ``j`` limits ``s_max`` (-1: none). Algorithm 2 of Flacco et al."""
    s_min, s_max, j_max = -math.inf, math.inf, -1
    for i in range(a.shape[0]):
        if not free[i]:
            continue
        if abs(a[i]) <= 1e-15:
            if b[i] > hi[i] + tol or b[i] < lo[i] - tol:
                return math.inf, -math.inf, -1
            continue
        s1 = (lo[i] - b[i]) / a[i]
        s2 = (hi[i] - b[i]) / a[i]
        if s1 > s2:
            s1, s2 = s2, s1
        s_min = max(s_min, s1)
        if s2 < s_max:
            s_max, j_max = s2, i
    return s_min, s_max, j_max


@kernel
def _sns(J, xd, lo, hi, qd0, tol, qd, G, L, wm, wn, wb, factored):  # type: ignore[no-untyped-def]
    """Algorithm 1 of Flacco et al. (2015): ``(status, scale)``, status FEASIBLE, SCALED or
    FAILED (no feasible scale found by the greedy saturation). ``factored``: ``L`` already
    holds the factor of the full ``J Jᵀ`` (skips the first factorisation)."""
    m, n = J.shape
    y, res, r = wm[0], wm[1], wm[2]
    qn, best_qn, a, b = wn[0], wn[1], wn[2], wn[3]
    free, best_free = wb[0], wb[1]
    for k in range(n):
        free[k] = True
        qn[k] = qd0[k]
    best = -1.0
    for it in range(n + 1):
        if not (it == 0 and factored) and not _factor(J, free, G, L):
            break
        for i in range(m):
            acc = xd[i]
            for k in range(n):
                acc -= J[i, k] * qn[k]
            r[i] = acc
        _min_norm(J, free, L, r, y, res, qd)
        if not _solved(r, res):
            break  # J W numerically rank-deficient: the task cannot be met with W
        worst, j_worst = tol, -1
        for k in range(n):
            qd[k] += qn[k]
            over = max(qd[k] - hi[k], lo[k] - qd[k])
            if over > worst:
                worst, j_worst = over, k
        if j_worst < 0:
            for k in range(n):
                qd[k] = min(max(qd[k], lo[k]), hi[k])
            return FEASIBLE, 1.0
        _min_norm(J, free, L, xd, y, res, a)
        for k in range(n):
            b[k] = qd[k] - a[k]
        s_min, s_max, j_max = _scale_interval(a, b, lo, hi, free, tol)
        if s_min <= s_max and s_max >= 0.0 and s_min <= 1.0 and min(s_max, 1.0) > best:
            best = min(s_max, 1.0)
            best_free[:] = free
            best_qn[:] = qn
        j = j_max if (s_max < 1.0 and j_max >= 0) else j_worst
        free[j] = False
        qn[j] = hi[j] if qd[j] > hi[j] else lo[j]
    if best < 0.0:
        return FAILED, 0.0
    free[:] = best_free
    _factor(J, free, G, L)
    for i in range(m):
        acc = best * xd[i]
        for k in range(n):
            acc -= J[i, k] * best_qn[k]
        r[i] = acc
    _min_norm(J, free, L, r, y, res, qd)
    if not _solved(r, res):
        return FAILED, 0.0
    for k in range(n):
        qd[k] += best_qn[k]
        if qd[k] > hi[k] + tol or qd[k] < lo[k] - tol:
            return FAILED, 0.0
        qd[k] = min(max(qd[k], lo[k]), hi[k])
    return SCALED, best


@kernel
def _solve(B, rhs, out, transpose, W):  # type: ignore[no-untyped-def]
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
def _simplex(A, low, up, cost, x, basis, at_upper, is_basic):  # type: ignore[no-untyped-def]
    """Bounded-variable primal simplex with Bland's rule: minimise ``cost·x`` subject to
    ``A x = 0``, ``low ≤ x ≤ up``, from the basic feasible solution ``(x, basis)``.
    Returns 0 (optimal), 1 (iteration limit) or 2 (singular basis); ``x`` is updated."""
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
            return 2
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
            return 0
        for i in range(m):
            rhs[i] = A[i, enter]
        if not _solve(B, rhs, w, False, W):
            return 2
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
            return 2
        x[enter] += sign * step
        if leave < 0:
            at_upper[enter] = not at_upper[enter]
            x[enter] = up[enter] if at_upper[enter] else low[enter]
        else:
            v = basis[leave]
            is_basic[v], at_upper[v] = False, leave_up
            x[v] = up[v] if leave_up else low[v]
            basis[leave], is_basic[enter] = enter, True
    return 1


@kernel
def _warm_start(J, xd, A, low, up, x, cost, basis, at_upper, is_basic, qd, s):  # type: ignore[no-untyped-def]
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
    return _simplex(A, low, up, cost, x, basis, at_upper, is_basic) == 0


@kernel
def _largest_scale(J, xd, lo, hi, qd, warm, s_warm):  # type: ignore[no-untyped-def]
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
        low[k], up[k] = max(lo[k], -_CAP), min(hi[k], _CAP)
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
    if _simplex(A, low, up, cost, x, basis, at_upper, is_basic) != 0:
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
        if _simplex(A, low, up, cost, x, basis, at_upper, is_basic) != 0:
            return FAILED, 0.0
        status = LP_SCALED
    for k in range(n):
        qd[k] = min(max(x[k], lo[k]), hi[k])
    return status, min(max(x[n], 0.0), 1.0)


@kernel
def _gram_singular_values(G, A, out, e):  # type: ignore[no-untyped-def]
    """Singular values of J from the eigenvalues of G = J Jᵀ: Householder reduction to
    tridiagonal form, then implicit QL with Wilkinson shifts (Golub & Van Loan 2013,
    §8.3), eigenvalues only; largest first."""
    m = G.shape[0]
    d = out  # diagonal of the tridiagonal form; e: its sub-diagonal (workspace, size m)
    for i in range(m):
        for j in range(m):
            A[i, j] = G[i, j]
    for k in range(m - 2):
        norm = 0.0
        for i in range(k + 1, m):
            norm += A[i, k] * A[i, k]
        norm = math.sqrt(norm)
        alpha = -norm if A[k + 1, k] > 0.0 else norm
        d[k] = A[k, k]
        e[k] = alpha
        if norm == 0.0:
            continue
        # v = x - alpha e1 (stored in column k below the diagonal), H = I - 2 v vᵀ / vᵀv
        A[k + 1, k] -= alpha
        vv = 0.0
        for i in range(k + 1, m):
            vv += A[i, k] * A[i, k]
        # p = A v * 2/vv ; w = p - (vᵀp / vv) v ; A -= v wᵀ + w vᵀ
        beta = 2.0 / vv
        for i in range(k + 1, m):  # p stored in row k (unused above the diagonal now)
            acc = 0.0
            for j in range(k + 1, m):
                acc += A[i, j] * A[j, k]
            A[k, i] = beta * acc
        vp = 0.0
        for i in range(k + 1, m):
            vp += A[i, k] * A[k, i]
        half = 0.5 * beta * vp
        for i in range(k + 1, m):
            A[k, i] -= half * A[i, k]
        for i in range(k + 1, m):
            for j in range(k + 1, m):
                A[i, j] -= A[i, k] * A[k, j] + A[k, i] * A[j, k]
    if m >= 2:
        d[m - 2] = A[m - 2, m - 2]
        e[m - 2] = A[m - 1, m - 2]
    d[m - 1] = A[m - 1, m - 1]
    if m >= 1:
        e[m - 1] = 0.0
    _tridiagonal_ql(d, e, m)
    for i in range(m):  # square roots, sorted largest first (insertion sort, m <= 6)
        v = math.sqrt(max(d[i], 0.0))
        j = i
        while j > 0 and d[j - 1] < v:
            d[j] = d[j - 1]
            j -= 1
        d[j] = v


@kernel
def _gram_rank(G, sigma):  # type: ignore[no-untyped-def]
    """Singular values of J (largest first) into ``sigma`` from ``G = J Jᵀ``; returns the
    rank ``#{σ > 1e-6 σ_max}``."""
    m = G.shape[0]
    _gram_singular_values(G, np.empty((m, m)), sigma, np.empty(m))
    rank = 0
    for i in range(m):
        if sigma[i] > 1e-6 * sigma[0]:
            rank += 1
    return rank


@kernel
def _tridiagonal_ql(d, e, m):  # type: ignore[no-untyped-def]
    """Eigenvalues of the symmetric tridiagonal (d, e) in place (implicit QL)."""
    for l in range(m):
        for _ in range(60):
            mm = l
            while mm < m - 1:
                dd = abs(d[mm]) + abs(d[mm + 1])
                if abs(e[mm]) <= 2.2e-16 * dd:
                    break
                mm += 1
            if mm == l:
                break
            g = (d[l + 1] - d[l]) / (2.0 * e[l])
            r = math.hypot(g, 1.0)
            g = d[mm] - d[l] + e[l] / (g + math.copysign(r, g))
            s = c = 1.0
            p = 0.0
            i = mm - 1
            underflow = False
            while i >= l:
                f = s * e[i]
                b = c * e[i]
                r = math.hypot(f, g)
                e[i + 1] = r
                if r == 0.0:
                    d[i + 1] -= p
                    e[mm] = 0.0
                    underflow = True
                    break
                s = f / r
                c = g / r
                g = d[i + 1] - p
                r = (d[i] - g) * s + 2.0 * c * b
                p = s * r
                d[i + 1] = g + p
                g = c * r - b
                i -= 1
            if underflow:
                continue
            d[l] -= p
            e[l] = g
            e[mm] = 0.0


@kernel
def _step(J, xd, lo, hi, qd0, use_qd0, tol, qd, G, L, wm, wn, wb, full):  # type: ignore[no-untyped-def]
    """One SNS step in a given box (module docstring): ``(status, scale, factored)``;
    ``factored``: ``L`` still holds the Cholesky factor of the full ``J Jᵀ``."""
    n = J.shape[1]
    zero, keep = wn[4], wn[5]
    for k in range(n):
        zero[k] = 0.0
    status, s = _sns(J, xd, lo, hi, qd0 if use_qd0 else zero, tol, qd, G, L, wm, wn, wb, full)
    factored = status == FEASIBLE
    if factored:
        for k in range(n):
            factored = factored and wb[0, k]
    if status != FEASIBLE and use_qd0:
        status, s = _sns(J, xd, lo, hi, zero, tol, qd, G, L, wm, wn, wb, False)
    if status != FEASIBLE:
        keep[:] = qd
        lp_status, lp_s = _largest_scale(J, xd, lo, hi, qd, status == SCALED, s)
        if status == SCALED and (lp_status != LP_SCALED or lp_s <= s + 1e-12):
            qd[:] = keep  # the greedy solution already has the largest scale
        elif lp_status != FAILED:
            status, s = lp_status, lp_s
        else:  # pragma: no cover - both failed (numerical breakdown): stay in the box
            for k in range(n):
                qd[k] = min(max(0.0, lo[k]), hi[k])
            status, s = FAILED, 0.0
    return status, s, factored


@kernel
def _finite(a):  # type: ignore[no-untyped-def]
    for x in a.flat:
        if not math.isfinite(x):
            return False
    return True


@kernel
def _prologue(q, prev, dt, lim, J, xd, qd0, out, codes, gram, M, wm):  # type: ignore[no-untyped-def]
    """Input check, box (``out[2]``, ``out[3]``, ``codes[0:3]``), ``G = J Jᵀ`` and its
    factor (``M[0]``, ``M[1]``), a copy of ``G`` in ``gram`` (for the singular values of
    the step's diagnostics, computed only when asked: :func:`gram_info`). Returns
    ``(error, #relaxed, full_rank)``; error -1/-2/-3/-4: ``q``/``J``/``xd``/secondary
    velocity not finite."""
    if not _finite(q):
        return -1, 0, False
    if not _finite(J):
        return -2, 0, False
    if not _finite(xd):
        return -3, 0, False
    if not _finite(qd0):
        return -4, 0, False
    relaxed = _bounds(q, prev, dt, lim[0], lim[1], lim[2], lim[3], out[2], out[3], codes[0],
                      codes[1], codes[2])  # fmt: skip
    every = np.ones(J.shape[1], np.bool_)
    full = _factor(J, every, M[0], M[1])  # fills G = J Jᵀ even when it fails
    m = J.shape[0]
    for i in range(m):
        for j in range(m):
            gram[i, j] = M[0, i, j]
    return 0, relaxed, full


@kernel
def _epilogue(J, xd, out, codes, M, wm, full, factored):  # type: ignore[no-untyped-def]
    """Clip ``q̇ = out[0]`` into the box, mark the active sides (``codes[3]``: +1 upper,
    -1 lower, 2 both), its null-space component (``out[1]``). Returns ``(#active,
    ‖J q̇ − ẋ‖)``."""
    m, n = J.shape
    active = 0
    for k in range(n):
        out[0, k] = min(max(out[0, k], out[2, k]), out[3, k])
        side = 0
        if out[0, k] >= out[3, k] - 1e-9:
            side = 1
        if out[0, k] <= out[2, k] + 1e-9:
            side = 2 if side == 1 else -1
        codes[3, k] = side
        if side != 0:
            active += 1
    residual = 0.0
    for i in range(m):
        acc = 0.0
        for k in range(n):
            acc += J[i, k] * out[0, k]
        wm[2, i] = acc
        residual += (acc - xd[i]) ** 2
    for k in range(n):
        out[1, k] = 0.0
    if full:  # null = (I − J⁺J) q̇
        every = np.ones(n, np.bool_)
        if not factored:
            _factor(J, every, M[0], M[1])
        _min_norm(J, every, M[1], wm[2], wm[0], wm[1], out[1])
        for k in range(n):
            out[1, k] = out[0, k] - out[1, k]
    return active, math.sqrt(residual)


@kernel
def _scheme_step(q, prev, dt, lim, J, xd, qd0, use_qd0, tol, out, codes, gram, M, wm, wn, wb):  # type: ignore[no-untyped-def]
    """Box and SNS step in one call. ``out`` rows: q̇, null term, lower, upper; ``codes``
    rows: lower kind, upper kind, relaxed, active side; ``gram``: ``J Jᵀ``. Returns
    ``(status or input error, scale, #relaxed, #active)``."""
    err, relaxed, full = _prologue(q, prev, dt, lim, J, xd, qd0, out, codes, gram, M, wm)
    if err:
        return err, 0.0, 0, 0
    status, s, factored = _step(J, xd, out[2], out[3], qd0, use_qd0, tol, out[0], M[0], M[1],
                                wm, wn, wb, full)  # fmt: skip
    active, _ = _epilogue(J, xd, out, codes, M, wm, full, factored)
    return status, s, relaxed, active


_KERNEL_NAMES: list[str] = [
    "_factor", "_min_norm", "_solved", "_scale_interval", "_sns", "_solve", "_simplex",
    "_warm_start",
    "_largest_scale", "_tridiagonal_ql", "_gram_singular_values", "_gram_rank", "_step",
    "_finite",
    "_prologue", "_epilogue", "_scheme_step",
]  # fmt: skip


# --------------------------------------------------------------------------- public API


def largest_scale(
    J: ArrayLike, xd: ArrayLike, lower: ArrayLike, upper: ArrayLike
) -> tuple[float, FloatArray, bool]:
    """The largest ``s ∈ [0, 1]`` with ``J q̇ = s ẋ`` for some ``q̇`` in the box, by the simplex.

    Args:
        J: task Jacobian, shape ``(m, n)``.
        xd: task velocity, shape ``(m,)``.
        lower, upper: the joint-velocity box, shapes ``(n,)``, rad/s (``lower ≤ upper``).

    Returns:
        ``(s, qd, feasible)``: the scale, a joint velocity of the box that achieves it
        (a vertex), and whether any scale in ``[0, 1]`` is feasible (if not, ``qd`` is the
        velocity whose task velocity is nearest, in the 1-norm, to the segment
        ``{s ẋ : 0 ≤ s ≤ 1}`` and ``s`` its scale there).
    """
    J = as_matrix(J, "J")
    m, n = J.shape
    xd = as_vector(xd, "xd", m)
    lo, hi = _box(lower, upper, n)
    register_kernels(globals(), _KERNEL_NAMES)
    qd = np.empty(n)
    status, s = globals()["_largest_scale"](J, xd, lo, hi, qd, False, 0.0)
    return float(s), qd, bool(status == LP_SCALED)


def _box(lower: ArrayLike, upper: ArrayLike, n: int) -> tuple[FloatArray, FloatArray]:
    lo = np.asarray(lower, dtype=float)
    hi = np.asarray(upper, dtype=float)
    if lo.shape != (n,) or hi.shape != (n,):
        raise ShapeError(f"lower and upper must have shape ({n},); got {lo.shape}, {hi.shape}")
    if np.isnan(lo).any() or np.isnan(hi).any() or np.any(lo > hi):
        raise ShapeError("lower and upper must be free of NaN with lower <= upper")
    return lo, hi


def kernels() -> dict[str, Any]:
    """The compiled kernels of this module (internal; compiles on first use)."""
    from . import limits

    globals()["_bounds"] = limits.bounds_kernel()  # the compiled box kernel, if any
    register_kernels(globals(), _KERNEL_NAMES)
    return globals()


_INPUTS = ("q", "J", "xd", "the secondary velocity (objective gradients)")


def input_error(code: int, values: tuple[Any, ...]) -> NonFiniteError:
    """The error for a kernel's input-check code (-1 .. -4) (internal)."""
    name = _INPUTS[-code - 1]
    return NonFiniteError(f"{name} contains NaN or infinity: {values[-code - 1]}")


def step_inputs(
    scheme: Any, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray
) -> tuple[Workspace, FloatArray, FloatArray]:
    """The prologue of a hard-limit scheme's step (shared by SNS and QP, internal).

    For arrays already checked (:func:`step_arrays`): (re)builds ``scheme``'s workspace
    when the robot or the task size changes, and returns ``(workspace, qd0, qd_prev)``
    with ``qd0 = −k ΣwᵢDᵢ`` the secondary target (zeros without objectives).
    """
    if robot is not scheme._robot or scheme._ws.key[1] != xd.shape[0]:
        scheme._prepare(robot, q, J, xd)
    ws = scheme._ws
    qd0 = ws.zero
    if scheme.objectives:
        qd0 = (-scheme.gain) * total_gradient(robot, q, scheme.objectives)  # new, C order
    prev = ws.zero if scheme.qd_prev is None else scheme.qd_prev
    return ws, qd0, prev


class BindingList(Sequence[Binding]):
    """The :class:`~redres.resolution.limits.Binding` bounds of a step, built on first
    access from the kernel's code rows (a list of namedtuples costs microseconds a step;
    most loops never read it). Compares equal to a list with the same entries."""

    __slots__ = ("_codes", "_items", "_relaxed")

    def __init__(self, codes: Any, relaxed: bool) -> None:
        self._codes, self._relaxed = codes, relaxed
        self._items: list[Binding] | None = None

    def _list(self) -> list[Binding]:
        if self._items is None:
            codes, relaxed, items = self._codes, self._relaxed, []
            for j, side in enumerate(codes[3].tolist()):
                gave_up = relaxed and bool(codes[2, j])
                if side in (1, 2):
                    items.append(Binding(j, "upper", BOUND_KINDS[codes[1, j]], gave_up))
                if side in (-1, 2):
                    items.append(Binding(j, "lower", BOUND_KINDS[codes[0, j]], gave_up))
            self._items = items
        return self._items

    def __getitem__(self, index: Any) -> Any:
        return self._list()[index]

    def __len__(self) -> int:
        return len(self._list())

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Sequence) and self._list() == list(other)

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return repr(self._list())


_GRAM_RANK: list[Any] = [None]  # the compiled _gram_rank's entry point, on first use


def gram_info(gram: FloatArray, method: str) -> InverseInfo:
    """Diagnostics of a hard-limit step from ``G = J Jᵀ`` (internal): the singular values
    of ``J`` (square roots of the eigenvalues of ``G``), rank ``σ > 1e-6 σ_max``."""
    m = gram.shape[0]
    sigma = np.empty(m)
    entry = _GRAM_RANK[0]
    if entry is None:
        entry = _GRAM_RANK[0] = fast_entry(kernels()["_gram_rank"], (gram, sigma))
    rank = entry(gram, sigma)
    return InverseInfo(rank, rank == m, float(sigma[-1]), float(sigma[0]), 0.0, method)


def binding_list(codes: Any, relaxed: bool) -> BindingList:
    """The bounds a step's ``q̇`` sits on (internal; see :class:`BindingList`)."""
    return BindingList(codes, relaxed)


class Workspace:
    """Arrays of one robot and task size, and the limits, for the schemes' kernels (internal)."""

    def __init__(self, limits: JointLimits, m: int) -> None:
        n = limits.n
        self.key: tuple[int, int] = (n, m)
        self.lim = np.ascontiguousarray(
            np.vstack([limits.q_min, limits.q_max, limits.qd_max, limits.qdd_max])
        )
        self.zero = np.zeros(n)
        self.M = np.zeros((3, m, m))
        self.wm = np.zeros((3, m))
        self.wn = np.zeros((6, n))
        self.wb = np.zeros((3, n), np.bool_)

    def outputs(self) -> tuple[FloatArray, Any, FloatArray]:
        """Fresh per-step outputs: ``out`` (q̇, null term, lower, upper), ``codes`` (bound
        kinds, relaxed, active side) and ``gram`` (``J Jᵀ``)."""
        n, m = self.key
        return np.empty((4, n)), np.empty((4, n), np.int8), np.empty((m, m))


class BoxScheme(Scheme):
    """What the hard-limit schemes share (internal): the velocity box of their limits and
    the previous joint velocity it is built from (:attr:`qd_prev`)."""

    hard_limits = True

    def _init_box(self, dt: float, qd_max: ArrayLike | None, qdd_max: ArrayLike | None) -> None:
        self.dt = as_scalar(dt, "dt", minimum=0.0, strict=True)
        self._overrides = (qd_max, qdd_max)
        #: The previous joint velocity (``None`` = at rest); the scheme's own copy.
        self.qd_prev: FloatArray | None = None
        self._robot: Any = None
        self._ws: Any = None

    def _reset(self) -> None:
        self.qd_prev = None

    def limits(self, robot: Robot) -> JointLimits:
        """The limits this scheme enforces on ``robot``."""
        return JointLimits.from_robot(robot, qd_max=self._overrides[0],
                                      qdd_max=self._overrides[1])  # fmt: skip


def relaxed_joints(codes: Any, relaxed: int) -> list[int]:
    """The joints whose box had to give up a limit (internal; ``relaxed`` counts them)."""
    return np.flatnonzero(codes[2]).tolist() if relaxed else []


@dataclass(frozen=True)
class SNSDetails:
    """What an SNS step adds to its :class:`~redres.resolution.StepResult`.

    Attributes:
        scale: ``s`` with ``J q̇ = s ẋ`` (1: the task is met; 0 when no scale is feasible).
        method: ``"sns"`` (Algorithm 1 met the task), ``"sns-scaled"`` (its scaled
            solution has the largest scale), ``"lp"`` (the simplex vertex, when the greedy
            saturation missed the largest scale), ``"nearest"`` (no scale in ``[0, 1]`` is
            feasible) or ``"failed"``.
        bounds: the joint-velocity box ``(lower, upper)``, two ``(n,)`` arrays, rad/s.
        relaxed: joints whose box had to give up a limit.
    """

    scale: float
    method: str
    bounds: tuple[FloatArray, FloatArray]
    relaxed: list[int]


class SNSScheme(BoxScheme):
    """Saturation in the null space (Flacco, De Luca, Khatib 2015) within hard limits.

    Every step the joint-velocity box of :func:`~redres.resolution.limits.velocity_bounds`
    (position, velocity and acceleration limits over one period) is computed at ``q`` from
    the velocity of the previous step, and the task is solved inside it by SNS (module
    docstring). The result never leaves the box, so a run through
    :func:`redres.control.run` keeps every limit (to rounding) — provided ``dt`` is the
    loop's period.

    Args:
        dt: control period, s; must equal the ``dt`` of the loop that applies ``q̇``.
        objectives: optional secondary costs (each ``obj`` or ``(obj, weight)``); their
            velocity ``−gain Σ wᵢ ∇Dᵢ`` is used on the free joints while the task allows.
        gain: ``k`` of the secondary velocity.
        qd_max, qdd_max: velocity / acceleration limits replacing the robot's (scalar or
            ``(n,)``; e.g. ``qdd_max`` for a model without acceleration limits).
        tolerance: slack of the box tests inside the algorithm, rad/s (the output is
            clipped into the exact box).

    Identifier ``sns``. State: the previous joint velocity :attr:`qd_prev` (``None`` = at
    rest; :meth:`reset` clears it, so a run starts at rest). ``StepResult.feasible``:
    ``s = 1``, the task is met exactly; ``binding``: the
    :class:`~redres.resolution.limits.Binding` bounds ``q̇`` sits on; ``details``: an
    :class:`SNSDetails` (scale, method, box, relaxed joints).
    ``null_term`` is the component of ``q̇`` in the null space of ``J``; ``info`` gives the
    singular values of ``J`` (rank: ``σ > 1e-6 σ_max``).
    """

    name = "sns"

    def __init__(
        self,
        dt: float = 1e-3,
        *,
        objectives: Sequence[WeightedObjective] = (),
        gain: float = 1.0,
        qd_max: ArrayLike | None = None,
        qdd_max: ArrayLike | None = None,
        tolerance: float = 1e-12,
    ) -> None:
        self._init_box(dt, qd_max, qdd_max)
        self.objectives = tuple(weighted_objectives(objectives))
        self.gain = as_scalar(gain, "gain", minimum=0.0)
        self.tolerance = as_scalar(tolerance, "tolerance", minimum=0.0)

    def _prepare(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> None:
        ws = Workspace(self.limits(robot), J.shape[0])
        args = (q, ws.zero, self.dt, ws.lim, J, xd, ws.zero, False, self.tolerance,
                *ws.outputs(), ws.M, ws.wm, ws.wn, ws.wb)  # fmt: skip
        self._kernel = fast_entry(kernels()["_scheme_step"], args)
        self._ws, self._robot = ws, robot

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        ws, qd0, prev = step_inputs(self, robot, q, J, xd)
        out, codes, gram = ws.outputs()
        status, s, relaxed, active = self._kernel(
            q, prev, self.dt, ws.lim, J, xd, qd0, bool(self.objectives), self.tolerance,
            out, codes, gram, ws.M, ws.wm, ws.wn, ws.wb,
        )  # fmt: skip
        if status < 0:
            raise input_error(status, (q, J, xd, qd0))
        self.qd_prev = out[0].copy()  # the scheme's own copy
        if status == NEAREST:
            s = 0.0
        details = SNSDetails(s, METHODS[status], (out[2], out[3]), relaxed_joints(codes, relaxed))
        return StepResult(
            out[0], lambda: gram_info(gram, "sns"), out[1], feasible=s == 1.0,
            binding=binding_list(codes, relaxed > 0) if active else (), details=details,
        )  # fmt: skip
