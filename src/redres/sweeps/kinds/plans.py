"""Path plans: the global optimum along scenarios' paths over a grid of settings, sharded.

A unit of the sweep is one :func:`redres.plan_path` call (dynamic programming over the
self-motion; Ferrentino, Salvioli & Chiacchio, Robotics 10(1):42, 2021): one of the
``scenarios``' paths (sampled every ``dt`` over its duration, or ``duration`` s of it),
planned at one ``resolution`` (parameter values per sample) for one ``objective`` under
one acceleration limit ``qdd_max`` (0: none). The units are the Cartesian product of
those lists, in the order scenario, objective, qdd_max, dt, resolution (the last
varying fastest), so a refinement study, a comparison of objectives and a study of
acceleration limits are each one spec. A query is a node of the largest grid (samples ×
values × 8 branches), so a shard of the default 10⁴ queries is one plan: large grids
run in parallel, one per worker.

Stored per unit: ``objective`` (the optimum, NaN without a path), ``feasible``,
``min_margin`` (rad), ``path_length`` (rad), the grid's ``nodes``, ``feasible_nodes``,
``transitions``, ``components``, ``first_impossible`` (the first sample without a
feasible node, else the first no path reaches; −1: none), ``seconds`` (the plan's wall
time, a clock reading) and the joint path ``q`` ``(samples, n)`` (NaN rows past the
unit's own samples, or without a path); the settings of each unit as ``scenario``,
``objective_index``, ``qdd_max``, ``dt``, ``resolution``. Every field but ``seconds`` is
the same, byte for byte, however the sweep is run. :func:`table` lists the units.
"""

from __future__ import annotations

import hashlib
import math
import time
from dataclasses import dataclass
from itertools import product
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..._toml import tomllib
from ..kind import Field, Kind, Plan, ShardJob

if TYPE_CHECKING:
    from collections.abc import Callable

    from ..._toml import Reader
    from ...robot import Robot
    from ...scenarios.spec import ScenarioSpec
    from ..kind import SweepSpec

__all__ = ["PATH_PLANS", "PathPlansParams", "table"]

#: The objectives a unit may plan for.
PLAN_OBJECTIVES = ("joint_limit_margin", "manipulability", "path_length")


@dataclass(frozen=True)
class PathPlansParams:
    """The ``[path_plans]`` table.

    Attributes:
        scenarios: the scenario files' texts (built-in names or paths in the spec); their
            robot is the spec's.
        scenario_names: their file names (for messages and the results).
        resolutions: parameter values per sample (each ≥ 2).
        objectives: names of :data:`PLAN_OBJECTIVES`.
        qdd_max: acceleration limits, rad/s² (0: none).
        dts: s between samples.
        parameter: ``"q7"``, ``"arm_angle"`` or ``""`` (the robot's default).
        duration: s of each path planned (0: the scenario's whole duration).
        free_start: leave the start free instead of the scenario's ``q0``.
    """

    scenarios: tuple[str, ...]
    scenario_names: tuple[str, ...]
    resolutions: tuple[int, ...] = (90, 180, 360)
    objectives: tuple[str, ...] = ("joint_limit_margin",)
    qdd_max: tuple[float, ...] = (0.0,)
    dts: tuple[float, ...] = (0.01,)
    parameter: str = ""
    duration: float = 0.0
    free_start: bool = False

    def settings(self) -> dict[str, Any]:
        out = dict(self.__dict__)
        out["scenarios"] = [hashlib.sha256(s.encode()).hexdigest() for s in self.scenarios]
        return out

    def units(self) -> list[tuple[int, int, float, float, int]]:
        """Every unit's ``(scenario, objective index, qdd_max, dt, resolution)``."""
        return list(product(range(len(self.scenarios)), range(len(self.objectives)),
                            self.qdd_max, self.dts, self.resolutions))  # fmt: skip


