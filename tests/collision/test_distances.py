"""The compiled pair distances against coal (Pinocchio's collision library), their
Jacobian rows against central finite differences, and compiled against plain Python."""

from __future__ import annotations

from typing import Any

import coal
import numpy as np
import pytest

import redres as rr
from redres import _compile
from redres.collision import (
    BoxObstacle,
    CapsuleObstacle,
    CollisionModel,
    PlaneObstacle,
    SphereObstacle,
    pack_obstacles,
)
from redres.collision.distances import KERNELS


def _rotation(rng: np.random.Generator) -> np.ndarray:
    Q, R = np.linalg.qr(rng.normal(size=(3, 3)))
    Q = Q * np.sign(np.diag(R))
    return Q if np.linalg.det(Q) > 0 else -Q


def _one_pair(a: Any, b: Any, r: float, obstacle: Any, *, plain: bool = False) -> tuple:
    """The kernel on one capsule ``[a, b]`` (radius ``r``, on a fixed joint at the world
    origin) against one obstacle: ``(d, p_a, p_b, n̂)``."""
    module = KERNELS.module(plain=plain) if _compile.enabled() else KERNELS.module()
    kinds, rows = pack_obstacles([obstacle])
    d, pa, pb, n = np.zeros(1), np.zeros((1, 3)), np.zeros((1, 3)), np.zeros((1, 3))
    module.pair_distances(
        np.eye(3)[None], np.zeros((1, 3)), np.zeros((6, 1)), np.zeros(1, np.int64),
        np.zeros(1, np.int64), np.asarray([a], float), np.asarray([b], float), np.array([r]),
        kinds, rows, np.array([[0, 0, 0]], np.int64), np.inf, d, pa, pb, n, np.zeros((1, 1)),
    )  # fmt: skip
    return d[0], pa[0], pb[0], n[0]


