"""Scheme statistics: the schemes of a scenario over many random paths.

A unit of the sweep is one random path: a start configuration drawn within the joint
limits (``margin`` inside them) from the shard's generator ``default_rng([seed, k])``,
and from the frame's pose there either a circle (radius uniform in ``radius``, a normal
uniform on the sphere, one turn in ``duration``) or a straight line (length uniform in
``length``, a direction uniform on the sphere, a minimum-jerk time law over
``duration``), with probability ``circles`` for a circle. Every scheme of the scenario
runs it through :func:`redres.run` (the :class:`~redres.Controller`; torque laws
through :func:`redres.dynamics.simulate`) with the scenario's ``dt`` and ``gain``; a
query is one control step, so a shard of 10⁴ queries is a few paths.

Stored per path and scheme: ``success`` (the run finished and its largest position
error stayed within ``success_tol``), ``violations`` (steps with a joint beyond a
position limit), ``max_error`` and ``rms_error`` (m), ``singular`` (steps where the
task Jacobian's smallest singular value was below ``singular_sigma``) and ``step_us``
(the median wall time of a control step, µs); per path its start ``q0``, its ``shape``
(0 circle, 1 line) and ``size`` (radius or length, m). Every field but ``step_us`` (a
clock reading) is the same, byte for byte, however the sweep is run.
:func:`summary` and :func:`table` summarise per scheme.
"""

from __future__ import annotations

import hashlib
import math
from dataclasses import dataclass
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

__all__ = ["SCHEME_STATISTICS", "SchemeStatsParams", "summary", "table"]

#: The fields stored per path and scheme, and their dtypes.
_PER_SCHEME = {"success": "bool", "violations": "int64", "max_error": "float64",
               "rms_error": "float64", "singular": "int64", "step_us": "float64"}  # fmt: skip


@dataclass(frozen=True)
class SchemeStatsParams:
    """The ``[scheme_statistics]`` table.

    Attributes:
        scenario: the scenario file's text (a built-in name or a path in the spec).
        scenario_name: its file name (for messages).
        paths: random paths.
        circles: share of circles (the rest are lines).
        radius, length: ``[min, max]`` of the circles' radii and the lines' lengths, m.
        duration: of each path, s.
        margin: start configurations this far inside the limits, rad.
        success_tol: largest position error of a successful run, m.
        singular_sigma: smallest singular value below which a step is singular.
    """

    scenario: str
    scenario_name: str
    paths: int = 100
    circles: float = 0.5
    radius: tuple[float, float] = (0.05, 0.15)
    length: tuple[float, float] = (0.1, 0.3)
    duration: float = 2.0
    margin: float = 0.3
    success_tol: float = 1e-3
    singular_sigma: float = 0.05

    def settings(self) -> dict[str, Any]:
        out = dict(self.__dict__)
        out["scenario"] = hashlib.sha256(self.scenario.encode()).hexdigest()
        return out


def _parse(r: Reader, base: Path) -> SchemeStatsParams:
    from ...scenarios.spec import scenario_text

    text, file = scenario_text(r, "scenario", r.string("scenario"), base)
    pair = []
    for key, default in (("radius", (0.05, 0.15)), ("length", (0.1, 0.3))):
        v = r.get(key, "vector", np.array(default), size=2)
        if not 0 < v[0] <= v[1]:
            raise r.fail(key, "expected [min, max] with 0 < min <= max (m)")
        pair.append((float(v[0]), float(v[1])))
    circles = r.nonnegative("circles", 0.5)
    if circles > 1:
        raise r.fail("circles", f"is a share, between 0 and 1; got {circles}")
    params = SchemeStatsParams(
        text, file, r.integer("paths", 100, minimum=1), circles, pair[0], pair[1],
        r.positive("duration", 2.0), r.nonnegative("margin", 0.3),
        r.positive("success_tol", 1e-3), r.nonnegative("singular_sigma", 0.05),
    )  # fmt: skip
    r.done()
    _scenario(params)  # refuse a bad scenario now, not in a worker
    return params


def _scenario(p: SchemeStatsParams) -> ScenarioSpec:
    from ...scenarios.spec import parse_scenario

    return parse_scenario(tomllib.loads(p.scenario), p.scenario_name)


def _plan(spec: SweepSpec, robot: Robot) -> Plan:
    from ..kind import SweepSpecError
    from ..source import model_digest

    p: SchemeStatsParams = spec.params
    scenario = _scenario(p)
    if model_digest(scenario.robot) != model_digest(robot, spec.robot.frame):
        raise SweepSpecError(f"{spec.file}: [robot] must be the robot of the scenario "
                             f"{p.scenario_name} ({scenario.robot.name})")  # fmt: skip
    count = len(scenario.schemes)
    steps = max(1, round(p.duration / scenario.dt))
    fields = {name: Field(dtype, (count,)) for name, dtype in _PER_SCHEME.items()}
    fields["q0"] = Field("float64", (scenario.robot.n,), "start configuration, rad")
    fields["shape"] = Field("int64", (), "0: circle, 1: line")
    fields["size"] = Field("float64", (), "radius or length, m")
    labels = [s.label for s in scenario.schemes]
    return Plan(p.paths, count * steps, fields, meta={"labels": labels})


