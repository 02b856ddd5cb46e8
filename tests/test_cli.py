"""The redres command line."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

import redres as rr
from redres.cli import main


def test_robots_table_lists_every_builtin(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    for name in rr.models.names():
        assert name in out
    assert "tcp" in out and "flange" in out


def test_robots_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots", "--json"]) == 0
    records = json.loads(capsys.readouterr().out)
    by_name = {r["name"]: r for r in records}
    assert by_name["panda"]["dof"] == 7 and by_name["panda"]["tip"] == "tcp"
    assert by_name["iiwa14"]["tau_max"][0] == 320.0


def test_demo_prints_robots_and_worked_examples(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo"]) == 0
    out = capsys.readouterr().out
    assert "panda" in out and "seed 002" in out


def test_demo_json_carries_the_seed_numbers(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["demo", "--json"]) == 0
    examples = json.loads(capsys.readouterr().out)["examples"]
    assert examples[0]["qd_rad_s"] == [-3.59, 5.56, -0.41]
    assert examples[1]["qd_rad_s"] == [-2.76, 5.56, -2.84]
    assert examples[2]["qd_rad_s"] == [0.146, 0.107]
    assert examples[4]["qd_rad_s"] == [0.8, 0.4]
    assert examples[5]["task_residual"] < 1e-12


def test_bad_usage_exits_2() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "redres", "fly"], capture_output=True, text=True, check=False
    )
    assert proc.returncode == 2 and "invalid choice" in proc.stderr