def _parse(r: Reader, base: Path) -> PathPlansParams:
    from ...scenarios.spec import scenario_text

    texts, files = [], []
    for name in _strings(r, "scenarios", None):
        text, file = scenario_text(r, "scenarios", name, base)
        texts.append(text)
        files.append(file)
    if not texts:
        raise r.fail("scenarios", "give at least one scenario")
    resolutions = r.get("resolutions", "vector", np.array([90.0, 180.0, 360.0]))
    if len(resolutions) == 0 or any(v < 2 or not float(v).is_integer() for v in resolutions):
        raise r.fail("resolutions", "expected integers >= 2 (parameter values per sample)")
    objectives = tuple(_strings(r, "objectives", ["joint_limit_margin"]))
    for objective in objectives:
        if objective not in PLAN_OBJECTIVES:
            raise r.fail("objectives", f"use names of {list(PLAN_OBJECTIVES)}; got {objective!r}")
    qdd = r.get("qdd_max", "vector", np.array([0.0]))
    dts = r.get("dts", "vector", np.array([0.01]))
    for key, values in (("qdd_max", qdd), ("dts", dts)):
        if len(values) == 0 or (values < 0).any() or (key == "dts" and (values <= 0).any()):
            raise r.fail(key, "expected a non-empty list of numbers > 0 (qdd_max: 0 is none)")
    parameter = r.string("parameter", "")
    if parameter not in ("", "q7", "arm_angle"):
        raise r.fail("parameter", f"use 'q7' or 'arm_angle'; got {parameter!r}")
    params = PathPlansParams(
        tuple(texts), tuple(files), tuple(int(v) for v in resolutions), objectives,
        tuple(float(v) for v in qdd), tuple(float(v) for v in dts), parameter,
        r.nonnegative("duration", 0.0), r.boolean("free_start", False),
    )  # fmt: skip
    r.done()
    for s in range(len(texts)):
        _scenario(params, s)  # refuse a bad scenario now, not in a worker
    return params


def _strings(r: Reader, key: str, default: list[str] | None) -> list[str]:
    """The list of strings at ``key`` (``default`` when absent; None: required)."""
    r.used.add(key)
    if key not in r.table:
        if default is None:
            raise r.fail(key, f'missing; add `{key} = ["..."]`')
        return default
    value = r.table[key]
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise r.fail(key, f'expected a list of strings, got {value!r} (write {key} = ["..."])')
    return value


def _scenario(p: PathPlansParams, index: int) -> ScenarioSpec:
    from ...scenarios.spec import parse_scenario

    return parse_scenario(tomllib.loads(p.scenarios[index]), p.scenario_names[index])


def _samples(p: PathPlansParams, scenario: ScenarioSpec, dt: float) -> int:
    duration = scenario.duration if p.duration == 0 else min(p.duration, scenario.duration)
    return math.floor(duration / dt + 1e-9) + 1


def _plan(spec: SweepSpec, robot: Robot) -> Plan:
    from ..kind import SweepSpecError
    from ..source import model_digest

    p: PathPlansParams = spec.params
    scenarios = [_scenario(p, s) for s in range(len(p.scenarios))]
    for name, scenario in zip(p.scenario_names, scenarios):
        if model_digest(scenario.robot) != model_digest(robot, spec.robot.frame):
            raise SweepSpecError(f"{spec.file}: [robot] must be the robot of the scenario "
                                 f"{name} ({scenario.robot.name})")  # fmt: skip
    samples = max(_samples(p, sc, dt) for sc in scenarios for dt in p.dts)
    units = p.units()
    fields = {
        "objective": Field("float64", (), "the optimum (NaN: no path)"),
        "feasible": Field("bool"), "min_margin": Field("float64", (), "rad"),
        "path_length": Field("float64", (), "rad"), "nodes": Field("int64"),
        "feasible_nodes": Field("int64"), "transitions": Field("int64"),
        "components": Field("int64"),
        "first_impossible": Field("int64", (), "first sample without a path (-1: none)"),
        "seconds": Field("float64", (), "wall time of the plan, s"),
        "q": Field("float64", (samples, robot.n), "the joint path, rad (NaN past its end)"),
    }  # fmt: skip
    columns = np.array(units, dtype=np.float64)  # (units, 5)
    inputs = {"unit": columns}
    tables = {"scenario": columns[:, 0].astype(np.int64),
              "objective_index": columns[:, 1].astype(np.int64), "qdd_max": columns[:, 2],
              "dt": columns[:, 3], "resolution": columns[:, 4].astype(np.int64)}  # fmt: skip
    meta = {"scenarios": list(p.scenario_names), "objectives": list(p.objectives)}
    return Plan(len(units), samples * max(p.resolutions) * 8, fields, inputs,
                {"samples": np.array([samples])}, tables, meta)  # fmt: skip


