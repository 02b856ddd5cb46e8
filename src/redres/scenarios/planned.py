"""A scenario's local schemes against the global optimum on the same path.

:func:`compare_with_plan` runs every scheme of a scenario (:func:`~.runner.run_scenario`)
and plans the same path from the same start by dynamic programming
(:func:`redres.plan.plan_path`; Ferrentino, Salvioli & Chiacchio, Robotics 10(1):42,
2021), then gives each scheme's value of the objective as a share of the optimum:
"gradient projection: min margin 0.277 rad, 57 % of the optimum 0.483 rad". The plan is
optimal over its grid, so a local scheme's value can pass it only by what the grid leaves
out (parameter values between the grid's: the refinement study of
docs/theory/dp_planning.md) or by leaving the path (torque control tracks it within
millimetres, not exactly).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any, Literal

import numpy as np

from ..control import RunLog
from ..errors import InvalidParameterError
from ..plan import PathPlan, clearances, plan_path
from .runner import aligned_table, run_scenario
from .spec import ScenarioSpec, builtin_scenarios, load_scenario

__all__ = ["COMPARED", "ComparisonRow", "PlanComparison", "compare_with_plan"]

Compared = Literal["joint_limit_margin", "obstacle_clearance", "path_length"]
#: The objectives compared, with what a run is measured by and its unit.
COMPARED = {
    "joint_limit_margin": ("min margin", "rad"),
    "obstacle_clearance": ("min clearance", "m"),
    "path_length": ("path length", "rad"),
}


@dataclass(frozen=True)
class ComparisonRow:
    """One scheme: its ``value`` of the objective (in the unit ``PlanComparison.unit`` names)
    and ``percent``, ``100 · value / optimum``."""

    scheme: str
    value: float
    percent: float


@dataclass(frozen=True)
class PlanComparison:
    """What :func:`compare_with_plan` found.

    Attributes:
        scenario: its name. objective: the objective's name. unit: its unit.
        optimum: the plan's objective (NaN when no admissible path exists).
        rows: one per scheme, in the scenario's order.
        plan: the :class:`~redres.plan.PathPlan`. logs: the schemes' runs.
    """

    scenario: str
    objective: str
    unit: str
    optimum: float
    rows: tuple[ComparisonRow, ...]
    plan: PathPlan
    logs: tuple[RunLog, ...]

    def table(self) -> str:
        """The rows as aligned text, the plan first."""
        measure = COMPARED[self.objective][0]
        head = ("scheme", f"{measure} ({self.unit})", "% of the optimum")
        body = [("global plan (DP)", f"{self.optimum:+.4f}", "100.0")]
        body += [(r.scheme, f"{r.value:+.4f}", f"{r.percent:.1f}") for r in self.rows]
        return aligned_table(head, body)

    def lines(self) -> list[str]:
        """One sentence per scheme: "gradient projection: min margin 0.277 rad, 57.4 % of
        the optimum 0.483 rad" (the optimum's own line when no path exists)."""
        measure = COMPARED[self.objective][0]
        if not math.isfinite(self.optimum):
            first = self.plan.stats.first_infeasible
            first = self.plan.stats.first_unreachable if first is None else first
            return [f"{self.scenario}: no admissible path for the global plan (first "
                    f"impossible sample {first})"]  # fmt: skip
        return [
            f"{r.scheme}: {measure} {r.value:.3f} {self.unit}, {r.percent:.1f} % of the "
            f"optimum {self.optimum:.3f} {self.unit}"
            for r in self.rows
        ]

    def summary(self) -> dict[str, Any]:
        """The comparison as plain data (JSON): scenario, objective, unit, optimum and
        one ``{scheme, value, percent}`` per scheme."""

        def number(x: float) -> float | None:
            return x if math.isfinite(x) else None

        return {
            "scenario": self.scenario, "objective": self.objective, "unit": self.unit,
            "optimum": number(self.optimum),
            "rows": [{"scheme": r.scheme, "value": number(r.value), "percent": number(r.percent)}
                     for r in self.rows],
        }  # fmt: skip


