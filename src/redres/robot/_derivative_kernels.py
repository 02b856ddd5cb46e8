"""Compiled kinematics helpers of a serial chain (internal), through :mod:`redres._compile`."""

from __future__ import annotations

from .._compile import kernel


@kernel
def revolute_jacobian_derivatives(J, out):
    """``out[i] = ∂J/∂qᵢ`` (n x 6 x n) of a serial chain of revolute joints from its
    world-aligned Jacobian ``J = [Jᵥ; J_ω]`` (6 x n): column j of ``∂J/∂qᵢ`` is
    ``[zᵢ × Jᵥ,ⱼ; zᵢ × zⱼ]`` for ``i < j`` and ``[zⱼ × Jᵥ,ᵢ; 0]`` for ``i ≥ j``
    (Bruyninckx and De Schutter; zⱼ = J_ω,ⱼ)."""
    n = J.shape[1]
    for i in range(n):
        zi0, zi1, zi2 = J[3, i], J[4, i], J[5, i]
        for j in range(n):
            if i < j:
                a0, a1, a2 = zi0, zi1, zi2
                v0, v1, v2 = J[0, j], J[1, j], J[2, j]
                w0, w1, w2 = J[3, j], J[4, j], J[5, j]
                out[i, 3, j] = a1 * w2 - a2 * w1
                out[i, 4, j] = a2 * w0 - a0 * w2
                out[i, 5, j] = a0 * w1 - a1 * w0
            else:
                a0, a1, a2 = J[3, j], J[4, j], J[5, j]
                v0, v1, v2 = J[0, i], J[1, i], J[2, i]
                out[i, 3, j] = 0.0
                out[i, 4, j] = 0.0
                out[i, 5, j] = 0.0
            out[i, 0, j] = a1 * v2 - a2 * v1
            out[i, 1, j] = a2 * v0 - a0 * v2
            out[i, 2, j] = a0 * v1 - a1 * v0
