"""Scenario files: a robot, a path and the schemes to compare on it, as TOML
(docs/scenarios.md), and the comparison runs they describe.

- :mod:`.spec`: reading and checking a file (:func:`load_scenario`), the built-in
  scenarios (shipped as ``data/*.toml``);
- :mod:`.registry`: the scheme types a file may name, each built by its class;
- :mod:`.runner`: running each scheme on the scenario's path (``redres run``).
"""

from .spec import (
    ScenarioError,
    ScenarioSpec,
    SchemeSpec,
    builtin,
    builtin_scenarios,
    load_scenario,
    parse_scenario,
)

__all__ = [
    "ScenarioError",
    "ScenarioSpec",
    "SchemeSpec",
    "builtin",
    "builtin_scenarios",
    "load_scenario",
    "parse_scenario",
]
