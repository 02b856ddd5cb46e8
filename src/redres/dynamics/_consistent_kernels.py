"""The task and null-space torques of the dynamically consistent inverse by Householder QR
(internal kernels): the formulas of :mod:`redres.dynamics.consistent`, called by
:func:`redres.dynamics._kernels.osc_step` and ``consistent_torques``.

Entry points (for kernels): :func:`_consistent_factor` (Cholesky of ``M``, then
:func:`_householder_qr`) and :func:`_consistent_parts` (:func:`_reflect`).
"""

from __future__ import annotations

import math

import numpy as np

from .._compile import kernel
from ..linalg._dense_kernels import _cholesky


@kernel
def _householder_qr(S, beta, rdiag):
    """Householder QR of ``S`` (rows x m, rows ≥ m) in place (Golub & Van Loan 2013,
    alg. 5.2.1): ``R`` above the diagonal of ``S`` and in ``rdiag``, reflector ``k``'s
    vector ``v`` in ``S[k:, k]``, ``H_k = I − beta[k] v vᵀ``; ``Q = H_0 ⋯ H_{m−1}``."""
    rows, m = S.shape
    for k in range(m):
        norm = 0.0
        for i in range(k, rows):
            norm += S[i, k] * S[i, k]
        norm = math.sqrt(norm)
        x0 = S[k, k]
        if norm == 0.0:  # a zero column: H_k = I (R singular; the caller never gets here)
            beta[k], rdiag[k] = 0.0, 0.0
            continue
        alpha = -norm if x0 >= 0.0 else norm  # v = x − α e₁ without cancellation
        S[k, k] = x0 - alpha
        beta[k] = 1.0 / (norm * (norm + abs(x0)))  # 2 / vᵀv
        rdiag[k] = alpha
        for c in range(k + 1, m):
            dot = 0.0
            for i in range(k, rows):
                dot += S[i, k] * S[i, c]
            f = beta[k] * dot
            for i in range(k, rows):
                S[i, c] -= f * S[i, k]


@kernel
def _reflect(S, beta, x, transpose):
    """``x <- Qᵀ x`` (``transpose``) or ``Q x`` in place, ``Q`` from :func:`_householder_qr`."""
    rows, m = S.shape
    for step in range(m):
        k = step if transpose else m - 1 - step
        dot = 0.0
        for i in range(k, rows):
            dot += S[i, k] * x[i]
        f = beta[k] * dot
        for i in range(k, rows):
            x[i] -= f * S[i, k]


@kernel
def _consistent_factor(M, Jm, lam):
    """``(L, S, beta, rdiag, u)``: ``M = L Lᵀ`` (n x n), Householder QR of
    ``[J L⁻ᵀ | λ I]ᵀ`` in ``S`` ((n + m) x m, or n x m when ``λ = 0``: the zero block adds
    nothing to ``R`` or ``Q₁`` and halves the work), ``beta``, ``rdiag``
    (:func:`_householder_qr`), and ``u``, scratch of S's length for
    :func:`_consistent_parts`. ``M`` is positive definite and ``R`` regular: the callers'
    inverse kernel checked both."""
    m, n = Jm.shape
    L = np.zeros((n, n))
    S = np.empty((n + m if lam > 0.0 else n, m))
    _cholesky(M, L, n, 0.0)
    for r in range(m):  # column r of J_sᵀ = L⁻¹ (row r of J), forward substitution
        for i in range(n):
            acc = Jm[r, i]
            for k in range(i):
                acc -= L[i, k] * S[k, r]
            S[i, r] = acc / L[i, i]
        for i in range(S.shape[0] - n):  # the λ I block
            S[n + i, r] = lam if i == r else 0.0
    beta = np.empty(m)
    rdiag = np.empty(m)
    _householder_qr(S, beta, rdiag)
    return L, S, beta, rdiag, np.empty(S.shape[0])


@kernel
def _consistent_parts(L, S, beta, rdiag, cmd, u, task, proj):
    """``task <- Jᵀ Λ cmd = L Q₁ R⁻ᵀ cmd`` and ``proj <- L Q₁ Q₁ᵀ u``, which is
    ``Jᵀ J̄ᵀ τ`` for ``u = L⁻¹ τ`` (``u``, as long as S has rows, holds it in its first n
    entries and is overwritten), from :func:`_consistent_factor`."""
    n = L.shape[0]
    m = beta.shape[0]
    rows = S.shape[0]
    z = np.zeros(rows)  # R⁻ᵀ cmd (Rᵀ lower triangular), then Q₁ of it
    for i in range(m):
        acc = cmd[i]
        for k in range(i):
            acc -= S[k, i] * z[k]
        z[i] = acc / rdiag[i]
    _reflect(S, beta, z, False)
    for i in range(n, rows):
        u[i] = 0.0
    _reflect(S, beta, u, True)
    for i in range(m, rows):
        u[i] = 0.0
    _reflect(S, beta, u, False)
    for a in range(n):  # L times each
        t = 0.0
        p = 0.0
        for k in range(a + 1):
            t += L[a, k] * z[k]
            p += L[a, k] * u[k]
        task[a] = t
        proj[a] = p
