"""The closed-loop rate-control loop: convergence, limits, bad input, and the two
scenarios of the redundancy-resolution issue (numbers reported in the closing note)."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control import Hold
from redres.errors import InvalidParameterError, JointLimitError, SimulationError
from redres.objectives import JointLimitObjective
from redres.resolution import (
    AugmentedJacobianScheme,
    GradientProjectionScheme,
    PseudoInverseScheme,
    Scheme,
    StepResult,
    WeightedLeastNormScheme,
)
from redres.scenarios.spec import builtin
from redres.tasks import ArmAngleTask, FrameTask


def test_task_error_decays_exponentially() -> None:
    robot = rr.models.panda()
    q0 = robot.neutral()
    target = robot.fk(q0)
    target[:3, 3] += [0.02, -0.01, 0.015]
    gain, dt = 10.0, 1e-3
    log = rr.run(
        robot, FrameTask(), Hold(target, 0.5), PseudoInverseScheme(), dt=dt, gain=gain, q0=q0
    )
    e = log.position_error
    assert np.all(np.diff(e) < 0)  # strictly decreasing
    # Discrete CLIK: e_k ≈ (1 − K dt)^k e_0 while the linearisation holds.
    k = 200
    assert e[k] / e[0] == pytest.approx((1 - gain * dt) ** k, rel=0.02)


def test_velocity_limits_scale_the_whole_command() -> None:
    robot = rr.models.panda()
    q0 = robot.neutral()
    target = robot.fk(q0)
    target[:3, 3] += [0.2, 0.0, 0.0]  # far: a large gain demands more than the limits
    log = rr.run(robot, FrameTask(), Hold(target, 0.2), PseudoInverseScheme(), gain=50.0, q0=q0)
    assert log.scaled.any()
    assert np.all(np.abs(log.qd) <= robot.qd_max + 1e-12)
    k = int(np.argmax(log.scaled))  # the scaled command keeps its direction
    J = robot.jacobian(log.q[k])
    xd = J @ log.qd[k]
    e = log.position[k] - log.target[k]
    cos = -(xd[:3] @ e) / (np.linalg.norm(xd[:3]) * np.linalg.norm(e))
    assert cos > 0.999


def test_bad_run_input() -> None:
    robot = rr.models.panda()
    hold = Hold(robot.fk(robot.neutral()), 0.01)
    scheme = PseudoInverseScheme()
    with pytest.raises(InvalidParameterError, match="dt must be > 0"):
        rr.run(robot, FrameTask(), hold, scheme, dt=0.0)
    with pytest.raises(InvalidParameterError, match="gain must be >= 0"):
        rr.run(robot, FrameTask(), hold, scheme, gain=-1.0)
    outside = robot.neutral()
    outside[3] = 0.5  # joint 4 must stay below −0.0698
    with pytest.raises(JointLimitError, match=r"q0\[3\] = 0.5 is outside the limits"):
        rr.run(robot, FrameTask(), hold, scheme, q0=outside)
    with pytest.raises(rr.errors.ShapeError, match="q0 must have shape"):
        rr.run(robot, FrameTask(), hold, scheme, q0=np.zeros(6))
    with pytest.raises(InvalidParameterError, match="give a duration"):
        rr.run(robot, FrameTask(), None, scheme)
    with pytest.raises(rr.errors.NonFiniteError, match="T_target"):
        target = robot.fk(robot.neutral())
        target[0, 3] = np.nan
        FrameTask().set_target(target)


def test_a_scheme_returning_nan_stops_the_run_with_the_step() -> None:
    class Broken(Scheme):
        name = "broken"

        def _step(self, robot, q, J, xd):  # type: ignore[no-untyped-def]
            qd = np.zeros(robot.n)
            if self.calls == 3:
                qd[0] = np.nan
            self.calls += 1
            info = rr.linalg.rate_step(J, xd)[1]
            return StepResult(qd, info, np.zeros(robot.n))

    scheme = Broken()
    scheme.calls = 0  # type: ignore[attr-defined]
    robot = rr.models.panda()
    with pytest.raises(SimulationError, match="step 3 .*broken.*non-finite"):
        rr.run(robot, FrameTask(), Hold(robot.fk(robot.neutral()), 0.01), scheme)


def test_run_log_summary_keys() -> None:
    robot = rr.models.iiwa14()
    log = rr.run(robot, FrameTask(), Hold(robot.fk(robot.neutral()), 0.02), PseudoInverseScheme())
    s = log.summary()
    for key in (
        "robot",
        "scheme",
        "steps",
        "max_position_error_m",
        "rms_position_error_m",
        "min_joint_limit_margin_rad",
        "min_sigma",
        "peak_speed_ratio",
        "step_time_us_median",
        "path_length_rad",
    ):
        assert key in s
    assert s["steps"] == 20 and s["robot"] == "iiwa14" and s["scheme"] == "pinv"


def test_panda_circle_pinv_hits_a_limit_and_self_motion_avoids_it() -> None:
    """Issue 4: 10 s at 1 kHz. Plain pseudo-inverse reaches or crosses a joint limit;
    gradient projection and weighted least-norm keep every joint inside with a margin,
    tracking error below 1e-4 m."""
    sc = builtin("panda_joint_limit_circle")
    results = {}
    for scheme in (
        PseudoInverseScheme(),
        GradientProjectionScheme([JointLimitObjective()], k_null=5.0),
        WeightedLeastNormScheme(),
    ):
        log = rr.run(sc.robot, FrameTask(), sc.trajectory, scheme, q0=sc.q0, dt=1e-3, gain=50.0)
        assert log.steps == 10_000
        results[scheme.name] = log.summary()
    for s in results.values():
        assert s["max_position_error_m"] < 1e-4
        assert s["scaled_steps"] == 0
    assert results["pinv"]["min_joint_limit_margin_rad"] <= 0.0
    assert results["gradient_projection"]["min_joint_limit_margin_rad"] > 0.05
    assert results["wln"]["min_joint_limit_margin_rad"] > 0.05


def test_iiwa_holds_its_arm_angle_with_the_augmented_jacobian() -> None:
    sc = builtin("iiwa_arm_angle_eight")
    arm = ArmAngleTask()
    phi0 = arm.value(sc.robot, sc.q0)
    logs = {}
    for scheme in (AugmentedJacobianScheme(), PseudoInverseScheme()):
        logs[scheme.name] = rr.run(sc.robot, FrameTask(), sc.trajectory, scheme, q0=sc.q0)
    aug = logs["augmented"]
    assert aug.steps == 10_000 and aug.summary()["max_position_error_m"] < 1e-4
    phis = np.array([arm.value(sc.robot, q) for q in aug.q[::50]])
    assert np.max(np.abs(phis - phi0)) < 1e-6
    assert not aug.extra["algorithmic_singularity"].any()
    drift = np.array([arm.value(sc.robot, q) for q in logs["pinv"].q[::50]])
    assert np.max(np.abs(drift - phi0)) > 1e-3  # without the extra row, φ wanders


class _OffsetTask(FrameTask):
    """A frame task with its own ``compute`` (target shifted 1 cm along x)."""

    def compute(self, robot: rr.Robot, q: np.ndarray) -> rr.tasks.TaskState:
        state = super().compute(robot, q)
        error = state.error.copy()
        error[0] += 0.01
        return rr.tasks.TaskState(error, state.jacobian, state.feedforward)


def test_run_takes_the_compiled_front_end_only_for_a_plain_frame_task() -> None:
    """``rr.run`` evaluates a FrameTask in the compiled kernel: same run as the task's own
    ``compute`` (a subclass overriding it keeps the general path), and the task is left as
    if it had computed the last step."""
    scenario = builtin("panda_joint_limit_circle")
    robot, q0 = scenario.robot, scenario.q0
    T = robot.fk(q0)
    T[:3, 3] += [0.01, 0.0, -0.01]
    twist = np.array([0.0, 0.0, 0.01, 0.0, 0.0, 0.0])
    fast, plain = FrameTask(), FrameTask()
    fast.set_target(T, twist)
    plain.set_target(T, twist)
    log = rr.run(robot, fast, None, PseudoInverseScheme(), duration=0.2, q0=q0)
    previous = rr.linalg._backend.set_jit_enabled(False)  # the composed path
    try:
        ref = rr.run(robot, plain, None, PseudoInverseScheme(), duration=0.2, q0=q0)
    finally:
        rr.linalg._backend.set_jit_enabled(previous)
    np.testing.assert_allclose(log.q, ref.q, rtol=0, atol=1e-12)
    np.testing.assert_allclose(log.position_error, ref.position_error, rtol=0, atol=1e-14)
    np.testing.assert_allclose(log.target, ref.target, rtol=0, atol=1e-15)
    np.testing.assert_allclose(fast.last_error, plain.last_error, rtol=0, atol=1e-13)
    np.testing.assert_allclose(fast.target, T, rtol=0, atol=0)
    np.testing.assert_allclose(fast.twist, twist, rtol=0, atol=0)
    offset = rr.run(robot, _OffsetTask(), None, PseudoInverseScheme(), duration=0.2, q0=q0)
    held = rr.run(robot, FrameTask(), None, PseudoInverseScheme(), duration=0.2, q0=q0)
    assert offset.position_error[-1] > 1e-3 > 1e-9 > held.position_error[-1]


@pytest.mark.parametrize("name", ["sns", "qp"])
def test_the_log_records_every_schemes_own_objectives(name: str) -> None:
    """``scheme.objectives`` is read for any scheme: the hard-limit schemes' costs are
    logged too (they were not while the log knew only two scheme classes)."""
    robot = rr.models.panda()
    costs = [JointLimitObjective(), (rr.objectives.PostureObjective(), 0.5)]
    if name == "qp":
        pytest.importorskip("daqp")
        scheme: Scheme = rr.resolution.QPScheme(dt=1e-3, objectives=costs)
    else:
        scheme = rr.resolution.SNSScheme(dt=1e-3, objectives=costs)
    hold = Hold(robot.fk(robot.neutral()), 0.02)
    log = rr.run(robot, FrameTask(), hold, scheme)
    assert set(log.objectives) == {"joint_limits", "posture"}
    q = log.q[-1]
    assert log.objectives["joint_limits"][-1] == JointLimitObjective().cost(robot, q)
