"""Scenario files: a robot, a path, run settings, obstacles and the schemes to compare.

Read with :mod:`tomllib` only; nothing in a scenario is executed. Every problem is
reported as one :class:`ScenarioError` naming the file, the key path (``[schemes][2].k_null``)
and the fix. See docs/scenarios.md for the format; built-in scenarios ship in
``redres/scenarios/data`` (``redres run --list``).
"""

from __future__ import annotations

import importlib.util

__all__ = [
    "PlanSettings",
    "ScenarioError",
    "ScenarioSpec",
    "SchemeSpec",
    "builtin",
    "builtin_scenarios",
    "load_scenario",
    "parse_scenario",
]

from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from importlib import resources
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pinocchio as pin

from .. import models
from .._toml import Reader, load, tomllib
from ..collision import DEFAULT_GAIN, BoxObstacle, Collisions, PlaneObstacle
from ..control.analysis import run_steps
from ..control.trajectories import Circle, FigureEight, Hold, Line, MinimumJerk, Trajectory
from ..errors import MissingDependencyError, RedresError, install_hint
from ..linalg import AdaptiveDamping
from ..objectives import (
    CapsuleObstacle,
    JointLimitObjective,
    ManipulabilityObjective,
    Objective,
    Obstacle,
    ObstacleObjective,
    PostureObjective,
    SphereObstacle,
)
from ..resolution import Inverse, make_inverse
from ..robot import Robot
from ..tasks import ArmAngleTask, FrameTask, LookAtTask, PostureTask, Task
from .registry import scheme_types

_T = TypeVar("_T")


class ScenarioError(RedresError, ValueError):
    """A scenario file is unreadable or invalid (the message names the key and the fix)."""


@dataclass
class SchemeSpec:
    """A scheme to run: its stable identifier, a label, and a factory."""

    kind: str
    label: str
    build: Callable[[], Any]  # a Scheme, or a torque law for "osc"


@dataclass(frozen=True)
class PlanSettings:
    """A scenario's ``[plan]`` table: plan its path globally and compare every scheme with
    the optimum (:func:`redres.scenarios.planned.compare_with_plan`, whose keywords these
    are).

    Attributes:
        objective: ``"joint_limit_margin"``, ``"obstacle_clearance"`` or
            ``"path_length"``.
        resolution: parameter values per sample. parameter: ``"q7"``, ``"arm_angle"``
            or None (the robot's default). dt: s between the plan's samples.
        clearance: m the plan's nodes keep to the obstacles (None: no constraint).
        qdd_max: rad/s² the plan's accelerations keep (None: no limit).
    """

    objective: str = "joint_limit_margin"
    resolution: int = 360
    parameter: str | None = None
    dt: float = 0.01
    clearance: float | None = None
    qdd_max: float | None = None


#: What a ``[plan]`` table's ``objective`` may name.
PLAN_OBJECTIVES = ("joint_limit_margin", "obstacle_clearance", "path_length")


def _plan(r: Reader) -> PlanSettings:
    objective = r.string("objective", "joint_limit_margin")
    if objective not in PLAN_OBJECTIVES:
        raise r.fail("objective", f"use one of {list(PLAN_OBJECTIVES)}; got {objective!r}")
    parameter = r.get("parameter", "string", None)
    if parameter not in (None, "q7", "arm_angle"):
        raise r.fail("parameter", f"use 'q7' or 'arm_angle'; got {parameter!r}")
    clearance = r.get("clearance", "number", None)
    if clearance is not None and clearance < 0:
        raise r.fail("clearance", f"must be >= 0; got {clearance}")
    qdd = r.get("qdd_max", "number", None)
    if qdd is not None and qdd <= 0:
        raise r.fail("qdd_max", f"must be > 0; got {qdd}")
    return PlanSettings(objective, r.integer("resolution", 360, minimum=2), parameter,
                        r.positive("dt", 0.01), clearance, qdd)  # fmt: skip


