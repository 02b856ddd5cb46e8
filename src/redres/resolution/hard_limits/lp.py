"""The largest task scale inside a joint-velocity box, by linear programming.

``max s  s.t.  J q̇ = s ẋ,  lower ≤ q̇ ≤ upper,  0 ≤ s ≤ 1``: the largest fraction of the
task velocity ``ẋ``, in its own direction, that some joint velocity of the box achieves.
SNS (:mod:`.sns`) uses it whenever its greedy saturation ends scaled. Solved exactly by a
bounded-variable primal simplex with Bland's rule (Dantzig 1963 ch. 18; Chvátal 1983
ch. 8), compiled in :mod:`._lp_kernels`; when no scale is feasible, its first phase gives
the velocity whose task velocity is nearest, in the 1-norm, to the segment ``{s ẋ}``.

References:
    G. B. Dantzig, Linear Programming and Extensions, Princeton, 1963.
    V. Chvátal, Linear Programming, Freeman, 1983.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from ..._validate import FloatArray, as_matrix, as_vector, real_array
from ...errors import ShapeError
from ._codes import LP_SCALED
from ._compiled import kernels


class ScaleResult(NamedTuple):
    """What :func:`largest_scale` finds.

    Attributes:
        scale: the largest ``s ∈ [0, 1]`` (when ``feasible``; else the scale of ``qd``).
        qd: a joint velocity of the box achieving it (a vertex), shape ``(n,)``, rad/s.
        feasible: whether any scale in ``[0, 1]`` is feasible; if not, ``qd`` is the
            velocity whose task velocity is nearest, in the 1-norm, to ``{s ẋ : 0 ≤ s ≤ 1}``.
    """

    scale: float
    qd: FloatArray
    feasible: bool


def largest_scale(J: ArrayLike, xd: ArrayLike, lower: ArrayLike, upper: ArrayLike) -> ScaleResult:
    """The largest ``s ∈ [0, 1]`` with ``J q̇ = s ẋ`` for some ``q̇`` in the box (simplex).

    Args:
        J: task Jacobian, shape ``(m, n)``.
        xd: task velocity, shape ``(m,)``.
        lower, upper: the joint-velocity box, shapes ``(n,)``, rad/s (``lower ≤ upper``).
    """
    J = as_matrix(J, "J")
    m, n = J.shape
    xd = as_vector(xd, "xd", m)
    lo = np.ascontiguousarray(real_array(lower, "lower"))
    hi = np.ascontiguousarray(real_array(upper, "upper"))
    if lo.shape != (n,) or hi.shape != (n,):
        raise ShapeError(f"lower and upper must have shape ({n},); got {lo.shape}, {hi.shape}")
    if np.isnan(lo).any() or np.isnan(hi).any() or np.any(lo > hi):
        raise ShapeError("lower and upper must be free of NaN with lower <= upper")
    qd = np.empty(n)
    method, s = kernels("_lp_kernels").largest_scale(J, xd, lo, hi, qd, False, 0.0)
    return ScaleResult(float(s), qd, bool(method == LP_SCALED))
