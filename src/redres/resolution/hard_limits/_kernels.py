"""Compiled kernels of the hard-limit schemes (internal): the velocity box, saturation in
the null space and the step's prologue and epilogue shared by SNS and the QP.

Plain Python written for numba and compiled through :mod:`redres._compile` (load this module
with ``KERNELS.module``); the linear program is in :mod:`._lp_kernels`, the QP's own kernels in
:mod:`._qp_kernels`. Formulas: :mod:`.box` (the box), :mod:`.sns` (Algorithm 1 and 2 of
Flacco, De Luca, Khatib 2015). Status codes are :mod:`redres.linalg._codes` (0 = OK).

Workspaces: ``wm`` (3, m) and ``wn`` (6, n) floats, ``wb`` (3, n) booleans, ``M`` (3, m, m).
"""

from __future__ import annotations

import math

import numpy as np

from ..._compile import kernel
from ...linalg._codes import GRAD_NONFINITE, J_NONFINITE, OK, Q_NONFINITE, XD_NONFINITE
from ...linalg._dense_kernels import _cholesky, _cholesky_solve, _copy, _finite_1d, _finite_2d
from ._codes import (
    ACCELERATION,
    FAILED,
    FEASIBLE,
    LP_SCALED,
    MET_ROUNDING,
    MET_TOLERANCE,
    NONE,
    POSITION,
    RELAXED_ACCELERATION,
    RELAXED_POSITION,
    SCALED,
    VELOCITY,
)
from ._lp_kernels import largest_scale

_INF = math.inf
# Above this many braking steps the discrete bound equals the continuous one to 1e-15
# relative, and float steps of k ± 1 stop being exact (2^53): no correction loop there.
_K_EXACT = 2.0**50
_RANK_TOL = 1e-12  # Cholesky pivot / largest Gram diagonal below which J W is rank-deficient
# Cholesky pivot / largest Gram diagonal below which J may be ill-conditioned, sigma_min <
# 1e-6 sigma_max: every pivot is >= sigma_min^2 (interlacing), about m sigma_min^2 for a
# generic near-null direction; 1e-8 leaves a factor 100 of margin.
_ILL_TOL = 1e-8

# --------------------------------------------------------------------------- the box


@kernel
def braking(distance, dt, qdd_max):
    """Largest velocity toward a limit ``distance`` away that can still stop before it."""
    x = distance / dt
    if not x > 0.0 or x == _INF:
        return x  # at or past the limit: come back within one step (x ≤ 0); no limit
    a = qdd_max * dt
    if a == _INF:
        return x
    k = np.floor((math.sqrt(1.0 + 8.0 * (x / a)) - 1.0) * 0.5)
    if not k < _K_EXACT:  # k ± 1 no longer changes k (or a underflowed): the continuous
        return min(math.sqrt(2.0 * a * x), x)  # bound, to which v_max tends as k grows
    for _ in range(4):  # correct the rounding of sqrt (at most a step or two)
        if k > 0.0 and 0.5 * a * k * (k + 1.0) > x:
            k -= 1.0
        elif 0.5 * a * (k + 1.0) * (k + 2.0) <= x:
            k += 1.0
        else:
            break
    return min(x / (k + 1.0) + 0.5 * a * k, x)


@kernel
def bounds(q, qd_prev, dt, q_min, q_max, qd_max, qdd_max, lo, hi, kind_lo, kind_hi, relaxed):
    """Fill ``lo``, ``hi`` (and the codes) with the velocity box; returns #relaxed joints."""
    count = 0
    for i in range(q.shape[0]):
        flag = 0
        up = braking(q_max[i] - q[i], dt, qdd_max[i])
        dn = -braking(q[i] - q_min[i], dt, qdd_max[i])
        ku = POSITION if up < _INF else NONE
        kl = POSITION if dn > -_INF else NONE
        v = qd_max[i]
        if v < up:
            up, ku = v, VELOCITY
        if -v > dn:
            dn, kl = -v, VELOCITY
        if up < dn:  # q outside its range, farther than one step at full speed
            flag |= RELAXED_POSITION
            if up < 0.0:
                up, ku = dn, kl
            else:
                dn, kl = up, ku
        a = qdd_max[i] * dt
        if a < _INF:
            a_lo = qd_prev[i] - a
            a_hi = qd_prev[i] + a
            slack = 1e-12 * (1.0 + abs(qd_prev[i]))  # rounding of the braking recursion
            if a_lo > up:
                dn, kl = up, ku
                if a_lo > up + slack:
                    flag |= RELAXED_ACCELERATION
            elif a_hi < dn:
                up, ku = dn, kl
                if a_hi < dn - slack:
                    flag |= RELAXED_ACCELERATION
            else:
                if a_lo > dn:
                    dn, kl = a_lo, ACCELERATION
                if a_hi < up:
                    up, ku = a_hi, ACCELERATION
        lo[i] = dn
        hi[i] = up
        kind_lo[i] = kl
        kind_hi[i] = ku
        relaxed[i] = flag
        if flag:
            count += 1
    return count


