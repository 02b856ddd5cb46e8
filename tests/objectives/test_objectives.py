"""Secondary objectives: analytic gradients against finite differences, seed 003's cost,
and each objective lowering its cost by self-motion with the end effector fixed."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control import Hold
from redres.objectives import (
    CapsuleObstacle,
    JointLimitObjective,
    ManipulabilityObjective,
    Objective,
    ObstacleObjective,
    PointObstacle,
    PostureObjective,
    SphereObstacle,
)
from redres.resolution import GradientProjectionScheme
from redres.tasks import FrameTask
from redres.testing import numerical_gradient

ARMS = ["panda", "iiwa14", "srs7"]


def near_elbow(robot: rr.Robot, q: np.ndarray) -> list:
    p = robot.fk(q, "elbow")[:3, 3]
    return [
        SphereObstacle(p + [0.12, 0.05, 0.0], 0.02, "ball"),
        CapsuleObstacle(p + [0.0, 0.0, 0.25], p + [0.2, 0.1, 0.25], 0.03, "bar"),
        PointObstacle(p + [-0.05, -0.15, -0.1]),
    ]


def objectives_for(robot: rr.Robot, q: np.ndarray) -> list[Objective]:
    return [
        JointLimitObjective(),
        ManipulabilityObjective(),
        ManipulabilityObjective(rows=(0, 1, 2)),
        PostureObjective(weights=np.linspace(0.5, 2.0, robot.n)),
        ObstacleObjective(near_elbow(robot, q), influence=0.3),
    ]


@pytest.mark.parametrize("name", ARMS)
def test_gradients_match_finite_differences(
    name: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    for _ in range(4):
        q = robot.random_configuration(rng)
        for obj in objectives_for(robot, q):
            g = obj.gradient(robot, q)
            fd = numerical_gradient(lambda x, obj=obj: obj.cost(robot, x), q)
            assert g.shape == (robot.n,)
            assert np.allclose(g, fd, atol=1e-7, rtol=1e-6), (obj.name, g, fd)


def test_joint_limit_cost_is_seed_003() -> None:
    robot = rr.models.planar([1.0, 1.0, 1.0])  # limits ±π: range 2π, mid 0
    obj = JointLimitObjective()
    q = np.array([np.pi / 2, 0.0, -np.pi])
    assert obj.cost(robot, q) == pytest.approx((0.25) ** 2 + 0 + 0.5**2)
    assert np.allclose(obj.gradient(robot, q), 2 * q / (2 * np.pi) ** 2)
    assert obj.cost(robot, np.zeros(3)) == 0.0


def test_seed_003_printed_g_would_raise_the_cost() -> None:
    """Seed 003 prints G = 2(q − q̄)/(q_min − q_max); it has the opposite sign of ∂D/∂q,
    so Δq = J⁺Δx + [J⁺J − I] G Δt taken literally climbs D. redres' gradient descends."""
    robot = rr.models.panda()
    obj = JointLimitObjective()
    q = robot.neutral() + np.array([0.4, -0.3, 0.5, 0.2, -0.6, 0.3, 0.8])
    J = robot.jacobian(q)
    N = np.eye(7) - rr.linalg.pinv(J) @ J
    mid = (robot.q_min + robot.q_max) / 2
    G_printed = 2 * (q - mid) / (robot.q_min - robot.q_max)
    dt = 1e-3
    assert obj.cost(robot, q - N @ G_printed * dt) > obj.cost(robot, q)  # seed, literally
    assert obj.cost(robot, q - N @ obj.gradient(robot, q) * dt) < obj.cost(robot, q)


def test_manipulability_cost_is_minus_sqrt_det() -> None:
    robot = rr.models.iiwa14()
    q = robot.neutral()
    J = robot.jacobian(q)
    assert ManipulabilityObjective().cost(robot, q) == pytest.approx(
        -np.sqrt(np.linalg.det(J @ J.T)), rel=1e-10
    )


