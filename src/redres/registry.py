"""The scheme types of scenario files, registered in one place.

Each scheme class (and the torque law :class:`~redres.dynamics.OperationalSpaceController`)
answers to the scenario ``type`` of its ``name``, or to its ``scenario_types`` (``("pinv",
"dls")``), and builds itself from that ``[[schemes]]`` table (a classmethod
``from_scenario(params)``, reading :class:`ScenarioParams`). :func:`scheme_types` maps each
name to its builder; :mod:`redres.scenario` loops over it, and its error for an unknown
type lists these names.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    from .objectives import Objective
    from .resolution import Inverse
    from .tasks import Task

__all__ = ["ScenarioBuilder", "ScenarioParams", "scheme_types"]


class ScenarioParams(Protocol):
    """Typed, validated access to one ``[[schemes]]`` table of a scenario file.

    Every read marks the key as valid for this table; a key nobody reads is reported
    as unknown, with the valid ones. Reading twice gives the same values, so a builder
    may be called once per run.

    Attributes:
        type: the scheme type the table names (``"pinv"``, ``"dls"``, ...).
        dt: the run's control period, s.
    """

    type: str
    dt: float

    def number(self, key: str, default: float) -> float:
        """A finite number (``default`` when the key is absent)."""
        ...

    def nonnegative(self, key: str, default: float) -> float:
        """A number ≥ 0, e.g. a gain."""
        ...

    def positive(self, key: str, default: float) -> float:
        """A number > 0."""
        ...

    def string(self, key: str, default: str) -> str:
        """A string."""
        ...

    def objectives(self) -> list[tuple[Objective, float]]:
        """The ``objectives = [...]`` list as ``(objective, weight)`` pairs (may be empty)."""
        ...

    def levels(self) -> list[Task]:
        """The ``levels = [...]`` list as fresh tasks, highest priority first (≥ 1)."""
        ...

    def inverse(self, default_damping: float | None = None) -> Inverse | None:
        """The inverse from ``damping = λ``, or ``max_damping`` and ``threshold`` (the
        adaptive law), or ``rcond``; ``None`` when none is given and there is no
        ``default_damping`` (the scheme's own default applies)."""
        ...

    def fail(self, key: str, message: str) -> Exception:
        """The error for ``key`` of this table, naming the file and key path."""
        ...


#: Builds one scheme (or torque law) from its table; called once per run.
ScenarioBuilder = Callable[[ScenarioParams], Any]


_REGISTRY: dict[str, ScenarioBuilder] = {}


def scheme_types() -> dict[str, ScenarioBuilder]:
    """Scenario type name -> builder, for every registered scheme and torque law (in the
    order the names are listed to users)."""
    if not _REGISTRY:
        from .dynamics import OperationalSpaceController
        from .resolution import (
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
