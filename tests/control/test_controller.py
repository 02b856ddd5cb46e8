"""Controller: the one CLIK step, on its three paths, against each other and its parts.

Oracles: Pinocchio's ``log3`` and ``exp3`` for the kernel's SO(3) logarithm; the step
composed by hand (FrameTask + total_gradient + rate_step + uniform velocity scaling, each
tested on its own elsewhere) for single steps; the same controller forced onto its other
paths (a FrameTask subclass with its own ``compute`` takes the composed path, a scheme
subclass with its own ``_step`` the frame path); ``rr.run`` for whole closed-loop runs.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pinocchio as pin
import pytest

import redres as rr
from redres import _compile as _jit
from redres.control import Controller
from redres.errors import (
    InvalidParameterError,
    NonFiniteError,
    ShapeError,
    SimulationError,
    UnknownParameterError,
)
from redres.linalg import AdaptiveDamping, _backend
from redres.objectives import JointLimitObjective, ManipulabilityObjective, PostureObjective
from redres.resolution import (
    AugmentedJacobianScheme,
    GradientProjectionScheme,
    Inverse,
    PseudoInverseScheme,
    Scheme,
    StepResult,
    WeightedLeastNormScheme,
)
from redres.resolution.gradient_projection import total_gradient, weighted_objectives
from redres.scenarios.spec import builtin
from redres.tasks import ArmAngleTask, FrameTask, PlanarTask, PositionTask, PostureTask

INVERSES: list[Inverse] = [
    Inverse(),
    Inverse(damping=0.05),
    Inverse(damping=AdaptiveDamping(0.1, 0.3)),
    Inverse(damping=AdaptiveDamping(0.1, 0.3, selective=True)),
    Inverse(rcond=1e-3),
]


class ComposedFrameTask(FrameTask):
    """A FrameTask with its own ``compute`` (FrameTask's): the controller composes it."""

    def compute(self, robot: rr.Robot, q: np.ndarray) -> rr.tasks.TaskState:
        return super().compute(robot, q)


class OwnStepGradient(GradientProjectionScheme):
    """Gradient projection with its own ``_step`` (the parent's): not fused."""

    def _step(self, robot: Any, q: Any, J: Any, xd: Any) -> StepResult:
        return super()._step(robot, q, J, xd)


class OwnStepPinv(PseudoInverseScheme):
    """The pseudo-inverse scheme with its own ``_step`` (the parent's): not fused."""

    def _step(self, robot: Any, q: Any, J: Any, xd: Any) -> StepResult:
        return super()._step(robot, q, J, xd)


def _kernels() -> Any:
    """The fused kernels' module (skips the test without compiled kernels)."""
    if _backend.kernels() is None:
        pytest.skip("compiled kernels unavailable")
    return _jit.groups()["controller"].module()


def composed_step(
    robot: rr.Robot,
    q: np.ndarray,
    target: np.ndarray,
    twist: np.ndarray,
    *,
    rows: list[int] | None,
    gain: float,
    objectives: list[Any],
    inverse: Inverse,
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


def _scheme_for(objectives: list[Any], inverse: Inverse, own_step: bool = False) -> Scheme:
    if objectives:
        kind = OwnStepGradient if own_step else GradientProjectionScheme
        return kind(objectives, k_null=0.7, inverse=inverse)
    return (OwnStepPinv if own_step else PseudoInverseScheme)(inverse)


@pytest.mark.parametrize("inverse", INVERSES, ids=lambda inv: f"{inv.kind}-{inv.rcond:g}")
@pytest.mark.parametrize(
    ("name", "rows"),
    [("panda", None), ("iiwa14", None), ("srs7", [0, 1, 2]), ("panda", ["x", "z", "ry"]),
     ("planar3", ["x", "y"])],
)  # fmt: skip
def test_the_three_paths_and_the_composed_step_agree(
    name: str,
    rows: Any,
    inverse: Inverse,
    builtin_robots: dict[str, rr.Robot],
    rng: np.random.Generator,
) -> None:
    """Fused kernel, frame front end + scheme, task.compute + scheme: the same step (and
    the same as the hand-composed one) for every inverse, row subset and set of costs."""
    _kernels()
    robot = builtin_robots[name]
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
        expected, qd, error = composed_step(
            robot, q, target, twist, rows=parsed, gain=40.0, objectives=objectives,
            inverse=inverse, limit=limit, dt=2e-3,
        )  # fmt: skip
        scale = 1.0 + np.abs(qd).max()
        paths = {
            "fused": (FrameTask(rows=rows), _scheme_for(objectives, inverse)),
            "frame": (FrameTask(rows=rows), _scheme_for(objectives, inverse, own_step=True)),
            "composed": (ComposedFrameTask(rows=rows), _scheme_for(objectives, inverse)),
        }
        for path, (task, scheme) in paths.items():
            controller = Controller(robot, task, scheme, gain=40.0, dt=2e-3, limit_velocity=limit)
            assert controller.path == path
            task.set_target(target, twist)
            q_next = controller.step(q)
            assert np.allclose(controller.qd, qd, rtol=0, atol=1e-11 * scale), path
            assert np.allclose(q_next, expected, rtol=0, atol=1e-13 * scale), path
            assert np.allclose(controller.error, error, rtol=0, atol=1e-14), path
            assert np.allclose(controller.pose, robot.fk(q), rtol=0, atol=1e-14), path  # type: ignore[arg-type]


def test_the_fused_step_is_the_schemes_bit_for_bit_with_one_cost(
    rng: np.random.Generator,
) -> None:
    """With one cost of weight 1 the fused kernel does the scheme's floating-point
    operations (``a ∘ (q − r)``, the same inverse, division by the speed ratio): ``rr.run``
    gives the same bits on either path, scaled or not."""
    _kernels()
    robot = rr.models.panda()
    seen = set()
    for trial in range(20):
        q = robot.random_configuration(rng, margin=0.2)
        target = _target_near(robot, q, rng)
        steps = []
        for kind in (GradientProjectionScheme, OwnStepGradient):
            task = FrameTask()
            task.set_target(target)
            scheme = kind([JointLimitObjective()], k_null=5.0, damping=0.01)
            controller = Controller(robot, task, scheme, gain=[1.0, 400.0][trial % 2])
            steps.append((controller.step(q), controller.qd.copy(), controller.scaled))
        (fused_q, fused_qd, fused_scaled), (frame_q, frame_qd, frame_scaled) = steps
        assert fused_scaled == frame_scaled
        seen.add(fused_scaled)
        np.testing.assert_array_equal(fused_qd, frame_qd)
        np.testing.assert_array_equal(fused_q, frame_q)
    assert seen == {False, True}


def test_the_path_is_chosen_from_the_task_the_scheme_and_the_kernels() -> None:
    _kernels()
    robot = rr.models.panda()
    sns = rr.resolution.SNSScheme(dt=1e-3)
    cases: list[tuple[Any, Scheme, str]] = [
        (FrameTask(), PseudoInverseScheme(), "fused"),
        (PositionTask(), PseudoInverseScheme(damping=0.05), "fused"),
        (PlanarTask(), GradientProjectionScheme([JointLimitObjective()]), "fused"),
        (FrameTask(), GradientProjectionScheme([ManipulabilityObjective()]), "frame"),
        (FrameTask(), OwnStepGradient([JointLimitObjective()]), "frame"),
        (FrameTask(), WeightedLeastNormScheme(), "frame"),
        (FrameTask(), sns, "frame"),
        (ComposedFrameTask(), PseudoInverseScheme(), "composed"),
        (PostureTask(robot.neutral()), PseudoInverseScheme(), "composed"),
    ]
    for task, scheme, path in cases:
        assert Controller(robot, task, scheme).path == path, (task, scheme)
    previous = _backend.set_jit_enabled(False)
    try:
        assert Controller(robot, FrameTask(), PseudoInverseScheme()).path == "composed"
    finally:
        _backend.set_jit_enabled(previous)


def test_info_and_scaling_describe_the_last_step(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    task = FrameTask()
    controller = Controller(robot, task, PseudoInverseScheme(damping=0.05), gain=500.0)
    task.set_target(_target_near(robot, q, rng))
    controller.step(q)
    reference = FrameTask()
    reference.set_target(task.target)
    state = reference.compute(robot, q)
    _, info = rr.linalg.rate_step(state.jacobian, state.command(500.0), damping=0.05)[:2]
    assert controller.info.rank == info.rank == 6 and controller.info.full_rank
    assert controller.info.method == info.method == "damped"
    assert controller.info.damping == 0.05
    assert np.isclose(controller.info.sigma_min, info.sigma_min, rtol=1e-12)
    assert np.isclose(controller.info.sigma_max, info.sigma_max, rtol=1e-12)
    assert controller.scaled and controller.speed_ratio > 1.0
    assert np.isclose(np.max(np.abs(controller.qd) / robot.qd_max), 1.0, rtol=1e-14)
    unlimited = Controller(robot, task, PseudoInverseScheme(damping=0.05), gain=500.0,
                           limit_velocity=False)  # fmt: skip
    unlimited.step(q)
    assert not unlimited.scaled
    assert np.isclose(unlimited.speed_ratio, controller.speed_ratio, rtol=1e-12)


def test_the_result_is_the_schemes_where_the_scheme_runs(rng: np.random.Generator) -> None:
    """``result``: None on the fused path; the scheme's StepResult (``qd`` before scaling)
    on the frame and composed paths."""
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    target = _target_near(robot, q, rng)
    for task, scheme, path in (
        (FrameTask(), PseudoInverseScheme(), "fused"),
        (FrameTask(), OwnStepPinv(), "frame"),
        (ComposedFrameTask(), PseudoInverseScheme(), "composed"),
    ):
        controller = Controller(robot, task, scheme, gain=500.0)
        assert controller.path == path and controller.result is None
        task.set_target(target)
        controller.step(q)
        if path == "fused":
            assert controller.result is None
            continue
        result = controller.result
        assert result is not None and controller.scaled
        assert np.allclose(result.qd / controller.speed_ratio, controller.qd, rtol=0, atol=1e-15)
        assert controller.info == result.info


def test_without_a_target_the_pose_is_held_and_the_null_space_acts_alone(
    rng: np.random.Generator,
) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    task = FrameTask()
    controller = Controller(robot, task, GradientProjectionScheme([JointLimitObjective()],
                                                                  k_null=5.0))  # fmt: skip
    assert task.target is None
    controller.step(q)
    assert np.allclose(task.target, robot.fk(q), rtol=0, atol=1e-15)  # type: ignore[arg-type]
    assert np.abs(controller.error).max() < 1e-14
    J = robot.jacobian(q)
    assert np.linalg.norm(controller.qd) > 1e-3  # the joint-limit cost moves the arm
    assert np.linalg.norm(J @ controller.qd) < 1e-10  # ... without moving the hand


def test_the_kernels_read_the_target_where_the_task_keeps_it() -> None:
    """FrameTask's 18 target numbers (R row-major, p, twist) are the kernels' CFG slots."""
    from redres.control._fused import TARGET
    from redres.linalg import _codes as codes

    assert (codes.CFG_ROTATION, codes.CFG_POSITION, codes.CFG_TWIST) == (0, 9, 12)
    assert (TARGET.start, TARGET.stop) == (0, 18)
    task = FrameTask()
    T = np.eye(4)
    T[:3, :3] = pin.exp3(np.array([0.1, -0.2, 0.3]))
    T[:3, 3] = [1.0, 2.0, 3.0]
    task.set_target(T, np.arange(6.0))
    np.testing.assert_array_equal(task._target, [*T[:3, :3].ravel(), 1, 2, 3, *range(6)])


def test_the_target_is_the_tasks_even_when_tasks_are_shared(rng: np.random.Generator) -> None:
    """The task owns its target (copied in, so later changes to the caller's array do not
    leak); two controllers on one task both follow it."""
    robot = rr.models.iiwa14()
    q = robot.random_configuration(rng, margin=0.3)
    target, twist = _target_near(robot, q, rng), rng.normal(size=6)
    task = FrameTask()
    first = Controller(robot, task, PseudoInverseScheme())
    second = Controller(robot, task, PseudoInverseScheme(damping=0.01))
    given = target.copy()
    task.set_target(given, twist)
    given[:3, 3] += 1.0
    np.testing.assert_array_equal(task.target, target)
    np.testing.assert_array_equal(task.twist, twist)
    alone = FrameTask()
    alone.set_target(target, twist)
    reference = Controller(robot, alone, PseudoInverseScheme())
    for controller in (first, second, reference):
        controller.step(q)
    np.testing.assert_allclose(first.qd, reference.qd, rtol=0, atol=0)
    np.testing.assert_allclose(first.error, second.error, rtol=0, atol=0)


def test_a_copied_or_pickled_frame_task_keeps_one_target(rng: np.random.Generator) -> None:
    """The target's views stay views of one block through copy.deepcopy and pickle, so a
    controller on the copy follows its set_target."""
    import copy
    import pickle

    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.3)
    task = FrameTask()
    Controller(robot, task, PseudoInverseScheme()).step(q)  # the target now lives in a kernel
    for clone in (copy.deepcopy(task), pickle.loads(pickle.dumps(task))):
        np.testing.assert_array_equal(clone.target, task.target)
        target = _target_near(robot, q, rng)
        clone.set_target(target)
        controller = Controller(robot, clone, PseudoInverseScheme())
        controller.step(q)
        np.testing.assert_allclose(clone.target, target, rtol=0, atol=0)
        np.testing.assert_allclose(controller.error[:3], target[:3, 3] - robot.fk(q)[:3, 3],
                                   rtol=0, atol=1e-15)  # fmt: skip
    assert np.abs(Controller(robot, task, PseudoInverseScheme()).step(q) - q).max() < 1e-12


def test_per_row_gains(rng: np.random.Generator) -> None:
    robot = rr.models.iiwa14()
    q = robot.random_configuration(rng, margin=0.3)
    target = _target_near(robot, q, rng)
    gains = np.array([10.0, 20.0, 30.0, 1.0, 2.0, 3.0])
    task = FrameTask()
    task.set_target(target)
    state = task.compute(robot, q)
    qd, _ = rr.linalg.rate_step(state.jacobian, gains * state.error)[:2]
    for kind in (FrameTask, ComposedFrameTask):
        task = kind()
        task.set_target(target)
        controller = Controller(robot, task, PseudoInverseScheme(), gain=gains,
                                limit_velocity=False)  # fmt: skip
        controller.step(q)
        assert np.allclose(controller.qd, qd, rtol=0, atol=1e-11)
        np.testing.assert_array_equal(controller.gain, gains)


def test_any_task_other_than_a_frame_task(rng: np.random.Generator) -> None:
    """A posture task through the composed path: ``q̇ = J#(K e)`` with its own error."""
    robot = rr.models.panda()
    q_ref = robot.neutral()
    q = q_ref + rng.uniform(-0.1, 0.1, robot.n)
    task = PostureTask(q_ref)
    controller = Controller(robot, task, PseudoInverseScheme(), gain=5.0, limit_velocity=False)
    q_next = controller.step(q)
    state = task.compute(robot, q)
    np.testing.assert_allclose(controller.error, state.error, rtol=0, atol=0)
    np.testing.assert_allclose(q_next, q + 1e-3 * 5.0 * (q_ref - q), rtol=0, atol=1e-14)
    assert controller.pose is None


def test_the_kernel_and_the_numpy_fallback_agree(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    q = robot.random_configuration(rng, margin=0.2)
    target = _target_near(robot, q, rng)

    def make() -> Controller:
        task = FrameTask()
        task.set_target(target)
        return Controller(robot, task, GradientProjectionScheme([JointLimitObjective()],
                                                                damping=0.05))  # fmt: skip

    compiled = make()
    expected = [compiled.step(q).copy(), compiled.qd.copy(), compiled.error.copy()]
    previous = _backend.set_jit_enabled(False)
    try:
        fallback = make()
        got = [fallback.step(q), fallback.qd, fallback.error]
        assert fallback.path == "composed" and fallback.info.method == "damped"
    finally:
        _backend.set_jit_enabled(previous)
    for a, b in zip(got, expected, strict=True):
        assert np.allclose(a, b, rtol=0, atol=1e-12)


def _scheme(name: str) -> Scheme:
    if name == "sns":
        return rr.resolution.SNSScheme(dt=1e-3, objectives=[JointLimitObjective()], k_null=2.0)
    if name == "qp":
        pytest.importorskip("daqp")
        return rr.resolution.QPScheme(dt=1e-3, objectives=[JointLimitObjective()], k_null=2.0)
    if name == "gradient_projection":
        return GradientProjectionScheme([JointLimitObjective()], k_null=5.0, damping=0.01)
    if name == "manipulability":
        return GradientProjectionScheme([ManipulabilityObjective()], k_null=0.1)
    if name == "augmented":
        return AugmentedJacobianScheme([ArmAngleTask()])
    if name == "dls":
        return PseudoInverseScheme(damping=0.01)
    if name == "pinv":
        return PseudoInverseScheme()
    if name == "priority":
        return rr.resolution.PriorityScheme([PostureTask(robot_q0())], gain=[1.0])
    return WeightedLeastNormScheme()


def robot_q0() -> np.ndarray:
    """The Panda circle's start configuration."""
    q0: np.ndarray = builtin("panda_joint_limit_circle").q0
    return q0


@pytest.mark.parametrize("jit", [True, False])
@pytest.mark.parametrize(
    "name",
    ["pinv", "dls", "gradient_projection", "manipulability", "wln", "augmented", "priority",
     "sns", "qp"],
)  # fmt: skip
def test_a_controller_with_each_scheme_reproduces_rr_run(name: str, jit: bool) -> None:
    """Half a second of the Panda circle, step for step: ``rr.run`` takes the compiled
    paths; with ``jit=False`` the controller composes, so this also checks path against
    path over a closed loop."""
    scenario = builtin("panda_joint_limit_circle")
    robot, trajectory = scenario.robot, scenario.trajectory
    assert trajectory is not None
    log = rr.run(robot, FrameTask(), trajectory, _scheme(name), duration=0.5, q0=scenario.q0)
    previous = _backend.set_jit_enabled(jit)
    try:
        task = FrameTask()
        controller = Controller(robot, task, _scheme(name))
        q = scenario.q0.copy()
        for k in range(log.steps):
            assert np.allclose(q, log.q[k], rtol=0, atol=1e-9), f"step {k}"
            sample = trajectory.sample(k * 1e-3)
            task.set_target(sample.pose, sample.twist, validate=False)
            q = controller.step(q)
            assert np.allclose(controller.qd, log.qd[k], rtol=0, atol=1e-8), f"step {k}"
            assert controller.scaled == log.scaled[k]
            assert np.isclose(controller.info.sigma_min, log.extra["inverse_sigma_min"][k],
                              rtol=1e-8, atol=1e-12)  # fmt: skip
    finally:
        _backend.set_jit_enabled(previous)
    assert np.allclose(q, rr.control.final_configuration(log), rtol=0, atol=1e-9)
    assert controller.info.rank == (7 if name == "augmented" else 6)  # + the arm angle row
    assert np.isclose(np.linalg.norm(controller.error[:3]), log.position_error[-1], atol=1e-12)


def test_bad_input_is_refused_with_a_clear_error() -> None:
    robot = rr.models.panda()
    task = FrameTask()
    controller = Controller(robot, task, PseudoInverseScheme())
    q = robot.neutral()
    for path_task in (task, ComposedFrameTask()):
        with pytest.raises(InvalidParameterError, match="not made a step"):
            _ = Controller(robot, path_task, PseudoInverseScheme()).info
    with pytest.raises(NonFiniteError, match="q contains NaN"):
        controller.step(np.full(7, np.nan))
    with pytest.raises(ShapeError, match=r"shape \(7,\)"):
        controller.step(np.zeros(6))
    with pytest.raises(ShapeError, match=r"shape \(7,\)"):
        controller.step(np.zeros((7, 1)))
    with pytest.raises(ShapeError):
        controller.step("not a configuration")
    for path_task in (task, ComposedFrameTask()):  # the fused path and the composed one
        with pytest.raises(InvalidParameterError, match="q .*complex"):
            Controller(robot, path_task, PseudoInverseScheme()).step(q + 0.5j)
    with pytest.raises(ShapeError, match="rotation"):
        task.set_target(np.diag([2.0, 1.0, 1.0, 1.0]))
    with pytest.raises(NonFiniteError):
        task.set_target(robot.fk(q), [0.0, 0.0, np.inf, 0.0, 0.0, 0.0])
    pinv = PseudoInverseScheme()
    with pytest.raises(InvalidParameterError, match="dt must be > 0"):
        Controller(robot, FrameTask(), pinv, dt=0.0)
    with pytest.raises(InvalidParameterError, match="gain"):
        Controller(robot, FrameTask(), pinv, gain=-1.0)
    with pytest.raises(ShapeError, match="gain"):
        Controller(robot, FrameTask(), pinv, gain=[1.0, 2.0])
    with pytest.raises(InvalidParameterError, match="Scheme"):
        Controller(robot, FrameTask(), "pinv")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="Task"):
        Controller(robot, "tip", pinv)  # type: ignore[arg-type]
    with pytest.raises(UnknownParameterError, match="did you mean 'gain'"):
        Controller(robot, FrameTask(), pinv, gian=3.0)  # type: ignore[call-arg]
    # A failed call leaves the controller usable.
    assert np.all(np.isfinite(controller.step(q)))


def test_a_scheme_planned_for_another_period_is_refused() -> None:
    """A hard-limit scheme's limits hold at its own period only: the controller, and so
    ``rr.run``, refuse another one, naming both."""
    robot = rr.models.panda()
    sns = rr.resolution.SNSScheme(dt=1e-3)
    with pytest.raises(InvalidParameterError, match=r"dt = 0.001 s.*dt = 0.005 s"):
        Controller(robot, FrameTask(), sns, dt=5e-3)
    hold = rr.control.Hold(robot.fk(robot.neutral()), 0.05)
    with pytest.raises(InvalidParameterError, match=r"sns scheme plans over dt = 0.001 s"):
        rr.run(robot, FrameTask(), hold, sns, dt=5e-3)
    assert Controller(robot, FrameTask(), sns, dt=1e-3).dt == 1e-3


def test_settings_are_read_only() -> None:
    controller = Controller(rr.models.panda(), FrameTask(), PseudoInverseScheme(), dt=1e-3)
    for name, value in (("dt", 2e-3), ("gain", 2.0), ("limit_velocity", False),
                        ("scheme", None), ("task", None), ("path", "composed")):  # fmt: skip
        with pytest.raises(AttributeError):
            setattr(controller, name, value)
    assert controller.dt == 1e-3 and "fused" in repr(controller)


class _WrongSize(PseudoInverseScheme):
    """A scheme that returns a joint velocity of the wrong length."""

    def _step(self, robot: Any, q: Any, J: Any, xd: Any) -> StepResult:
        result = super()._step(robot, q, J, xd)
        return StepResult(np.zeros(3), result.info, np.zeros(3))


class _NotFinite(PseudoInverseScheme):
    """A scheme that returns NaN."""

    def _step(self, robot: Any, q: Any, J: Any, xd: Any) -> StepResult:
        result = super()._step(robot, q, J, xd)
        return StepResult(np.full(robot.n, np.nan), result.info, result.null_term)


def test_a_scheme_returning_a_bad_velocity_is_caught() -> None:
    robot = rr.models.panda()
    for task in (FrameTask(), ComposedFrameTask()):
        for limit in (True, False):
            controller = Controller(robot, task, _WrongSize(), limit_velocity=limit)
            with pytest.raises(ShapeError, match=r"shape \(3,\); expected \(7,\)"):
                controller.step(robot.neutral())
            controller = Controller(robot, task, _NotFinite(), limit_velocity=limit)
            with pytest.raises(SimulationError, match="pinv scheme returned a non-finite"):
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
        task = FrameTask()
        task.set_target(target)
        controller = Controller(robot, task, PseudoInverseScheme(), limit_velocity=False)
        controller.step(q)
        e = controller.error[3:]
        assert np.isclose(np.linalg.norm(e), np.pi, rtol=0, atol=1e-12)
        assert np.allclose(pin.exp3(e), target[:3, :3] @ T[:3, :3].T, rtol=0, atol=1e-12)


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
