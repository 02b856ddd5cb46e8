"""IK datasets: every stored solution is an IK solution of its pose (Pinocchio FK), the
solutions of a pose are distinct, and the pose is the FK of its configuration."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

import redres as rr
from redres import sweeps
from redres.sweeps.kinds.ikdata import distinct

SPEC = """
kind = "ik_dataset"
seed = 4
shard_size = 20
small_shards = true
[robot]
model = "iiwa14"
[solver]
tol_position = 1e-6
tol_orientation = 1e-5
[ik_dataset]
poses = 50
solutions = 4
attempts = 12
"""


def test_dataset(tmp_path: Path) -> None:
    (tmp_path / "ik.toml").write_text(SPEC)
    report = sweeps.run(tmp_path / "ik.toml", tmp_path / "out", workers=1, progress=False)
    assert report.shards == 3 and report.queries == 50
    data = sweeps.load(tmp_path / "out")
    robot = rr.models.iiwa14()
    count, solutions = data["count"], data["solutions"]
    assert (count >= 1).mean() > 0.9 and (count >= 2).any()
    assert (data["attempts"] >= 1).all() and (data["attempts"] <= 12).all()
    for i in range(50):
        np.testing.assert_allclose(robot.fk(data["q_true"][i]), data["pose"][i], atol=1e-12)
        for s in range(count[i]):
            q = solutions[i, s]
            assert robot.within_limits(q)
            T = robot.fk(q)
            assert np.linalg.norm(T[:3, 3] - data["pose"][i][:3, 3]) <= 1e-6
            assert np.linalg.norm(pin.log3(data["pose"][i][:3, :3].T @ T[:3, :3])) <= 1e-5 + 1e-9
            for t in range(s):
                assert np.abs(solutions[i, t] - q).max() > 1e-3
        assert np.isnan(solutions[i, count[i] :]).all()


def test_distinct() -> None:
    a, b = np.zeros(3), np.ones(3)
    solutions = np.array([[a, a + 1e-4, b, np.full(3, np.nan)], [b, a, b + 2e-3, a]])
    out, kept = distinct(solutions, np.array([3, 4]), 1e-3)
    assert kept.tolist() == [2, 3]
    np.testing.assert_array_equal(out[0, :2], [a, b])
    np.testing.assert_array_equal(out[1, :3], [b, a, b + 2e-3])
    assert np.isnan(out[0, 2:]).all() and np.isnan(out[1, 3]).all()
