"""The DP's optimum equals exhaustive enumeration of every admissible path, exactly, on
small grids: the iiwa14's arm-angle grid, the Panda's ``q7`` grid, a planar 3R arm's grid
by its own closed form (the end-effector orientation as the free parameter), and random
grids; for each objective."""

from __future__ import annotations

import math

import numpy as np
import pytest
from _plan_enumeration import admissible_paths, margins, sequential_sums

import redres as rr
from redres.control.trajectories import Circle
from redres.objectives import SphereObstacle, proximities
from redres.plan import PathGrid, PathPlan, plan_path, solve_grid


def check_all_objectives(robot: rr.Robot, grid: PathGrid, dt: float, qd_max: float,
                         start: tuple[int, int] | None = None) -> int:  # fmt: skip
    """Plan with each objective and compare with the enumeration; returns the number of
    admissible paths."""
    delta = np.broadcast_to(qd_max * dt, (robot.n,))
    nodes, paths = admissible_paths(grid, delta, start=start)
    assert len(paths) > 1, "the grid must leave a choice"
    zero = [np.zeros(len(x)) for x in nodes]

    plan = solve_grid(robot, grid, dt=dt, qd_max=qd_max, start=start)
    bottleneck = np.min([margins(robot, nodes[k][paths[:, k]]) for k in range(len(nodes))], axis=0)
    assert plan.feasible and plan.objective == bottleneck.max()
    assert plan.min_margin == plan.objective
    # the shortest of the max-min paths
    best = bottleneck == bottleneck.max()
    lengths = sequential_sums(nodes, paths, zero, 1.0)
    assert plan.path_length == pytest.approx(lengths[best].min(), rel=1e-14)
    _admissible(plan, delta)

    plan = solve_grid(robot, grid, dt=dt, objective="path_length", qd_max=qd_max, start=start)
    assert plan.objective == lengths.min()
    _admissible(plan, delta)

    target = np.linspace(-0.5, 0.5, robot.n)

    def cost(q: np.ndarray) -> np.ndarray:
        return np.sum((q - target) ** 2, axis=1)

    plan = solve_grid(robot, grid, dt=dt, objective=cost, qd_max=qd_max, start=start)
    sums = sequential_sums(nodes, paths, [cost(x) for x in nodes], 0.0)
    assert plan.objective == sums.min()
    _admissible(plan, delta)
    return len(paths)


def _admissible(plan: PathPlan, delta: np.ndarray) -> None:
    assert np.all(np.abs(np.diff(plan.q, axis=0)) <= delta)
    assert plan.speed_ratio <= 1.0


# ---------------------------------------------------------------------- grids


def test_iiwa14_arm_angle_grid_equals_enumeration() -> None:
    robot = rr.models.iiwa14()
    q = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])
    path = Circle(robot.fk(q), 0.15, 2.0, normal=(1.0, 0.0, 0.0))
    dt, qd = 0.2, 2.6  # 10 samples; a step of 0.52 rad: the next arm-angle value is in reach
    plan = plan_path(robot, path, dt=dt, resolution=12, qd_max=qd)
    assert plan.grid.shape == (11, 12, 8)
    grid = PathGrid(plan.grid.q[:9], plan.grid.feasible[:9], plan.grid.values[:9],
                    plan.grid.t[:9], "arm_angle")  # fmt: skip
    count = check_all_objectives(robot, grid, dt, qd)
    assert count > 1000