def _run(job: ShardJob, robot: Robot) -> dict[str, np.ndarray]:
    from ...plan import plan_path

    p: PathPlansParams = job.params
    rows = job.inputs["unit"]
    count = len(rows)
    out: dict[str, np.ndarray] = {
        "objective": np.full(count, np.nan), "feasible": np.zeros(count, bool),
        "min_margin": np.full(count, np.nan), "path_length": np.full(count, np.nan),
        "nodes": np.zeros(count, np.int64), "feasible_nodes": np.zeros(count, np.int64),
        "transitions": np.zeros(count, np.int64), "components": np.zeros(count, np.int64),
        "first_impossible": np.full(count, -1, np.int64), "seconds": np.zeros(count),
    }  # fmt: skip
    q_out = np.full((count, int(job.constants["samples"][0]), robot.n), np.nan)
    for i, (s, o, qdd, dt, resolution) in enumerate(rows):
        scenario = _scenario(p, int(s))
        K = _samples(p, scenario, float(dt))
        poses = np.array([scenario.trajectory.sample(k * dt).pose for k in range(K)])
        began = time.perf_counter()
        plan = plan_path(
            scenario.robot, poses, dt=float(dt), parameter=p.parameter or None,  # type: ignore[arg-type]
            resolution=int(resolution), objective=p.objectives[int(o)],  # type: ignore[arg-type]
            q0=None if p.free_start else scenario.q0, qdd_max=None if qdd == 0 else float(qdd),
        )  # fmt: skip
        out["seconds"][i] = time.perf_counter() - began
        stats = plan.stats
        first = stats.first_infeasible if stats.first_infeasible is not None else (
            stats.first_unreachable)  # fmt: skip
        out["objective"][i], out["feasible"][i] = plan.objective, plan.feasible
        out["min_margin"][i], out["path_length"][i] = plan.min_margin, plan.path_length
        out["nodes"][i], out["feasible_nodes"][i] = stats.nodes, stats.feasible_nodes
        out["transitions"][i], out["components"][i] = stats.transitions, stats.components
        out["first_impossible"][i] = -1 if first is None else first
        q_out[i, :K] = plan.q
    out["q"] = q_out
    return out


def _limit_text(value: float) -> str:
    """An acceleration limit in a table cell: ``none`` for 0 (no limit)."""
    return "none" if value == 0 else f"{value:g}"


def table(out: str | Path) -> str:
    """One line per unit of the sweep in ``out``: its settings, the optimum, whether a
    path exists, the grid's size and the plan's time."""
    from ...scenarios.runner import column_table
    from ..results import load

    data = load(out)
    names, objectives, tables = data.meta["scenarios"], data.meta["objectives"], data.tables
    columns: list[tuple[str, Callable[[int], str]]] = [
        ("scenario", lambda u: str(names[int(tables["scenario"][u])])),
        ("objective", lambda u: str(objectives[int(tables["objective_index"][u])])),
        ("qdd_max rad/s²", lambda u: _limit_text(float(tables["qdd_max"][u]))),
        ("dt s", lambda u: f"{float(tables['dt'][u]):g}"),
        ("values", lambda u: str(int(tables["resolution"][u]))),
        ("optimum", lambda u: f"{data['objective'][u]:.5f}" if data["feasible"][u] else "no path"),
        ("grid nodes", lambda u: f"{int(data['nodes'][u]):,}"),
        ("plan s", lambda u: f"{data['seconds'][u]:.2f}"),
    ]
    return column_table(columns, range(len(data["objective"])))


#: The sweep kind ``path_plans``: global plans over resolutions, objectives, limits, paths.
PATH_PLANS = Kind(
    "path_plans",
    "path plans: the global optimum along scenarios' paths x resolutions, objectives, limits",
    _parse,
    _plan,
    _run,
    warmup=("analytic ik", "batch", "plan"),
)
