"""Partial derivatives ``∂J/∂qᵢ`` of a revolute chain's Jacobian, from the Jacobian alone.

For a serial chain of revolute joints with axes ``zⱼ`` and ``J = [Jᵥ; J_ω]`` (world-aligned;
Bruyninckx and De Schutter; also the form Pinocchio's kinematic Hessian takes)::

    ∂Jᵥ,ⱼ/∂qᵢ = zᵢ × Jᵥ,ⱼ  (i < j),    zⱼ × Jᵥ,ᵢ  (i ≥ j)
    ∂J_ω,ⱼ/∂qᵢ = zᵢ × zⱼ   (i < j),    0          (i ≥ j)

One compiled kernel (:mod:`redres.robot._derivative_kernels`) computes them; the NumPy form below is
the path without kernels and the tests' second opinion (``tests/robot`` checks both
against finite differences of Pinocchio's Jacobian).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .. import _compile
from .._validate import FloatArray

#: The derivative kernel; routed with linalg's (:func:`redres.linalg._backend.routed`).
KERNELS = _compile.KernelGroup(
    "derivatives", ("redres.robot._derivative_kernels",), cold_seconds=1.0
)
_KERNEL: list[Any] = [None]


def revolute_jacobian_derivatives(J: FloatArray) -> FloatArray:
    """``out[i] = ∂J/∂qᵢ``, shape ``(n, 6, n)``, from the world-aligned ``J (6, n)`` of a
    chain of revolute joints (module docstring)."""
    n = J.shape[1]
    kernel = _kernel()
    if kernel is not None:
        out = np.empty((n, 6, n))
        kernel(np.ascontiguousarray(J, dtype=np.float64), out)
        return out
    Jv, z = J[:3].T, J[3:].T  # (n, 3) each
    # cross[i, j] = z_i × Jv_j and zz[i, j] = z_i × z_j for every pair.
    cross_v = _pairwise_cross(z, Jv)
    cross_w = _pairwise_cross(z, z)
    upper = np.triu(np.ones((n, n), dtype=bool), 1)[:, :, None]  # i < j
    dv = np.where(upper, cross_v, cross_v.transpose(1, 0, 2))  # i ≥ j: zⱼ × Jᵥ,ᵢ
    dw = np.where(upper, cross_w, 0.0)
    out = np.empty((n, 6, n))
    out[:, :3, :] = dv.transpose(0, 2, 1)
    out[:, 3:, :] = dw.transpose(0, 2, 1)
    return out


def _kernel() -> Any:
    """The compiled kernel's entry point, None without the kernels (or when switched off)."""
    from ..linalg import _backend

    if _backend.kernels() is None or not KERNELS.ready():
        return None
    if _KERNEL[0] is None:
        warm = (np.zeros((6, 1)), np.zeros((1, 6, 1)))
        _KERNEL[0] = _backend.entry(KERNELS, "revolute_jacobian_derivatives", warm)
    return _KERNEL[0]


def _pairwise_cross(a: FloatArray, b: FloatArray) -> FloatArray:
    """``out[i, j] = a[i] × b[j]`` for ``(n, 3)`` arrays (np.cross is slow on small sizes)."""
    ax, ay, az = a[:, 0:1], a[:, 1:2], a[:, 2:3]
    bx, by, bz = b[:, 0], b[:, 1], b[:, 2]
    return np.stack((ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx), axis=-1)
