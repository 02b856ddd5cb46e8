"""Scheme statistics: every stored figure is the figure of the run it stands for.

Oracle: :func:`redres.run` on the stored start configuration and the path the shard's
generator ``default_rng([seed, k])`` gives, computed here again, scheme by scheme."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres import sweeps
from redres.scenarios.spec import load_scenario
from redres.sweeps.kinds.schemes import _path, table

SCENARIO = """
name = "two"
[robot]
model = "panda"
[trajectory]
type = "hold"
duration = 1.0
[run]
dt = 0.002
gain = 50.0
[[schemes]]
type = "pinv"
[[schemes]]
type = "gradient_projection"
label = "joint limits"
objectives = [{ type = "joint_limits" }]
k_null = 5.0
"""

SPEC = """
kind = "scheme_statistics"
seed = 3
shard_size = 400
small_shards = true
[robot]
model = "panda"
[scheme_statistics]
scenario = "two.toml"
paths = 5
duration = 0.2
"""


def test_statistics_match_the_runs(tmp_path: Path) -> None:
    (tmp_path / "two.toml").write_text(SCENARIO)
    (tmp_path / "stats.toml").write_text(SPEC)
    report = sweeps.run(tmp_path / "stats.toml", tmp_path / "out", workers=1, progress=False)
    assert report.shards == 3 and report.queries == 5 * 2 * 100
    data = sweeps.load(tmp_path / "out")
    assert list(data.meta["labels"]) == ["pinv", "joint limits"]
    spec = sweeps.load_spec(tmp_path / "stats.toml")
    scenario = load_scenario(tmp_path / "two.toml")
    robot = scenario.robot
    for shard, (start, stop) in enumerate([(0, 2), (2, 4), (4, 5)]):
        rng = np.random.default_rng([3, shard])
        for i in range(start, stop):
            q0, shape, size, path = _path(robot, spec.params, rng)
            assert np.array_equal(q0, data["q0"][i]) and shape == data["shape"][i]
            assert size == data["size"][i]
            for s, scheme in enumerate(scenario.schemes):
                log = rr.run(robot, scenario.task(), path, scheme.build(), dt=0.002,
                             duration=0.2, q0=q0, gain=50.0)  # fmt: skip
                assert data["max_error"][i, s] == log.position_error.max()
                rms = math.sqrt(np.mean(log.position_error**2))
                assert data["rms_error"][i, s] == rms
                assert data["violations"][i, s] == (log.joint_limit_margin < 0).sum()
                assert data["success"][i, s] == (log.position_error.max() <= 1e-3)
    text = table(tmp_path / "out")
    assert "pinv" in text and "joint limits" in text


@pytest.mark.parametrize(
    ("scenario", "content", "message"),
    [
        ("notes.txt", "hello world = {", r"notes\.txt is not a scenario file \(not valid TOML"),
        ("/dev/zero", None, r"cannot read '/dev/zero': not a regular file"),
        ("missing.toml", None, r"cannot read .*missing\.toml; give a scenario file or one of"),
    ],
)
def test_a_scenario_that_is_no_scenario_file_is_named(
    tmp_path: Path, scenario: str, content: str | None, message: str
) -> None:
    """A text file that is not TOML was a raw TOMLDecodeError; /dev/zero was read until
    memory ran out."""
    if content is not None:
        (tmp_path / scenario).write_text(content)
    (tmp_path / "stats.toml").write_text(SPEC.replace("two.toml", scenario))
    with pytest.raises(sweeps.SweepSpecError, match=rf"\[scheme_statistics\]\.scenario: {message}"):
        sweeps.load_spec(tmp_path / "stats.toml")
