"""The batched clearance of :mod:`redres.plan.clearance` equals
:func:`redres.objectives.proximities` row by row; the batched segment distances equal the
scalar closest points, degenerate segments included; bad obstacles are refused."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.collision.geometry import (
    closest_point_on_segment,
    closest_points_segments,
    segment_point_distances,
    segment_segment_distances,
)
from redres.errors import InvalidParameterError, NonFiniteError
from redres.objectives import CapsuleObstacle, SphereObstacle, proximities
from redres.plan import plan_path
from redres.plan.clearance import clearances


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(38)


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_clearances_equal_proximities(name: str, rng: np.random.Generator) -> None:
    robot = getattr(rr.models, name)()
    q = rng.uniform(robot.q_min, robot.q_max, (200, 7))
    obstacles = [
        SphereObstacle([0.3, 0.2, 0.5], 0.1),
        SphereObstacle([0.1, 0.1, 0.9]),  # a point
        CapsuleObstacle([0.4, -0.3, 0.2], [0.4, 0.3, 0.6], 0.05),
        CapsuleObstacle([0.2, 0.2, 0.2], [0.2, 0.2, 0.2], 0.03),  # a ball as a capsule
    ]
    got = clearances(robot, q, obstacles)
    want = [min(p.distance for p in proximities(robot, x, obstacles, robot.capsules)) for x in q]
    assert np.abs(got - want).max() < 1e-12
    assert (got < 0).any() and (got > 0).any()
    assert np.isinf(clearances(robot, q, [])).all()


def test_segment_distances_equal_the_closest_points(rng: np.random.Generator) -> None:
    a = rng.normal(size=(300, 3))
    b = a + rng.normal(size=(300, 3))
    b[:20] = a[:20]  # points
    b[20:40] = a[20:40] + [1.0, 0.0, 0.0]  # parallel to the segment below
    p2, q2 = np.array([0.0, 0.5, 0.0]), np.array([2.0, 0.5, 0.0])
    for start, end in ((p2, q2), (p2, p2)):
        want = [np.linalg.norm(np.subtract(*closest_points_segments(x, y, start, end)))
                for x, y in zip(a, b)]  # fmt: skip
        assert np.allclose(segment_segment_distances(a, b, start, end), want, atol=1e-12)
    want = [np.linalg.norm(closest_point_on_segment(p2, x, y) - p2) for x, y in zip(a, b)]
    assert np.allclose(segment_point_distances(a, b, p2), want, atol=1e-12)


def test_obstacle_arguments_are_checked() -> None:
    robot = rr.models.iiwa14()
    poses = np.array([robot.fk(np.array([0.3, 0.8, 0.2, -1.2, 0.3, 0.9, 0.1]))])
    with pytest.raises(InvalidParameterError, match="needs obstacles"):
        plan_path(robot, poses, dt=0.1, objective="obstacle_clearance")
    with pytest.raises(InvalidParameterError, match="SphereObstacle"):
        plan_path(robot, poses, dt=0.1, obstacles=[(0.0, 0.0, 0.0)])
    with pytest.raises(NonFiniteError, match="clearance"):
        plan_path(robot, poses, dt=0.1, obstacles=[SphereObstacle([1, 1, 1])], clearance=np.nan)
    with pytest.raises(InvalidParameterError, match="capsules"):
        plan_path(robot, poses, dt=0.1, obstacles=[SphereObstacle([1, 1, 1])], capsules=[])
    # a ball around the whole arm: every node collides, the first sample is infeasible
    plan = plan_path(robot, poses, dt=0.1, obstacles=[SphereObstacle([0, 0, 0.5], 2.0)])
    assert not plan.feasible and plan.stats.first_infeasible == 0
    assert plan.stats.feasible_nodes == 0 and plan.stats.colliding_nodes > 0
