"""Scenario files: a robot, a path and the schemes to compare on it, as TOML
(docs/scenarios.md), and the comparison runs they describe.

- :mod:`.spec`: reading and checking a file (:func:`~.spec.load_scenario`), the built-in
  scenarios (shipped as ``data/*.toml``);
- :mod:`.registry`: the scheme types a file may name, each built by its class;
- :mod:`.runner`: running each scheme on the scenario's path (``redres run``);
- :mod:`.planned`: the schemes against the global optimum on the same path
  (:func:`~.planned.compare_with_plan`, ``redres plan``).
"""

from . import planned, registry, runner, spec

__all__ = ["planned", "registry", "runner", "spec"]