def test_iiwa14_obstacle_clearance_equals_enumeration() -> None:
    """A ball by the elbow: the largest smallest clearance over the admissible paths, and
    the joint-limit optimum over the nodes at least 2 cm clear; the clearance of each node
    measured here by :func:`redres.objectives.proximities` (Pinocchio's FK), the plan's
    by the batched FK: equal to rounding."""
    robot = rr.models.iiwa14()
    q = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])
    ball = [SphereObstacle(robot.fk(q, "link4")[:3, 3] + [0.0, 0.15, 0.1], 0.1)]
    path = Circle(robot.fk(q), 0.15, 2.0, normal=(1.0, 0.0, 0.0))
    dt, qd = 0.2, 2.6
    full = plan_path(robot, path, dt=dt, resolution=12, qd_max=qd).grid  # no obstacles
    K = 9
    grid = PathGrid(full.q[:K], full.feasible[:K], full.values[:K], full.t[:K], "arm_angle")
    clear = np.full(grid.feasible.shape, -np.inf)
    for index in zip(*np.nonzero(grid.feasible)):
        clear[index] = min(p.distance for p in proximities(robot, grid.q[index], ball,
                                                             robot.capsules))  # fmt: skip
    delta = np.full(7, qd * dt)
    for margin in (0.0, 0.02):
        clean = PathGrid(grid.q, grid.feasible & (clear >= margin), grid.values, grid.t,
                         "arm_angle")  # fmt: skip
        nodes, paths = admissible_paths(clean, delta)
        assert len(paths) > 100
        node_clear = [clear[k][clean.feasible[k]] for k in range(K)]
        worst = np.min([node_clear[k][paths[:, k]] for k in range(K)], axis=0)
        plan = solve_grid(robot, grid, dt=dt, qd_max=qd, objective="obstacle_clearance",
                          obstacles=ball, clearance=margin)  # fmt: skip
        assert plan.feasible and plan.objective == pytest.approx(worst.max(), abs=1e-12)
        assert plan.min_clearance == plan.objective >= margin
        assert plan.stats.colliding_nodes == int((grid.feasible & (clear < margin)).sum()) > 0
        _admissible(plan, delta)
        plan = solve_grid(robot, grid, dt=dt, qd_max=qd, obstacles=ball, clearance=margin)
        bottleneck = np.min([margins(robot, nodes[k][paths[:, k]]) for k in range(K)], axis=0)
        assert plan.objective == bottleneck.max() and plan.min_clearance >= margin
    free = solve_grid(robot, grid, dt=dt, qd_max=qd)
    assert free.objective > plan.objective  # the ball costs joint-limit margin here


def test_iiwa14_manipulability_equals_enumeration() -> None:
    robot = rr.models.iiwa14()
    q = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])
    poses = [Circle(robot.fk(q), 0.15, 2.0, normal=(1.0, 0.0, 0.0)).sample(0.2 * k).pose
             for k in range(6)]  # fmt: skip
    dt, qd = 0.2, 2.6
    plan = plan_path(robot, np.array(poses), dt=dt, resolution=12, qd_max=qd,
                     objective="manipulability")  # fmt: skip
    nodes, paths = admissible_paths(plan.grid, np.full(7, qd * dt))
    w = [np.array([math.sqrt(np.linalg.det(J @ J.T)) for J in map(robot.jacobian, x)])
         for x in nodes]  # fmt: skip
    h = np.array([dt / 2] + [dt] * 4 + [dt / 2])
    integral = -sequential_sums(nodes, paths, [-h[k] * w[k] for k in range(6)], 0.0)
    # Pinocchio's Jacobians here, the batch kernel's in the plan: equal to rounding
    assert plan.objective == pytest.approx(integral.max(), rel=1e-12)
    assert len(paths) > 100


def test_panda_q7_grid_equals_enumeration() -> None:
    robot = rr.models.panda()
    q = np.array([0.2, -0.3, 0.1, -2.0, 0.1, 1.8, 0.6])
    path = Circle(robot.fk(q), 0.1, 2.0, normal=(0.0, 1.0, 0.0))
    dt, qd = 0.25, 4.0  # a step of 1 rad: the neighbouring q7 values (0.53 rad on) are in reach
    plan = plan_path(robot, path, dt=dt, parameter="q7", resolution=12, qd_max=qd)
    K = 7
    grid = PathGrid(plan.grid.q[:K], plan.grid.feasible[:K], plan.grid.values[:K],
                    plan.grid.t[:K], "q7")  # fmt: skip
    assert check_all_objectives(robot, grid, dt, qd) > 100


