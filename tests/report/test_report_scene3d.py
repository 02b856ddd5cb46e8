"""Obstacles, link capsules and the closest pair in the 3D view; the clearance column."""

from __future__ import annotations

import json

import numpy as np
import pytest

import redres as rr
from redres.control import Circle
from redres.objectives import (
    CapsuleObstacle,
    ObstacleObjective,
    PointObstacle,
    SphereObstacle,
)
from redres.report import animation_figure, arm_animation
from redres.report.scene3d import capsule_mesh, obstacle_traces
from redres.report.table import table_html
from redres.resolution import PseudoInverseScheme
from redres.scenarios.runner import format_table, summarise
from redres.tasks import FrameTask


def _segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> float:
    """Distance from p to segment [a, b] by dense sampling (an oracle independent of the
    closed-form closest point)."""
    s = np.linspace(0.0, 1.0, 20001)[:, None]
    return float(np.min(np.linalg.norm(a + s * (b - a) - p, axis=1)))


@pytest.mark.parametrize(
    ("a", "b", "r"),
    [
        ([0.1, 0.2, 0.3], [0.1, 0.2, 0.3], 0.05),  # a sphere
        ([0.0, 0.0, 0.0], [0.0, 0.0, 0.5], 0.03),  # a vertical pole
        ([0.2, -0.1, 0.4], [-0.3, 0.5, 0.1], 0.08),  # oblique
    ],
)
def test_capsule_mesh_vertices_lie_on_the_surface(a: list, b: list, r: float) -> None:
    a_, b_ = np.array(a), np.array(b)
    vertices, triangles = capsule_mesh(a_, b_, r)
    distances = [_segment_distance(v, a_, b_) for v in vertices]
    np.testing.assert_allclose(distances, r, atol=1e-6)
    assert triangles.min() == 0 and triangles.max() == len(vertices) - 1
    # closed surface: with coincident vertices merged (the poles, a sphere's two equators)
    # and collapsed triangles dropped, every edge is shared by exactly two triangles
    _, ids = np.unique(np.round(vertices, 12), axis=0, return_inverse=True)
    merged = ids.reshape(-1)[triangles]
    merged = merged[(merged[:, 0] != merged[:, 1]) & (merged[:, 1] != merged[:, 2])
                    & (merged[:, 0] != merged[:, 2])]  # fmt: skip
    edges: dict[tuple[int, int], int] = {}
    for t in merged:
        for i, j in ((t[0], t[1]), (t[1], t[2]), (t[2], t[0])):
            key = (min(i, j), max(i, j))
            edges[key] = edges.get(key, 0) + 1
    assert set(edges.values()) == {2}


def test_mesh_of_an_axis_aligned_capsule_spans_its_true_box() -> None:
    a, b, r = np.array([0.4, -0.2, 0.1]), np.array([0.4, -0.2, 0.6]), 0.05
    vertices, _ = capsule_mesh(a, b, r)
    np.testing.assert_allclose(vertices.min(axis=0), np.minimum(a, b) - r, atol=1e-12)
    np.testing.assert_allclose(vertices.max(axis=0), np.maximum(a, b) + r, atol=1e-12)


def test_obstacle_traces_name_every_obstacle() -> None:
    found = obstacle_traces(
        [
            SphereObstacle([0, 0, 1], 0.1, "ball"),
            CapsuleObstacle([0, 0, 0], [0, 0, 1], 0.02, "pole"),
            PointObstacle([1, 2, 3], "dot"),
        ]
    )
    shapes = [(t["name"], t["type"], t["meta"]["shape"]) for t in found]
    assert shapes == [("ball", "mesh3d", "sphere"), ("pole", "mesh3d", "capsule"),
                      ("dot", "scatter3d", "point")]  # fmt: skip
    assert found[2]["x"] == [1.0] and found[2]["z"] == [3.0]


@pytest.fixture(scope="module")
def obstacle_run() -> tuple[rr.Robot, rr.RunLog, list]:
    panda = rr.models.panda()
    tip = panda.fk(panda.neutral())[:3, 3]
    ball = SphereObstacle(tip + [0.0, 0.0, -0.12], 0.03, "ball")
    pole = CapsuleObstacle(tip + [0.15, 0.0, -0.3], tip + [0.15, 0.0, 0.1], 0.02, "pole")
    obstacles = [ball, pole]
    log = rr.run(panda, FrameTask(), Circle(panda.fk(panda.neutral()), 0.03, 0.2),
                 PseudoInverseScheme(), log_objectives=[ObstacleObjective(obstacles)])  # fmt: skip
    return panda, log, obstacles


def _segments_distance(a: np.ndarray, b: np.ndarray, c: np.ndarray, d: np.ndarray) -> float:
    """Distance between segments [a, b] and [c, d] by sampling both (oracle)."""
    s = np.linspace(0.0, 1.0, 401)[:, None]
    p, q = a + s * (b - a), c + s * (d - c)
    return float(np.min(np.linalg.norm(p[:, None, :] - q[None, :, :], axis=2)))


