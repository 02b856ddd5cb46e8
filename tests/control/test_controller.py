"""ClikController: the compiled CLIK step against the composed path it fuses.

Oracles: Pinocchio's ``log3`` and ``exp3`` for the kernel's SO(3) logarithm; the composed
step (FrameTask + total_gradient + rate_step + uniform velocity scaling, each tested on
its own elsewhere) for single steps; ``rr.run`` with the equivalent scheme for a whole
closed-loop run.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import _jit
from redres.control import ClikController
from redres.errors import InvalidParameterError, NonFiniteError, ShapeError
from redres.linalg import _backend
from redres.objectives import JointLimitObjective, ManipulabilityObjective, PostureObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme, StepResult
from redres.resolution.gradient_projection import total_gradient, weighted_objectives
from redres.scenario import builtin
from redres.tasks import FrameTask

INVERSES: list[tuple[str, dict[str, Any]]] = [
    ("exact", {}),
    ("damped", {"damping": 0.05}),
    ("adaptive", {"max_damping": 0.1, "threshold": 0.3}),
    ("svd", {"rcond": 1e-3}),
]


def _so3_log() -> Any:
    if _backend.kernels() is None:
        pytest.skip("compiled kernels unavailable")
    return _jit.load("redres.control._kernels")._so3_log  # type: ignore[union-attr]


def _random_rotation(rng: np.random.Generator, angle: float) -> np.ndarray:
    axis = rng.normal(size=3)
    return np.asarray(pin.exp3(angle * axis / np.linalg.norm(axis)))


@pytest.mark.parametrize(
    "angle",
    [0.0, 1e-12, 1e-8, 1e-5, 1e-4, 2e-4, 0.1, 1.0, 2.0, 2.69, 2.7, 3.0, 3.14, np.pi - 1e-6,
     np.pi - 1e-10],
)  # fmt: skip
def test_so3_log_matches_pinocchio_at_every_angle(angle: float, rng: np.random.Generator) -> None:
    log = _so3_log()
    for _ in range(20):
        R = _random_rotation(rng, angle)
        out = np.empty(3)
        log(R, out)
        assert np.allclose(out, pin.log3(R), rtol=0, atol=2e-9)
        assert np.allclose(pin.exp3(out), R, rtol=0, atol=1e-14)  # exp(log R) = R


def test_so3_log_at_exactly_pi_gives_a_valid_logarithm() -> None:
    log = _so3_log()
    for axis in np.eye(3).tolist() + [[1.0, 1.0, 0.0], [1.0, -2.0, 3.0]]:
        u = np.array(axis) / np.linalg.norm(axis)
        R = 2.0 * np.outer(u, u) - np.eye(3)  # rotation by pi about u
        out = np.empty(3)
        log(R, out)
        assert np.isclose(np.linalg.norm(out), np.pi, rtol=0, atol=1e-12)
        assert np.allclose(pin.exp3(out), R, rtol=0, atol=1e-14)


def composed_step(
    robot: rr.Robot,
    q: np.ndarray,
    target: np.ndarray,
    twist: np.ndarray,
    *,
    rows: list[int] | None,
    gain: float,
    objectives: list[Any],
    inverse: rr.resolution.InverseChoice,
    limit: bool,
    dt: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The step built from its tested parts: ``(q_next, qd, six-row error)``."""
    task = FrameTask(rows=rows)
    task.set_target(target, twist)
    state = task.compute(robot, q)
    pairs = weighted_objectives(objectives)
    grad = total_gradient(robot, q, pairs) if pairs else None
    qd, _, _ = rr.linalg.rate_step(
        state.jacobian, state.command(gain), grad, k_null=0.7, **inverse.rate_kwargs()
    )
    speed = np.max(np.abs(qd) / robot.qd_max)
    if limit and speed > 1.0:
        qd = qd / speed
    assert task.last_error is not None
    return q + qd * dt, qd, task.last_error


