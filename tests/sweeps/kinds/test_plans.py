"""Path plans as a sweep: every stored unit is the plan :func:`redres.plan_path` gives for
its settings, called here again (the objective and the joint path, bit for bit), each
stored path on the tool path by Pinocchio's FK, one shard per unit, and the table."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres import sweeps
from redres.scenarios.spec import builtin
from redres.sweeps.kind import SweepSpecError
from redres.sweeps.kinds.plans import table
from redres.sweeps.spec import parse_spec

SPEC = """
kind = "path_plans"
shard_size = 1
small_shards = true
[robot]
model = "panda"
[path_plans]
scenarios = ["panda_joint_limit_circle"]
resolutions = [12, 24]
objectives = ["joint_limit_margin", "path_length"]
qdd_max = [0.0, 400.0]
dts = [0.05]
parameter = "q7"
duration = 0.3
"""


def test_each_unit_is_its_plan(tmp_path: Path) -> None:
    (tmp_path / "plans.toml").write_text(SPEC)
    report = sweeps.run(tmp_path / "plans.toml", tmp_path / "out", workers=1, progress=False)
    assert report.shards == 8  # 2 objectives x 2 limits x 2 resolutions, one plan each
    data = sweeps.load(tmp_path / "out")
    scenario = builtin("panda_joint_limit_circle")
    robot = scenario.robot
    poses = np.array([scenario.trajectory.sample(0.05 * k).pose for k in range(7)])
    units = 0
    for u in range(8):
        objective = data.meta["objectives"][int(data.tables["objective_index"][u])]
        qdd = float(data.tables["qdd_max"][u])
        plan = rr.plan_path(robot, poses, dt=0.05, parameter="q7", q0=scenario.q0,
                            resolution=int(data.tables["resolution"][u]), objective=objective,
                            qdd_max=None if qdd == 0 else qdd)  # fmt: skip
        assert bool(data["feasible"][u]) == plan.feasible
        if not plan.feasible:
            continue
        units += 1
        assert data["objective"][u] == plan.objective
        assert np.array_equal(data["q"][u], plan.q)
        for q, T in zip(data["q"][u], poses):
            assert np.allclose(robot.fk(q), T, atol=1e-8)
        assert data["nodes"][u] == 7 * int(data.tables["resolution"][u]) * 8
    assert units >= 4
    text = table(tmp_path / "out")
    assert "joint_limit_margin" in text and "path_length" in text and "400" in text


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ({"scenarios": ["nope.toml"]}, "scenarios"),
        ({"scenarios": []}, "scenarios"),
        ({"scenarios": "panda_joint_limit_circle"}, "scenarios"),
        ({"scenarios": ["panda_joint_limit_circle"], "resolutions": [1]}, "resolutions"),
        ({"scenarios": ["panda_joint_limit_circle"], "objectives": ["x"]}, "objectives"),
        ({"scenarios": ["panda_joint_limit_circle"], "dts": [0.0]}, "dts"),
        ({"scenarios": ["panda_joint_limit_circle"], "qdd_max": [-1.0]}, "qdd_max"),
        ({"scenarios": ["panda_joint_limit_circle"], "parameter": "q3"}, "parameter"),
    ],
)
def test_bad_tables_are_refused(table: dict[str, object], key: str) -> None:
    with pytest.raises(SweepSpecError, match=rf"\[path_plans\]\.{key}"):
        parse_spec({"kind": "path_plans", "robot": {"model": "panda"}, "path_plans": table})
