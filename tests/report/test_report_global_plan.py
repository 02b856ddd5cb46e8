"""The report's section "Against the global optimum": every scheme's sentence and table row
with its share of the optimum (recomputed here from the run's joint positions and the
plan's), the bar chart as a file and inline; no section without a comparison; a
scenario's ``[plan]`` table read and checked."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from redres.report import write_report
from redres.scenarios.planned import compare_with_plan
from redres.scenarios.spec import PlanSettings, ScenarioError, builtin, parse_scenario


def test_the_report_shows_each_scheme_against_the_optimum(tmp_path: Path) -> None:
    spec = builtin("panda_joint_limit_circle")
    spec.duration = 0.6
    found = compare_with_plan(spec, resolution=90, duration=0.6)
    robot = spec.robot
    # the optimum and each value recomputed from the joint positions
    plan_margin = np.minimum(found.plan.q - robot.q_min, robot.q_max - found.plan.q).min()
    assert found.optimum == pytest.approx(plan_margin, abs=1e-15)
    page_path = write_report(tmp_path / "r", [(robot, log, spec.obstacles) for log in found.logs],
                             title="t", comparisons=[found])  # fmt: skip
    page = page_path.read_text(encoding="utf-8")
    section = page[page.index('<section id="global-plan">') :]
    section = section[: section.index("</section>")]
    assert "<h2>Against the global optimum</h2>" in section
    for log in found.logs:
        value = float(np.minimum(log.q - robot.q_min, robot.q_max - log.q).min())
        percent = 100.0 * value / plan_margin
        name = log.label or log.scheme
        sentence = (f"{name}: min margin {value:.3f} rad, {percent:.1f} % of the optimum "
                    f"{plan_margin:.3f} rad")  # fmt: skip
        assert sentence.replace("&", "&amp;") in section
        row = re.search(rf"<tr><td>{re.escape(name)}</td><td>([^<]+)</td><td>([^<]+)</td>", section)
        assert row is not None and float(row.group(1)) == pytest.approx(value, abs=5e-5)
        assert float(row.group(2)) == pytest.approx(percent, abs=0.05)
    png = tmp_path / "r" / "global-plan-panda_joint_limit_circle.png"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "data:image/png;base64," in section

    plain = write_report(tmp_path / "p", [(robot, found.logs[0])], title="t").read_text()
    assert 'id="global-plan"' not in plain


def _scenario(plan: dict[str, object]) -> dict[str, object]:
    return {"robot": {"model": "panda"}, "trajectory": {"type": "hold", "duration": 0.1},
            "schemes": [{"type": "pinv"}], "plan": plan}  # fmt: skip


def test_a_scenario_plan_table_is_read_and_checked() -> None:
    spec = parse_scenario(_scenario({"resolution": 120, "parameter": "q7", "qdd_max": 8.0}))
    assert spec.plan == PlanSettings(resolution=120, parameter="q7", qdd_max=8.0)
    assert builtin("iiwa_arm_angle_eight").plan == PlanSettings()
    for bad, key in (({"objective": "manipulability"}, "objective"),
                     ({"resolution": 1}, "resolution"), ({"parameter": "q3"}, "parameter"),
                     ({"qdd_max": 0.0}, "qdd_max"), ({"speed": 1.0}, "speed")):  # fmt: skip
        with pytest.raises(ScenarioError, match=rf"\[plan\]\.{key}"):
            parse_scenario(_scenario(bad))
