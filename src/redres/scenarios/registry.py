"""The scheme types of scenario files, registered in one place.

Each scheme class (and the torque law :class:`~redres.dynamics.OperationalSpaceController`)
answers to the scenario ``type`` of its ``name``, or to its ``scenario_types`` (``("pinv",
"dls")``), and builds itself from that ``[[schemes]]`` table (a classmethod
``from_scenario(params)``, reading :class:`ScenarioParams`). :func:`scheme_types` maps each
name to its builder; :mod:`redres.scenarios.spec` loops over it, and its error for an unknown
type lists these names.
"""

from __future__ import annotations

from typing import Any

from .._toml import ScenarioBuilder, ScenarioParams

__all__ = ["ScenarioBuilder", "ScenarioParams", "scheme_types"]


_REGISTRY: dict[str, ScenarioBuilder] = {}


def scheme_types() -> dict[str, ScenarioBuilder]:
    """Scenario type name -> builder, for every registered scheme and torque law (in the
    order the names are listed to users)."""
    if not _REGISTRY:
        from ..dynamics import OperationalSpaceController
        from ..resolution import (
            AugmentedJacobianScheme,
            GradientProjectionScheme,
            PriorityScheme,
            PseudoInverseScheme,
            QPScheme,
            SNSScheme,
            WeightedLeastNormScheme,
        )

        classes: tuple[Any, ...] = (
            PseudoInverseScheme,
            GradientProjectionScheme,
            WeightedLeastNormScheme,
            AugmentedJacobianScheme,
            PriorityScheme,
            QPScheme,
            SNSScheme,
            OperationalSpaceController,
        )
        for cls in classes:
            names = cls.scenario_types or (cls.name,)
            _REGISTRY.update(dict.fromkeys(names, cls.from_scenario))
    return dict(_REGISTRY)
