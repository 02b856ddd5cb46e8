"""The built-in scenario with a table, a shelf and a self-collision moment, end to end
through ``redres run panda_table_shelf --json``: the constrained QP run never comes
closer than ``d_s`` to an obstacle or to itself and says where its task yielded; the
runs without the constraint, measured on the same pairs, touch."""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest

from redres.cli import main
from redres.scenarios.spec import builtin, builtin_scenarios

pytest.importorskip("daqp")

NAME = "panda_table_shelf"


@pytest.fixture(scope="module")
def ran(tmp_path_factory: pytest.TempPathFactory) -> tuple[dict[str, Any], Path]:
    import contextlib
    import io

    out = tmp_path_factory.mktemp("run") / "report"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        assert main(["run", NAME, "--json", "--out", str(out)]) == 0
    return json.loads(printed.getvalue()), out


def test_it_is_a_builtin_with_a_table_a_shelf_and_the_constraint() -> None:
    assert NAME in builtin_scenarios()
    spec = builtin(NAME)
    assert {type(o).__name__ for o in spec.obstacles} == {"BoxObstacle"}
    assert {o.name for o in spec.obstacles} == {"table", "shelf"}
    settings = [s.build().collisions for s in spec.schemes if s.kind == "qp"]
    assert settings[1] is None
    first = settings[0]
    assert (first.influence, first.safety, first.self_collision) == (0.10, 0.01, True)
    assert any(s.kind == "gradient_projection" for s in spec.schemes)


def test_the_constrained_run_never_comes_closer_than_d_s(ran) -> None:  # type: ignore[no-untyped-def]
    payload, _ = ran
    runs = {r["label"]: r for r in payload["runs"]}
    qp = runs["qp: collision constraint"]
    assert qp["min_obstacle_clearance_m"] >= 0.01 - 1e-6
    assert qp["min_self_clearance_m"] >= 0.01 - 1e-6
    # where the path asks for a collision the task yields, and the run says so
    assert qp["collision_binding_steps"] > 0
    assert qp["max_position_error_m"] > 0.005
    assert 0.005 < qp["max_position_error_where_bound_m"] <= qp["max_position_error_m"]
    assert "not_reached" in {w["kind"] for w in qp["warnings"]}


def test_the_runs_without_the_constraint_touch(ran) -> None:  # type: ignore[no-untyped-def]
    payload, _ = ran
    runs = {r["label"]: r for r in payload["runs"]}
    for label in ("qp: joint limits only", "gradient projection: obstacle penalty"):
        run = runs[label]
        assert "collision_binding_steps" not in run
        assert run["min_obstacle_clearance_m"] < 0.0  # into the table or the shelf
        assert run["min_self_clearance_m"] < 0.01
    soft = runs["gradient projection: obstacle penalty"]
    assert soft["min_self_clearance_m"] < 0.0  # the hand or forearm into the base
    assert "collision" in {w["kind"] for w in soft["warnings"]}


def test_the_report_draws_the_boxes_and_the_pairs(ran) -> None:  # type: ignore[no-untyped-def]
    payload, out = ran
    assert payload["report"] is not None
    html = (out / "report.html").read_text(encoding="utf-8")
    assert len(re.findall(r'"shape":\s*"box"', html)) >= 2
    assert "binding collision pairs" in html and "collision pairs within d_i" in html
    assert "min self clearance" in html and "collision-bound steps" in html  # the table
