"""compare_with_plan: the scenario's schemes against the global optimum on the same path,
one row per scheme, the share of the optimum consistent with the values; the local
schemes at or below the max-min optima; bad objectives refused."""

from __future__ import annotations

import pytest

from redres.errors import InvalidParameterError
from redres.plan.clearance import clearances
from redres.scenarios.planned import compare_with_plan
from redres.scenarios.spec import builtin


def test_panda_circle_schemes_against_the_optimum() -> None:
    spec = builtin("panda_joint_limit_circle")
    # one turn of the four (2.5 s): the schemes already spread (measured: the best local
    # scheme, osc, 0.382 rad, minimum norm 0.202 rad, against the optimum 0.4825 rad)
    found = compare_with_plan("panda_joint_limit_circle", duration=2.5)
    assert found.plan.feasible and found.optimum == found.plan.objective
    assert [r.scheme for r in found.rows] == [s.label for s in spec.schemes]
    for row, log in zip(found.rows, found.logs):
        assert row.value == float(log.joint_limit_margin.min())
        assert row.percent == pytest.approx(100.0 * row.value / found.optimum, rel=1e-12)
        assert row.value <= found.optimum
    table = found.table()
    assert "% of the optimum" in table and "global plan (DP)" in table
    assert all(r.scheme.split(":")[0] in table for r in found.rows)

    clear = compare_with_plan(spec, objective="obstacle_clearance", duration=2.5)
    assert clear.unit == "m" and clear.plan.min_clearance == clear.optimum
    for row, log in zip(clear.rows, clear.logs):
        assert row.value == float(clearances(spec.robot, log.q, spec.obstacles).min())
        assert row.value <= clear.optimum + 1e-9  # the start binds (q0 to 1e-9 rad)


def test_bad_objectives_are_refused() -> None:
    with pytest.raises(InvalidParameterError, match="to compare"):
        compare_with_plan("panda_joint_limit_circle", objective="manipulability")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="no obstacles"):
        compare_with_plan("iiwa_arm_angle_eight", objective="obstacle_clearance", duration=0.1)


def test_iiwa_circle_scenario_against_the_optimum() -> None:
    """The built-in iiwa14 circle: its [plan] settings, and on its first 0.5 s every
    scheme at or below the optimum (measured on the whole path: the plan 0.4778 rad,
    pinv 0.4687, gradient projection 0.4739, wln 0.4732)."""
    spec = builtin("iiwa_joint_limit_circle")
    assert spec.plan is not None and spec.plan.resolution == 720
    found = compare_with_plan(spec, resolution=spec.plan.resolution, duration=0.5)
    assert found.plan.feasible and [r.scheme for r in found.rows] == [s.label for s in spec.schemes]
    for row, log in zip(found.rows, found.logs):
        assert row.value == float(log.joint_limit_margin.min()) <= found.optimum
