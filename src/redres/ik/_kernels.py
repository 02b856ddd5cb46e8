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
    _copy,
    _finite_2d,
)
from ..robot._chain_kernels import pose_error
from ._layout import (
    BEST_ORIENTATION,
    BEST_POSITION,
    BEST_SCORE,
    BUDGET,
    CONVERGED,
    ERR_ORIENTATION,
    ERR_POSITION,
    ERROR_SCALE,
    FLAT_GAIN,
    FLAT_ITERATIONS,
    K_LIMITS,
    MAX_DAMPING,
    MAX_ITERATIONS,
    MAX_STEP,
    N_OPTIONS,
    N_STATE,
    PATIENCE,
    PREFERENCE_GAIN,
    PREFERENCE_STEP,
    PREFERENCE_TOL,
    STALLED,
    STICKY_ERROR,
    THRESHOLD,
    TOL_ORIENTATION,
    TOL_POSITION,
    UNSETTLED,
)
from ._step_kernels import _blocked_more, _cap, _direction

_MASK = 0xFFFFFFFF


@kernel
def _hash32(x):
    """``lowbias32`` of a value in ``[0, 2³²)`` (Wellons 2018)."""
    x ^= x >> 16
    x = (x * 0x7FEB352D) & _MASK
    x ^= x >> 15
    x = (x * 0x846CA68B) & _MASK
    x ^= x >> 16
    return x


@kernel
def uniform(key, item, attempt, counter):
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
def _errors(e, rows):
    ep = math.sqrt(e[0] * e[0] + e[1] * e[1] + e[2] * e[2])
    eo = 0.0 if rows == 3 else math.sqrt(e[3] * e[3] + e[4] * e[4] + e[5] * e[5])
    return ep, eo


@kernel
def solve_packed(links, axes, kinds, limits, problem, io, rows, has_pref, key, first, stop, spend):
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
def _is_pose(T):
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
def solve(
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
def _attempt(
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
            if ep + eo < (1.0 - FLAT_GAIN) * flat_error:
                flat_error, flat_at = ep + eo, it
            elif it - flat_at >= FLAT_ITERATIONS:
                return STALLED, it, False
            if it - check_at >= patience:
                if ep + eo > 0.5 * check_error:
                    return STALLED, it, False
                check_error, check_at = ep + eo, it
            elif it == 0:
                check_error = ep + eo
        # ---- the step (ReferenceSolver.step)
        error = ep + eo
        fade = min(1.0, error / ERROR_SCALE)
        lam = 0.0
        if sigma < threshold:
            ratio = max(sigma, 0.0) / threshold
            lam = lam_max * math.sqrt(1.0 - ratio * ratio)
        lam *= fade
        k = PREFERENCE_GAIN if prefer else k_limits * fade
        recompute = False
        for j in range(n):
            blocked[j] = False
        if at_limit and prefer:  # ReferenceSolver.clamp: sticky joints stay blocked
            for j in range(n):
                if error > STICKY_ERROR:
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
            _cap(pref, PREFERENCE_STEP)
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
