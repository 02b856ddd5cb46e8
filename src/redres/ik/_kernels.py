"""Compiled position IK of a serial chain (internal): the iteration of :mod:`redres.ik`.

:func:`solve` runs the attempts ``first … stop − 1`` of one target: each attempt is the
CLIK iteration of the :mod:`redres.ik` docstring (error and Jacobian from
:func:`redres.robot._chain_kernels.pose_error`, the adaptively damped step with its
null-space term from :func:`redres.linalg._kernels.step`, clamping of joints at a limit
that the step pushes outward, ``max_step`` scaling, clipping, the stall test, and the
``q_preferred`` phase 2), transcribed line by line from the reference path
(:class:`redres.ik.reference.ReferenceSolver`, which stays the path of the arm-angle
preference and of models that are not serial chains). It allocates only its scratch
memory and touches no global state, so a batch kernel may call it over a ``prange``.

Restarts. Attempt ``r >= 1`` starts at a configuration drawn uniformly within the
sampling box by a counter-based generator: uniform number ``c`` of attempt ``r`` of item
``i`` under key ``s`` is a function of ``(s, i, r, c)`` only (a chain of the 32-bit
``lowbias32`` integer hash of C. Wellons, 2018; two hashes give the 53 bits of a double),
so results do not depend on how the attempts are split between calls, on threads, or on
any generator's state. The arithmetic stays within ``int64`` (products wrap identically
in numba and are exact in plain Python), so the plain-Python twin draws the same numbers.
The caller reads the clock between calls: a call ends after the attempt that brings its
iterations to ``spend``, so with ``spend = max_iterations`` at most twice that many.
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..linalg._dense_kernels import (
    _back_project,
    _cholesky,
    _cholesky_solve,
    _copy,
    _finite_2d,
    _gram,
)
from ..linalg._eigen_kernels import _extreme_eigenvalues, _tridiagonalize
from ..linalg._kernels import step as _rate_step
from ..robot._chain_kernels import pose_error

#: Status of :func:`solve`: converged, the last attempt stalled, or it used its iterations.
CONVERGED, STALLED, BUDGET = 0, 1, 2
#: Layout of ``options``.
TOL_POSITION, TOL_ORIENTATION, MAX_STEP, K_LIMITS, MAX_DAMPING, THRESHOLD = range(6)
PREFERENCE_TOL, MAX_ITERATIONS, PATIENCE, N_OPTIONS = 6, 7, 8, 9
#: Layout of ``state`` (kept between calls for one target).
BEST_SCORE, BEST_POSITION, BEST_ORIENTATION, ERR_POSITION, ERR_ORIENTATION = range(5)
UNSETTLED, N_STATE = 5, 6

_ERROR_SCALE = 0.1  # m or rad: damping and the joint-limit term fade out below this error
_PREFERENCE_GAIN = 0.5  # fraction of the distance to the preference covered per iteration
_PREFERENCE_STEP = 0.1  # rad: largest joint motion per iteration toward the preference
_STICKY_ERROR = 1e-3  # m + rad: above this error in phase 2, clamped joints are released
_FLAT_ITERATIONS = 3  # an attempt whose error has not fallen by _FLAT_GAIN in this many
_FLAT_GAIN = 0.01  # iterations has stalled (stuck at a local minimum, often at limits)
_RCOND = 1e-10  # redres.linalg.RCOND: rank tolerance of the exact step
_CHOLESKY_MIN_RATIO = 1e-3  # linalg._kernels: below this σ_min/σ_max it takes the SVD
_MASK = 0xFFFFFFFF


@kernel
def _hash32(x):  # type: ignore[no-untyped-def]
    """``lowbias32`` of a value in ``[0, 2³²)`` (Wellons 2018)."""
    x ^= x >> 16
    x = (x * 0x7FEB352D) & _MASK
    x ^= x >> 15
    x = (x * 0x846CA68B) & _MASK
    x ^= x >> 16
    return x


@kernel
def uniform(key, item, attempt, counter):  # type: ignore[no-untyped-def]
    """Uniform number in ``[0, 1)`` number ``counter`` of ``attempt`` of ``item`` under
    ``key`` (all non-negative integers below 2⁶³; module docstring)."""
    h = _hash32(0x5BD1E995 ^ (key & _MASK))
    h = _hash32(h ^ ((key >> 32) & _MASK))
    h = _hash32(h ^ (item & _MASK))
    h = _hash32(h ^ ((item >> 32) & _MASK))
    h = _hash32(h ^ (attempt & _MASK))
    a = _hash32(h ^ ((2 * counter) & _MASK))
    b = _hash32(a ^ ((2 * counter + 1) & _MASK))
    return ((a >> 5) * 67108864.0 + (b >> 6)) / 9007199254740992.0


@kernel
def _errors(e, rows):  # type: ignore[no-untyped-def]
    ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    eo = 0.0 if rows == 3 else math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return ep, eo


@kernel
def _cap(dq, largest):  # type: ignore[no-untyped-def]
    """``dq`` scaled down in place so that no entry exceeds ``largest`` in magnitude."""
    peak = 0.0
    for x in dq:
        peak = max(peak, abs(x))
    if peak > largest:
        ratio = largest / peak
        for j in range(dq.shape[0]):
            dq[j] *= ratio


@kernel
def _direction(  # type: ignore[no-untyped-def]
    J, Jb, e, rows, q, blocked, prefer, q_pref, mid, weight, k, lam, threshold, grad, task, pref,
    mats, vecs,
):  # fmt: skip
    """``task`` (and, in phase 2, ``pref``) <- the two parts of the step with the
    ``blocked`` joints' columns removed; returns ``σ_min`` of the (blocked) Jacobian, or
    ``threshold`` when it is at least that (the damping law needs no more).
    Phase 1: the joint-limit term is in ``task``; phase 2: ``pref`` is the null-space
    step toward ``q_pref``. ``mats`` (3, 6, 6), ``vecs`` (6, 6): scratch."""
    n = q.shape[0]
    for j in range(n):
        b = blocked[j]
        for i in range(rows):
            Jb[i, j] = 0.0 if b else J[i, j]
        if b:
            grad[j] = 0.0
        elif prefer:
            grad[j] = q[j] - q_pref[j]
        else:
            grad[j] = weight[j] * (q[j] - mid[j])
    null = pref if prefer else pref[:0]
    free = 0
    for j in range(n):
        if not blocked[j]:
            free += 1
    if free < rows and _dual_step(J, e, rows, blocked, free, grad, k, lam, task, null):
        sigma = 0.0  # as the reference: σ_rows of J with blocked columns, rank < rows
    else:
        sigma = _primal_step(Jb, e, rows, grad, k, lam, threshold, task, null, mats, vecs)
        if sigma < 0.0:  # near-singular: the rate step's SVD
            sigma = _rate_step(Jb[:rows], e[:rows], grad, task, null, k, lam, _RCOND)[3]
    if prefer:
        for j in range(n):
            task[j] -= pref[j]
    return sigma


@kernel
def _primal_step(J, e, rows, grad, k, lam, threshold, out, null, mats, vecs):  # type: ignore[no-untyped-def]
    """``out <- Jᵀ (J Jᵀ + λ² I)⁻¹ (e + k J grad) − k grad`` (``null`` <- its second
    part, if of length n) by the Cholesky factorisation of ``J Jᵀ + λ² I``, the path
    :func:`redres.linalg._kernels.step` takes where ``σ_min/σ_max >= 1e-3``, without
    its general-purpose preamble. Returns ``σ_min(J)`` for the next damping law, or
    ``threshold`` when it is at least that (the Cholesky factorisation of
    ``J Jᵀ − threshold² I`` succeeds: the law gives 0, no eigenvalues needed); below,
    ``σ_min`` as that step finds it (Householder tridiagonalisation, extreme
    eigenvalues). Returns −1 where that step would take its SVD (``σ_min/σ_max <
    1e-3``, fewer columns than rows). ``mats`` (3, 6, 6), ``vecs`` (6, 6): scratch
    (2-D and 3-D arrays indexed by row: a reshape per call costs as much as a Cholesky
    factorisation).
    """
    n = J.shape[1]
    if not threshold > 0.0 or n < rows:
        return -1.0
    A, L = mats[0], mats[1]
    r, rt = vecs[0], vecs[1]
    _gram(J, rows, A)
    sigma = threshold
    if not _cholesky(A, L, rows, -threshold * threshold):
        T = mats[2]
        for a in range(rows):
            for b in range(a + 1):
                T[a, b] = A[a, b]
        d, off, v, p = vecs[2], vecs[3], vecs[4], vecs[5]
        _tridiagonalize(T, rows, d, off, v, p)
        lowest, highest = _extreme_eigenvalues(d, off, rows, True)
        sigma = math.sqrt(max(lowest, 0.0))
        if not sigma >= _CHOLESKY_MIN_RATIO * math.sqrt(max(highest, 0.0)) or sigma == 0.0:
            return -1.0
    if not _cholesky(A, L, rows, lam * lam):  # pragma: no cover - A + λ² I ≻ 0 here
        return -1.0
    for a in range(rows):
        acc = 0.0
        for j in range(n):
            acc += J[a, j] * grad[j]
        r[a] = e[a] + k * acc
        rt[a] = e[a]
    _cholesky_solve(L, r, rows)
    if null.shape[0] == n:
        _cholesky_solve(L, rt, rows)
    _back_project(J, rows, r, rt, grad, k, out, null)
    return sigma


@kernel
def _dual_step(J, e, rows, blocked, free, grad, k, lam, out, null):  # type: ignore[no-untyped-def]
    """``out <- J# e − k (I − J# J) grad`` (``null`` <- its second part, if of length n)
    for a Jacobian whose ``free`` unblocked columns are fewer than its rows, in the dual
    form ``J# = (JᵀJ + λ² I)⁻¹ Jᵀ`` over the free columns (Cholesky of the small
    ``free x free`` Gram matrix). It equals the inverse of
    :func:`redres.linalg._kernels.step` on the Jacobian with the blocked columns zeroed,
    ``Jᵀ (J Jᵀ + λ² I)⁻¹`` (the push-through identity; blocked joints get
    ``−k grad = 0``), which must take its Jacobi SVD there (``J Jᵀ`` is singular), 30
    times slower. Returns False, leaving that path to the caller, when ``λ = 0`` and the
    free columns are not well conditioned (``κ(JᵀJ) > 1e8``).
    """
    n = blocked.shape[0]
    index = np.empty(free, dtype=np.int64)
    f = 0
    for j in range(n):
        if not blocked[j]:
            index[f] = j
            f += 1
    G = np.empty((free, free))
    L = np.empty((free, free))
    r = np.empty(free)
    rt = np.empty(free)
    largest = 0.0
    for a in range(free):
        for b in range(a + 1):
            acc = 0.0
            for i in range(rows):
                acc += J[i, index[a]] * J[i, index[b]]
            G[a, b] = acc
            G[b, a] = acc
        largest = max(largest, G[a, a])
    if free > 0:
        if not _cholesky(G, L, free, lam * lam):
            return False
        if lam == 0.0:
            for a in range(free):
                if L[a, a] * L[a, a] < 1e-8 * largest:
                    return False
    for a in range(free):
        acc = 0.0
        for i in range(rows):
            acc += J[i, index[a]] * e[i]
        rt[a] = acc
        acc2 = 0.0
        for b in range(free):
            acc2 += G[a, b] * grad[index[b]]
        r[a] = acc + k * acc2
    _cholesky_solve(L, r, free)
    _cholesky_solve(L, rt, free)
    want_null = null.shape[0] == n
    for j in range(n):
        out[j] = -k * grad[j]
        if want_null:
            null[j] = out[j]
    for a in range(free):
        j = index[a]
        out[j] += r[a]
        if want_null:
            null[j] = out[j] - rt[a]
    return True


@kernel
def _blocked_more(q, lo, hi, task, pref, prefer, blocked):  # type: ignore[no-untyped-def]
    """Block the joints at a limit that the step pushes outward; whether any was new."""
    more = False
    for j in range(q.shape[0]):
        if blocked[j]:
            continue
        dq = task[j] + pref[j] if prefer else task[j]
        if (q[j] <= lo[j] and dq < 0.0) or (q[j] >= hi[j] and dq > 0.0):
            blocked[j] = True
            more = True
    return more


@kernel
def solve_packed(links, axes, kinds, limits, problem, io, rows, has_pref, key, first, stop, spend):  # type: ignore[no-untyped-def]
    """:func:`solve` for a call from Python, with few arrays to unbox (each costs about as
    much as an iteration): ``limits`` (6, n) stacks ``lo, hi, sample_lo, sample_hi, mid,
    weight``; ``problem`` is the target (16 values, row-major 4x4), the options
    (:data:`N_OPTIONS`) and, when ``has_pref``, ``q_pref`` (n); ``io`` is ``q`` (n),
    ``best_q`` (n) and ``state`` (:data:`N_STATE`). ``q`` is first clipped into the
    limits. Returns ``(status, attempts, iterations)``, status -1 (nothing done) when
    ``q`` holds NaN or infinity or the target is not a finite homogeneous transform with
    a rotation block (the checks of :func:`redres._validate.as_transform`).
    """
    n = limits.shape[1]
    for j in range(n):
        if not math.isfinite(io[j]):
            return -1, 0, 0
    target = problem[:16].reshape((4, 4))
    if not _is_pose(target):
        return -1, 0, 0
    options = problem[16 : 16 + N_OPTIONS]
    q_pref = problem[16 + N_OPTIONS : 16 + N_OPTIONS + (n if has_pref else 0)]
    q, best_q, state = io[:n], io[n : 2 * n], io[2 * n : 2 * n + N_STATE]
    for j in range(n):
        q[j] = min(max(q[j], limits[0, j]), limits[1, j])
    return solve(links, axes, kinds, limits, target, rows, q_pref, options, key, 0, first,
                 stop, spend, q, best_q, state)  # fmt: skip


@kernel
def _is_pose(T):  # type: ignore[no-untyped-def]
    """Finite, last row ``[0, 0, 0, 1]`` to 1e-9, ``R Rᵀ = I`` to 1e-6 and ``det R >= 0``."""
    if not _finite_2d(T):
        return False
    if abs(T[3, 0]) + abs(T[3, 1]) + abs(T[3, 2]) + abs(T[3, 3] - 1.0) > 1e-9:
        return False
    for i in range(3):
        for j in range(3):
            dot = T[i, 0] * T[j, 0] + T[i, 1] * T[j, 1] + T[i, 2] * T[j, 2]
            if abs(dot - (1.0 if i == j else 0.0)) > 1e-6:
                return False
    det = (
        T[0, 0] * (T[1, 1] * T[2, 2] - T[1, 2] * T[2, 1])
        - T[0, 1] * (T[1, 0] * T[2, 2] - T[1, 2] * T[2, 0])
        + T[0, 2] * (T[1, 0] * T[2, 1] - T[1, 1] * T[2, 0])
    )
    return det >= 0.0


@kernel
def solve(  # type: ignore[no-untyped-def]
    links,
    axes,
    kinds,
    limits,
    target,
    rows,
    q_pref,
    options,
    key,
    item,
    first,
    stop,
    spend,
    q,
    best_q,
    state,
):
    """Attempts ``first … stop − 1`` of one target (module docstring): the per-target
    kernel of a batch.

    ``limits`` (6, n): rows ``lo, hi, sample_lo, sample_hi, mid, weight`` (the joint
    limits, the sampling box of the restarts, the mid-range and weight of the
    joint-limit cost); ``target`` (4, 4); ``rows`` 3 (position) or 6 (pose); ``q_pref``
    (n) enables the preference phase, length 0 none; ``options``: the layout
    :data:`TOL_POSITION` … :data:`PATIENCE`; ``key``, ``item``: the restart stream.
    ``spend``: the call ends after the attempt that brings its iterations to this
    many (the caller reads its clock between calls). ``q`` (n): in, the start of
    attempt ``first`` when it is 0 (later attempts draw theirs); out, the solution when
    converged, else the last attempt's end. ``best_q`` and ``state`` (:data:`N_STATE`;
    ``state[BEST_SCORE] = inf`` before the first call) carry the best configuration over
    calls. Returns ``(status, attempts made,
    iterations)``; when converged, ``state[ERR_POSITION]``, ``state[ERR_ORIENTATION]``
    hold the errors at ``q`` and ``state[UNSETTLED]`` whether the preference had not
    settled.
    """
    n = q.shape[0]
    T, e, J, Jb = np.empty((4, 4)), np.empty(6), np.empty((6, n)), np.empty((6, n))
    vectors, mats, vecs = np.empty((6, n)), np.empty((3, 6, 6)), np.empty((6, 6))
    flags = np.zeros(2 * n, dtype=np.bool_)
    iterations = 0
    status = BUDGET
    attempt = first
    while attempt < stop:
        if attempt > 0:
            for j in range(n):
                u = uniform(key, item, attempt, j)
                q[j] = limits[2, j] + (limits[3, j] - limits[2, j]) * u
        status, used, unsettled = _attempt(
            links, axes, kinds, limits, target, rows, q_pref, options, q, best_q, state, T, e,
            J, Jb, vectors, mats, vecs, flags,
        )  # fmt: skip
        iterations += used
        attempt += 1
        if status == CONVERGED:
            pose_error(links, axes, kinds, q, target, T, J, e)
            ep, eo = _errors(e, rows)
            state[ERR_POSITION], state[ERR_ORIENTATION] = ep, eo
            state[UNSETTLED] = 1.0 if unsettled else 0.0
            break
        if iterations >= spend:
            break
    return status, attempt - first, iterations


@kernel
def _attempt(  # type: ignore[no-untyped-def]
    links, axes, kinds, limits, target, rows, q_pref, options, q, best_q, state, T, e, J, Jb,
    vectors, mats, vecs, flags,
):  # fmt: skip
    """One attempt from ``q`` (updated in place: the answer when converged);
    ``(status, iterations, whether the preference had not settled)``. The rest is
    scratch: ``T`` (4, 4), ``e`` (6), ``J``, ``Jb``, ``vectors`` (6, n), ``mats``
    (3, 6, 6), ``vecs`` (6, 6), ``flags`` (2n)."""
    n = q.shape[0]
    grad, task, pref, cand, last, qn = (vectors[0], vectors[1], vectors[2], vectors[3],
                                        vectors[4], vectors[5])  # fmt: skip
    blocked, sticky = flags[:n], flags[n:]
    lo, hi, mid, weight = limits[0], limits[1], limits[4], limits[5]
    has_pref = q_pref.shape[0] == n
    tol_p, tol_o = options[TOL_POSITION], options[TOL_ORIENTATION]
    max_iterations, patience = int(options[MAX_ITERATIONS]), int(options[PATIENCE])
    max_step, k_limits = options[MAX_STEP], options[K_LIMITS]
    lam_max, threshold = options[MAX_DAMPING], options[THRESHOLD]
    pref_tol = options[PREFERENCE_TOL]
    sigma = 0.0
    has_cand = prefer = has_last = False
    at_limit = True
    moved = math.inf
    check_error, check_at = math.inf, 0
    flat_error, flat_at = math.inf, 0
    scale = 1.0
    it, limit = 0, max_iterations
    for j in range(n):
        sticky[j] = False
    while it < limit:
        pose_error(links, axes, kinds, q, target, T, J, e)
        ep, eo = _errors(e, rows)
        score = max(ep / tol_p, eo / tol_o)
        if score < state[BEST_SCORE]:
            state[BEST_SCORE], state[BEST_POSITION], state[BEST_ORIENTATION] = score, ep, eo
            _copy(best_q, q)
        if ep <= tol_p and eo <= tol_o:
            if not has_pref or (prefer and moved <= pref_tol):
                return CONVERGED, it, False
            has_cand = True
            _copy(cand, q)
            if not prefer:  # phase 2, with a budget of its own
                prefer, moved, limit = True, math.inf, it + max_iterations
                scale, has_last = 1.0, False
                for j in range(n):
                    sticky[j] = False
        elif not has_cand:
            if ep + eo < (1.0 - _FLAT_GAIN) * flat_error:
                flat_error, flat_at = ep + eo, it
            elif it - flat_at >= _FLAT_ITERATIONS:
                return STALLED, it, False
            if it - check_at >= patience:
                if ep + eo > 0.5 * check_error:
                    return STALLED, it, False
                check_error, check_at = ep + eo, it
            elif it == 0:
                check_error = ep + eo
        # ---- the step (ReferenceSolver.step)
        error = ep + eo
        fade = min(1.0, error / _ERROR_SCALE)
        lam = 0.0
        if sigma < threshold:
            ratio = max(sigma, 0.0) / threshold
            lam = lam_max * math.sqrt(1.0 - ratio * ratio)
        lam *= fade
        k = _PREFERENCE_GAIN if prefer else k_limits * fade
        recompute = False
        for j in range(n):
            blocked[j] = False
        if at_limit and prefer:  # ReferenceSolver.clamp: sticky joints stay blocked
            for j in range(n):
                if error > _STICKY_ERROR:
                    sticky[j] = False
                blocked[j] = sticky[j]
                recompute = recompute or sticky[j]
        if not recompute:
            sigma = _direction(J, Jb, e, rows, q, blocked, prefer, q_pref, mid, weight, k,
                               lam, threshold, grad, task, pref, mats, vecs)  # fmt: skip
        if at_limit:
            for _ in range(3):
                if recompute:
                    sigma = _direction(J, Jb, e, rows, q, blocked, prefer, q_pref, mid,
                                       weight, k, lam, threshold, grad, task, pref,
                                       mats, vecs)  # fmt: skip
                if not _blocked_more(q, lo, hi, task, pref, prefer, blocked):
                    break
                recompute = True
            if prefer:
                _copy(sticky, blocked)
        if prefer:  # ReferenceSolver.preference_part
            _cap(pref, _PREFERENCE_STEP)
            dot = 0.0
            for j in range(n):
                pref[j] *= scale
                dot += pref[j] * last[j]
            if has_last and dot < 0.0:
                scale *= 0.5
                for j in range(n):
                    pref[j] *= 0.5
            _copy(last, pref)
            has_last = True
            for j in range(n):
                task[j] += pref[j]
        _cap(task, max_step)
        at_limit = False
        moved = 0.0
        for j in range(n):
            x = q[j] + task[j]
            if x <= lo[j] or x >= hi[j]:
                at_limit = True
            qn[j] = x
        for j in range(n):
            x = min(max(qn[j], lo[j]), hi[j]) if at_limit else qn[j]
            moved = max(moved, abs(x - q[j]))
            q[j] = x
        it += 1
    if has_cand:  # the preference had not settled: the last configuration on target
        _copy(q, cand)
        return CONVERGED, it, True
    return BUDGET, it, False
