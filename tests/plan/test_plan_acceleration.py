"""Acceleration limits (``qdd_max``): the DP over transitions equals exhaustive enumeration
of every path whose steps hold the velocity limits and whose central second differences
``|q_{k+1} − 2 q_k + q_{k−1}|`` hold ``qdd_max·dt²``, exactly, on small grids (the
iiwa14's arm-angle grid, the Panda's ``q7`` grid, random grids); the returned path's
finite-difference accelerations hold the limit; a path the acceleration limits alone
forbid is reported with its first unreachable sample."""

from __future__ import annotations

import numpy as np
import pytest
from _plan_enumeration import admissible_paths, margins, sequential_sums

import redres as rr
from redres.control.trajectories import Circle
from redres.errors import InvalidParameterError
from redres.plan import PathGrid, PathPlan, plan_path, solve_grid


def held(plan: PathPlan, qd: float, qdd: float) -> None:
    """The plan's finite differences, recomputed here, hold both limits."""
    assert plan.feasible
    assert np.all(np.abs(np.diff(plan.q, axis=0)) <= qd * plan.dt)
    second = plan.q[2:] - 2.0 * plan.q[1:-1] + plan.q[:-2]
    assert np.all(np.abs(second) <= qdd * plan.dt**2)
    assert plan.acceleration_ratio <= 1.0


def compare(robot: rr.Robot, grid: PathGrid, dt: float, qd: float, qdd: float,
            start: tuple[int, int] | None = None) -> tuple[int, int]:  # fmt: skip
    """Each objective with ``qdd_max`` against the enumeration; returns how many paths
    the velocity limits allow and how many both allow."""
    n = robot.n
    delta, accel = np.full(n, qd * dt), np.full(n, qdd * dt * dt)
    _, loose = admissible_paths(grid, delta, start=start)
    nodes, paths = admissible_paths(grid, delta, accel, start)
    assert len(paths) > 1, "the grid must leave a choice"
    K = len(nodes)
    zero = [np.zeros(len(x)) for x in nodes]

    plan = solve_grid(robot, grid, dt=dt, qd_max=qd, qdd_max=qdd, start=start)
    worst = np.min([margins(robot, nodes[k][paths[:, k]]) for k in range(K)], axis=0)
    assert plan.objective == worst.max() == plan.min_margin
    lengths = sequential_sums(nodes, paths, zero, 1.0)
    assert plan.path_length == pytest.approx(lengths[worst == worst.max()].min(), rel=1e-14)
    held(plan, qd, qdd)
    assert plan.stats.edge_pairs_checked >= plan.stats.edge_pairs > 0

    plan = solve_grid(robot, grid, dt=dt, objective="path_length", qd_max=qd, qdd_max=qdd,
                      start=start)  # fmt: skip
    assert plan.objective == lengths.min()
    held(plan, qd, qdd)

    target = np.linspace(-0.5, 0.5, n)

    def cost(q: np.ndarray) -> np.ndarray:
        return np.sum((q - target) ** 2, axis=1)

    plan = solve_grid(robot, grid, dt=dt, objective=cost, qd_max=qd, qdd_max=qdd, start=start)
    assert plan.objective == sequential_sums(nodes, paths, [cost(x) for x in nodes], 0.0).min()
    held(plan, qd, qdd)
    return len(loose), len(paths)


def test_iiwa14_arm_angle_grid_equals_enumeration() -> None:
    robot = rr.models.iiwa14()
    q = np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1])
    path = Circle(robot.fk(q), 0.15, 2.0, normal=(1.0, 0.0, 0.0))
    dt, qd, qdd = 0.2, 2.6, 13.0  # a second difference of 0.52 rad at most
    full = plan_path(robot, path, dt=dt, resolution=12, qd_max=qd).grid
    K = 8
    grid = PathGrid(full.q[:K], full.feasible[:K], full.values[:K], full.t[:K], "arm_angle")
    loose, both = compare(robot, grid, dt, qd, qdd)
    assert loose > both > 100  # the limit binds (968 paths without it) and leaves a choice
    # and it binds the optimum: the velocity-only plan breaks it
    free = solve_grid(robot, grid, dt=dt, qd_max=qd)
    assert free.objective >= solve_grid(robot, grid, dt=dt, qd_max=qd, qdd_max=qdd).objective