@dataclass
class ScenarioSpec:
    """A validated scenario."""

    name: str
    description: str
    robot: Robot
    q0: np.ndarray
    task: Callable[[], FrameTask]
    trajectory: Trajectory
    dt: float
    duration: float
    gain: float
    obstacles: list[Obstacle]
    schemes: list[SchemeSpec] = field(default_factory=list)
    source: str = ""
    #: End each rate-control step in command shaping (``shaping = true`` in ``[run]``).
    shaping: bool = False
    #: What simulates the runs: ``"redres"`` or ``"mujoco"`` (``plant =`` in ``[run]``).
    plant: str = "redres"
    #: The robot's MJCF file, if it has one (what a MuJoCo plant loads).
    mjcf: Path | None = None
    #: The scenario's path from another start pose (4x4): a real robot starts where it is.
    trajectory_from: Callable[[np.ndarray], Trajectory] | None = None
    #: Plan the path globally and compare the schemes with the optimum (``[plan]``).
    plan: PlanSettings | None = None


def _robot(r: Reader, base: Path) -> tuple[Robot, np.ndarray, Path | None]:
    """The robot, its start configuration ``q0`` and its MJCF file (None for another)."""
    key, file = r.robot_source()
    tip = r.get("tip", "string", None)
    model = file if key == "model" else None
    mjcf: Path | None = None
    with r.blame(key):
        if key == "model":
            robot = models.load(file)
        elif key == "menagerie":  # a MuJoCo Menagerie arm (MUJOCO_MENAGERIE, or shipped)
            robot, mjcf = models.menagerie(file, tip=tip), models.menagerie_path(file)
        else:  # a path relative to the scenario file
            load = Robot.from_urdf if key == "urdf" else Robot.from_mjcf
            robot = load(base / file, tip=tip)
            mjcf = base / file if key == "mjcf" else None
    if tip is not None and model is not None:
        if tip not in robot.frames():
            raise r.fail("tip", f"unknown frame {tip!r}; frames: {', '.join(robot.frames())}")
        robot = robot.derived(tip=tip)
    limits = r.joint_limits(robot.n)
    if limits:
        with r.blame(None):  # the message names the limit
            robot = robot.with_limits(**limits)
    q0 = r.get("q0", "vector", None, size=robot.n)
    if q0 is None:
        q0 = robot.neutral()
    elif not robot.within_limits(q0):
        raise r.fail("q0", "is outside the joint limits; see `redres robots` for them")
    return robot, q0, mjcf


def _trajectory(r: Reader, start: np.ndarray) -> Trajectory:
    """The path of ``[trajectory]`` from the tip's pose ``start`` (checks reported here)."""
    with r.blame(None):
        kind = r.string("type")
        if kind == "circle":
            return Circle(
                start,
                r.positive("radius"),
                r.positive("period"),
                normal=r.get("normal", "vector", (0.0, 0.0, 1.0), size=3),
                phase=r.number("phase", 0.0),
                turns=r.positive("turns", 1.0),
                ramp=r.number("ramp", 0.0),
            )
        if kind == "figure_eight":
            return FigureEight(
                start,
                r.positive("width"),
                r.positive("height"),
                r.positive("period"),
                normal=r.get("normal", "vector", (0.0, 0.0, 1.0), size=3),
                turns=r.positive("turns", 1.0),
                ramp=r.number("ramp", 0.0),
            )
        if kind == "line":
            return Line(start, r.get("end", "vector", size=3), r.positive("duration"))
        if kind == "minimum_jerk":
            end = start.copy()
            end[:3, 3] = r.get("end_position", "vector", start[:3, 3], size=3)
            rotation = r.get("rotation", "vector", np.zeros(3), size=3)
            end[:3, :3] = start[:3, :3] @ pin.exp3(rotation)
            return MinimumJerk(start, end, r.positive("duration"))
        if kind == "hold":
            return Hold(start, r.positive("duration"))
        raise r.fail(
            "type",
            f"unknown trajectory {kind!r}; use circle, figure_eight, line, minimum_jerk or hold",
        )


