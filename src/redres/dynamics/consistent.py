"""The torques of the dynamically consistent inverse from one orthogonal factorisation.

With ``M = L Lᵀ`` (Cholesky), the weighted Jacobian ``J_s = J L⁻ᵀ`` (m x n) and a damping
``λ ≥ 0``, Householder QR of the stacked ``(n + m) x m`` matrix::

    [ J_sᵀ ]   [ Q₁ ]
    [ λ I  ] = [ Q₂ ] R          so that  Rᵀ R = J_s J_sᵀ + λ² I = J M⁻¹ Jᵀ + λ² I = Λ⁻¹

gives both torques of :mod:`redres.dynamics.osc` without forming ``Λ⁻¹`` (Golub & Van
Loan, *Matrix Computations*, 4th ed., 2013, §5.3: least squares by QR rather than by the
normal equations, whose matrix squares the condition number):

* the task torque ``Jᵀ Λ a = L J_sᵀ R⁻¹ R⁻ᵀ a = L Q₁ (R⁻ᵀ a)``;
* the consistent projection ``Jᵀ J̄ᵀ τ = L J_sᵀ Λ J_s L⁻¹ τ = L Q₁ Q₁ᵀ (L⁻¹ τ)``,
  hence the null-space torque ``(I − Jᵀ J̄ᵀ) τ₀``; with ``τ₀ = M q̈₀``, ``L⁻¹ τ₀ = Lᵀ q̈₀``.

The rounding error of ``R⁻ᵀ a`` grows with ``κ(J_s)``, that of a solve with the Gram matrix
``J_s J_sᵀ`` (Cholesky of ``Λ⁻¹``, or ``J̄`` then ``M J̄ a``) with ``κ(J_s)²``: near a
singularity (``κ(J_s) ≈ 10³``) the latter loses a few 1e-12 of ``max |τ|`` where the exact
torque moves by 1e-14 under the same 1e-16 changes of ``M`` and ``J``
(``tests/dynamics/test_consistent.py`` checks both paths against exact rational
arithmetic). Valid for an inverse that is the same damped (or exact, full-rank) one in
every direction: not for a truncated pseudo-inverse (rank-deficient, undamped) or
selective damping, where the callers keep ``J̄``.

:func:`consistent_torques` runs the compiled kernel of the operational-space step's
(``redres.dynamics._consistent_kernels``) once it is compiled, and :class:`ConsistentFactor`
(NumPy) before: small LAPACK calls cost 10–15 µs each here, and their threaded BLAS can
stall for milliseconds on a loaded machine.
"""

from __future__ import annotations

import numpy as np

from .._validate import FloatArray
from .chain import KERNELS


def _forward(L: FloatArray, B: FloatArray) -> FloatArray:
    """``L⁻¹ B`` for a lower triangular ``L`` (n x n) and ``B`` of shape ``(n,)`` or ``(n, k)``,
    by forward substitution. Small NumPy operations, no LAPACK call: LAPACK's threaded
    BLAS stalls for milliseconds on a loaded machine at these sizes."""
    X = np.array(B, dtype=float)
    for i in range(L.shape[0]):
        X[i] = (X[i] - L[i, :i] @ X[:i]) / L[i, i]
    return X


class ConsistentFactor:
    """``L``, ``Q₁`` and ``R`` of the module docstring for one ``(J, M, λ)``.

    Args:
        J: task Jacobian, ``(m, n)``.
        M: joint-space inertia, symmetric positive definite, ``(n, n)``, kg·m² (checked
            by the caller).
        damping: ``λ ≥ 0`` applied in every direction, in the units of the singular values
            of ``J M^{-1/2}``; with ``λ = 0``, ``J M^{-1/2}`` must have full row rank.
    """

    def __init__(self, J: FloatArray, M: FloatArray, damping: float) -> None:
        """The arguments are described in ``help(ConsistentFactor)``."""
        m, n = J.shape
        self.L = np.linalg.cholesky(M).astype(float)
        S = np.zeros((n + m, m))
        S[:n] = _forward(self.L, J.T)  # J_sᵀ = L⁻¹ Jᵀ
        S[n:] = damping * np.eye(m)
        # Householder QR (Golub & Van Loan 2013, alg. 5.2.1): H_k = I − β_k v_k v_kᵀ on
        # rows k.., Q₁ = (H_0 ⋯ H_{m−1})[:n, :m] accumulated backwards, R in S's upper part.
        vs: list[tuple[int, FloatArray, float]] = []
        for k in range(m):
            x = S[k:, k].copy()
            norm = float(np.sqrt(x @ x))
            alpha = -norm if x[0] >= 0.0 else norm  # v = x − α e₁ without cancellation
            x[0] -= alpha
            beta = 1.0 / (norm * (norm + abs(S[k, k])))  # 2 / vᵀv
            S[k:, k:] -= np.outer(beta * x, x @ S[k:, k:])
            vs.append((k, x, beta))
        Q = np.eye(n + m, m)
        for k, v, beta in reversed(vs):
            Q[k:] -= np.outer(beta * v, v @ Q[k:])
        self.R = np.triu(S[:m])
        self.Q1 = Q[:n]

    def task(self, a: FloatArray) -> FloatArray:
        """``Jᵀ Λ a = L Q₁ R⁻ᵀ a``, ``(n,)``, for ``a`` of shape ``(m,)``."""
        y = _forward(self.R.T, a)
        return self.L @ (self.Q1 @ y)  # type: ignore[no-any-return]

    def project(self, tau: FloatArray) -> FloatArray:
        """``Jᵀ J̄ᵀ τ = L Q₁ Q₁ᵀ L⁻¹ τ``, ``(n,)``, for a torque ``τ`` of shape ``(n,)``."""
        u = _forward(self.L, tau)
        return self.L @ (self.Q1 @ (self.Q1.T @ u))  # type: ignore[no-any-return]


def consistent_torques(
    J: FloatArray, M: FloatArray, damping: float, a: FloatArray, tau: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """``(Jᵀ Λ a, Jᵀ J̄ᵀ τ)``, each ``(n,)``, the arguments as for :class:`ConsistentFactor`
    with ``a`` of shape ``(m,)`` and ``τ`` of shape ``(n,)`` (N·m)."""
    kernels = KERNELS.compiled()
    if kernels is None:
        factor = ConsistentFactor(J, M, damping)
        return factor.task(a), factor.project(tau)
    n = J.shape[1]
    task, proj = np.empty(n), np.empty(n)
    c = np.ascontiguousarray
    kernels.consistent_torques(c(M), c(J), float(damping), c(a), c(tau), task, proj)
    return task, proj
