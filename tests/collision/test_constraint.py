"""Collision avoidance as a hard constraint of the QP scheme: no pair goes below the
safety distance in closed loop, the task yields (``feasible=False``) and the rows are
reported; the settings are checked; scenario files carry them."""

from __future__ import annotations

import numpy as np
import pytest

import redres as rr
from redres.collision import BoxObstacle, Collisions, PlaneObstacle, SphereObstacle
from redres.control.trajectories import Line
from redres.errors import InvalidParameterError
from redres.objectives import ObstacleObjective
from redres.resolution import GradientProjectionScheme, QPScheme
from redres.scenarios.spec import parse_scenario
from redres.tasks import FrameTask
from redres.testing import collision_scene

pytest.importorskip("daqp")

DT = 1e-3
POSITION = ["x", "y", "z"]


def _run(robot: rr.Robot, scene: object, scheme: object, steps: int = 400) -> np.ndarray:
    trajectory = Line(robot.fk(scene.q0), scene.end, steps * DT)  # type: ignore[attr-defined]
    log = rr.run(robot, FrameTask(rows=POSITION), trajectory, scheme, dt=DT,  # type: ignore[arg-type]
                 q0=scene.q0, progress=False)  # type: ignore[attr-defined]  # fmt: skip
    return log.q


@pytest.mark.parametrize("name", ["panda", "iiwa14"])
def test_random_scenes_never_go_below_the_safety_distance(name: str) -> None:
    """A few scenes of benchmarks/collision_validation.py: with the constraint no pair
    (environment or self) goes below d_s − 1e-6 m at any step; the soft objective alone,
    on the same scenes, is measured too and must come closer in at least one."""
    robot = getattr(rr.models, name)()
    rng = np.random.default_rng(7)
    hard, soft = [], []
    for _ in range(3):
        scene = collision_scene(robot, rng)
        collisions = Collisions(scene.obstacles, influence=0.10, safety=0.01)
        model = collisions.model(robot)
        qs = _run(robot, scene, QPScheme(DT, collisions=collisions))
        hard.append(min(model.distances(q).min() for q in qs))
        objective = ObstacleObjective(scene.obstacles, influence=0.10, self_collision=True)
        qs = _run(robot, scene, GradientProjectionScheme([objective], k_null=1.0))
        soft.append(min(model.distances(q).min() for q in qs))
    assert min(hard) >= 0.01 - 1e-6
    assert min(soft) < min(hard)  # the scenes do drive the arm into the obstacles


def _ball_ahead(ahead: float, radius: float, self_collision: bool) -> tuple:
    """The Panda at its neutral pose, a ball ``ahead`` m along x from its tip, and a QP
    scheme constrained by it: ``(robot, q, collisions, scheme, model)``."""
    robot = rr.models.panda()
    q = robot.neutral()
    ball = SphereObstacle(robot.fk(q)[:3, 3] + [ahead, 0.0, 0.0], radius, "ball")
    collisions = Collisions([ball], influence=0.10, safety=0.01, self_collision=self_collision)
    return robot, q, collisions, QPScheme(DT, collisions=collisions), collisions.model(robot)


def test_a_path_into_an_obstacle_yields_the_task_not_the_row() -> None:
    """The tip driven through a ball: the rows bind, the task is not met
    (``feasible=False``), the distance stays at or above d_s, and the details say so."""
    robot, q, _, scheme, model = _ball_ahead(0.15, 0.05, False)
    tip = robot.fk(q)[:3, 3]
    task = FrameTask(rows=POSITION)
    controller = rr.Controller(robot, task, scheme, dt=DT, gain=50.0)
    trajectory = Line(robot.fk(q), tip + [0.30, 0.0, 0.0], 1.0)
    infeasible, binding, closest = 0, 0, np.inf
    for k in range(1200):
        sample = trajectory.sample(min(k * DT, 1.0))
        task.set_target(sample.pose, sample.twist, validate=False)
        q = controller.step(q)
        closest = min(closest, float(model.distances(q).min()))
        result = controller.result
        assert result is not None
        contact = result.details.collisions
        infeasible += not result.feasible
        if contact.bound:
            binding += 1
            assert not result.feasible
            assert {p.second for p in contact.binding} == {"ball"}
            assert contact.closest[0].second == "ball"
            assert contact.closest[1] == pytest.approx(min(contact.distances))
    assert closest >= 0.01 - 1e-6
    assert binding > 100 and infeasible >= binding
    assert np.linalg.norm(robot.fk(q)[:3, 3] - trajectory.sample(1.0).pose[:3, 3]) > 0.05


