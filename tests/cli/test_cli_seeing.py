"""Command-line additions: ``redres run --list --json``, ``redres robots`` naming the
example robots, "did you mean" for robot names, and ``redres view``."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

import redres as rr
from redres.cli import main
from redres.errors import RobotNotFoundError
from redres.scenarios.spec import builtin_scenarios


def test_run_list_honours_json(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--list", "--json"]) == 0
    listing = json.loads(capsys.readouterr().out)
    assert {item["name"] for item in listing} == set(builtin_scenarios())
    assert all(item["description"] for item in listing)


def test_robots_says_where_the_example_robots_are(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["robots"]) == 0
    out = capsys.readouterr().out
    assert "example-robot-data" in out
    assert main(["robots", "--json", "--all"]) == 0
    payload = json.loads(capsys.readouterr().out)
    assert {r["name"] for r in payload["builtin"]} == set(rr.models.names())
    assert isinstance(payload["example_robots"], list)


def test_unknown_robot_names_get_a_suggestion() -> None:
    with pytest.raises(RobotNotFoundError, match="did you mean 'panda'"):
        rr.models.load("pandas")
    with pytest.raises(RobotNotFoundError, match="did you mean 'iiwa14'"):
        rr.models.load("iiwa")


def test_view_serves_a_scenario_and_stops(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("viser")
    scenario = tmp_path / "short.toml"
    scenario.write_text(
        'name = "short"\n[robot]\nmodel = "planar3"\n[trajectory]\ntype = "hold"\n'
        'duration = 0.05\n[[schemes]]\ntype = "dls"\n'
    )
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    assert main(["view", str(scenario), "--port", str(port), "--seconds", "0.5"]) == 0
    assert f"1 runs at http://127.0.0.1:{port}" in capsys.readouterr().out


def test_run_view_serves_the_runs_it_made(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("viser")
    scenario = tmp_path / "short.toml"
    scenario.write_text(
        'name = "short"\n[robot]\nmodel = "planar3"\n[trajectory]\ntype = "hold"\n'
        'duration = 0.05\n[[schemes]]\ntype = "dls"\n[[schemes]]\ntype = "pinv"\n'
    )
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    args = ["run", str(scenario), "--quiet", "--out", str(tmp_path / "report"), "--view"]
    assert main([*args, "--port", str(port), "--seconds", "0.3"]) == 0
    out = capsys.readouterr().out
    assert f"2 runs at http://127.0.0.1:{port}" in out
    assert (tmp_path / "report" / "report.html").is_file()  # the report is written too


def test_run_view_plays_the_runs_while_they_are_computed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    pytest.importorskip("viser")
    from redres.viewer import Viewer

    events: list[str] = []
    push, show_runs = Viewer.push, Viewer.show_runs

    def recording_push(self: Viewer, q: object, target: object = None) -> None:
        events.append("push")
        push(self, q, target)

    def recording_show(self: Viewer, runs: object) -> None:
        events.append("show_runs")
        show_runs(self, runs)  # type: ignore[arg-type]

    monkeypatch.setattr(Viewer, "push", recording_push)
    monkeypatch.setattr(Viewer, "show_runs", recording_show)
    scenario = tmp_path / "short.toml"
    scenario.write_text(
        'name = "short"\n[robot]\nmodel = "planar3"\n[trajectory]\ntype = "hold"\n'
        'duration = 0.2\n[[schemes]]\ntype = "dls"\n'
    )
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    args = ["run", str(scenario), "--quiet", "--out", str(tmp_path / "report"), "--view"]
    assert main([*args, "--port", str(port), "--seconds", "0.1"]) == 0
    assert "push" in events and events.index("push") < events.index("show_runs")


def test_run_view_draws_the_pairs_of_the_scenarios_collision_constraint() -> None:
    """``redres run --view`` gives the live viewer the first collision constraint among the
    scenario's schemes (its pairs drawn while the runs are computed), none without one."""
    pytest.importorskip("daqp")
    from redres.cli import _collisions_of
    from redres.scenarios.spec import builtin, builtin_scenarios

    found = _collisions_of(builtin("panda_table_shelf"))
    assert isinstance(found, rr.Collisions)
    assert (found.influence, found.safety, found.self_collision) == (0.10, 0.01, True)
    assert {o.name for o in found.obstacles} == {"table", "shelf"}
    assert "panda_joint_limit_circle" in builtin_scenarios()
    assert _collisions_of(builtin("panda_joint_limit_circle")) is None