def _path(robot: Robot, p: SchemeStatsParams, rng: np.random.Generator) -> tuple[Any, ...]:
    from ...control import Circle, Line

    q0 = robot.random_configuration(rng, margin=p.margin)
    start = robot.fk(q0)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    if rng.random() < p.circles:
        size = float(rng.uniform(*p.radius))
        return q0, 0, size, Circle(start, size, p.duration, normal=axis)
    size = float(rng.uniform(*p.length))
    return q0, 1, size, Line(start, start[:3, 3] + size * axis, p.duration)


def _run(job: ShardJob, robot: Robot) -> dict[str, np.ndarray]:
    from ...control import run
    from ...dynamics import simulate
    from ...errors import SimulationError

    p: SchemeStatsParams = job.params
    scenario = _scenario(p)
    robot = scenario.robot
    rng = job.rng()
    count, schemes = job.stop - job.start, scenario.schemes
    out: dict[str, np.ndarray] = {
        name: np.zeros((count, len(schemes)), dtype=dtype) for name, dtype in _PER_SCHEME.items()
    }
    out.update(q0=np.zeros((count, robot.n)), shape=np.zeros(count, dtype=np.int64),
               size=np.zeros(count))  # fmt: skip
    for i in range(count):
        q0, shape, size, path = _path(robot, p, rng)
        out["q0"][i], out["shape"][i], out["size"][i] = q0, shape, size
        for s, scheme in enumerate(schemes):
            common: dict[str, Any] = {"dt": scenario.dt, "duration": p.duration, "q0": q0,
                                      "progress": False}  # fmt: skip
            try:
                if scheme.kind == "osc":
                    log = simulate(robot, scheme.build(), path, **common)
                else:
                    log = run(robot, scenario.task(), path, scheme.build(), gain=scenario.gain,
                              **common)  # fmt: skip
            except SimulationError:
                out["max_error"][i, s] = out["rms_error"][i, s] = math.inf
                continue
            error = log.position_error
            out["max_error"][i, s] = float(error.max())
            out["rms_error"][i, s] = float(np.sqrt(np.mean(error**2)))
            out["success"][i, s] = out["max_error"][i, s] <= p.success_tol
            out["violations"][i, s] = int((log.joint_limit_margin < 0).sum())
            out["singular"][i, s] = int((log.sigma_min < p.singular_sigma).sum())
            out["step_us"][i, s] = float(np.median(log.step_time_ns) / 1e3)
    return out


def summary(out: str | Path) -> list[dict[str, Any]]:
    """Per scheme of the sweep in ``out``, a row: ``scheme`` (label), ``paths``,
    ``success_pct`` (paths tracked within ``success_tol``), ``violating_pct`` (paths with
    a step beyond a position limit), ``violation_steps`` (their mean count of such
    steps), ``rms_error_median_m`` and ``rms_error_max_m`` (RMS tracking error of a path,
    m; ``inf`` where a simulation failed), ``singular_pct`` (paths with a singular step),
    ``step_us_median`` (the median of the paths' median step times, µs)."""
    from ..results import load

    data = load(out)
    rows = []
    for s, label in enumerate(data.meta["labels"]):
        rms, violations = data["rms_error"][:, s], data["violations"][:, s]
        rows.append({
            "scheme": str(label), "paths": len(rms),
            "success_pct": float(100 * data["success"][:, s].mean()),
            "violating_pct": float(100 * (violations > 0).mean()),
            "violation_steps": float(violations.mean()),
            "rms_error_median_m": float(np.median(rms)), "rms_error_max_m": float(rms.max()),
            "singular_pct": float(100 * (data["singular"][:, s] > 0).mean()),
            "step_us_median": float(np.median(data["step_us"][:, s])),
        })  # fmt: skip
    return rows


def table(out: str | Path) -> str:
    """:func:`summary` as aligned text: success rate, runs with a limit violation,
    median and worst RMS tracking error, runs with singular steps, median step time."""
    from ...scenarios.runner import column_table

    columns: list[tuple[str, Callable[[dict[str, Any]], str]]] = [
        ("scheme", lambda r: str(r["scheme"])),
        ("success %", lambda r: f"{r['success_pct']:.1f}"),
        ("violating %", lambda r: f"{r['violating_pct']:.1f}"),
        ("rms err mm (median)", lambda r: f"{1e3 * r['rms_error_median_m']:.3f}"),
        ("rms err mm (max)", lambda r: f"{1e3 * r['rms_error_max_m']:.3f}"),
        ("singular %", lambda r: f"{r['singular_pct']:.1f}"),
        ("step us", lambda r: f"{r['step_us_median']:.1f}"),
    ]
    return column_table(columns, summary(out))


#: The sweep kind ``scheme_statistics``: each scheme of a scenario over random starts.
SCHEME_STATISTICS = Kind(
    "scheme_statistics",
    "scheme statistics: random circles and lines x the schemes of a scenario",
    _parse,
    _plan,
    _run,
    warmup=("linalg", "derivatives", "controller", "hard limits"),
)
