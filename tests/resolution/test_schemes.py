"""Schemes against their defining formulas and optimality conditions."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.errors import InvalidParameterError, ShapeError
from redres.objectives import JointLimitObjective, ManipulabilityObjective, Objective
from redres.resolution import (
    AugmentedJacobianScheme,
    GradientProjectionScheme,
    PseudoInverseScheme,
    WeightedLeastNormScheme,
    joint_limit_gradient,
)
from redres.tasks import FrameTask


def random_state(robot: rr.Robot, rng: np.random.Generator) -> tuple:
    q = robot.random_configuration(rng, margin=0.1)
    return q, robot.jacobian(q), rng.normal(size=6) * 0.1


def test_pinv_scheme_is_the_right_pseudo_inverse(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    for _ in range(10):
        q, J, xd = random_state(robot, rng)
        res = PseudoInverseScheme().step(robot, q, J, xd)
        assert np.allclose(res.qd, J.T @ np.linalg.solve(J @ J.T, xd), atol=1e-12)
        assert res.info.rank == 6 and np.all(res.null_term == 0.0)


def test_damped_scheme_is_damped_least_squares(rng: np.random.Generator) -> None:
    robot = rr.models.iiwa14()
    q, J, xd = random_state(robot, rng)
    scheme = PseudoInverseScheme(damping=0.1)
    assert scheme.name == "dls"
    qd = scheme.step(robot, q, J, xd).qd
    assert np.allclose(qd, J.T @ np.linalg.solve(J @ J.T + 0.01 * np.eye(6), xd), atol=1e-12)


@pytest.mark.parametrize("name", ["panda", "iiwa14", "srs7"])
def test_null_space_term_never_disturbs_the_task(
    name: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    """‖J q̇_null‖ ≤ 1e-10 with the exact inverse, and J q̇ = ẋ."""
    robot = builtin_robots[name]
    objectives: list[Objective] = [JointLimitObjective(), (ManipulabilityObjective(), 10.0)]  # type: ignore[list-item]
    scheme = GradientProjectionScheme(objectives, k_null=3.0)
    for _ in range(20):
        q, J, xd = random_state(robot, rng)
        res = scheme.step(robot, q, J, xd)
        assert np.linalg.norm(res.null_term) > 1e-6  # the term is really there
        assert np.linalg.norm(J @ res.null_term) <= 1e-10
        assert np.allclose(J @ res.qd, xd, atol=1e-10)
        grad = JointLimitObjective().gradient(robot, q) + 10 * ManipulabilityObjective().gradient(
            robot, q
        )
        N = np.eye(robot.n) - np.linalg.pinv(J) @ J
        assert np.allclose(res.null_term, -3.0 * N @ grad, atol=1e-10)


def test_weighted_least_norm_solves_its_optimisation(rng: np.random.Generator) -> None:
    """q̇ minimises q̇ᵀWq̇ subject to Jq̇ = ẋ: KKT conditions W q̇ = Jᵀλ."""
    robot = rr.models.panda()
    scheme = WeightedLeastNormScheme()
    q, J, xd = random_state(robot, rng)
    scheme.step(robot, q, J, xd)  # remembers |h|
    q2 = q + 0.01 * np.sign(q - (robot.q_min + robot.q_max) / 2)  # every joint moves outward
    res = scheme.step(robot, q2, J, xd)
    w = res.details.weights
    assert np.all(w > 1.0)
    assert np.allclose(J @ res.qd, xd, atol=1e-10)
    lam = np.linalg.lstsq(J.T, w * res.qd, rcond=None)[0]
    assert np.allclose(w * res.qd, J.T @ lam, atol=1e-10)


def test_wln_weights_relax_when_moving_away(rng: np.random.Generator) -> None:
    robot = rr.models.panda()
    scheme = WeightedLeastNormScheme()
    mid = (robot.q_min + robot.q_max) / 2
    q = mid + 0.5 * (robot.q_max - mid)
    scheme.weights(robot, q)
    toward = scheme.weights(robot, q + 0.01)
    assert np.all(toward > 1.0)
    away = scheme.weights(robot, q)
    assert np.all(away == 1.0)
    scheme.reset()
    assert np.all(scheme.weights(robot, q + 0.02) == 1.0)  # no history: unit weights


def test_seed_001_weight_function_equals_chan_dubey() -> None:
    """With c = 4/(q_max − q_min), h is Chan & Dubey's ∂H/∂q, checked by differences of H."""
    lo, hi = np.array([-2.0, -1.0]), np.array([1.0, 3.0])
    q = np.array([0.4, 2.1])

    def criterion(x: np.ndarray) -> float:
        return float(np.sum((hi - lo) ** 2 / (4 * (hi - x) * (x - lo))))

    fd = np.array([(criterion(q + e * 1e-6) - criterion(q - e * 1e-6)) / 2e-6 for e in np.eye(2)])
    assert np.allclose(joint_limit_gradient(q, lo, hi, 4 / (hi - lo)), fd, rtol=1e-6)


