"""A robot under tighter limits than its file says: a 1 kHz loop under ``qd_max`` halved
never exceeds it, in ``rr.run`` and in the compiled controller loop."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control import Circle
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.tasks import FrameTask


def _fast_circle(robot: rr.Robot) -> Circle:
    # 12 cm circle in 0.5 s: about 1.5 m/s at the tool, more than the halved limits allow
    return Circle(robot.fk(robot.neutral()), 0.12, 0.5)


@pytest.fixture(scope="module")
def robots() -> tuple[rr.Robot, rr.Robot]:
    panda = rr.models.panda()
    return panda, panda.with_limits(qd_max=0.5 * panda.qd_max)


def _gradient_projection() -> GradientProjectionScheme:
    return GradientProjectionScheme([JointLimitObjective()])


@pytest.mark.parametrize("make", [PseudoInverseScheme, _gradient_projection])
def test_rr_run_honours_the_halved_velocity_limits(robots: tuple, make: object) -> None:
    panda, slow = robots
    circle = _fast_circle(panda)
    fast_log = rr.run(panda, FrameTask(), circle, make(), duration=0.3)  # type: ignore[operator]
    assert np.max(np.abs(fast_log.qd) / slow.qd_max) > 1.2  # the fixture needs the limit
    log = rr.run(slow, FrameTask(), circle, make(), duration=0.3)  # type: ignore[operator]
    # oracle: the joint velocity applied, recomputed from the recorded positions
    applied = np.diff(np.vstack([log.q, rr.control.final_configuration(log)]), axis=0) / log.dt
    assert np.max(np.abs(applied) / slow.qd_max) <= 1.0 + 1e-9
    assert np.max(np.abs(applied) / slow.qd_max) > 0.99  # the limit was reached
    assert log.scaled.any()


def test_the_compiled_loop_honours_the_halved_velocity_limits(robots: tuple) -> None:
    panda, slow = robots
    circle = _fast_circle(panda)
    task = FrameTask()
    controller = rr.Controller(slow, task, GradientProjectionScheme([JointLimitObjective()]))
    assert controller.path == "fused"  # the one compiled call per step
    q, worst = slow.neutral(), 0.0
    for k in range(300):
        sample = circle.sample(k * 1e-3)
        task.set_target(sample.pose, sample.twist, validate=False)
        q_next = controller.step(q)
        worst = max(worst, float(np.max(np.abs(q_next - q) / 1e-3 / slow.qd_max)))
        q = q_next
    assert 0.99 < worst <= 1.0 + 1e-9


def test_jerk_limits_are_data_on_the_robot() -> None:
    """``qddd_max`` beside ``qdd_max``: the Panda carries Franka's published values
    (Franka, "Limits for Panda"; libfranka's ``kMaxJointJerk`` plus its 1e-3 margin);
    ``with_limits`` tightens them and refuses looser ones; every derived robot (payload,
    another tip) keeps them; a DH record takes them; bad values are refused by name."""
    from redres.dynamics import Payload, with_payload
    from redres.models.franka import FR3, PANDA

    panda = rr.models.panda()
    np.testing.assert_array_equal(panda.qddd_max, [7500, 3750, 5000, 6250, 7500, 10000, 10000])
    np.testing.assert_array_equal(panda.qdd_max, PANDA.qdd_max)
    assert FR3.qddd_max == (5000.0,) * 7 and FR3.qdd_max == (10.0,) * 7
    gentle = panda.with_limits(qddd_max=1000.0)
    np.testing.assert_array_equal(gentle.qddd_max, np.full(7, 1000.0))
    np.testing.assert_array_equal(gentle.qdd_max, panda.qdd_max)  # the others unchanged
    assert len(gentle.capsules) == len(panda.capsules)
    with pytest.raises(rr.errors.InvalidParameterError, match="qddd_max"):
        panda.with_limits(qddd_max=1e5)  # looser than the robot's own
    loaded = with_payload(gentle, Payload(1.0, frame="tcp"))
    np.testing.assert_array_equal(loaded.qddd_max, gentle.qddd_max)
    np.testing.assert_array_equal(gentle.derived(tip="flange").qddd_max, gentle.qddd_max)
    assert gentle.derived(tip="flange").tip == "flange"
    assert np.all(np.isinf(rr.models.planar().qddd_max))  # unknown: inf
    arm = rr.Robot.from_dh([{"a": 1.0, "alpha": 0.0, "d": 0.0, "qddd_max": 50.0}] * 2)
    np.testing.assert_array_equal(arm.qddd_max, [50.0, 50.0])
    with pytest.raises(rr.errors.DHParameterError, match="qddd_max must be > 0"):
        rr.Robot.from_dh([{"a": 1.0, "alpha": 0.0, "d": 0.0, "qddd_max": -1.0}])
    with pytest.raises(rr.errors.InvalidParameterError, match="qddd_max must be positive"):
        rr.Robot(panda.model, tip="tcp", qddd_max=np.zeros(7))
    with pytest.raises(rr.errors.ShapeError, match=r"qddd_max must have shape \(7,\)"):
        rr.Robot(panda.model, tip="tcp", qddd_max=np.ones(6))