def test_rows_hold_on_a_single_step(rng: np.random.Generator) -> None:
    """Where pairs are active the answer meets ``n̂ᵀ(J_a − J_b) q̇ ≥ −ξ(d − d_s)/(d_i − d_s)``
    for each, computed independently from finite differences of the distances."""
    robot = rr.models.panda()
    scene = collision_scene(robot, rng)
    collisions = Collisions(scene.obstacles, influence=0.10, safety=0.01)
    model = collisions.model(robot)
    checked = 0
    for _ in range(300):
        q = (
            scene.q0
            + rng.uniform(0.0, 1.0) * (scene.q1 - scene.q0)
            + rng.normal(0.0, 0.05, robot.n)
        )
        q = np.clip(q, robot.q_min + 0.05, robot.q_max - 0.05)
        d = model.distances(q)
        near = (d < 0.10) & (d > 0.0)
        if not near.any() or checked >= 10:
            continue
        scheme = QPScheme(DT, collisions=collisions)
        J = robot.jacobian(q)[:3]
        qd = scheme.step(robot, q, J, rng.normal(0.0, 0.5, 3)).qd
        h = 1e-6  # the rate of each distance along qd, by central differences
        rate = (model.distances(q + h * qd) - model.distances(q - h * qd)) / (2 * h)
        bound = -collisions.gain * (d - 0.01) / (0.10 - 0.01)
        assert np.all(rate[near] >= bound[near] - 1e-5)
        checked += 1
    assert checked > 5


def test_settings_are_checked() -> None:
    with pytest.raises(InvalidParameterError, match="safety"):
        Collisions([], influence=0.05, safety=0.05)
    with pytest.raises(InvalidParameterError, match="gain"):
        QPScheme(0.5, collisions=Collisions([], gain=1.0))
    with pytest.raises(InvalidParameterError, match="levels"):
        QPScheme(DT, collisions=Collisions([]), levels=[rr.tasks.PostureTask()])
    with pytest.raises(InvalidParameterError, match="Collisions"):
        QPScheme(DT, collisions={"influence": 0.1})  # type: ignore[arg-type]
    with pytest.raises(InvalidParameterError, match="BoxObstacle"):
        rr.collision.CollisionModel(rr.models.panda(), [object()])
    with pytest.raises(InvalidParameterError, match="normal"):
        PlaneObstacle([0.0, 0.0, 0.0], 1.0)
    with pytest.raises(InvalidParameterError, match="rotation"):
        BoxObstacle([0, 0, 0], [1, 1, 1], np.diag([1.0, 1.0, -1.0]))


def _scenario(extra: str) -> dict:
    import tomllib

    text = f"""
name = "t"
[robot]
model = "panda"
[trajectory]
type = "line"
end = [0.4, 0.1, 0.4]
duration = 0.2
[run]
dt = 0.001
[[obstacles]]
type = "box"
name = "shelf"
center = [0.5, -0.4, 0.3]
half_extents = [0.1, 0.2, 0.02]
rpy = [0.0, 0.0, 0.3]
[[obstacles]]
type = "plane"
name = "table"
normal = [0, 0, 1]
offset = -0.1
[[schemes]]
type = "qp"
{extra}
"""
    return tomllib.loads(text)


def test_scenario_collisions_keys() -> None:
    spec = parse_scenario(_scenario(
        "collisions = { influence = 0.12, safety = 0.02, self = false, gain = 0.4, "
        'allowed = [["hand", "table"]] }'
    ))  # fmt: skip
    scheme = spec.schemes[0].build()
    c = scheme.collisions
    assert (c.influence, c.safety, c.gain, c.self_collision) == (0.12, 0.02, 0.4, False)
    assert [type(o).__name__ for o in c.obstacles] == ["BoxObstacle", "PlaneObstacle"]
    pairs = [p.names for p in c.model(spec.robot).pairs]
    assert ("hand", "table") not in pairs and ("hand", "shelf") in pairs
    box = spec.obstacles[0]
    assert np.allclose(box.rotation[:2, :2], [[np.cos(0.3), -np.sin(0.3)],
                                              [np.sin(0.3), np.cos(0.3)]])  # fmt: skip
    default = parse_scenario(
        _scenario("collisions = { influence = 0.10, safety = 0.01, self = true }")
    )
    assert default.schemes[0].build().collisions.gain == rr.collision.DEFAULT_GAIN
    with pytest.raises(rr.errors.RedresError, match="influenc"):
        parse_scenario(_scenario("collisions = { influenc = 0.1 }"))
    with pytest.raises(rr.errors.RedresError, match="safety"):
        parse_scenario(_scenario("collisions = { influence = 0.1, safety = 0.2 }"))


