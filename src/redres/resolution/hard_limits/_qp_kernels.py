"""Compiled kernels of the QP scheme (internal): its box prologue, the least-violating
QP's normal equations and the Farkas test that skips an exact QP known to be infeasible.

Plain Python written for numba, compiled through :mod:`redres._compile`; the box and the
step's prologue and epilogue are those of :mod:`._kernels` (shared with SNS). Formulas:
:mod:`.qp`. Status codes are :mod:`redres.linalg._codes` (0 = OK).
"""

from __future__ import annotations

import numpy as np

from ..._compile import kernel
from ...linalg._codes import OK
from ._kernels import epilogue, min_norm, prologue, solved


@kernel
def qp_begin(q, prev, dt, lim, J, xd, qd0, out, codes, Jc, M, wm, bu, bl, f, w, lam2, P, c):
    """Box, ``G = J Jᵀ``, the copy ``Jc`` of ``J`` and the unconstrained optimum of the exact QP,
    ``q̇ = q̇_0 + J⁺(ẋ − J q̇_0)`` in ``out[0]``; fills DAQP's ``bu``, ``bl`` (box, then
    ``ẋ``) and ``f = −q̇_0``, and, when that optimum is not in the box, the least-violating
    QP's ``P``, ``c`` (:func:`_qp_normal`). Returns ``(status, #relaxed, full_rank,
    inside)``: ``inside`` means the optimum is in the box, hence the QP's solution."""
    status, relaxed, full = prologue(q, prev, dt, lim, J, xd, qd0, out, codes, Jc, M)
    if status != OK:
        return status, 0, False, False
    m, n = J.shape
    for k in range(n):
        bu[k], bl[k], f[k] = out[3, k], out[2, k], -qd0[k]
    for i in range(m):
        bu[n + i] = bl[n + i] = xd[i]
    inside = False
    if full:
        r = wm[2]
        for i in range(m):
            acc = xd[i]
            for k in range(n):
                acc -= J[i, k] * qd0[k]
            r[i] = acc
        every = np.ones(n, np.bool_)
        min_norm(J, every, M[1], r, wm[0], wm[1], out[0])
        inside = solved(r, wm[1])
        for k in range(n):
            out[0, k] += qd0[k]
            inside = inside and out[2, k] <= out[0, k] <= out[3, k]
    if not inside:
        _qp_normal(J, xd, w, lam2, qd0, P, c)
    return OK, relaxed, full, inside


@kernel
def _qp_farkas(J, xd, lo, hi, x):
    """Whether ``y = ẋ − J x`` proves ``{J q̇ = ẋ, lo ≤ q̇ ≤ hi}`` empty (Farkas' lemma):
    ``yᵀẋ > max_{lo ≤ q̇ ≤ hi} yᵀ J q̇ = Σ_k max(c_k lo_k, c_k hi_k)``, ``c = Jᵀ y``."""
    m, n = J.shape
    y = np.empty(m)
    gap, size = 0.0, 0.0
    for i in range(m):
        acc = xd[i]
        for k in range(n):
            acc -= J[i, k] * x[k]
        y[i] = acc
        gap += acc * xd[i]
        size += abs(acc * xd[i])
    for k in range(n):
        c = 0.0
        for i in range(m):
            c += J[i, k] * y[i]
        if c != 0.0:
            bound = max(c * lo[k], c * hi[k])
            gap -= bound
            size += abs(bound)
    return gap > 1e-12 * size


@kernel
def qp_end(J, xd, x, out, wm):
    """If ``x`` (the least-violating QP's answer) proves the task infeasible
    (:func:`_qp_farkas`), take it as ``q̇`` and finish the step (:func:`_epilogue`).
    Returns ``(proved, #active, ‖J q̇ − ẋ‖)``."""
    if not _qp_farkas(J, xd, out[2], out[3], x):
        return False, 0, 0.0
    for k in range(x.shape[0]):
        out[0, k] = x[k]
    active, residual = epilogue(J, xd, out, wm)
    return True, active, residual


@kernel
def _qp_normal(J, xd, w, lam2, qd0, P, c):
    """The least-violating QP: ``P = Jᵀ W J + λ² I``, ``c = −Jᵀ W ẋ − λ² q̇_0``."""
    m, n = J.shape
    for a in range(n):
        acc = 0.0
        for i in range(m):
            acc += J[i, a] * w[i] * xd[i]
        c[a] = -acc - lam2 * qd0[a]
        for b in range(a + 1):
            acc = 0.0
            for i in range(m):
                acc += J[i, a] * w[i] * J[i, b]
            P[a, b] = acc
            P[b, a] = acc
        P[a, a] += lam2