# --------------------------------------------------------------------------- SNS


@kernel
def factor(J, free, G, L):
    """``G = J W Jᵀ`` (free columns) and ``L Lᵀ = G``; False when ``J W`` is rank-deficient
    (a pivot ``≤ 1e-12`` times the largest diagonal of ``G``)."""
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
    if top <= 0.0 or not _cholesky(G, L, m, 0.0):
        return False
    for j in range(m):
        if L[j, j] * L[j, j] <= _RANK_TOL * top:
            return False
    return True


@kernel
def _ridge(G, L, m):
    """``L Lᵀ = G + δ I`` with ``δ = 1e-12 ×`` the largest diagonal of ``G``, for a
    rank-deficient ``J W`` (an exactly singular ``J``); False when ``G = 0``. With it
    :func:`min_norm`'s refinement converges to the least-squares solution of ``J W``
    (each pass shrinks the residual along a singular value ``σ`` by ``δ / (σ² + δ)``), so
    a consistent task is met to rounding and :func:`solved` tells an inconsistent one."""
    top = 0.0
    for i in range(m):
        top = max(top, G[i, i])
    return top > 0.0 and _cholesky(G, L, m, _RANK_TOL * top)


@kernel
def min_norm(J, free, L, r, y, res, out):
    """``out = (J W)⁺ r = W Jᵀ (J W Jᵀ)⁻¹ r``, refined once against the residual."""
    m, n = J.shape
    for k in range(n):
        out[k] = 0.0
    for i in range(m):
        res[i] = r[i]
    for _ in range(2):
        for i in range(m):
            y[i] = res[i]
        _cholesky_solve(L, y, m)
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
def solved(r, res):
    """Whether the residual ``res`` of a solve for ``r`` is at rounding level."""
    size, err = 1.0, 0.0
    for i in range(r.shape[0]):
        size = max(size, abs(r[i]))
        err = max(err, abs(res[i]))
    return err <= 1e-12 * size


