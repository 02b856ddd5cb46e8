"""Runs that tell: a joint past its limit, singular configurations and an unreachable
target each give a warning, in ``rr.run(...).summary()`` and ``log.warnings``, on
``redres run``'s output and in --json."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.cli import main
from redres.control import Circle, Line
from redres.control.log import NOT_REACHED_M, SINGULAR_SIGMA
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.scenarios.runner import summarise
from redres.tasks import FrameTask


def _kinds(log: rr.control.RunLog) -> dict[str, dict]:
    """The warnings a Python user of ``rr.run`` sees, by kind, checked to be one list."""
    found = log.summary()["warnings"]
    assert found == [w.as_dict() for w in log.warnings]
    assert [str(w) for w in log.warnings] == [w["message"] for w in found]
    return {w["kind"]: w for w in found}


def test_a_joint_that_leaves_its_limits_is_named_with_the_amount() -> None:
    # Baxter-like: gradient projection on the joint-limit cost, too weak to hold joint 4
    # (range [-3.07, -0.07]) of a Panda that starts 0.02 rad inside its upper limit while
    # the tool is pushed along the direction that closes that joint.
    robot = rr.models.panda()
    q0 = robot.neutral()
    q0[3] = robot.q_max[3] - 0.02
    start = robot.fk(q0)
    end = start[:3, 3] + np.array([0.25, 0.0, -0.05])
    scheme = GradientProjectionScheme([JointLimitObjective()], k_null=0.05)
    log = rr.run(robot, FrameTask(), Line(start, end, 0.6), scheme, q0=q0)
    excess = np.maximum(robot.q_min - log.q, log.q - robot.q_max)  # oracle
    assert excess.max() > 0.01, "the fixture must leave the limits"
    j = int(np.unravel_index(np.argmax(excess), excess.shape)[1])
    assert log.q_min is not None and np.array_equal(log.q_min, robot.q_min)
    warning = _kinds(log)["joint_limits"]
    assert warning["joint"] == robot.joint_names[j]
    assert warning["value"] == pytest.approx(excess.max(), rel=1e-12)
    assert warning["steps"] == int((excess > 1e-9).any(axis=1).sum())
    assert robot.joint_names[j] in warning["message"] and "past its" in warning["message"]
    assert -log.summary()["min_joint_limit_margin_rad"] == pytest.approx(excess.max())


def test_an_unreachable_circle_warns_of_the_error_and_the_singularity() -> None:
    # A vertical circle of 0.3 m radius whose centre is 0.3 m in front of the Panda's
    # ready pose: it runs out to x = 0.91 m at the TCP's height, past the arm's reach,
    # so the tool stops short and the arm stretches out (σ_min → 0).
    robot = rr.models.panda()
    start = robot.fk(robot.neutral())
    circle = Circle(start, 0.3, 4.0, normal=(0.0, 1.0, 0.0), phase=-np.pi / 2)
    log = rr.run(robot, FrameTask(), circle, PseudoInverseScheme(damping=0.05), duration=1.2)
    found = _kinds(log)
    assert set(found) >= {"not_reached", "singular"}
    error = log.position_error  # oracle: the log itself
    assert found["not_reached"]["value"] == pytest.approx(error.max())
    assert error.max() > NOT_REACHED_M
    assert f"{1e3 * error.max():.1f} mm" in found["not_reached"]["message"]
    assert found["singular"]["value"] == pytest.approx(log.sigma_min.min())
    assert log.sigma_min.min() < SINGULAR_SIGMA
    assert found["singular"]["steps"] == int((log.sigma_min < SINGULAR_SIGMA).sum())


def test_a_clean_run_has_no_warning() -> None:
    robot = rr.models.panda()
    circle = Circle(robot.fk(robot.neutral()), 0.02, 0.2)
    log = rr.run(robot, FrameTask(), circle, PseudoInverseScheme())
    assert log.warnings == [] and log.summary()["warnings"] == []


def test_a_log_without_recorded_limits_warns_only_through_a_robot() -> None:
    # A log built by hand (here: a run's log with its limits dropped) cannot know the
    # limits; summarise(robot, log) measures it against the robot's.
    from dataclasses import replace

    robot = rr.models.panda()
    circle = Circle(robot.fk(robot.neutral()), 0.02, 0.2)
    log = rr.run(robot, FrameTask(), circle, PseudoInverseScheme(), duration=0.01)
    log.q[3, 1] = robot.q_max[1] + 0.25  # oracle: this one excursion
    bare = replace(log, q_min=None, q_max=None, joint_names=())
    assert "joint_limits" not in {w.kind for w in bare.warnings}
    warning = {w["kind"]: w for w in summarise(robot, bare)["warnings"]}["joint_limits"]
    assert warning["joint"] == robot.joint_names[1] and warning["steps"] == 1
    assert warning["value"] == pytest.approx(0.25) and warning["t"] == pytest.approx(log.t[3])
    assert summarise(robot, log) == log.summary()  # a recorded log: the same summary


SCENARIO = """
name = "far"
[robot]
model = "panda"
[trajectory]
type = "circle"
radius = 0.3
period = 4.0
normal = [0.0, 1.0, 0.0]
phase = -1.5707963
[run]
duration = 1.2
[[schemes]]
type = "dls"
damping = 0.05
"""


def test_redres_run_prints_one_line_per_warning_and_puts_them_in_json(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    scenario = tmp_path / "far.toml"
    scenario.write_text(SCENARIO)
    assert main(["run", str(scenario), "--quiet", "--out", str(tmp_path / "a")]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("warning:")]
    assert any("target not reached" in ln for ln in lines)
    assert any("singular" in ln for ln in lines)
    assert main(["run", str(scenario), "--json", "--out", str(tmp_path / "b")]) == 0
    payload = json.loads(capsys.readouterr().out)
    kinds = {w["kind"] for w in payload["runs"][0]["warnings"]}
    assert kinds == {"not_reached", "singular"}
    assert len(lines) == len(payload["runs"][0]["warnings"])


def test_a_simulated_run_records_its_limits_and_warns_too() -> None:
    # An unpowered Panda falls under gravity from near an upper limit of joint 2; the
    # simulator clips nothing, so the fall leaves the limits and the log says so.
    from redres.dynamics import ZeroTorque, simulate

    robot = rr.models.panda()
    q0 = robot.neutral()
    q0[1] = robot.q_max[1] - 0.05
    log = simulate(robot, ZeroTorque(), dt=1e-3, duration=0.6, q0=q0)
    assert log.q_min is not None and np.array_equal(log.q_max, robot.q_max)
    excess = np.maximum(robot.q_min - log.q, log.q - robot.q_max)  # oracle
    assert excess.max() > 0.01, "the fixture must leave the limits"
    warning = _kinds(log)["joint_limits"]
    assert warning["value"] == pytest.approx(excess.max(), rel=1e-12)
    assert warning["joint"] == robot.joint_names[int(np.argmax(excess.max(axis=0)))]


BALL = """
name = "ball"
[robot]
model = "panda"
q0 = [-0.811, -1.061, 0.515, -2.269, -0.299, 1.036, 0.521]
[trajectory]
type = "circle"
radius = 0.10
period = 2.5
normal = [-0.404, -0.565, -1.433]
phase = 1.851
[run]
duration = 10.0
[[obstacles]]
type = "sphere"
name = "ball"
center = [0.09, 0.33, 0.40]
radius = 0.05
[[schemes]]
type = "pinv"
[[schemes]]
type = "gradient_projection"
k_null = 1.0
objectives = [{ type = "obstacles", influence = 0.15 }]
"""


def test_a_run_into_an_obstacle_warns_with_the_obstacle_the_depth_and_the_time(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """The built-in joint-limit circle's ball: the minimum-norm run's elbow goes into it,
    and the table and the JSON say so (obstacle, link, depth, time), as a joint past its
    limits is; the depth is the logged clearance (an independent distance: Pinocchio's
    poses of the capsules against the sphere), the run that avoids it has no warning."""
    scenario = tmp_path / "ball.toml"
    scenario.write_text(BALL)
    assert main(["run", str(scenario), "--json", "--out", str(tmp_path / "a")]) == 0
    runs = json.loads(capsys.readouterr().out)["runs"]
    into = [w for w in runs[0]["warnings"] if w["kind"] == "collision"]
    assert len(into) == 1 and into[0]["joint"] == "ball", runs[0]["warnings"]
    assert into[0]["value"] == pytest.approx(-runs[0]["min_obstacle_clearance_m"], abs=1e-12)
    assert into[0]["value"] > 0.01 and 0.0 < into[0]["t"] < 10.0
    assert "mm into obstacle 'ball'" in into[0]["message"]
    assert runs[1]["min_obstacle_clearance_m"] > 0.0
    assert not [w for w in runs[1]["warnings"] if w["kind"] == "collision"]
    assert main(["run", str(scenario), "--quiet", "--out", str(tmp_path / "b")]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if "collision:" in ln]
    assert len(lines) == 1 and "'ball'" in lines[0]
