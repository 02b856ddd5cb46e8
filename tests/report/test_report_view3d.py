"""The 3D view's data: arm frames and points, sampled animations, plotly figures."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.control import RunLog
from redres.errors import ShapeError
from redres.report import animation_figure, arm_animation, arm_frames, arm_points

from .conftest import Runs


@pytest.mark.parametrize(
    ("name", "expected"),
    [
        ("panda", ["base", *(f"link{i}" for i in range(1, 8)), "tcp"]),
        ("iiwa14", [*(f"link{i}" for i in range(8)), "flange"]),
        ("planar3", ["base", "link1", "link2", "link3", "tool"]),
    ],
)
def test_arm_frames_of_the_builtin_models(
    builtin_robots: dict[str, rr.Robot], name: str, expected: list[str]
) -> None:
    assert arm_frames(builtin_robots[name]) == expected


def test_arm_frames_of_a_urdf_model(fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_hand")
    frames = arm_frames(robot)
    assert frames == ["panda_link0", *robot.joint_names, "panda_hand"]


@pytest.mark.parametrize("name", ["panda", "iiwa14", "srs7"])
def test_arm_points_are_the_frame_origins(
    builtin_robots: dict[str, rr.Robot], name: str, rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    for _ in range(3):
        q = robot.random_configuration(rng)
        points = arm_points(robot, q)
        frames = arm_frames(robot)
        assert points.shape == (len(frames), 3)
        expected = np.array([robot.fk(q, f)[:3, 3] for f in frames])
        np.testing.assert_allclose(points, expected, rtol=0, atol=1e-12)
        np.testing.assert_allclose(points[-1], robot.fk(q)[:3, 3], rtol=0, atol=1e-12)


def test_arm_segments_are_rigid(
    builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    # Independent check: consecutive frame origins are fixed to one body (modified DH
    # puts joint i+1's axis through frame i+1's origin), so segment lengths never change.
    robot = builtin_robots["panda"]
    lengths = [
        np.linalg.norm(np.diff(arm_points(robot, robot.random_configuration(rng)), axis=0), axis=1)
        for _ in range(4)
    ]
    for other in lengths[1:]:
        np.testing.assert_allclose(other, lengths[0], rtol=0, atol=1e-12)
    assert arm_points(robot, robot.neutral())[0] == pytest.approx([0.0, 0.0, 0.0], abs=1e-12)


def test_arm_points_with_chosen_frames_and_bad_input(builtin_robots: dict[str, rr.Robot]) -> None:
    robot = builtin_robots["panda"]
    q = robot.neutral()
    points = arm_points(robot, q, ["elbow", "wrist"])
    np.testing.assert_allclose(points[1], robot.fk(q, "wrist")[:3, 3], atol=1e-12)
    with pytest.raises(ShapeError, match="q"):
        arm_points(robot, np.zeros(6))
    with pytest.raises(KeyError):
        arm_points(robot, q, ["no_such_frame"])


def test_animation_samples_the_run(runs: Runs) -> None:
    robot, log = runs[0]
    anim = arm_animation(robot, log, frames=40, path_points=100)
    k = len(arm_frames(robot))
    assert anim.arm.shape == (40, k, 3)
    assert anim.steps[0] == 0 and anim.steps[-1] == log.steps - 1
    np.testing.assert_array_equal(anim.times, log.t[anim.steps])
    for f in (0, 17, 39):
        np.testing.assert_allclose(anim.arm[f], arm_points(robot, log.q[anim.steps[f]]), atol=1e-12)
    assert anim.target is not None
    assert anim.target.shape == anim.position.shape and len(anim.position) <= 100
    np.testing.assert_array_equal(anim.position[0], log.position[0])
    np.testing.assert_array_equal(anim.target[-1], log.target[-1])
    np.testing.assert_array_equal(anim.now, log.target[anim.steps])
    short = arm_animation(robot, log, frames=1000)
    assert short.arm.shape[0] == log.steps  # never more frames than steps


def test_frameless_runs_show_the_tip_path(runs: Runs, frameless_log: RunLog) -> None:
    robot = runs[0][0]
    anim = arm_animation(robot, frameless_log, frames=10, path_points=20)
    assert anim.target is None
    np.testing.assert_array_equal(anim.now, anim.arm[:, -1])  # the tip
    np.testing.assert_allclose(anim.position[-1], robot.fk(frameless_log.q[-1])[:3, 3], atol=1e-12)
    figure = animation_figure(anim)
    names = [t["name"] for t in figure["data"]]
    assert names == ["arm", "tip now", "arm at t = 0", "actual path", "link capsules"]


def test_figure_is_plain_json_with_one_frame_per_sample(runs: Runs) -> None:
    robot, log = runs[2]
    anim = arm_animation(robot, log, frames=30)
    figure = json.loads(json.dumps(animation_figure(anim, "#123456"), allow_nan=False))
    frames = figure["frames"]
    assert len(frames) == 30 == len(figure["layout"]["sliders"][0]["steps"])
    assert figure["play"]["frame_ms"] >= 20
    for f in (0, 29):
        arm = frames[f]["data"][0]
        got = np.column_stack([arm["x"], arm["y"], arm["z"]])
        np.testing.assert_allclose(got, anim.arm[f], atol=1e-5)  # rounded to 10 µm
        now = frames[f]["data"][1]
        np.testing.assert_allclose([now["x"][0], now["y"][0], now["z"][0]], anim.now[f], atol=1e-5)
        assert frames[f]["traces"] == [0, 1]
    names = [t["name"] for t in figure["data"]]
    assert names == ["arm", "target now", "arm at t = 0", "actual path", "target path",
                     "link capsules"]  # fmt: skip
    assert figure["data"][0]["line"]["color"] == "#123456"


def test_scene_has_equal_scale_and_holds_everything(runs: Runs) -> None:
    robot, log = runs[1]
    anim = arm_animation(robot, log)
    scene = animation_figure(anim)["layout"]["scene"]
    ranges = np.array([scene[f"{c}axis"]["range"] for c in "xyz"])
    spans = ranges[:, 1] - ranges[:, 0]
    ratio = np.array([scene["aspectratio"][c] for c in "xyz"])
    # equal scale: metres per unit of aspect ratio are the same on all three axes
    np.testing.assert_allclose(spans / ratio, spans[0] / ratio[0], rtol=2e-3)
    points = np.concatenate([anim.arm.reshape(-1, 3), anim.position])
    assert np.all(points >= ranges[:, 0] - 1e-9) and np.all(points <= ranges[:, 1] + 1e-9)