@kernel
def _scale_interval(a, b, lo, hi, free, tol):
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
def _sns(J, xd, lo, hi, qd0, tol, qd, G, L, wm, wn, wb, factored):
    """Algorithm 1 of Flacco et al. (2015): ``(method, scale)``, method FEASIBLE, SCALED or
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
        if not (it == 0 and factored) and not factor(J, free, G, L) and not _ridge(G, L, m):
            break
        for i in range(m):
            acc = xd[i]
            for k in range(n):
                acc -= J[i, k] * qn[k]
            r[i] = acc
        min_norm(J, free, L, r, y, res, qd)
        if not solved(r, res):
            break  # the task is not in the range of J W: it cannot be met with W
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
        min_norm(J, free, L, xd, y, res, a)
        for k in range(n):
            b[k] = qd[k] - a[k]
        s_min, s_max, j_max = _scale_interval(a, b, lo, hi, free, tol)
        if s_min <= s_max and s_max >= 0.0 and s_min <= 1.0 and min(s_max, 1.0) > best:
            best = min(s_max, 1.0)
            _copy(best_free, free)
            _copy(best_qn, qn)
        j = j_max if (s_max < 1.0 and j_max >= 0) else j_worst
        free[j] = False
        qn[j] = hi[j] if qd[j] > hi[j] else lo[j]
    if best < 0.0:
        return FAILED, 0.0
    _copy(free, best_free)
    if not factor(J, free, G, L):
        _ridge(G, L, m)
    for i in range(m):
        acc = best * xd[i]
        for k in range(n):
            acc -= J[i, k] * best_qn[k]
        r[i] = acc
    min_norm(J, free, L, r, y, res, qd)
    if not solved(r, res):
        return FAILED, 0.0
    for k in range(n):
        qd[k] += best_qn[k]
        if qd[k] > hi[k] + tol or qd[k] < lo[k] - tol:
            return FAILED, 0.0
        qd[k] = min(max(qd[k], lo[k]), hi[k])
    return SCALED, best


@kernel
def _sns_step(J, xd, lo, hi, qd0, use_qd0, tol, qd, G, L, wm, wn, wb, full):
    """One SNS step in a given box (:mod:`.sns`): ``(method, scale, factored)``;
    ``factored``: ``L`` still holds the Cholesky factor of the full ``J Jᵀ``."""
    n = J.shape[1]
    zero, keep = wn[4], wn[5]
    for k in range(n):
        zero[k] = 0.0
    method, s = _sns(J, xd, lo, hi, qd0 if use_qd0 else zero, tol, qd, G, L, wm, wn, wb, full)
    factored = method == FEASIBLE
    if factored:
        for k in range(n):
            factored = factored and wb[0, k]
    if method != FEASIBLE and use_qd0:  # `factored` is False here: passed as a bool, not
        # the literal False (a second compiled specialisation of _sns, 2 s cold)
        method, s = _sns(J, xd, lo, hi, zero, tol, qd, G, L, wm, wn, wb, factored)
    if method != FEASIBLE:
        _copy(keep, qd)
        lp_method, lp_s = largest_scale(J, xd, lo, hi, qd, method == SCALED, s)
        if method == SCALED and (lp_method != LP_SCALED or lp_s <= s + 1e-12):
            _copy(qd, keep)  # the greedy solution already has the largest scale
        elif lp_method != FAILED:
            method, s = lp_method, lp_s
        else:  # pragma: no cover - both failed (numerical breakdown): stay in the box
            for k in range(n):
                qd[k] = min(max(0.0, lo[k]), hi[k])
            method, s = FAILED, 0.0
    return method, s, factored


# --------------------------------------------------------------------------- the step


@kernel
def prologue(q, prev, dt, lim, J, xd, qd0, out, codes, Jc, M):
    """Input check, box (``out[2]``, ``out[3]``, ``codes[0:3]``), ``G = J Jᵀ`` and its
    factor (``M[0]``, ``M[1]``), a copy of ``J`` in ``Jc`` (for the step's diagnostics,
    computed only when asked). Returns ``(status, #relaxed, full_rank)``; status
    ``Q_NONFINITE``, ``J_NONFINITE``, ``XD_NONFINITE`` or ``GRAD_NONFINITE`` (the secondary
    velocity) of :mod:`redres.linalg._codes`, else ``OK``."""
    if not _finite_1d(q):
        return Q_NONFINITE, 0, False
    if not _finite_2d(J):
        return J_NONFINITE, 0, False
    if not _finite_1d(xd):
        return XD_NONFINITE, 0, False
    if not _finite_1d(qd0):
        return GRAD_NONFINITE, 0, False
    relaxed = bounds(q, prev, dt, lim[0], lim[1], lim[2], lim[3], out[2], out[3], codes[0],
                     codes[1], codes[2])  # fmt: skip
    every = np.ones(J.shape[1], np.bool_)
    full = factor(J, every, M[0], M[1])  # fills G = J Jᵀ even when it fails
    m, n = J.shape
    for i in range(m):
        for k in range(n):
            Jc[i, k] = J[i, k]
    return OK, relaxed, full


@kernel
def epilogue(J, xd, out, wm):
    """Clip ``q̇ = out[0]`` into the box; ``wm[2] = J q̇``. Returns ``(#joints on a bound
    within 1e-9, ‖J q̇ − ẋ‖)``. (The null-space component is :func:`null_term`'s, computed
    when a caller reads it.)"""
    m, n = J.shape
    active = 0
    for k in range(n):
        out[0, k] = min(max(out[0, k], out[2, k]), out[3, k])
        if out[0, k] >= out[3, k] - 1e-9 or out[0, k] <= out[2, k] + 1e-9:
            active += 1
    residual = 0.0
    for i in range(m):
        acc = 0.0
        for k in range(n):
            acc += J[i, k] * out[0, k]
        wm[2, i] = acc
        residual += (acc - xd[i]) ** 2
    return active, math.sqrt(residual)


@kernel
def null_term(J, qd, null):
    """``null = (I − J⁺J) q̇``, the component of ``q̇`` in the null space of ``J``, when
    ``J`` has full row rank by :func:`factor`'s test (``J⁺ = Jᵀ(J Jᵀ)⁻¹``, one step of
    refinement: :func:`min_norm`); zeros otherwise."""
    m, n = J.shape
    G, L, w = np.empty((m, m)), np.empty((m, m)), np.empty((3, m))
    every = np.ones(n, np.bool_)
    for k in range(n):
        null[k] = 0.0
    if not factor(J, every, G, L):
        return
    for i in range(m):
        acc = 0.0
        for k in range(n):
            acc += J[i, k] * qd[k]
        w[2, i] = acc
    min_norm(J, every, L, w[2], w[0], w[1], null)
    for k in range(n):
        null[k] = qd[k] - null[k]


@kernel
def sns_step(q, prev, dt, lim, J, xd, qd0, use_qd0, tol, out, codes, Jc, M, wm, wn, wb):
    """Box and SNS step in one call. ``out`` rows: q̇, null term, lower, upper; ``codes``
    rows: lower kind, upper kind, relaxed; ``Jc``: a copy of ``J``. Returns
    ``(status, method, scale, #relaxed, #active, met, ill, full)``: ``met``, the task is met
    (:data:`._codes.MET_TOLERANCE`); ``ill``, it is not, after the LP, and ``J`` may be
    ill-conditioned (:func:`_well_conditioned` fails), where the LP on ``J``'s nearly
    dependent rows may have missed it; ``full``, ``J`` has full row rank (the prologue's
    factor, for :func:`epilogue` after such a retry)."""
    status, relaxed, full = prologue(q, prev, dt, lim, J, xd, qd0, out, codes, Jc, M)
    if status != OK:
        return status, FAILED, 0.0, 0, 0, False, False, False
    method, s, _ = _sns_step(J, xd, out[2], out[3], qd0, use_qd0, tol, out[0], M[0],
                                    M[1], wm, wn, wb, full)  # fmt: skip
    active, residual = epilogue(J, xd, out, wm)
    met, ill = method == FEASIBLE, False  # Algorithm 1 met the task (refined solves)
    if method != FEASIBLE and method != SCALED:  # the LP's answer: is the task met?
        met = _task_met(J, xd, out[0], residual)
        ill = not met and not (full and _well_conditioned(M[0], M[1], J.shape[0]))
    return OK, method, s, relaxed, active, met, ill, full


@kernel
def _task_met(J, xd, qd, residual):
    """``‖J q̇ − ẋ‖ ≤ MET_TOLERANCE ‖ẋ‖ + MET_ROUNDING ‖J‖_F ‖q̇‖`` (``residual`` given)."""
    m, n = J.shape
    x2, j2, q2 = 0.0, 0.0, 0.0
    for i in range(m):
        x2 += xd[i] * xd[i]
        for k in range(n):
            j2 += J[i, k] * J[i, k]
    for k in range(n):
        q2 += qd[k] * qd[k]
    return residual <= MET_TOLERANCE * math.sqrt(x2) + MET_ROUNDING * math.sqrt(j2 * q2)


@kernel
def _well_conditioned(G, L, m):
    """Every Cholesky pivot of ``G = J Jᵀ = L Lᵀ`` above ``_ILL_TOL`` times ``G``'s largest
    diagonal. A screen for ``σ_min < 1e-6 σ_max``, not a bound: a pivot is never below
    ``σ_min²``, and the last one is about ``m σ_min²`` when the near-null direction is
    generic in ``J``'s rows (as at a robot's singularities), but a matrix built against the
    elimination order can hide it."""
    top = 0.0
    low = math.inf
    for i in range(m):
        top = max(top, G[i, i])
        low = min(low, L[i, i] * L[i, i])
    return low > _ILL_TOL * top
