"""Minimum-norm resolved motion rate control: ``q̇ = J# ẋ`` (seed 000 eq. 3, seed 002).

With the exact inverse this is ``Jᵀ(JJᵀ)⁻¹ẋ``, the joint velocity of least norm that
achieves ``ẋ``; near singularities choose ``"damped"`` (Nakamura–Hanafusa, Wampler) or
``"adaptive"`` so that the joint speed stays bounded.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .._validate import FloatArray
from ..linalg import rate_step
from .base import InverseChoice, Scheme, StepResult, as_inverse

if TYPE_CHECKING:
    from ..robot import Robot


class PseudoInverseScheme(Scheme):
    """``q̇ = J# ẋ`` with the chosen inverse; identifier ``pinv`` (exact, SVD) or ``dls``
    (damped, adaptive).

    Args:
        inverse: ``"exact"``, ``"svd"``, ``"damped"``, ``"adaptive"`` or an
            :class:`InverseChoice`; keyword parameters (``damping``, ``threshold``,
            ``max_damping``, ``rcond``) are passed to it.
    """

    def __init__(self, inverse: InverseChoice | str = "exact", **inverse_params: Any) -> None:
        self.inverse = as_inverse(inverse, **inverse_params)
        self.name = "dls" if self.inverse.kind in ("damped", "adaptive") else "pinv"
        self._kwargs = self.inverse.rate_kwargs()

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        qd, info = rate_step(J, xd, **self._kwargs)
        return StepResult(qd, info, np.zeros(qd.shape[0]))
