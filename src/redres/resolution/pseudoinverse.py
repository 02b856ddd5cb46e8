"""Minimum-norm resolved motion rate control: ``q̇ = J# ẋ`` (Whitney 1969).

With the exact inverse this is ``Jᵀ(JJᵀ)⁻¹ẋ``, the joint velocity of least norm that
achieves ``ẋ``; near singularities give a ``damping`` (Nakamura–Hanafusa, Wampler) or an
:class:`~redres.linalg.AdaptiveDamping` so that the joint speed stays bounded.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .._validate import FloatArray, checked_keywords
from ..linalg import AdaptiveDamping, rate_step
from .base import Inverse, Scheme, StepResult, make_inverse

if TYPE_CHECKING:
    from .._toml import ScenarioParams
    from ..robot import Robot


class PseudoInverseScheme(Scheme):
    """``q̇ = J# ẋ`` with the chosen inverse; identifier ``pinv`` (exact) or ``dls``
    (damped or adaptively damped).

    Args:
        inverse: an :class:`~redres.resolution.Inverse`; or give ``damping``/``rcond``.
        damping: ``λ ≥ 0`` of damped least squares ``Jᵀ(JJᵀ + λ²I)⁻¹`` (units of ``J``,
            m for position rows) or an :class:`~redres.linalg.AdaptiveDamping`; default 0
            (exact).
        rcond: relative rank cut of the exact inverse (refused next to a damping).

    Raises:
        InvalidParameterError: a negative damping, ``rcond`` next to a damping, or both
            ``inverse`` and a keyword.
        UnknownParameterError: a misspelt keyword (the message names the valid ones).
    """

    #: Scenario ``type`` names (``dls``: damped, ``damping = 0.05`` unless given).
    scenario_types = ("pinv", "dls")

    @checked_keywords
    def __init__(
        self,
        inverse: Inverse | None = None,
        *,
        damping: float | AdaptiveDamping | None = None,
        rcond: float | None = None,
    ) -> None:
        """The arguments are described in ``help(PseudoInverseScheme)``."""
        self.inverse = make_inverse(inverse, damping, rcond)
        self.name = "pinv" if self.inverse.kind == "exact" else "dls"
        self._kwargs = self.inverse.rate_kwargs()

    @classmethod
    def from_scenario(cls, params: ScenarioParams) -> PseudoInverseScheme:
        """The scheme of a scenario table: the inverse keys only."""
        return cls(params.inverse(default_damping=0.05 if params.type == "dls" else None))

    def _step(self, robot: Robot, q: FloatArray, J: FloatArray, xd: FloatArray) -> StepResult:
        qd, info, _ = rate_step(J, xd, **self._kwargs)
        return StepResult(qd, info, np.zeros(qd.shape[0]))

    def __repr__(self) -> str:
        return f"PseudoInverseScheme({self.inverse!r})"
