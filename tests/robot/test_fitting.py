"""Capsules fitted to collision geometry hold it (every sampled surface point inside) and
are at most 30 % larger in volume than the smallest capsule that holds it; obstacle
avoidance then works on a URDF robot."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.objectives import ObstacleObjective, SphereObstacle
from redres.robot import Capsule


def _segment_distance(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    denom = float(ab @ ab)
    s = np.clip((points - a) @ ab / denom, 0.0, 1.0) if denom > 0 else np.zeros(len(points))
    return np.linalg.norm(points - (a + s[:, None] * ab), axis=1)


def _cylinder_surface(rng: np.random.Generator, r: float, length: float, k: int) -> np.ndarray:
    """Random points on a cylinder's side and end discs, along z, centred at 0."""
    angle = rng.uniform(0, 2 * np.pi, k)
    side = np.column_stack(
        [r * np.cos(angle), r * np.sin(angle), rng.uniform(-0.5, 0.5, k) * length]
    )
    rho = r * np.sqrt(rng.uniform(0, 1, k))
    disc = np.column_stack([rho * np.cos(angle), rho * np.sin(angle),
                            rng.choice([-0.5, 0.5], k) * length])  # fmt: skip
    rim = np.column_stack(
        [r * np.cos(angle), r * np.sin(angle), rng.choice([-0.5, 0.5], k) * length]
    )
    return np.vstack([side, disc, rim])


def _box_surface(rng: np.random.Generator, size: np.ndarray, k: int) -> np.ndarray:
    p = rng.uniform(-0.5, 0.5, (k, 3)) * size
    axis = rng.integers(0, 3, k)
    p[np.arange(k), axis] = rng.choice([-0.5, 0.5], k) * size[axis]
    corners = np.array(np.meshgrid([-1, 1], [-1, 1], [-1, 1])).reshape(3, -1).T * size / 2
    return np.vstack([p, corners])


def _prism_surface(rng: np.random.Generator, k: int) -> np.ndarray:
    """Points on meshes/prism.stl in metres: 12-sided prism, r 25 mm, z from 0 to 0.2 m,
    sampled on its side faces (oracle: the solid as the fixture's script made it)."""
    n, r = 12, 0.025
    j = rng.integers(0, n, k)
    w = rng.uniform(0, 1, k)[:, None]
    p0 = np.column_stack([r * np.cos(2 * np.pi * j / n), r * np.sin(2 * np.pi * j / n)])
    p1 = np.column_stack([r * np.cos(2 * np.pi * (j + 1) / n), r * np.sin(2 * np.pi * (j + 1) / n)])
    xy = p0 + w * (p1 - p0)
    return np.column_stack([xy, rng.uniform(0, 0.2, k)])


def _smallest_coaxial(rho: float, half: float) -> float:
    """Volume of the smallest capsule, coaxial with a cylinder of radius ``rho`` and
    half-length ``half`` (a box: ``rho`` = half the diagonal of its cross-section), that
    holds its rim: radius r ≥ ρ, half segment h − √(r² − ρ²) (closed form, dense grid)."""
    r = np.linspace(rho, rho + 2 * half, 200001)
    ell = np.maximum(half - np.sqrt(r**2 - rho**2), 0.0)
    return float(np.min(np.pi * r**2 * 2 * ell + 4 / 3 * np.pi * r**3))


def _volume(c: Capsule) -> float:
    return float(np.pi * c.radius**2 * np.linalg.norm(c.b - c.a) + 4 / 3 * np.pi * c.radius**3)


@pytest.fixture(scope="module", params=["urdf", "mjcf"])
def arm(request: pytest.FixtureRequest, fixtures_dir: Path) -> rr.Robot:
    if request.param == "urdf":
        return rr.Robot.from_urdf(fixtures_dir / "arm3.urdf")
    return rr.Robot.from_mjcf(fixtures_dir / "arm3.xml")


