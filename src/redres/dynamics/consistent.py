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
"""

from __future__ import annotations

import numpy as np

from .._validate import FloatArray


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
        from scipy.linalg import solve_triangular  # on first use: 0.2 s of import

        self._solve = solve_triangular
        m, n = J.shape
        self.L = np.linalg.cholesky(M)
        stacked = np.zeros((n + m, m))
        stacked[:n] = solve_triangular(self.L, J.T, lower=True)  # J_sᵀ = L⁻¹ Jᵀ
        stacked[n:] = damping * np.eye(m)
        Q, self.R = np.linalg.qr(stacked)
        self.Q1 = Q[:n]

    def task(self, a: FloatArray) -> FloatArray:
        """``Jᵀ Λ a = L Q₁ R⁻ᵀ a``, ``(n,)``, for ``a`` of shape ``(m,)``."""
        y = self._solve(self.R, a, trans="T")
        return self.L @ (self.Q1 @ y)  # type: ignore[no-any-return]

    def project(self, tau: FloatArray) -> FloatArray:
        """``Jᵀ J̄ᵀ τ = L Q₁ Q₁ᵀ L⁻¹ τ``, ``(n,)``, for a torque ``τ`` of shape ``(n,)``."""
        u = self._solve(self.L, tau, lower=True)
        return self.L @ (self.Q1 @ (self.Q1.T @ u))  # type: ignore[no-any-return]