def test_panda_q7_grid_equals_enumeration() -> None:
    robot = rr.models.panda()
    q = np.array([0.2, -0.3, 0.1, -2.0, 0.1, 1.8, 0.6])
    path = Circle(robot.fk(q), 0.1, 2.0, normal=(0.0, 1.0, 0.0))
    dt, qd, qdd = 0.25, 4.0, 16.0  # a second difference of 1 rad at most
    full = plan_path(robot, path, dt=dt, parameter="q7", resolution=12, qd_max=qd).grid
    K = 7
    grid = PathGrid(full.q[:K], full.feasible[:K], full.values[:K], full.t[:K], "q7")
    loose, both = compare(robot, grid, dt, qd, qdd)
    assert loose > both > 10  # 196 paths without the limit


def random_grid(seed: int) -> tuple[rr.Robot, PathGrid]:
    """Random walks of a 3-joint arm's configurations: branches that cross, nodes that
    drop out."""
    rng = np.random.default_rng(seed)
    link = {"a": 1.0, "alpha": 0.0, "d": 0.0, "theta": 0.0, "joint": "revolute",
            "q_min": -2.2, "q_max": 2.2, "qd_max": 2.0}  # fmt: skip
    robot = rr.Robot.from_dh([link] * 3, convention="standard")
    K, P, B = 8, 6, 3
    q = np.cumsum(rng.normal(0.0, 0.15, (K, P, B, 3)), axis=0) + rng.uniform(-1.5, 1.5, (P, B, 3))
    feasible = np.all(np.abs(q) <= 2.2, axis=-1) & (rng.random((K, P, B)) > 0.15)
    return robot, PathGrid(q, feasible, np.zeros((K, P)), np.arange(K) * 0.1, "random")


@pytest.mark.parametrize("seed", range(5))
def test_random_grids_equal_enumeration(seed: int) -> None:
    robot, grid = random_grid(seed)
    loose, both = compare(robot, grid, 0.1, 5.0, 50.0)  # second differences up to 0.5 rad
    assert loose > both


def test_given_start_equals_enumeration() -> None:
    robot, grid = random_grid(7)
    _, paths = admissible_paths(grid, np.full(3, 0.5), np.full(3, 0.5))
    p, b = np.argwhere(grid.feasible[0])[paths[-1, 0]]
    compare(robot, grid, 0.1, 5.0, 50.0, (int(p), int(b)))


def test_acceleration_alone_can_forbid_the_path() -> None:
    """One node per sample on a straight-then-reversing line: every step within the
    velocity limit, the reversal beyond the acceleration limit: no path, and the sample
    after the reversal is the first unreachable one."""
    robot, _ = random_grid(0)
    steps = np.array([0.0, 0.1, 0.2, 0.3, 0.2, 0.1])  # reverses at sample 3
    q = np.zeros((6, 1, 1, 3))
    q[:, 0, 0, 0] = steps
    grid = PathGrid(q, np.ones((6, 1, 1), bool), np.zeros((6, 1)), np.arange(6) * 0.1, "line")
    assert solve_grid(robot, grid, dt=0.1, qd_max=2.0).feasible
    plan = solve_grid(robot, grid, dt=0.1, qd_max=2.0, qdd_max=15.0)  # 0.15 rad < 0.2
    assert not plan.feasible and plan.stats.first_unreachable == 4
    assert plan.stats.first_infeasible is None
    assert solve_grid(robot, grid, dt=0.1, qd_max=2.0, qdd_max=20.0).feasible  # 0.2 rad: held


def test_bad_qdd_max_is_refused() -> None:
    robot, grid = random_grid(0)
    with pytest.raises(InvalidParameterError, match="qdd_max"):
        solve_grid(robot, grid, dt=0.1, qdd_max=0.0)
    with pytest.raises(InvalidParameterError, match="qdd_max"):
        solve_grid(robot, grid, dt=0.1, qdd_max=-1.0)