def _capsule_coal(a: np.ndarray, b: np.ndarray, r: float) -> tuple[Any, Any]:
    """A coal capsule with segment ``[a, b]`` (its axis is local z)."""
    axis = b - a
    length = float(np.linalg.norm(axis))
    z = axis / length
    x = np.cross(z, [1.0, 0.0, 0.0] if abs(z[0]) < 0.9 else [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    R = np.column_stack([x, np.cross(z, x), z])
    return coal.Capsule(r, length), coal.Transform3s(R, 0.5 * (a + b))


def _coal_shape(obstacle: Any) -> tuple[Any, Any]:
    if isinstance(obstacle, SphereObstacle):
        return coal.Sphere(obstacle.radius), coal.Transform3s(np.eye(3), obstacle.center)
    if isinstance(obstacle, CapsuleObstacle):
        return _capsule_coal(obstacle.a, obstacle.b, obstacle.radius)
    if isinstance(obstacle, BoxObstacle):
        shape = coal.Box(*(2.0 * obstacle.half_extents))
        return shape, coal.Transform3s(obstacle.rotation, obstacle.center)
    return coal.Halfspace(obstacle.normal, obstacle.offset), coal.Transform3s()


def _coal_distance(a: np.ndarray, b: np.ndarray, r: float, obstacle: Any) -> float:
    shape1, T1 = _capsule_coal(a, b, r)
    shape2, T2 = _coal_shape(obstacle)
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    request.gjk_tolerance = 1e-12
    return float(coal.distance(shape1, T1, shape2, T2, request, result))


def _random_obstacle(kind: str, rng: np.random.Generator) -> Any:
    if kind == "sphere":
        return SphereObstacle(rng.normal(size=3), rng.uniform(0.0, 0.3))
    if kind == "capsule":
        return CapsuleObstacle(rng.normal(size=3), rng.normal(size=3), rng.uniform(0.01, 0.3))
    if kind == "box":
        return BoxObstacle(rng.normal(size=3), rng.uniform(0.05, 0.5, 3), _rotation(rng))
    return PlaneObstacle(rng.normal(size=3), rng.normal())


@pytest.mark.parametrize("kind", ["sphere", "capsule", "box", "plane"])
def test_distances_match_coal(kind: str, rng: np.random.Generator) -> None:
    """Separated random pairs: the signed distance equals coal's, the witnesses are that
    far apart along the normal."""
    checked = 0
    for _ in range(300):
        a, b, r = rng.normal(size=3), rng.normal(size=3), rng.uniform(0.01, 0.2)
        obstacle = _random_obstacle(kind, rng)
        d, pa, pb, n = _one_pair(a, b, r, obstacle)
        if d <= 1e-3:  # penetration: coal's GJK/EPA depth is checked separately below
            continue
        assert d == pytest.approx(_coal_distance(a, b, r, obstacle), abs=1e-7)
        assert np.linalg.norm(n) == pytest.approx(1.0, abs=1e-12)
        r_obs = getattr(obstacle, "radius", 0.0)  # witnesses on centre lines (and centres)
        assert np.allclose(pa - pb, (d + r + r_obs) * n, atol=1e-9)
        checked += 1
    assert checked > 50


def test_parallel_and_touching_pairs() -> None:
    """Parallel segments (overlapping, offset) and touching shapes (d = 0)."""
    a, b = np.array([0.0, 0.0, 0.0]), np.array([1.0, 0.0, 0.0])
    parallel = CapsuleObstacle([0.3, 0.5, 0.0], [1.7, 0.5, 0.0], 0.1)
    d, _, _, n = _one_pair(a, b, 0.1, parallel)
    assert d == pytest.approx(0.3, abs=1e-14)
    assert d == pytest.approx(_coal_distance(a, b, 0.1, parallel), abs=1e-9)
    assert np.allclose(n, [0.0, -1.0, 0.0])
    beyond = CapsuleObstacle([1.5, 0.0, 0.0], [2.5, 0.0, 0.0], 0.1)  # collinear, apart
    assert _one_pair(a, b, 0.1, beyond)[0] == pytest.approx(0.3, abs=1e-14)
    touching = [
        SphereObstacle([0.5, 0.0, 0.3], 0.2),
        CapsuleObstacle([0.2, 0.25, -1.0], [0.2, 0.25, 1.0], 0.15),
        BoxObstacle([0.5, 0.0, 0.6], [1.0, 1.0, 0.5]),
        PlaneObstacle([0.0, 0.0, -1.0], -0.1),
    ]
    for obstacle in touching:
        d = _one_pair(a, b, 0.1, obstacle)[0]
        assert d == pytest.approx(0.0, abs=1e-14)
        assert _coal_distance(a, b, 0.1, obstacle) == pytest.approx(0.0, abs=1e-8)


def test_box_penetration_depth_is_the_most_penetrating_point() -> None:
    """A segment through a box: the signed distance is the deepest point's (closed form)."""
    box = BoxObstacle([0.0, 0.0, 0.0], [0.5, 0.3, 0.2])
    d, pa, pb, n = _one_pair([-1.0, 0.05, 0.0], [1.0, 0.05, 0.0], 0.0, box)
    # at x = 0: max(|x| − 0.5, |y| − 0.3, |z| − 0.2) = max(−0.5, −0.25, −0.2): the z faces
    assert d == pytest.approx(-0.2, abs=1e-12)
    # the deepest points form a plateau (|x| ≤ 0.3): any is a witness, the face its normal
    assert sorted(np.abs(n)) == pytest.approx([0.0, 0.0, 1.0])
    assert np.allclose(pa - pb, d * n, atol=1e-12)
    d = _one_pair([0.1, 0.0, 0.0], [0.2, 0.0, 0.0], 0.05, box)[0]
    assert d == pytest.approx(-0.2 - 0.05, abs=1e-12)  # radius 0.05 deeper still


def _scene() -> list[Any]:
    return [
        SphereObstacle([0.45, 0.1, 0.45], 0.08),
        CapsuleObstacle([0.3, -0.4, 0.1], [0.5, 0.4, 0.3], 0.04),
        BoxObstacle([0.45, -0.25, 0.7], [0.08, 0.1, 0.05], _rotation(np.random.default_rng(3))),
        PlaneObstacle([0.1, 0.0, 1.0], -0.05),
    ]


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_gradients_match_finite_differences(name: str, rng: np.random.Generator) -> None:
    """``∂d/∂q = n̂ᵀ(J_a − J_b)`` of every pair, environment and self, against central
    differences of the distances at random configurations."""
    robot = getattr(rr.models, name)()
    model = CollisionModel(robot, _scene())
    assert any(p.self_pair for p in model.pairs) and any(not p.self_pair for p in model.pairs)
    h, checked = 1e-6, 0
    for _ in range(20):
        q = rng.uniform(robot.q_min, robot.q_max)
        found = model.compute(q)
        d, G = found.distance.copy(), found.gradient.copy()
        fd = np.empty_like(G)
        for k in range(robot.n):
            step = np.zeros(robot.n)
            step[k] = h
            fd[:, k] = (model.distances(q + step) - model.distances(q - step)) / (2 * h)
        smooth = np.abs(fd - G).max(axis=1) < 1e-4  # a tie (plane, parallel) may switch
        assert smooth.mean() > 0.9
        assert np.allclose(fd[smooth], G[smooth], atol=2e-7)
        checked += int(smooth.sum())
        assert np.all(np.isfinite(d))
    assert checked > 100


def test_cutoff_skips_far_pairs_with_a_lower_bound(rng: np.random.Generator) -> None:
    """The broad phase: a pair beyond the cutoff gets a lower bound of its distance and a
    zero row; one within gets the exact distance."""
    robot = rr.models.panda()
    model = CollisionModel(robot, _scene())
    for _ in range(10):
        q = rng.uniform(robot.q_min, robot.q_max)
        exact = model.distances(q)
        found = model.compute(q, 0.1)
        bound = found.distance.copy()
        assert np.all(bound <= exact + 1e-12)
        near = exact < 0.1
        assert np.allclose(bound[near], exact[near], atol=1e-14)
        assert found.resolved >= near.sum()


@pytest.mark.skipif(not _compile.enabled(), reason="compiled against plain needs numba")
def test_compiled_equals_plain(rng: np.random.Generator) -> None:
    for kind in ("sphere", "capsule", "box", "plane"):
        for _ in range(20):
            a, b, r = rng.normal(size=3), rng.normal(size=3), rng.uniform(0.01, 0.2)
            obstacle = _random_obstacle(kind, rng)
            got = _one_pair(a, b, r, obstacle)
            want = _one_pair(a, b, r, obstacle, plain=True)
            assert got[0] == pytest.approx(want[0], abs=1e-13)
            for x, y in zip(got[1:], want[1:]):
                assert np.allclose(x, y, atol=1e-12)


def test_self_pairs_leave_out_adjacent_links_and_contact_at_neutral() -> None:
    robot = rr.models.panda()
    model = CollisionModel(robot, [])
    joints = {c.name: robot.model.frames[robot.frame_id(c.frame)].parentJoint
              for c in robot.capsules}  # fmt: skip
    for pair in model.pairs:
        assert abs(joints[pair.first] - joints[pair.second]) > 1
        assert model.compute(robot.neutral()).distance.min() > 0.0
    allowed = CollisionModel(robot, [], allowed=[("base", "hand")])
    assert ("base", "hand") in [p.names for p in model.pairs]
    assert ("base", "hand") not in [p.names for p in allowed.pairs]
    srdf = ('<robot name="r"><disable_collisions link1="link1" link2="link7" reason="x"/>'
            "</robot>")  # fmt: skip
    from_srdf = CollisionModel(robot, [], srdf=srdf)
    assert ("base", "hand") not in [p.names for p in from_srdf.pairs]
    assert len(from_srdf.pairs) == len(model.pairs) - 1


@pytest.mark.parametrize("name", ["panda", "iiwa14", "menagerie iiwa14"])
def test_compiled_chain_equals_pinocchio(name: str, rng: np.random.Generator) -> None:
    """The joints' poses and Jacobian from the compiled serial chain (the default on a
    serial arm) against Pinocchio's ``computeJointJacobians`` (the path of a model that is
    not one): the same distances, witnesses and rows, on built-in and fitted capsules."""
    robot = rr.models.menagerie("iiwa14") if name.startswith("menagerie") else getattr(
        rr.models, name)()  # fmt: skip
    chained = CollisionModel(robot, _scene())
    pinocchio = CollisionModel(robot, _scene())
    assert chained._chain is not None
    pinocchio._chain = None
    for _ in range(10):
        q = rng.uniform(robot.q_min, robot.q_max)
        got, want = chained.compute(q), pinocchio.compute(q)
        assert np.allclose(got.distance, want.distance, atol=1e-12)
        assert np.allclose(got.gradient, want.gradient, atol=1e-12)
        assert np.allclose(got.point_a, want.point_a, atol=1e-12)


def test_damper_rows_are_the_distances_rows(rng: np.random.Generator) -> None:
    """``CollisionModel.damper``: ``G`` equals ``compute``'s ``∂d/∂q`` for the pairs the
    broad phase resolves and the bound is ``rate·(d − d_s)`` exactly for the pairs closer
    than ``d_i``, ``−1e30`` (no bound) for the others."""
    robot = rr.models.panda()
    model = CollisionModel(robot, _scene())
    P, seen = len(model.pairs), 0
    G, lower = np.full((P, robot.n), np.nan), np.full(P, np.nan)
    for _ in range(20):
        q = rng.uniform(robot.q_min, robot.q_max)
        active = model.damper(q, 0.1, 0.01, -5.0, G, lower)
        found = model.compute(q, 0.1)
        near = found.distance < 0.1
        assert active == int(near.sum())
        assert np.allclose(G, found.gradient, atol=1e-14)
        assert np.allclose(lower[near], -5.0 * (found.distance[near] - 0.01), atol=1e-14)
        assert np.all(lower[~near] == -1e30)
        seen += active
    assert seen > 0
