"""Scenario files: the built-in ones load; every kind of mistake gives one clear message
with the key path and the fix, exit code 2, and no report folder."""

from __future__ import annotations

from pathlib import Path

import pytest

from redres.cli import main
from redres.scenario import ScenarioError, builtin_scenarios, load_scenario

GOOD = """
name = "tiny"
description = "a short hold"

[robot]
model = "panda"

[trajectory]
type = "circle"
radius = 0.05
period = 1.0

[run]
dt = 0.002
duration = 0.02

[[schemes]]
type = "pinv"
"""


def write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    return path


def test_builtin_scenarios_load() -> None:
    found = builtin_scenarios()
    assert {"panda_joint_limit_circle", "iiwa_arm_angle_eight"} <= set(found)
    for path in found.values():
        spec = load_scenario(path)
        assert spec.schemes and spec.duration > 0


def test_a_good_scenario_runs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(write(tmp_path, GOOD)), "--quiet", "--out", str(tmp_path / "o")]) == 0
    assert "pinv" in capsys.readouterr().out


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (
            ("[run]\n", "[run]\nspeed = 3\n"),
            r"\[run\]\.speed: unknown key; valid keys here: dt, duration, gain",
        ),
        (
            ("dt = 0.002", 'dt = "fast"'),
            r"\[run\]\.dt: expected a number, got 'fast' \(write dt = 1.0\)",
        ),
        (("dt = 0.002", "dt = 0.0"), r"\[run\]\.dt: must be > 0; got 0.0"),
        (
            ('model = "panda"', 'model = "ur5"'),
            r"\[robot\]\.model: unknown robot 'ur5'; built-in robots: iiwa14",
        ),
        (
            ('model = "panda"', 'model = "panda"\ntip = "gripper"'),
            r"\[robot\]\.tip: unknown frame 'gripper'; frames: .*tcp",
        ),
        (
            ('type = "pinv"', 'type = "magic"'),
            r"\[schemes\]\[0\]\.type: unknown scheme 'magic'; use pinv",
        ),
        (("radius = 0.05", "radius = [0.05]"), r"\[trajectory\]\.radius: expected a number"),
        (
            ('type = "circle"', 'type = "spiral"'),
            r"\[trajectory\]\.type: unknown trajectory 'spiral'",
        ),
        (
            ('[[schemes]]\ntype = "pinv"', '[[schemes]]\ntype = "pinv"\ndamping = -1.0'),
            r"\[schemes\]\[0\]\.damping: must be > 0",
        ),
        (
            ('[robot]\nmodel = "panda"', '[robot]\nmodel = "panda"\nq0 = [0, 0, 0, 0, 0, 0, 0]'),
            r"\[robot\]\.q0: is outside the joint limits",
        ),
        (
            (
                '[[schemes]]\ntype = "pinv"',
                '[[schemes]]\ntype = "gradient_projection"\nobjectives = [{ type = "obstacles" }]',
            ),
            r"needs \[\[obstacles\]\]",
        ),
        (("period = 1.0", "period = 1.0\n\n[oops"), r"not valid TOML"),
    ],
)
def test_bad_scenarios_name_the_key(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], edit: tuple[str, str], message: str
) -> None:
    old, new = edit
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(ScenarioError, match=message):
        load_scenario(path)
    out_dir = tmp_path / "report"
    assert main(["run", str(path), "--out", str(out_dir)]) == 2
    err = capsys.readouterr().err
    assert "scenario.toml" in err and err.count("\n") == 1  # one message, one line
    assert not out_dir.exists()  # no partial report


def test_missing_file_exits_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", str(tmp_path / "none.toml")]) == 2
    assert "no such scenario file" in capsys.readouterr().err


def test_scenario_files_are_not_executed(tmp_path: Path) -> None:
    """A string that looks like code stays a string (tomllib only)."""
    text = GOOD.replace('description = "a short hold"', "description = \"__import__('os')\"")
    assert load_scenario(write(tmp_path, text)).description == "__import__('os')"