def planar_arm() -> rr.Robot:
    """A planar 3R arm with unit links and limits ±2.2 rad (a margin that binds)."""
    link = {"a": 1.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "joint": "revolute",
            "q_min": -2.2, "q_max": 2.2, "qd_max": 2.0}  # fmt: skip
    return rr.Robot.from_dh([link] * 3, convention="standard")


def planar_grid(robot: rr.Robot, points: np.ndarray, P: int, dt: float) -> PathGrid:
    """The planar 3R arm's closed form with the tool's orientation ``φ`` as the free
    parameter: the wrist ``w = p − (cos φ, sin φ)``, then the 2R elbow ``q₂ = ±acos(c)``
    (two branches), ``q₁ = atan2(w) − atan2(sin q₂, 1 + cos q₂)``, ``q₃ = φ − q₁ − q₂``
    (unit links); angles wrapped to ``(−π, π]``."""
    K = len(points)
    phi = np.linspace(-math.pi, math.pi, P, endpoint=False)
    q = np.full((K, P, 2, 3), np.nan)
    for k, (x, y) in enumerate(points):
        wx, wy = x - np.cos(phi), y - np.sin(phi)
        c = (wx * wx + wy * wy - 2.0) / 2.0
        ok = np.abs(c) <= 1.0
        for b, sign in enumerate((1.0, -1.0)):
            q2 = sign * np.arccos(np.clip(c, -1.0, 1.0))
            q1 = np.arctan2(wy, wx) - np.arctan2(np.sin(q2), 1.0 + np.cos(q2))
            q3 = phi - q1 - q2
            sol = np.angle(np.exp(1j * np.stack((q1, q2, q3), axis=-1)))
            q[k, ok, b] = sol[ok]
    with np.errstate(invalid="ignore"):
        feasible = np.all((q >= robot.q_min) & (q <= robot.q_max), axis=-1)
    return PathGrid(q, feasible, np.broadcast_to(phi, (K, P)).copy(), np.arange(K) * dt, "phi")


def test_planar_3r_grid_is_on_the_path() -> None:
    robot = planar_arm()
    points = np.array([[1.5, 0.5], [1.4, 0.7]])
    grid = planar_grid(robot, points, 12, 0.1)
    for k in range(2):
        for q in grid.q[k][~np.isnan(grid.q[k]).any(axis=-1)]:
            assert np.allclose(robot.fk(q)[:2, 3], points[k], atol=1e-12)


@pytest.mark.parametrize("start", [None, "given"])
def test_planar_3r_equals_enumeration(start: str | None) -> None:
    robot = planar_arm()
    s = np.linspace(0.0, 1.0, 12)
    points = np.stack((1.6 - 0.8 * s, 0.3 + 1.2 * s), axis=1)  # a line across the workspace
    grid = planar_grid(robot, points, 12, 0.1)
    node = None
    if start:  # a start node some admissible path leaves from, not the best one
        _, paths = admissible_paths(grid, np.full(3, 1.0))
        p, b = np.argwhere(grid.feasible[0])[paths[-1, 0]]
        node = (int(p), int(b))
        free = solve_grid(robot, grid, dt=0.1, qd_max=10.0)
        assert solve_grid(robot, grid, dt=0.1, qd_max=10.0, start=node).objective <= free.objective
    assert check_all_objectives(robot, grid, 0.1, 10.0, node) > 100


@pytest.mark.parametrize("seed", range(5))
def test_random_grids_equal_enumeration(seed: int) -> None:
    """Random walks of configurations: branches that cross, nodes that drop out."""
    rng = np.random.default_rng(seed)
    robot = planar_arm()
    K, P, B = 8, 6, 3
    q = np.cumsum(rng.normal(0.0, 0.15, (K, P, B, 3)), axis=0) + rng.uniform(-1.5, 1.5, (P, B, 3))
    feasible = np.all(np.abs(q) <= 2.2, axis=-1) & (rng.random((K, P, B)) > 0.15)
    grid = PathGrid(q, feasible, np.zeros((K, P)), np.arange(K) * 0.1, "random")
    assert check_all_objectives(robot, grid, 0.1, 5.0) > 1
