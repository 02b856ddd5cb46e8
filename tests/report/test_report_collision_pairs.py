"""The per-step record of the collision pairs (``log.extra["collision_pairs"]``), and the
report drawing it with boxes and half-spaces: the binding flags against the QP scheme's own
step result, the witness points against the shapes' geometry, the figure's segments
against the record, box and plane meshes against their definitions."""

from __future__ import annotations

import itertools
import json
import re

import numpy as np
import pytest

import redres as rr
from redres.collision import BoxObstacle, CollisionModel, Collisions, PlaneObstacle
from redres.control import Controller, Line, RunLog
from redres.control.analysis import collision_clearance
from redres.report import animation_figure, arm_animation, write_report
from redres.report.scene3d import obstacle_traces
from redres.tasks import FrameTask

pytest.importorskip("daqp")

DT = 5e-3
STEPS = 60


def _scene() -> tuple[rr.Robot, list, Collisions]:
    """The Panda's hand 5 cm above a box, a floor 20 cm under the base; the path goes
    15 cm down, into the box."""
    panda = rr.models.panda()
    hand = panda.fk(panda.neutral())[:3, 3]
    box = BoxObstacle([hand[0], hand[1], hand[2] - 0.05 - 0.05 - 0.08], [0.15, 0.2, 0.08],
                      name="box")  # fmt: skip
    floor = PlaneObstacle([0.0, 0.0, 1.0], -0.2, name="floor")
    return panda, [box, floor], Collisions([box, floor])


@pytest.fixture(scope="module")
def constrained() -> tuple[rr.Robot, list, Collisions, RunLog, list[set[tuple[str, str]]]]:
    """A QP run with the collision constraint, stepped by hand so that each step's own
    ``details.collisions.binding`` is kept; the log is filled from the same steps."""
    from redres.resolution import QPScheme

    panda, obstacles, settings = _scene()
    start = panda.fk(panda.neutral())
    line = Line(start, start[:3, 3] - [0.0, 0.0, 0.15], STEPS * DT)
    task = FrameTask()
    controller = Controller(panda, task, QPScheme(dt=DT, collisions=settings), dt=DT, gain=20.0)
    log = RunLog.empty(panda.name, "qp", DT, STEPS, panda.n, "qp: collisions")
    q, binding = panda.neutral(), []
    for k in range(STEPS):
        sample = line.sample(k * DT)
        task.set_target(sample.pose, sample.twist)
        log.q[k] = q
        q = controller.step(q)
        log.qd[k] = controller.qd
        binding.append({p.names for p in controller.result.details.collisions.binding})
    collision_clearance(log, panda, settings)
    return panda, obstacles, settings, log, binding


def test_the_record_binds_where_the_scheme_said_it_bound(constrained) -> None:  # type: ignore[no-untyped-def]
    _, _, _, log, binding = constrained
    record = log.extra["collision_pairs"]
    assert record.constrained and record.binding.any()  # the path drives into the box
    for k in range(STEPS):
        rows = record.at(k)
        ours = {record.pairs[i].names for i in record.pair[rows][record.binding[rows]]}
        assert ours == binding[k], k
    assert record.binding_steps == sum(1 for b in binding if b)