def test_obstacle_penalty_is_hat_shaped() -> None:
    robot = rr.models.srs7()
    q = robot.neutral()
    p = robot.fk(q, "elbow")[:3, 3]
    far = ObstacleObjective([PointObstacle(p + [0.0, 2.0, 0.0])], influence=0.2)
    assert far.cost(robot, q) == 0.0 and np.all(far.gradient(robot, q) == 0.0)
    costs = []
    for gap in (0.19, 0.1, 0.05, 0.0):
        obj = ObstacleObjective([PointObstacle(p + [0.0, 0.07 + gap, 0.0])], influence=0.2)
        d = obj.min_distance(robot, q)
        costs.append(obj.cost(robot, q))
        assert d == pytest.approx(gap, abs=1e-9)  # nearest: the upper arm, radius 0.07
    assert costs == sorted(costs)
    # Touching the upper arm (d = 0: penalty 1) and 0.01 m from the forearm (radius 0.06).
    assert costs[-1] == pytest.approx(1.0 + (1.0 - 0.01 / 0.2) ** 2)


def self_motion_costs(robot: rr.Robot, obj: Objective, q0: np.ndarray, gain: float) -> tuple:
    """Hold the end-effector pose, descend ``obj`` in the null space for 0.5 s; returns
    the cost at every step and the largest pose change."""
    T0 = robot.fk(q0)
    scheme = GradientProjectionScheme([obj], k_null=gain)
    log = rr.run(robot, FrameTask(), Hold(T0, 0.5), scheme, dt=2e-3, q0=q0, gain=20.0)
    q1 = rr.control.final_configuration(log)
    costs = np.append(log.objectives[obj.name], obj.cost(robot, q1))
    return costs, float(np.linalg.norm(robot.fk(q1) - T0))


@pytest.mark.parametrize("name", ARMS)
def test_each_objective_alone_lowers_its_cost_by_self_motion(
    name: str, builtin_robots: dict, rng: np.random.Generator
) -> None:
    robot = builtin_robots[name]
    q0 = robot.random_configuration(rng, margin=0.3)
    gains = {"joint_limits": 2.0, "manipulability": 5.0, "posture": 0.5, "obstacles": 0.05}
    for obj in objectives_for(robot, q0)[:2] + objectives_for(robot, q0)[3:]:
        costs, pose_change = self_motion_costs(robot, obj, q0, gains[obj.name])
        assert np.all(np.diff(costs) <= 1e-12), obj.name  # monotone descent
        assert costs[-1] < costs[0] - 1e-6, (obj.name, costs[0], costs[-1])
        assert pose_change < 1e-6, (obj.name, pose_change)


def test_posture_defaults_to_the_neutral_pose() -> None:
    robot = rr.models.panda()
    assert PostureObjective().cost(robot, robot.neutral()) == 0.0
    with pytest.raises(ValueError, match="weights"):
        PostureObjective(weights=-1.0)


def test_obstacles_need_capsules() -> None:
    robot = rr.models.planar([1.0, 1.0])
    with pytest.raises(rr.errors.InvalidParameterError, match="no link capsules"):
        ObstacleObjective([PointObstacle([0.0, 0.0, 0.0])]).cost(robot, np.zeros(2))
    with pytest.raises(rr.errors.NonFiniteError):
        PointObstacle([np.nan, 0.0, 0.0])


def test_posture_refuses_bad_weights_and_sizes_with_redres_errors() -> None:
    """Issue 18, item 11: these were plain ValueErrors or raw numpy broadcast errors."""
    from redres.errors import InvalidParameterError, NonFiniteError, ShapeError

    robot = rr.models.panda()
    with pytest.raises(InvalidParameterError, match="weights must be >= 0"):
        PostureObjective(weights=[-1.0] * 7)
    with pytest.raises(InvalidParameterError, match="weights must be >= 0"):
        PostureObjective(weights=-1.0)
    with pytest.raises(NonFiniteError, match="weights"):
        PostureObjective(weights=[np.nan] * 7)
    for kwargs, name in ((dict(q_ref=[0.0, 1.0]), "q_ref"), (dict(weights=[1.0, 2.0]), "weights")):
        with pytest.raises(ShapeError, match=f"{name} has 2 entries but robot 'panda' has 7"):
            PostureObjective(**kwargs).gradient(robot, robot.neutral())