def _blamed(parse: Callable[..., _T]) -> Callable[..., _T]:
    """``parse`` with a constructor's :class:`RedresError` reported at its table's path."""

    def wrapper(r: Reader, **kwargs: Any) -> _T:
        with r.blame(None):
            return parse(r, **kwargs)

    return wrapper


@_blamed
def _obstacle(r: Reader) -> Obstacle:
    kind = r.string("type")
    name = r.string("name", kind)
    if kind == "box":  # rpy: roll, pitch, yaw (rad) of the box axes, Rz(y) Ry(p) Rx(r)
        rpy = r.get("rpy", "vector", np.zeros(3), size=3)
        center, half = r.get("center", "vector", size=3), r.get("half_extents", "vector", size=3)
        return BoxObstacle(center, half, pin.rpy.rpyToMatrix(*rpy), name)
    if kind == "plane":  # the solid side: normal · x <= offset
        return PlaneObstacle(r.get("normal", "vector", size=3), r.number("offset", 0.0), name)
    radius = r.nonnegative("radius", 0.0)
    if kind in ("sphere", "point"):
        return SphereObstacle(r.get("center", "vector", size=3), radius, name)
    if kind == "capsule":
        return CapsuleObstacle(
            r.get("a", "vector", size=3), r.get("b", "vector", size=3), radius, name
        )
    raise r.fail("type", f"unknown obstacle {kind!r}; use sphere, point, capsule, box or plane")


@_blamed
def _objective(r: Reader, obstacles: list[Obstacle], n: int) -> tuple[Objective, float]:
    kind, weight = r.string("type"), r.nonnegative("weight", 1.0)
    if kind == "joint_limits":
        return JointLimitObjective(), weight
    if kind == "manipulability":
        return ManipulabilityObjective(), weight
    if kind == "posture":
        q_ref = r.get("q_ref", "vector", None, size=n)
        return PostureObjective(q_ref, r.get("weights", "vector", np.ones(n), size=n)), weight
    if kind == "obstacles":
        if not obstacles:
            raise r.fail("type", "an obstacles objective needs [[obstacles]] in the scenario")
        return ObstacleObjective(obstacles, r.positive("influence", 0.15)), weight
    raise r.fail(
        "type",
        f"unknown objective {kind!r}; use joint_limits, manipulability, posture or obstacles",
    )


def _collisions(r: Reader, obstacles: list[Obstacle]) -> Collisions:
    allowed = r.get("allowed", "list", [])
    ok = isinstance(allowed, list) and all(
        isinstance(p, list) and len(p) == 2 and all(isinstance(x, str) for x in p)
        for p in allowed
    )  # fmt: skip
    if not ok:
        raise r.fail("allowed", 'expected pairs of names, e.g. allowed = [["hand", "base"]]')
    influence, safety = r.positive("influence", 0.10), r.nonnegative("safety", 0.01)
    gain, self_collision = r.positive("gain", DEFAULT_GAIN), r.boolean("self", True)
    with r.blame(None):
        pairs = [(str(p[0]), str(p[1])) for p in allowed]
        return Collisions(obstacles, influence=influence, safety=safety, gain=gain,
                          self_collision=self_collision, allowed=pairs)  # fmt: skip


@_blamed
def _level(r: Reader, n: int) -> Task:
    """One priority level's task (fresh on every call: tasks keep targets)."""
    kind = r.string("type")
    if kind == "arm_angle":
        target = r.get("target", "number", None)
        reference = r.get("reference", "vector", (0.0, 0.0, 1.0), size=3)
        return ArmAngleTask(reference=reference, target=target)
    if kind == "posture":
        return PostureTask(r.get("q_ref", "vector", None, size=n))
    if kind == "look_at":
        return LookAtTask(r.get("frame", "string", None), target=r.get("target", "vector", size=3))
    raise r.fail("type", f"unknown level {kind!r}; use arm_angle, posture, look_at")