def test_augmented_jacobian_tracks_task_and_arm_angle(rng: np.random.Generator) -> None:
    robot = rr.models.iiwa14()
    scheme = AugmentedJacobianScheme(gain=0.0)
    q, J, xd = random_state(robot, rng)
    res = scheme.step(robot, q, J, xd)
    arm = scheme.tasks[0]
    _, row = arm.evaluate(robot, q)  # type: ignore[attr-defined]
    assert np.allclose(J @ res.qd, xd, atol=1e-10)
    assert abs(row @ res.qd) < 1e-10  # the arm angle is held
    assert not res.algorithmic_singularity


def test_augmented_jacobian_reports_an_algorithmic_singularity() -> None:
    """srs7 with the wrist straight above the shoulder and the elbow bent: the arm angle
    (reference z) is undefined although the end-effector Jacobian has full rank. The
    exact inverse of J_ext explodes there; the scheme stays bounded and says why."""
    robot = rr.models.srs7()
    q = np.array([0.0, 0.5, 0.0, 1.0, 0.0, 0.8, 0.0])
    w = robot.fk(q, "wrist")[:3, 3] - robot.fk(q, "shoulder")[:3, 3]
    assert np.allclose(w[:2], 0.0, atol=1e-12)  # w parallel to the reference z
    J = robot.jacobian(q)
    assert rr.linalg.sigma_min(J) > 0.05
    q_near = q.copy()
    q_near[1] += 1e-4  # just off the singular configuration
    xd = np.array([0.0, 0.05, 0.0, 0.0, 0.0, 0.0])  # sideways: turns the reference plane
    res = AugmentedJacobianScheme().step(robot, q_near, robot.jacobian(q_near), xd)
    assert res.algorithmic_singularity
    assert np.all(np.isfinite(res.qd)) and np.linalg.norm(res.qd) < 20.0
    task = AugmentedJacobianScheme().tasks[0]
    _, row = task.evaluate(robot, q_near)  # type: ignore[attr-defined]
    J_ext = np.vstack([robot.jacobian(q_near), row])
    exact = np.linalg.solve(J_ext, np.append(xd, 0.0))
    assert np.linalg.norm(exact) > 10 * np.linalg.norm(res.qd)


def test_augmented_needs_a_square_jacobian() -> None:
    robot = rr.models.panda()
    q = robot.neutral()
    J = robot.jacobian(q)[:3]
    with pytest.raises(ShapeError, match="must be square: 3 task rows"):
        AugmentedJacobianScheme().step(robot, q, J, np.zeros(3))


def test_bad_scheme_parameters() -> None:
    with pytest.raises(InvalidParameterError, match="inverse must be a redres.resolution.Inverse"):
        PseudoInverseScheme("magic")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="damping must be >= 0"):
        PseudoInverseScheme(damping=-0.1)
    with pytest.raises(InvalidParameterError, match="at least one objective"):
        GradientProjectionScheme([])
    with pytest.raises(InvalidParameterError, match="Objective instances"):
        GradientProjectionScheme(["joint_limits"])  # type: ignore[list-item]
    with pytest.raises(InvalidParameterError, match="c must be positive"):
        WeightedLeastNormScheme(c=0.0)
    assert PseudoInverseScheme(rcond=1e-3).inverse.rate_kwargs()["rcond"] == 1e-3


def test_gradient_of_wrong_size_is_a_clear_error() -> None:
    class Broken(Objective):
        name = "broken"

        def cost(self, robot: rr.Robot, q: np.ndarray) -> float:
            return 0.0

        def gradient(self, robot: rr.Robot, q: np.ndarray) -> np.ndarray:
            return np.zeros(3)

    robot = rr.models.panda()
    q = robot.neutral()
    with pytest.raises(ShapeError, match=r"gradient of broken has shape \(3,\); expected \(7,\)"):
        GradientProjectionScheme([Broken()]).step(robot, q, robot.jacobian(q), np.zeros(6))


def test_frame_task_rows_by_name() -> None:
    robot = rr.models.panda()
    task = FrameTask(rows=["x", "y", "rz"])
    state = task.compute(robot, robot.neutral())
    assert state.jacobian.shape == (3, 7)
    assert np.allclose(state.jacobian, robot.jacobian(robot.neutral())[[0, 1, 5]])
    with pytest.raises(InvalidParameterError, match="task rows"):
        FrameTask(rows=["w"])
