"""Scenario files: a robot from an MJCF file (``mjcf = "arm.xml"``, next to ``urdf``) and
the figure eight's ``ramp``."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
import tomllib

import redres as rr
from redres.cli import main
from redres.control import FigureEight
from redres.scenarios.runner import run_scenario
from redres.scenarios.spec import ScenarioError, load_scenario, parse_scenario

MJCF = """
name = "arm3_mjcf"
[robot]
mjcf = "models/arm3.xml"
[trajectory]
type = "line"
end = [0.45, 0.05, 0.5]
duration = 0.05
[run]
dt = 0.001
[[schemes]]
type = "dls"
"""


@pytest.fixture
def mjcf_scenario(tmp_path: Path, fixtures_dir: Path) -> Path:
    """The scenario above, its MJCF model (and meshes) in a folder next to it."""
    shutil.copytree(fixtures_dir, tmp_path / "models")
    path = tmp_path / "arm3.toml"
    path.write_text(MJCF)
    return path


def test_a_scenario_robot_from_mjcf_is_the_file_robot(
    mjcf_scenario: Path, fixtures_dir: Path, rng: np.random.Generator
) -> None:
    spec = load_scenario(mjcf_scenario)
    direct = rr.Robot.from_mjcf(fixtures_dir / "arm3.xml")  # oracle: the loader itself
    urdf = rr.Robot.from_urdf(fixtures_dir / "arm3.urdf")  # and the same arm as URDF
    assert spec.robot.joint_names == direct.joint_names and spec.robot.tip == direct.tip
    np.testing.assert_array_equal(spec.q0, direct.neutral())  # the keyframe "home"
    for _ in range(5):
        q = direct.random_configuration(rng)
        np.testing.assert_allclose(spec.robot.fk(q), direct.fk(q), atol=0)
        np.testing.assert_allclose(spec.robot.fk(q), urdf.fk(q), atol=1e-12)
    start = spec.trajectory.sample(0.0).pose
    np.testing.assert_allclose(start, direct.fk(direct.neutral()), atol=1e-12)


def test_a_tip_picks_the_mjcf_robots_frame(mjcf_scenario: Path) -> None:
    text = MJCF.replace('mjcf = "models/arm3.xml"', 'mjcf = "models/arm3.xml"\ntip = "l3"')
    mjcf_scenario.write_text(text)
    spec = load_scenario(mjcf_scenario)
    assert spec.robot.tip == "l3"
    np.testing.assert_allclose(spec.trajectory.sample(0.0).pose, spec.robot.fk(spec.q0, "l3"))


def test_redres_runs_an_mjcf_scenario(
    mjcf_scenario: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["run", str(mjcf_scenario), "--json", "--out", str(tmp_path / "out")]) == 0
    runs = json.loads(capsys.readouterr().out)["runs"]
    direct = load_scenario(mjcf_scenario)
    assert [r["robot"] for r in runs] == [direct.robot.name]
    assert runs[0]["steps"] == round(direct.duration / direct.dt)
    # An MJCF file has no velocity limits: no ratio to infinity, a dash in the table.
    assert runs[0]["peak_speed_ratio"] is None
    assert main(["run", str(mjcf_scenario), "--out", str(tmp_path / "table")]) == 0
    lines = capsys.readouterr().out.splitlines()
    rule = next(i for i, line in enumerate(lines) if line.startswith("---"))
    header, row = lines[rule - 1], lines[rule + 1]  # the header's last line: units
    start = header.index("qd_max")
    assert row[start : start + len("qd_max")].strip() == "-", row


@pytest.mark.parametrize(
    ("robot", "message"),
    [
        (
            'urdf = "a.urdf"\nmjcf = "a.xml"',
            r"\[robot\]\.mjcf: give exactly one of .*urdf and mjcf",
        ),
        ('model = "panda"\nmjcf = "a.xml"', r"\[robot\]\.mjcf: give exactly one of"),
        ("", r"\[robot\]\.model: give exactly one of model .* or menagerie"),
        ('mjcf = "missing.xml"', r"\[robot\]\.mjcf: .*missing\.xml"),
        ("mjcf = 3", r"\[robot\]\.mjcf: expected a string"),
    ],
)
def test_mjcf_mistakes_name_the_key(tmp_path: Path, robot: str, message: str) -> None:
    text = MJCF.replace('mjcf = "models/arm3.xml"', robot)
    data = tomllib.loads(text)
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(data, "s.toml", tmp_path)


EIGHT = """
[robot]
model = "panda"
[trajectory]
type = "figure_eight"
width = 0.08
height = 0.05
period = 2.0
turns = 1.5
ramp = {ramp}
[[schemes]]
type = "pinv"
"""


def test_the_figure_eights_ramp_is_read(tmp_path: Path) -> None:
    spec = parse_scenario(tomllib.loads(EIGHT.format(ramp=0.6)), "eight.toml", tmp_path)
    start = spec.robot.fk(spec.q0)
    oracle = FigureEight(start, 0.08, 0.05, 2.0, turns=1.5, ramp=0.6)  # the constructor
    assert isinstance(spec.trajectory, FigureEight) and spec.trajectory.ramp == 0.6
    assert spec.duration == pytest.approx(1.5 * 2.0 + 0.6 / 2)
    for t in np.linspace(0.0, spec.duration, 13):
        a, b = spec.trajectory.sample(t), oracle.sample(t)
        np.testing.assert_array_equal(a.pose, b.pose)
        np.testing.assert_array_equal(a.twist, b.twist)
    # the ramp is what makes the start smooth: zero speed at t = 0, not without it
    plain = parse_scenario(tomllib.loads(EIGHT.format(ramp=0.0)), "eight.toml", tmp_path)
    assert np.linalg.norm(spec.trajectory.sample(0.0).twist) == pytest.approx(0.0, abs=1e-12)
    assert np.linalg.norm(plain.trajectory.sample(0.0).twist) > 0.05


def test_a_negative_ramp_is_refused_at_its_key(tmp_path: Path) -> None:
    with pytest.raises(ScenarioError, match=r"\[trajectory\].*ramp"):
        parse_scenario(tomllib.loads(EIGHT.format(ramp=-0.5)), "eight.toml", tmp_path)


MENAGERIE_STYLE = """
name = "arm3_limits"
[robot]
mjcf = "fixtures/arm3_menagerie.xml"
qd_max = [2.0, 2.0, 3.0]
qdd_max = 40.0
[trajectory]
type = "line"
end = [0.45, 0.05, 0.5]
duration = 0.2
[run]
dt = 0.001
[[schemes]]
type = "dls"
"""


def test_a_menagerie_style_file_robot_runs_under_the_limits_its_files_set(
    tmp_path: Path, fixtures_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Torque limits from the MJCF's actuators, velocity and acceleration limits from the
    scenario: the robot carries them, and the table's ratio is measured against them."""
    shutil.copytree(fixtures_dir, tmp_path / "fixtures")
    path = tmp_path / "limits.toml"
    path.write_text(MENAGERIE_STYLE)
    spec = load_scenario(path)
    urdf = rr.Robot.from_urdf(fixtures_dir / "arm3.urdf")  # the same arm, limits in the URDF
    np.testing.assert_array_equal(spec.robot.tau_max, urdf.tau_max)  # [50, 50, 20] N·m
    np.testing.assert_array_equal(spec.robot.qd_max, [2.0, 2.0, 3.0])
    np.testing.assert_array_equal(spec.robot.qdd_max, [40.0, 40.0, 40.0])
    assert main(["run", str(path), "--json", "--out", str(tmp_path / "out")]) == 0
    run = json.loads(capsys.readouterr().out)["runs"][0]
    (log,) = run_scenario(spec, progress=False)
    expected = float(np.max(np.abs(log.qd) / spec.robot.qd_max))
    assert run["peak_speed_ratio"] == pytest.approx(expected, rel=1e-12) and expected > 0


@pytest.mark.parametrize(
    ("line", "message"),
    [
        ("qd_max = [2.0, 2.0]", r"\[robot\]\.qd_max: expected 3 numbers"),
        ("qd_max = 0.0", r"\[robot\]\.qd_max: must be > 0 for every joint"),
        ("tau_max = 60.0", r"\[robot\]: tau_max\[2\] = 60 exceeds the robot's own limit 20"),
        ('qd_max = "fast"', r"\[robot\]\.qd_max: expected a number"),
    ],
)
def test_limit_mistakes_name_the_key(
    tmp_path: Path, fixtures_dir: Path, line: str, message: str
) -> None:
    text = MENAGERIE_STYLE.replace("qd_max = [2.0, 2.0, 3.0]\nqdd_max = 40.0", line)
    with pytest.raises(ScenarioError, match=message):
        parse_scenario(tomllib.loads(text), "s.toml", fixtures_dir.parent)
