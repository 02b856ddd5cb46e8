"""One step of the compiled position IK (internal), called by :func:`._kernels.solve`:
the adaptively damped direction of the task error with the joint-limit term
(:func:`_direction`), solved on the free joints (:func:`_primal_step`, or the dual form
:func:`_dual_step` when the joints blocked at a limit leave fewer free joints than task
rows), scaled to ``max_step`` (:func:`_cap`), and the test that blocks joints the step
pushes outward at a limit (:func:`_blocked_more`). Transcribed from the reference path
(:class:`redres.ik.reference.ReferenceSolver`).
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..linalg._codes import RCOND
from ..linalg._dense_kernels import (
    _back_project,
    _cholesky,
    _cholesky_solve,
    _gram,
)
from ..linalg._eigen_kernels import _extreme_eigenvalues, _tridiagonalize
from ..linalg._factor_kernels import _CHOLESKY_MIN_RATIO
from ..linalg._kernels import step as _rate_step


@kernel
def _cap(dq, largest):
    """``dq`` scaled down in place so that no entry exceeds ``largest`` in magnitude."""
    peak = 0.0
    for x in dq:
        peak = max(peak, abs(x))
    if peak > largest:
        ratio = largest / peak
        for j in range(dq.shape[0]):
            dq[j] *= ratio


@kernel
def _direction(
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
            sigma = _rate_step(Jb[:rows], e[:rows], grad, task, null, k, lam, RCOND)[3]
    if prefer:
        for j in range(n):
            task[j] -= pref[j]
    return sigma


@kernel
def _primal_step(J, e, rows, grad, k, lam, threshold, out, null, mats, vecs):
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
def _dual_step(J, e, rows, blocked, free, grad, k, lam, out, null):
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
def _blocked_more(q, lo, hi, task, pref, prefer, blocked):
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