def _in_joint_frame(points: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    return points @ R.T + t


def test_capsules_hold_the_geometry_and_are_small(arm: rr.Robot, rng: np.random.Generator) -> None:
    caps = {c.frame: c for c in arm.capsules}
    assert sorted(caps) == ["j1", "j2", "j3"]
    ry90 = np.array([[0.0, 0, 1], [0, 1, 0], [-1, 0, 0]])  # rpy (0, π/2, 0)
    cylinder = _cylinder_surface(rng, 0.04, 0.3, 3000)
    box = _box_surface(rng, np.array([0.3, 0.06, 0.05]), 3000)
    prism = _prism_surface(rng, 3000) - [0, 0, 0.1]
    surfaces = {
        # the fixture's shapes in their joint frames, and their smallest coaxial capsule
        "j1": (_in_joint_frame(cylinder, np.eye(3), np.array([0, 0, 0.15])),
               _smallest_coaxial(0.04, 0.15)),
        "j2": (_in_joint_frame(box, np.eye(3), np.array([0.15, 0, 0])),
               _smallest_coaxial(np.hypot(0.03, 0.025), 0.15)),
        "j3": (_in_joint_frame(prism, ry90, np.array([0.12, 0, 0])),
               _smallest_coaxial(0.025, 0.1)),
    }  # fmt: skip
    for frame, (points, needed) in surfaces.items():
        cap = caps[frame]
        distance = _segment_distance(points, cap.a, cap.b)
        assert np.all(distance <= cap.radius + 1e-12), frame
        assert _volume(cap) <= 1.30 * needed, (frame, _volume(cap) / needed)
        assert _volume(cap) >= 0.999 * needed  # sanity: none holds it with less


def test_capsules_follow_their_links(arm: rr.Robot, rng: np.random.Generator) -> None:
    # The fixture's cylinder, in link l1's frame (the URDF's link frames), must stay inside
    # l1's capsule at every configuration: the capsule is on the right frame.
    points = _cylinder_surface(rng, 0.04, 0.3, 500) + [0, 0, 0.15]
    cap = next(c for c in arm.capsules if c.frame == "j1")
    for _ in range(3):
        q = arm.random_configuration(rng)
        T_link, T_cap = arm.fk(q, "l1"), arm.fk(q, cap.frame)
        world = points @ T_link[:3, :3].T + T_link[:3, 3]
        a = T_cap[:3, :3] @ cap.a + T_cap[:3, 3]
        b = T_cap[:3, :3] @ cap.b + T_cap[:3, 3]
        assert np.all(_segment_distance(world, a, b) <= cap.radius + 1e-12)


def test_obstacle_avoidance_works_on_a_urdf_robot(fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "arm3.urdf")
    q = np.array([0.0, 0.6, -0.9])
    T = robot.fk(q, "j3")
    ball = SphereObstacle(T[:3, 3] + [0.0, 0.0, 0.09], 0.02)
    objective = ObstacleObjective([ball], influence=0.1)
    d0 = objective.min_distance(robot, q)
    assert 0 < d0 < 0.1
    step = -1e-3 * objective.gradient(robot, q) / np.linalg.norm(objective.gradient(robot, q))
    assert objective.min_distance(robot, q + step) > d0  # descending the cost moves away
    fd = np.array([(objective.cost(robot, q + h) - objective.cost(robot, q - h)) / 2e-6
                   for h in 1e-6 * np.eye(3)])  # fmt: skip
    np.testing.assert_allclose(objective.gradient(robot, q), fd, rtol=1e-4, atol=1e-6)


def test_a_robot_without_collision_geometry_is_told_what_to_do(fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "panda_description.urdf", tip="panda_hand")
    with pytest.raises(rr.errors.InvalidParameterError, match="collision"):
        ObstacleObjective([SphereObstacle([0.5, 0, 0.5], 0.1)]).cost(robot, robot.neutral())