def test_the_record_keeps_every_pair_within_d_i_with_true_witness_points(constrained) -> None:  # type: ignore[no-untyped-def]
    panda, obstacles, settings, log, _ = constrained
    record = log.extra["collision_pairs"]
    box, floor = obstacles
    radius = {c.name: c.radius for c in panda.capsules}
    fresh = CollisionModel(panda, obstacles)  # another model: the same pairs, counted anew
    for k in (0, STEPS // 2, STEPS - 1):
        rows = record.at(k)
        assert np.all(record.step[rows] == k)
        near = np.flatnonzero(fresh.distances(log.q[k]) < settings.influence)
        assert sorted(fresh.pairs[i].names for i in near) == sorted(
            record.pairs[i].names for i in record.pair[rows]
        )
    assert np.all(np.diff(record.step) >= 0)
    for i, d, a, b in zip(record.pair, record.distance, record.point_a, record.point_b):
        pair = record.pairs[i]
        gap = np.linalg.norm(a - b) - radius[pair.first]
        if pair.self_pair:
            gap -= radius[pair.second]
        # signed: a capsule's centre line inside the other shape gives a negative distance
        assert abs(abs(gap) - abs(d)) < 1e-9, (pair, gap, d)
        if pair.second == "box":  # on the box's surface
            local = np.abs(box.rotation.T @ (b - box.center)) - box.half_extents
            assert abs(local.max()) < 1e-9
        if pair.second == "floor":
            assert abs(floor.normal @ b - floor.offset) < 1e-9
    assert log.objectives["obstacle_distance_m"].min() >= settings.safety - 1e-6


def test_a_run_without_the_constraint_is_measured_on_the_same_pairs(constrained) -> None:  # type: ignore[no-untyped-def]
    panda, _, settings, log, _ = constrained
    other = RunLog.empty(panda.name, "pinv", DT, STEPS, panda.n, "pinv")
    other.q[:] = log.q
    other.qd[:] = log.qd
    record = collision_clearance(other, panda, settings, constrained=False)
    ours = log.extra["collision_pairs"]
    assert not record.constrained and not record.binding.any()
    np.testing.assert_array_equal(record.pair, ours.pair)
    np.testing.assert_allclose(record.distance, ours.distance, rtol=0, atol=0)


def test_boxes_and_planes_are_drawn_at_their_place_and_size() -> None:
    angle = 0.3
    rotation = np.array([[np.cos(angle), -np.sin(angle), 0], [np.sin(angle), np.cos(angle), 0],
                         [0, 0, 1.0]])  # fmt: skip
    box = BoxObstacle([0.5, -0.2, 0.1], [0.1, 0.2, 0.05], rotation, name="crate")
    plane = PlaneObstacle([0.0, 1.0, 1.0], 0.3, name="ramp")
    traces = obstacle_traces([box, plane], plane_half_side=0.7)
    drawn = {t["meta"]["name"]: t for t in traces}
    assert {t["meta"]["shape"] for t in traces} == {"box", "plane"}
    corners = {tuple(np.round(box.center + rotation @ (np.array(s) * box.half_extents), 5))
               for s in itertools.product((-1, 1), repeat=3)}  # fmt: skip
    got = drawn["crate"]
    assert set(zip(got["x"], got["y"], got["z"])) == corners
    assert len(got["i"]) == 12
    ramp = drawn["ramp"]
    points = np.column_stack([ramp["x"], ramp["y"], ramp["z"]])
    np.testing.assert_allclose(points @ plane.normal, plane.offset, atol=1e-5)
    np.testing.assert_allclose(np.linalg.norm(points - points.mean(axis=0), axis=1),
                               0.7 * np.sqrt(2), atol=1e-4)  # fmt: skip


def _points(trace: dict) -> np.ndarray:
    """A segments trace's coordinates as ``(k, 2, 3)`` (``None`` between segments)."""
    xyz = [(x, y, z) for x, y, z in zip(trace["x"], trace["y"], trace["z"]) if x is not None]
    return np.array(xyz, dtype=float).reshape(-1, 2, 3)


def test_the_figure_draws_each_frames_pairs_from_the_record(constrained, tmp_path) -> None:  # type: ignore[no-untyped-def]
    panda, obstacles, _, log, _ = constrained
    record = log.extra["collision_pairs"]
    anim = arm_animation(panda, log, frames=12, obstacles=obstacles)
    figure = animation_figure(anim)
    data = figure["data"]
    kinds = [i for i, t in enumerate(data) if t.get("meta", {}).get("kind") == "pairs"]
    assert [data[i]["meta"]["binding"] for i in kinds] == [False, True]
    assert data[kinds[1]]["line"]["color"] == "#d62728"
    some_binding = False
    for f, frame in enumerate(figure["frames"]):
        k = int(anim.steps[f])
        rows = record.at(k)
        bound = record.binding[rows]
        segments = np.stack([record.point_a[rows], record.point_b[rows]], axis=1)
        moving = dict(zip(frame["traces"], frame["data"]))
        np.testing.assert_allclose(_points(moving[kinds[0]]), segments[~bound].reshape(-1, 2, 3),
                                   atol=1e-5)  # fmt: skip
        np.testing.assert_allclose(_points(moving[kinds[1]]), segments[bound].reshape(-1, 2, 3),
                                   atol=1e-5)  # fmt: skip
        some_binding |= bool(bound.any())
    assert some_binding
    page = write_report(tmp_path / "r", [(panda, log, obstacles)], title="pairs")
    html = page.read_text(encoding="utf-8")
    assert "binding collision pairs" in html
    assert re.search(r'"shape":\s*"box"', html) and re.search(r'"shape":\s*"plane"', html)
    json.dumps(figure)  # plain JSON types only