def test_a_run_reports_self_and_obstacle_clearances() -> None:
    """``redres run --json``'s summary: ``min_self_clearance_m`` beside
    ``min_obstacle_clearance_m`` for a qp scheme with ``collisions``."""
    from redres.scenarios.runner import run_scenario

    spec = parse_scenario(
        _scenario("collisions = { influence = 0.10, safety = 0.01, self = true }")
    )
    (log,) = run_scenario(spec, progress=False)
    summary = log.summary()
    assert summary["min_self_clearance_m"] >= 0.01 - 1e-6
    assert summary["min_obstacle_clearance_m"] >= 0.01 - 1e-6
    model = spec.schemes[0].build().collisions.model(spec.robot)
    self_pairs = model.self_mask()
    want = min(model.distances(q)[self_pairs].min() for q in log.q)
    assert summary["min_self_clearance_m"] == pytest.approx(want, abs=1e-12)


def test_warm_started_rows_give_the_cold_solution() -> None:
    """Along a path into a ball (the rows active and binding over many steps, DAQP warm
    started from step to step), each answer equals a cold solve of the QP written out from
    its definition: the rows from ``CollisionModel.compute`` (not the scheme's buffers),
    the box the step reports; the exact QP where the task is met, the least-violating one
    where it is not."""
    import daqp

    robot, q, collisions, scheme, model = _ball_ahead(0.12, 0.04, True)
    rate = -collisions.gain / (collisions.influence - collisions.safety)
    compared = {True: 0, False: 0}
    for _ in range(400):
        J = robot.jacobian(q)[:3]
        xd = np.array([0.4, 0.0, -0.05])
        result = scheme.step(robot, q, J, xd)
        found = model.compute(q, collisions.influence)
        near = found.distance < collisions.influence
        contact = result.details.collisions
        if contact.bound:
            G, h = found.gradient[near], rate * (found.distance[near] - collisions.safety)
            lo, hi = result.details.bounds
            n, free = robot.n, np.full(int(near.sum()), 1e30)
            if result.feasible:
                A = np.vstack([J, G])
                sense = np.r_[np.zeros(n), np.full(3, 5), np.zeros(len(h))].astype(np.intc)
                x, _, flag, _ = daqp.solve(np.eye(n), np.zeros(n), A, np.r_[hi, xd, free],
                                           np.r_[lo, xd, h], sense, primal_tol=1e-10)  # fmt: skip
            else:
                P = J.T @ J + scheme.damping**2 * np.eye(n)
                sense = np.zeros(n + len(h), np.intc)
                x, _, flag, _ = daqp.solve(P, -J.T @ xd, G, np.r_[hi, free], np.r_[lo, h], sense,
                                           primal_tol=1e-10)  # fmt: skip
            assert flag > 0
            assert np.allclose(result.qd, x, atol=1e-7)
            compared[bool(result.feasible)] += 1
        q = q + DT * result.qd
    assert compared[False] > 20  # the ball stops the task


def test_the_damper_bound_is_zero_at_d_s_and_minus_the_gain_at_d_i() -> None:
    """``−ξ (d − d_s)/(d_i − d_s)``: no approach allowed at the safety distance, approach
    at ``ξ`` at the influence distance, linear between (the record and the rows share it)."""
    c = rr.Collisions([], influence=0.10, safety=0.02, gain=0.4)
    assert c.bound(0.02) == 0.0
    assert c.bound(0.10) == pytest.approx(-0.4, abs=1e-15)
    assert c.bound(np.array([0.06])) == pytest.approx([-0.2], abs=1e-15)
    assert c.rate == pytest.approx(-0.4 / 0.08, abs=1e-12)