def compare_with_plan(
    scenario: ScenarioSpec | str,
    *,
    objective: Compared = "joint_limit_margin",
    resolution: int = 360,
    parameter: Literal["q7", "arm_angle"] | None = None,
    dt: float = 0.01,
    clearance: float | None = None,
    duration: float | None = None,
    progress: bool | None = False,
    qdd_max: float | None = None,
    logs: Sequence[RunLog] | None = None,
) -> PlanComparison:
    """Run the scenario's schemes and plan its path; each scheme's objective against the
    optimum (module docstring).

    Args:
        scenario: a :class:`~.spec.ScenarioSpec`, a scenario file or a built-in name.
        objective: ``"joint_limit_margin"`` (the smallest margin along the run, rad),
            ``"obstacle_clearance"`` (the smallest clearance to the scenario's
            obstacles, m, each run's at every step) or ``"path_length"``
            (``Σ ‖Δq‖``, rad).
        resolution, parameter: the plan's grid (:func:`redres.plan.plan_path`).
        dt: s between the plan's samples.
        clearance: the plan's nodes keep this clearance to the scenario's obstacles, m
            (None: obstacles are no constraint, except for ``"obstacle_clearance"``,
            which keeps 0).
        duration: s of the path (default the scenario's).
        progress: the runs' progress bars.
        qdd_max: the plan's acceleration limit, rad/s² (None: none).
        logs: the scenario's runs, if already run (``redres run`` passes its own);
            default: run them here.

    Raises:
        InvalidParameterError: an objective not compared here; ``"obstacle_clearance"``
            for a scenario without obstacles.
        ScenarioError: a scenario that cannot be read (an unknown name among them).
    """
    if objective not in COMPARED:
        raise InvalidParameterError(
            f"objective must be one of {list(COMPARED)} to compare; got {objective!r}"
        )
    spec = scenario if isinstance(scenario, ScenarioSpec) else _load(scenario)
    if duration is not None:
        spec = replace(spec, duration=min(spec.duration, float(duration)))
    if objective == "obstacle_clearance" and not spec.obstacles:
        raise InvalidParameterError(
            f"scenario {spec.name!r} has no obstacles: 'obstacle_clearance' needs [[obstacles]]"
        )
    keep = objective == "obstacle_clearance" or clearance is not None
    count = math.floor(spec.duration / dt + 1e-9) + 1
    poses = np.array([spec.trajectory.sample(k * dt).pose for k in range(count)])
    plan = plan_path(spec.robot, poses, dt=dt, parameter=parameter, resolution=resolution,
                     objective=objective, q0=spec.q0, qdd_max=qdd_max,
                     obstacles=spec.obstacles if keep else None,
                     clearance=0.0 if clearance is None else clearance)  # fmt: skip
    logs = tuple(run_scenario(spec, progress=progress) if logs is None else logs)
    rows = tuple(
        ComparisonRow(log.label or log.scheme, value, 100.0 * value / plan.objective)
        for log in logs
        for value in [_measure(spec, log, objective)]
    )
    unit = COMPARED[objective][1]
    return PlanComparison(spec.name, objective, unit, plan.objective, rows, plan, logs)


def _measure(spec: ScenarioSpec, log: RunLog, objective: str) -> float:
    """The run's value of ``objective`` over every step it logged."""
    q = np.asarray(log.q)
    if objective == "joint_limit_margin":
        return float(np.minimum(q - spec.robot.q_min, spec.robot.q_max - q).min())
    if objective == "obstacle_clearance":
        return float(clearances(spec.robot, q, spec.obstacles).min())
    return float(np.linalg.norm(np.diff(q, axis=0), axis=1).sum())


def _load(name: str) -> ScenarioSpec:
    """A scenario file, or the built-in scenario of that name when no such file exists."""
    builtin: dict[str, Any] = builtin_scenarios()
    if name in builtin and not Path(name).exists():
        return load_scenario(builtin[name])
    return load_scenario(name)