class _SchemeReader(Reader):
    """One ``[[schemes]]`` table as :class:`~redres.scenarios.registry.ScenarioParams`."""

    def __init__(
        self, table: Any, path: str, file: str, obstacles: list[Obstacle], n: int, dt: float
    ) -> None:
        super().__init__(table, path, file, ScenarioError)
        self.obstacles, self.n, self.dt = obstacles, n, dt
        self.type = self.string("type")

    def objectives(self) -> list[tuple[Objective, float]]:
        return self.each("objectives", partial(_objective, obstacles=self.obstacles, n=self.n), [])

    def collisions(self) -> Collisions | None:
        """The ``collisions = { influence = 0.10, safety = 0.01, self = true }`` table (also
        ``gain``, m/s, and ``allowed = [["hand", "base"], ...]``) as a :class:`Collisions`
        over the scenario's obstacles; None when absent."""
        self.used.add("collisions")
        if "collisions" not in self.table:
            return None
        table = self.table["collisions"]
        if not isinstance(table, dict):
            example = "collisions = { influence = 0.10, safety = 0.01, self = true }"
            raise self.fail("collisions", f"expected a table, e.g. {example}")
        path = f"{self.path}.collisions" if self.path else "collisions"
        return self.read(table, path, partial(_collisions, obstacles=self.obstacles))

    def levels(self) -> list[Task]:
        levels = self.each("levels", partial(_level, n=self.n))
        if not levels:
            example = 'levels = [{ type = "posture" }]'
            raise self.fail("levels", f"list at least one level, e.g. {example}")
        return levels

    def inverse(self, default_damping: float | None = None) -> Inverse | None:
        keys = ("damping", "max_damping", "threshold", "rcond")
        given = {k: self.positive(k) for k in keys if k in self.table}
        self.used.update(keys)
        damping: float | AdaptiveDamping | None = given.get("damping")
        if "max_damping" in given or "threshold" in given:
            if damping is not None:
                raise self.fail("damping", "give damping = λ, or max_damping and threshold")
            damping = AdaptiveDamping(given.get("max_damping", 0.1), given.get("threshold", 0.05))
        if damping is None and "rcond" not in given:
            if default_damping is None:
                return None
            damping = default_damping
        with self.blame("rcond" if "rcond" in given else "damping"):
            return make_inverse(None, damping, given.get("rcond"))

    def spec(self) -> SchemeSpec:
        """The registered builder of the table's ``type``, run once now to validate (a
        scheme whose optional dependency is missing is validated as far as it reads its
        table; running it says what to install, :func:`~redres.scenarios.runner.run_scenario`)."""
        label, builders = self.string("label", self.type), scheme_types()
        if self.type not in builders:
            raise self.fail("type", f"unknown scheme {self.type!r}; use {', '.join(builders)}")
        builder = builders[self.type]
        with self.blame("type"):
            try:
                builder(self)
            except MissingDependencyError:
                pass
        self.done()
        return SchemeSpec(self.type, label, lambda: builder(self))


def load_scenario(path: str | Path) -> ScenarioSpec:
    """Read and validate a scenario file; raises :class:`ScenarioError`."""
    file = Path(path)
    data = load(file, "scenario", ScenarioError)
    return parse_scenario(data, file.name, file.parent)