def test_closest_pair_is_the_smallest_distance(obstacle_run: tuple) -> None:
    robot, log, obstacles = obstacle_run
    ball, pole = obstacles
    anim = arm_animation(robot, log, frames=6, obstacles=obstacles)
    assert anim.closest is not None and anim.clearance is not None
    assert anim.closest.shape == (6, 2, 3)
    radii = set()
    for f, k in enumerate(anim.steps):
        q, oracle = log.q[k], []
        for cap in robot.capsules:
            T = robot.fk(q, cap.frame)
            a, b = T[:3, :3] @ cap.a + T[:3, 3], T[:3, :3] @ cap.b + T[:3, 3]
            oracle.append(_segment_distance(ball.center, a, b) - cap.radius - ball.radius)
            oracle.append(_segments_distance(a, b, pole.a, pole.b) - cap.radius - pole.radius)
            radii |= {cap.radius + ball.radius, cap.radius + pole.radius}
        assert anim.clearance[f] == pytest.approx(min(oracle), abs=1e-3)
        link, obs = anim.closest[f]
        gap = np.linalg.norm(link - obs) - anim.clearance[f]
        assert min(abs(gap - r) for r in radii) < 1e-9  # the witnesses of that distance


def test_figure_draws_obstacles_capsules_and_the_pair(obstacle_run: tuple) -> None:
    robot, log, obstacles = obstacle_run
    anim = arm_animation(robot, log, frames=6, obstacles=obstacles)
    figure = json.loads(json.dumps(animation_figure(anim), allow_nan=False))
    names = [t["name"] for t in figure["data"]]
    assert names[:3] == ["arm", "target now", "closest pair"]
    assert names[-3:] == ["link capsules", "ball", "pole"]
    assert figure["frames"][0]["traces"] == [0, 1, 2]  # the page adds the capsules' trace
    (spec,) = figure["rigid"]  # a built-in arm: its capsules alone move, shown
    assert spec["trace"] == names.index("link capsules")
    assert "visible" not in figure["data"][spec["trace"]]
    pair = figure["frames"][5]["data"][2]
    np.testing.assert_allclose(np.column_stack([pair["x"], pair["y"], pair["z"]]),
                               anim.closest[5], atol=1e-5)  # fmt: skip
    ranges = np.array([figure["layout"]["scene"][f"{c}axis"]["range"] for c in "xyz"])
    pole = obstacles[1]
    assert np.all(ranges[:, 0] <= pole.a - pole.radius) and np.all(ranges[:, 1] >= pole.b)


def test_minimum_clearance_is_over_the_whole_run(obstacle_run: tuple) -> None:
    robot, log, obstacles = obstacle_run
    summary = summarise(robot, log)
    objective = ObstacleObjective(obstacles)
    every = [objective.min_distance(robot, q) for q in log.q]
    assert summary["min_obstacle_clearance_m"] == pytest.approx(min(every), abs=1e-12)
    assert summary["min_obstacle_clearance_m"] <= log.objectives["obstacle_distance_m"][-1]
    assert "clear" in format_table([summary])
    assert "min obstacle clearance" in table_html([summary])
    assert log.summary() == summary  # the run's own summary carries it
    plain = {k: v for k, v in summary.items() if k != "min_obstacle_clearance_m"}
    assert "clear" not in format_table([plain])  # no obstacles: no column
    assert "min obstacle clearance" not in table_html([plain])


def test_rigid_spec_moves_the_capsules_with_their_links(obstacle_run: tuple) -> None:
    robot, log, obstacles = obstacle_run
    anim = arm_animation(robot, log, frames=5, obstacles=obstacles)
    figure = animation_figure(anim)
    (spec,) = figure["rigid"]
    assert figure["data"][spec["trace"]]["name"] == "link capsules"
    local = np.column_stack([spec["x"], spec["y"], spec["z"]])
    for f in (0, 4):
        q = log.q[anim.steps[f]]
        for (start, count, link), cap in zip(spec["parts"], robot.capsules):
            T = np.array(spec["poses"][f][link]).reshape(3, 4)  # as the page applies it
            world = local[start : start + count] @ T[:, :3].T + T[:, 3]
            F = robot.fk(q, cap.frame)  # oracle: the capsule's segment by forward kinematics
            a, b = F[:3, :3] @ cap.a + F[:3, 3], F[:3, :3] @ cap.b + F[:3, 3]
            d = [_segment_distance(p, a, b) for p in world]
            np.testing.assert_allclose(d, cap.radius, atol=2e-4)  # 0.1 mm rounding


def test_runs_of_one_robot_share_its_mesh_in_the_page(obstacle_run: tuple) -> None:
    from redres.report.html import share_meshes

    robot, log, _ = obstacle_run
    figures = [animation_figure(arm_animation(robot, log, frames=f)) for f in (4, 6)]
    shared, slim = share_meshes(figures)
    assert len(shared) == 1  # one robot, one mesh, written once
    for fig, small in zip(figures, slim):
        ((spec,), (slim_spec,)) = fig["rigid"], small["rigid"]
        mesh = shared[slim_spec["mesh"]]
        trace = small["data"][spec["trace"]]
        assert "i" not in trace and "x" not in slim_spec
        # what the page restores is what the figure held
        for c in ("x", "y", "z"):
            assert mesh[c] == spec[c]
        for c in ("i", "j", "k"):
            assert mesh[c] == fig["data"][spec["trace"]][c]
        assert trace["x"] == fig["data"][spec["trace"]]["x"]  # frame 0 stays
        assert "i" in fig["data"][spec["trace"]]  # the input is unchanged
