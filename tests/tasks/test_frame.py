"""Frame tasks: the planar target of PlanarTask."""

from __future__ import annotations

import numpy as np

import redres as rr
from redres.tasks import PlanarTask


def test_planar_target_is_the_pose_and_twist_it_names() -> None:
    robot = rr.models.planar([1.0, 1.0, 1.0])
    q = np.array([0.3, -0.2, 0.5])
    T = robot.fk(q)
    task = PlanarTask()
    task.set_planar_target(T[0, 3], T[1, 3], float(q.sum()), velocity=(0.1, -0.2, 0.3))
    np.testing.assert_allclose(task.target, T, atol=1e-12)
    np.testing.assert_allclose(task.twist, [0.1, -0.2, 0.0, 0.0, 0.0, 0.3])
    state = task.compute(robot, q)
    np.testing.assert_allclose(state.error, np.zeros(3), atol=1e-12)
    np.testing.assert_allclose(state.feedforward, [0.1, -0.2, 0.3])