def parse_scenario(
    data: dict[str, Any], file: str = "<scenario>", base: Path = Path()
) -> ScenarioSpec:
    """Validate a parsed scenario (a dict as :mod:`tomllib` returns)."""
    top = Reader(data, "", file, ScenarioError)
    name, description = top.string("name", Path(file).stem), top.string("description", "")
    top.used.update({"robot", "trajectory", "run", "obstacles", "schemes", "plan"})
    if "robot" not in data:
        raise ScenarioError(f'{file}: missing [robot] table; add [robot] with model = "panda"')
    robot, q0, mjcf = top.read(data["robot"], "[robot]", partial(_robot, base=base))
    if "trajectory" not in data:
        raise ScenarioError(f'{file}: missing [trajectory] table; add type = "circle" etc.')

    def trajectory_from(start: np.ndarray) -> Trajectory:
        return top.read(data["trajectory"], "[trajectory]", partial(_trajectory, start=start))

    trajectory = trajectory_from(robot.fk(q0))
    run = Reader(data.get("run", {}), "[run]", file, ScenarioError)
    dt, duration = run.positive("dt", 1e-3), run.positive("duration", trajectory.duration)
    gain = run.nonnegative("gain", 50.0)
    shaping = run.boolean("shaping", False)
    plant = run.string("plant", "redres")
    if plant not in ("redres", "mujoco"):
        raise run.fail("plant", f"use 'redres' or 'mujoco'; got {plant!r}")
    if plant == "mujoco" and mjcf is None:
        raise run.fail("plant", "MuJoCo simulates an MJCF robot: give [robot] mjcf = ... or "
                       'menagerie = "panda"')  # fmt: skip
    if plant == "mujoco" and importlib.util.find_spec("mujoco") is None:
        raise run.fail("plant", f"MuJoCo is not installed: {install_hint('mujoco')}")
    if shaping and np.all(np.isinf(robot.qdd_max)) and np.all(np.isinf(robot.qddd_max)):
        raise run.fail("shaping", f"the robot {robot.name!r} has no acceleration or jerk "
                       "limits to shape to; give them (qdd_max, qddd_max) in its DH records "
                       "or use a model that has them")  # fmt: skip
    with run.blame(None):
        run_steps(duration, dt)  # 1 to MAX_STEPS steps
    run.done()
    obstacles = top.each("obstacles", _obstacle, [])  # checks blamed on the table
    tables = top.get("schemes", "tables")
    if not tables:
        raise ScenarioError(f'{file}: [[schemes]] is empty; add one with type = "pinv"')
    schemes = [
        _SchemeReader(t, top.at("schemes", i), file, obstacles, robot.n, dt).spec()
        for i, t in enumerate(tables)
    ]
    plan = top.read(data["plan"], "[plan]", _plan) if "plan" in data else None
    top.done()
    return ScenarioSpec(
        name, description, robot, q0, FrameTask, trajectory, dt, duration, gain, obstacles,
        schemes, file, shaping, plant, mjcf, trajectory_from, plan,
    )  # fmt: skip


def builtin_scenarios() -> dict[str, Path]:
    """Name -> path of the scenario files shipped with redres (``redres run --list``)."""
    folder = resources.files("redres") / "scenarios" / "data"
    return {Path(str(p)).stem: Path(str(p)) for p in folder.iterdir() if str(p).endswith(".toml")}


def scenario_text(r: Reader, key: str, name: str, base: Path) -> tuple[str, str]:
    """The text and file name of the scenario that ``key`` of a spec names: a file relative
    to ``base`` or, when no such file exists, a built-in name; checked to be TOML.

    Raises:
        The reader's error naming ``key``: no such file or built-in, unreadable, not TOML.
    """
    builtin = builtin_scenarios()
    path = builtin[name] if name in builtin and not (base / name).exists() else base / name
    if not path.exists():
        raise r.fail(key, f"cannot read {path}; give a scenario file or one of "
                     f"{', '.join(sorted(builtin))}")  # fmt: skip
    text = r.file_text(key, path)
    try:
        tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        why = f"{path.name} is not a scenario file (not valid TOML: {exc})"
        raise r.fail(key, why) from None
    return text, path.name


def builtin(name: str) -> ScenarioSpec:
    """A built-in scenario, loaded from the TOML file redres ships (its one definition).

    Args:
        name: ``"panda_joint_limit_circle"``, ``"iiwa_arm_angle_eight"``, ... (see
            :func:`builtin_scenarios`).

    Raises:
        ScenarioError: no built-in scenario has that name (the message lists them).
    """
    files = builtin_scenarios()
    if name not in files:
        raise ScenarioError(
            f"no built-in scenario {name!r}; built-in scenarios: {', '.join(sorted(files))}"
        )
    return load_scenario(files[name])