def _target_near(robot: rr.Robot, q: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    T = robot.fk(q)
    T[:3, 3] += rng.uniform(-0.03, 0.03, 3)
    T[:3, :3] = T[:3, :3] @ pin.exp3(rng.uniform(-0.05, 0.05, 3))
    return T


@pytest.mark.parametrize(("kind", "params"), INVERSES)
@pytest.mark.parametrize(
    ("name", "rows"),
    [("panda", None), ("iiwa14", None), ("srs7", [0, 1, 2]), ("panda", ["x", "z", "ry"]),
     ("planar3", ["x", "y"])],
)  # fmt: skip
def test_step_equals_the_composed_step(
    name: str,
    rows: Any,
    kind: str,
    params: dict[str, Any],
    builtin_robots: dict[str, rr.Robot],
    rng: np.random.Generator,
) -> None:
    robot = builtin_robots[name]
    inverse = rr.resolution.InverseChoice(kind, **params)  # type: ignore[arg-type]
    parsed = None if rows is None else FrameTask(rows=rows).rows
    for trial in range(12):
        q = robot.random_configuration(rng)
        target = _target_near(robot, q, rng)
        twist = rng.uniform(-0.2, 0.2, 6)
        objectives: list[Any] = [
            [],
            [JointLimitObjective()],
            [(JointLimitObjective(), 2.0), (PostureObjective(weights=0.3), 0.5)],
        ][trial % 3]
        limit = trial % 2 == 0
        controller = ClikController(
            robot, rows=rows, gain=40.0, objectives=objectives, k_null=0.7, inverse=inverse,
            dt=2e-3, limit_velocity=limit,
        )  # fmt: skip
        controller.set_target(target, twist)
        q_next = controller.step(q)
        expected, qd, error = composed_step(
            robot, q, target, twist, rows=parsed, gain=40.0, objectives=objectives,
            inverse=inverse, limit=limit, dt=2e-3,
        )  # fmt: skip
        scale = 1.0 + np.abs(qd).max()
        assert np.allclose(controller.qd, qd, rtol=0, atol=1e-11 * scale)
        assert np.allclose(q_next, expected, rtol=0, atol=1e-13 * scale)
        assert np.allclose(controller.error, error, rtol=0, atol=1e-14)


def test_info_and_scaling_describe_the_last_step(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    controller = ClikController(robot, inverse="damped", damping=0.05, gain=500.0)
    controller.set_target(_target_near(robot, q, rng))
    controller.step(q)
    task = FrameTask()
    task.set_target(controller.target)
    state = task.compute(robot, q)
    _, info, _ = rr.linalg.rate_step(state.jacobian, state.command(500.0), damping=0.05)
    assert controller.info.rank == info.rank == 6 and controller.info.full_rank
    assert controller.info.method == "damped" and controller.info.damping == 0.05
    assert np.isclose(controller.info.sigma_min, info.sigma_min, rtol=1e-12)
    assert np.isclose(controller.info.sigma_max, info.sigma_max, rtol=1e-12)
    assert controller.scaled and controller.speed_ratio > 1.0
    assert np.isclose(np.max(np.abs(controller.qd) / robot.qd_max), 1.0, rtol=1e-14)


def test_without_a_target_the_pose_is_held_and_the_null_space_acts_alone(
    rng: np.random.Generator,
) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    controller = ClikController(robot, objectives=[JointLimitObjective()], k_null=5.0)
    assert controller.target is None
    controller.step(q)
    assert np.allclose(controller.target, robot.fk(q), rtol=0, atol=1e-15)  # type: ignore[arg-type]
    assert np.abs(controller.error).max() < 1e-14
    J = robot.jacobian(q)
    assert np.linalg.norm(controller.qd) > 1e-3  # the joint-limit cost moves the arm
    assert np.linalg.norm(J @ controller.qd) < 1e-10  # ... without moving the hand


def test_per_row_gains(rng: np.random.Generator) -> None:
    robot = rr.models.iiwa14()
    q = robot.random_configuration(rng, margin=0.3)
    target = _target_near(robot, q, rng)
    gains = np.array([10.0, 20.0, 30.0, 1.0, 2.0, 3.0])
    controller = ClikController(robot, gain=gains, limit_velocity=False)
    controller.set_target(target)
    controller.step(q)
    task = FrameTask()
    task.set_target(target)
    state = task.compute(robot, q)
    qd, _, _ = rr.linalg.rate_step(state.jacobian, gains * state.error)
    assert np.allclose(controller.qd, qd, rtol=0, atol=1e-11)


def test_the_kernel_and_the_numpy_fallback_agree(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.2)
    target = _target_near(robot, q, rng)
    kwargs: dict[str, Any] = {"objectives": [JointLimitObjective()], "inverse": "damped"}
    compiled = ClikController(robot, **kwargs)
    compiled.set_target(target)
    expected = [compiled.step(q).copy(), compiled.qd.copy(), compiled.error.copy()]
    previous = _backend.set_jit_enabled(False)
    try:
        fallback = ClikController(robot, **kwargs)
        fallback.set_target(target)
        got = [fallback.step(q), fallback.qd, fallback.error]
        assert fallback.info.method == "damped"
    finally:
        _backend.set_jit_enabled(previous)
    for a, b in zip(got, expected, strict=True):
        assert np.allclose(a, b, rtol=0, atol=1e-12)


@pytest.mark.parametrize("objectives", [[], [(JointLimitObjective(), 1.0)]])
def test_a_closed_loop_run_reproduces_rr_run(objectives: list[Any]) -> None:
    """One second of the Panda joint-limit circle, step for step."""
    scenario = builtin("panda_joint_limit_circle")
    robot, trajectory = scenario.robot, scenario.trajectory
    assert trajectory is not None
    scheme = (
        GradientProjectionScheme(objectives, k_null=5.0, damping=0.01)
        if objectives
        else PseudoInverseScheme(damping=0.01)
    )
    log = rr.run(robot, FrameTask(), trajectory, scheme, duration=1.0, q0=scenario.q0, gain=50.0)
    controller = ClikController(
        robot, objectives=objectives, k_null=5.0, inverse="damped", damping=0.01, gain=50.0
    )
    q = follow(controller, trajectory, scenario.q0, log)
    assert np.allclose(q, rr.control.final_configuration(log), rtol=0, atol=1e-9)


def follow(controller: ClikController, trajectory: Any, q0: np.ndarray, log: Any) -> np.ndarray:
    """Run ``controller`` along ``trajectory`` from ``q0``, checking each step against the
    ``rr.run`` log (configuration, velocity, scaling); returns the final configuration."""
    q = q0.copy()
    for k in range(len(log.t)):
        assert np.allclose(q, log.q[k], rtol=0, atol=1e-9), f"step {k}"
        sample = trajectory.sample(k * 1e-3)
        controller.set_target(sample.pose, sample.twist, validate=False)
        q = controller.step(q)
        assert np.allclose(controller.qd, log.qd[k], rtol=0, atol=1e-8), f"step {k}"
        assert controller.scaled == log.scaled[k]
    return q


def test_bad_input_is_refused_with_a_clear_error(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    controller = ClikController(robot)
    q = robot.neutral()
    with pytest.raises(NonFiniteError, match="q contains NaN"):
        controller.step(np.full(7, np.nan))
    with pytest.raises(ShapeError, match=r"shape \(7,\)"):
        controller.step(np.zeros(6))
    with pytest.raises(ShapeError, match=r"shape \(7,\)"):
        controller.step(np.zeros((7, 1)))
    with pytest.raises(ShapeError):
        controller.step("not a configuration")
    with pytest.raises(ShapeError, match="rotation"):
        controller.set_target(np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(NonFiniteError):
        controller.set_target(robot.fk(q), [0.0, 0.0, np.inf, 0.0, 0.0, 0.0])
    with pytest.raises(InvalidParameterError, match="manipulability.*GradientProjectionScheme"):
        ClikController(robot, objectives=[ManipulabilityObjective()])
    with pytest.raises(InvalidParameterError, match="dt must be > 0"):
        ClikController(robot, dt=0.0)
    with pytest.raises(InvalidParameterError, match="gain"):
        ClikController(robot, gain=-1.0)
    with pytest.raises(ShapeError, match="gain"):
        ClikController(robot, gain=[1.0, 2.0])
    with pytest.raises(InvalidParameterError, match="inverse"):
        ClikController(robot, inverse="magic")
    # A failed call leaves the controller usable.
    assert np.all(np.isfinite(controller.step(q)))


def test_quadratic_forms_reproduce_the_gradients(
    builtin_robots: dict[str, rr.Robot], rng: np.random.Generator
) -> None:
    for robot in builtin_robots.values():
        for obj in (JointLimitObjective(), PostureObjective(weights=rng.uniform(0, 2, robot.n))):
            form = obj.quadratic_form(robot)
            assert form is not None
            a, r = form
            for _ in range(5):
                q = robot.random_configuration(rng)
                assert np.allclose(a * (q - r), obj.gradient(robot, q), rtol=1e-14, atol=1e-15)
    assert ManipulabilityObjective().quadratic_form(rr.models.panda()) is None


def _scheme(name: str) -> Any:
    if name == "sns":
        return rr.resolution.SNSScheme(dt=1e-3, objectives=[JointLimitObjective()], k_null=2.0)
    if name == "qp":
        pytest.importorskip("daqp")
        return rr.resolution.QPScheme(dt=1e-3, objectives=[JointLimitObjective()], gain=2.0)
    return rr.resolution.WeightedLeastNormScheme()


@pytest.mark.parametrize("jit", [True, False])
@pytest.mark.parametrize("name", ["sns", "qp", "wln"])
def test_a_scheme_in_the_controller_reproduces_rr_run(name: str, jit: bool) -> None:
    """Half a second of the Panda circle: kernel front end + the scheme's velocity()."""
    scenario = builtin("panda_joint_limit_circle")
    robot, trajectory = scenario.robot, scenario.trajectory
    assert trajectory is not None
    log = rr.run(robot, FrameTask(), trajectory, _scheme(name), duration=0.5, q0=scenario.q0)
    previous = _backend.set_jit_enabled(jit)
    try:
        controller = ClikController(robot, scheme=_scheme(name))
        follow(controller, trajectory, scenario.q0, log)
    finally:
        _backend.set_jit_enabled(previous)
    result = controller.last_result()
    assert np.allclose(result.qd, log.qd[-1], rtol=0, atol=1e-8)
    assert controller.info.rank == result.info.rank == 6
    assert np.isclose(np.linalg.norm(controller.error[:3]), log.position_error[-1], atol=1e-12)


def test_scheme_arguments_are_checked() -> None:
    robot = rr.models.panda()
    sns = rr.resolution.SNSScheme(dt=1e-3)
    with pytest.raises(InvalidParameterError, match="objectives, k_null and the inverse"):
        ClikController(robot, scheme=sns, objectives=[JointLimitObjective()])
    with pytest.raises(InvalidParameterError, match="to the scheme"):
        ClikController(robot, scheme=sns, inverse="damped", damping=0.1)
    with pytest.raises(InvalidParameterError, match="to the scheme"):
        ClikController(robot, scheme=sns, k_null=3.0)
    with pytest.raises(InvalidParameterError, match="dt = 0.001.*dt = 0.002"):
        ClikController(robot, scheme=sns, dt=2e-3)
    with pytest.raises(InvalidParameterError, match="Scheme"):
        ClikController(robot, scheme="sns")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="scheme="):
        ClikController(robot).last_result()
    with pytest.raises(InvalidParameterError, match="after a step"):
        ClikController(robot, scheme=sns).last_result()


def test_settings_are_read_only_and_fixed_at_construction() -> None:
    controller = ClikController(rr.models.panda(), dt=1e-3)
    for name, value in (("dt", 2e-3), ("k_null", 2.0), ("limit_velocity", False),
                        ("objectives", ()), ("inverse", "damped"), ("scheme", None)):  # fmt: skip
        with pytest.raises(AttributeError):
            setattr(controller, name, value)
    assert controller.dt == 1e-3


class _WrongSize(rr.resolution.PseudoInverseScheme):
    """A scheme that returns a joint velocity of the wrong length."""

    def _step(self, robot: Any, q: Any, J: Any, xd: Any) -> StepResult:
        result = super()._step(robot, q, J, xd)
        return StepResult(np.zeros(3), result.info, np.zeros(3))


def test_a_scheme_returning_a_wrong_velocity_is_caught() -> None:
    robot = rr.models.panda()
    for limit in (True, False):
        controller = ClikController(robot, scheme=_WrongSize(), limit_velocity=limit)
        with pytest.raises(ShapeError, match=r"shape \(3,\); expected \(7,\)"):
            controller.step(robot.neutral())


def test_a_half_turn_error_through_the_kernel(rng: np.random.Generator) -> None:
    """Target rotated by π about a random axis: ‖e_rot‖ = π and exp(e_rot) = R_d Rᵀ (either
    axis is a valid logarithm there)."""
    robot = rr.models.iiwa14()
    for _ in range(10):
        q = robot.random_configuration(rng, margin=0.2)
        T = robot.fk(q)
        axis = rng.normal(size=3)
        axis /= np.linalg.norm(axis)
        target = T.copy()
        target[:3, :3] = pin.exp3(np.pi * axis) @ T[:3, :3]
        controller = ClikController(robot, limit_velocity=False)
        controller.set_target(target)
        controller.step(q)
        e = controller.error[3:]
        assert np.isclose(np.linalg.norm(e), np.pi, rtol=0, atol=1e-12)
        assert np.allclose(pin.exp3(e), target[:3, :3] @ T[:3, :3].T, rtol=0, atol=1e-12)


@pytest.mark.parametrize("jit", [True, False])
def test_command_is_the_frame_task_evaluated(jit: bool, rng: np.random.Generator) -> None:
    """``command(q)``: the Jacobian rows, ``ẋ_d + K e``, the error and the pose, as
    FrameTask computes them."""
    robot = rr.models.iiwa14()
    previous = _backend.set_jit_enabled(jit)
    try:
        for rows in (None, ["x", "y", "rz"]):
            gains = np.array([5.0, 6.0, 7.0] * 2 if rows is None else [5.0, 6.0, 7.0])
            controller = ClikController(robot, rows=rows, gain=gains)
            q = robot.random_configuration(rng, margin=0.2)
            target, twist = _target_near(robot, q, rng), rng.normal(size=6)
            controller.set_target(target, twist)
            cmd = controller.command(q)
            task = FrameTask(rows=rows)
            task.set_target(target, twist)
            state = task.compute(robot, q)
            assert np.allclose(cmd.jacobian, state.jacobian, rtol=0, atol=1e-14)
            assert np.allclose(cmd.command, state.feedforward + gains * state.error, atol=1e-13)
            assert np.allclose(cmd.error, task.last_error, rtol=0, atol=1e-14)
            assert np.allclose(cmd.pose, robot.fk(q), rtol=0, atol=1e-14)
    finally:
        _backend.set_jit_enabled(previous)
    with pytest.raises(ShapeError):
        controller.command(np.zeros(3))
