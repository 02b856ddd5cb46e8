"""``rr.plan_path``: the plan is on the path (Pinocchio's FK), within the velocity limits,
starts at ``q0`` when given; infeasible paths and disconnected feasible regions are
reported (constructed cases); bad input is refused by name."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.control.trajectories import Circle
from redres.errors import InvalidParameterError, ShapeError
from redres.plan import PathGrid, plan_path, solve_grid

Q_IIWA = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])


def _circle(robot: rr.Robot, q: np.ndarray) -> Circle:
    return Circle(robot.fk(q), 0.1, 2.0, normal=(1.0, 0.0, 0.0))


@pytest.mark.parametrize(("name", "parameter"), [("iiwa14", "arm_angle"), ("iiwa14", "q7"),
                                                 ("panda", "q7")])  # fmt: skip
def test_plan_is_on_the_path_within_the_velocity_limits(name: str, parameter: str) -> None:
    robot = rr.models.load(name)
    q = Q_IIWA if name == "iiwa14" else np.array([0.2, -0.3, 0.1, -2.0, 0.1, 1.8, 0.6])
    path = _circle(robot, q)
    plan = plan_path(robot, path, dt=0.02, parameter=parameter, resolution=120)  # type: ignore[arg-type]
    assert plan.feasible and plan.q.shape == (101, 7) and np.allclose(plan.t, 0.02 * np.arange(101))
    for k, t in enumerate(plan.t):
        T, F = path.sample(float(t)).pose, robot.fk(plan.q[k])
        assert np.abs(F - T).max() < 1e-10
    steps = np.abs(np.diff(plan.q, axis=0))
    assert np.all(steps <= robot.qd_max * 0.02)
    assert plan.speed_ratio <= 1.0
    margin = np.minimum(plan.q - robot.q_min, robot.q_max - plan.q).min()
    assert plan.min_margin == margin == plan.objective > 0.0
    s = plan.stats
    assert s.nodes == 101 * 120 * 8
    assert 0 < s.traversable_nodes <= s.reachable_nodes <= s.feasible_nodes
    assert s.transitions <= s.pairs_checked and s.components >= 1
    assert s.first_infeasible is None and s.first_unreachable is None
    assert plan.branch.shape == plan.values.shape == (101,)
    q_mid, qd_mid = plan.at(0.03)
    assert np.allclose(q_mid, (plan.q[1] + plan.q[2]) / 2)
    assert np.all(np.abs(qd_mid) <= robot.qd_max)


def test_q0_is_the_first_node() -> None:
    robot = rr.models.iiwa14()
    path = _circle(robot, Q_IIWA)
    for parameter in ("arm_angle", "q7"):
        plan = plan_path(robot, path, dt=0.05, parameter=parameter, resolution=90, q0=Q_IIWA)  # type: ignore[arg-type]
        assert plan.feasible
        assert np.abs(plan.q[0] - Q_IIWA).max() < 1e-9
        free = plan_path(robot, path, dt=0.05, parameter=parameter, resolution=90)  # type: ignore[arg-type]
        assert plan.objective <= free.objective + 0.02  # a different grid: about as good
    with pytest.raises(InvalidParameterError, match="q0 is not a configuration at the path"):
        plan_path(robot, path, dt=0.05, q0=Q_IIWA + 0.1)


def test_unreachable_pose_is_the_first_infeasible_sample() -> None:
    robot = rr.models.iiwa14()
    path = _circle(robot, Q_IIWA)
    poses = np.array([path.sample(0.05 * k).pose for k in range(8)])
    poses[5, :3, 3] += [3.0, 0.0, 0.0]  # out of reach
    plan = plan_path(robot, poses, dt=0.05, resolution=36)
    assert not plan.feasible and np.isnan(plan.objective) and np.isnan(plan.q).all()
    assert plan.stats.first_infeasible == 5 and plan.stats.components == 0


def _grid(q: np.ndarray, feasible: np.ndarray | None = None) -> PathGrid:
    K, P, B, _ = q.shape
    if feasible is None:
        feasible = np.ones((K, P, B), dtype=bool)
    return PathGrid(q, feasible, np.zeros((K, P)), 0.1 * np.arange(K), "constructed")


def planar() -> rr.Robot:
    return rr.models.planar([1.0, 1.0, 1.0])


def test_constructed_grid_with_an_infeasible_sample() -> None:
    q = np.zeros((6, 3, 2, 3)) + np.linspace(-1, 1, 3)[None, :, None, None]
    feasible = np.ones((6, 3, 2), dtype=bool)
    feasible[3] = False
    plan = solve_grid(planar(), _grid(q, feasible), dt=0.1, qd_max=1.0)
    assert not plan.feasible
    assert plan.stats.first_infeasible == 3 and plan.stats.first_unreachable is None


def test_constructed_grid_unreachable_from_the_start() -> None:
    """Every node feasible, but at sample 4 the configurations jump by more than a step
    allows: no node there is reached."""
    q = np.zeros((7, 3, 2, 3)) + np.linspace(-1, 1, 3)[None, :, None, None]
    q[4:] += 0.5  # a step of 0.5 rad, the limit is 0.1 rad
    plan = solve_grid(planar(), _grid(q), dt=0.1, qd_max=1.0)
    assert not plan.feasible
    assert plan.stats.first_infeasible is None and plan.stats.first_unreachable == 4
    assert plan.stats.components == 0


def test_constructed_disconnected_region() -> None:
    """Two corridors of configurations 1 rad apart, each continuous: two components; the
    plan takes the one with the larger margin. Joined by one bridge node, one component."""
    K = 8
    low = np.zeros((K, 3, 1, 3)) + (np.array([-0.05, 0.0, 0.05])[None, :, None, None] - 1.0)
    high = low + 1.5
    q = np.concatenate((low, high), axis=2)  # branch 0: around -1 rad, branch 1: around 0.5
    plan = solve_grid(planar(), _grid(q), dt=0.1, qd_max=1.0)
    assert plan.feasible and plan.stats.components == 2
    assert np.all(plan.branch == 1)  # farther from the ±π limits
    assert plan.objective == pytest.approx(np.pi - 0.45)  # the corridor value nearest 0
    # a corridor that ends early is no component from start to end
    feasible = np.ones((K, 3, 2), dtype=bool)
    feasible[5, :, 0] = False
    assert solve_grid(planar(), _grid(q, feasible), dt=0.1, qd_max=1.0).stats.components == 1
    # a bridge: intermediate nodes on the third parameter value let both corridors meet
    bridged = q.copy()
    steps = np.linspace(-0.95, 0.55, K)  # 0.21 rad per sample
    bridged[:, 2, 0] = steps[:, None]
    plan = solve_grid(planar(), _grid(bridged), dt=0.1, qd_max=2.2)
    assert plan.stats.components == 1


def test_objectives_and_bad_input() -> None:
    robot = rr.models.iiwa14()
    path = _circle(robot, Q_IIWA)
    lengths = plan_path(robot, path, dt=0.1, resolution=36, objective="path_length")
    margin = plan_path(robot, path, dt=0.1, resolution=36)
    assert lengths.path_length <= margin.path_length and lengths.objective == lengths.path_length
    assert margin.min_margin >= lengths.min_margin
    with pytest.raises(InvalidParameterError, match="objective must be one of"):
        plan_path(robot, path, dt=0.1, objective="fastest")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="resolution must be an integer"):
        plan_path(robot, path, dt=0.1, resolution=1)
    with pytest.raises(InvalidParameterError, match="parameter must be"):
        plan_path(robot, path, dt=0.1, parameter="elbow")  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="dt"):
        plan_path(robot, path, dt=0.0)
    with pytest.raises(ShapeError, match=r"\(K, 4, 4\)"):
        plan_path(robot, np.eye(4), dt=0.1)
    with pytest.raises(ShapeError, match=r"cost function must map"):
        plan_path(robot, path, dt=0.1, resolution=12, objective=lambda q: q)
    with pytest.raises(InvalidParameterError, match="qd_max"):
        plan_path(robot, path, dt=0.1, resolution=12, qd_max=0.0)


def test_last_sample_infeasible() -> None:
    q = np.zeros((5, 2, 2, 3))
    feasible = np.ones((5, 2, 2), dtype=bool)
    feasible[4] = False
    plan = solve_grid(planar(), _grid(q, feasible), dt=0.1, qd_max=1.0)
    assert not plan.feasible and plan.stats.first_infeasible == 4
    assert plan.stats.reachable_nodes == 16


def test_dt_defaults_for_a_trajectory_and_one_sample_is_a_plan() -> None:
    robot = rr.models.iiwa14()
    path = Circle(robot.fk(Q_IIWA), 0.1, 2.0, normal=(1.0, 0.0, 0.0), turns=0.1)
    plan = plan_path(robot, path, resolution=12)
    assert plan.dt == 0.01 and len(plan.q) == 21 and plan.feasible
    # a turn in 0.2 s (3 m/s) is too fast for the velocity limits from the first step on
    fast = plan_path(robot, Circle(robot.fk(Q_IIWA), 0.1, 0.2, normal=(1.0, 0.0, 0.0)),
                     resolution=12)  # fmt: skip
    assert not fast.feasible and fast.stats.first_unreachable == 1
    with pytest.raises(InvalidParameterError, match="dt is required for poses"):
        plan_path(robot, robot.fk(Q_IIWA)[None], resolution=12)
    one = plan_path(robot, robot.fk(Q_IIWA)[None], dt=0.1, resolution=12)
    assert one.feasible and one.q.shape == (1, 7) and one.path_length == 0.0
    assert (
        one.objective
        == one.min_margin
        == max(robot.joint_limit_margin(q).min() for q in one.grid.q[0][one.grid.feasible[0]])
    )
