"""Redundancy maps: the closed form of the S-R-S arms against forward kinematics and the
library's arm angle, its interval endpoints against the limits, dense sampling and the
self-motion trace; the sweep kind end to end."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres import sweeps
from redres.ik.arcs import contains, from_arcs, merge, pieces
from redres.ik.srs import BRANCHES, NotSRSError, SRSArm
from redres.sweeps.kinds.selfmotion import CLOSED, LIMIT, trace
from redres.tasks import ArmAngleTask

from ..helpers import tree_digest

EPS = 1e-6  # rad: "just inside" / "just outside" an endpoint
AGREE = 1e-3  # rad: the trace's endpoints against the closed form's


def wrap(x: np.ndarray) -> np.ndarray:
    return np.pi - np.mod(np.pi - np.asarray(x), 2 * np.pi)


def random_poses(robot: rr.Robot, count: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    q = rng.uniform(robot.q_min, robot.q_max, (count, robot.n))
    return q, np.array([robot.fk(qi) for qi in q])


def branch_of(arm: SRSArm, q: np.ndarray, q4_plus: float) -> int:
    """The :data:`BRANCHES` row of a configuration (signs of q2, q4 from straight, q6)."""
    g4 = 1 if abs(wrap(q[3] - q4_plus)) < 1e-9 else -1
    signs = (int(np.sign(q[1])), g4, int(np.sign(q[5])))
    return int(np.flatnonzero((BRANCHES == signs).all(axis=1))[0])


@pytest.fixture(scope="module", params=["iiwa14", "srs7"])
def arm_case(request: pytest.FixtureRequest) -> tuple[rr.Robot, SRSArm]:
    robot = rr.models.load(request.param)
    return robot, SRSArm.from_robot(robot)


def arm_angles(robot: rr.Robot, q: np.ndarray) -> np.ndarray:
    return ArmAngleTask().values(robot, q)


def test_closed_form_reproduces_pose_and_arm_angle(arm_case: tuple[rr.Robot, SRSArm]) -> None:
    robot, arm = arm_case
    q_true, T = random_poses(robot, 40, 2)
    poses = arm.poses(T)
    phi = np.random.default_rng(3).uniform(-np.pi, np.pi, (40, 25))
    task, checked, pose_error, angle_error = ArmAngleTask(), 0, 0.0, 0.0
    for b in range(8):
        q = poses.joints(phi, b)
        for i in range(40):
            if not poses.valid[i, 1 if BRANCHES[b, 1] < 0 else 0]:
                continue
            for m in range(25):
                pose_error = max(pose_error, np.abs(robot.fk(q[i, m]) - T[i]).max())
                angle = abs(wrap(task.value(robot, q[i, m]) - phi[i, m]))
                angle_error = max(angle_error, angle)
                checked += 1
    print(
        f"\n{robot.name}: {checked} closed-form configurations: largest |fk - T| "
        f"{pose_error:.1e}, largest arm-angle error {angle_error:.1e} rad"
    )
    assert pose_error < 1e-10 and angle_error < 1e-10
    assert checked >= 40 * 25 * 8 * 0.9
    # the configuration a pose was made from is on its branch, at its own arm angle
    for i in range(40):
        b = branch_of(arm, q_true[i], poses.q4[i, 0])
        own = poses.joints(np.full((40, 1), task.value(robot, q_true[i])), b)[i, 0]
        np.testing.assert_allclose(own, q_true[i], atol=1e-9)


def test_not_srs() -> None:
    with pytest.raises(NotSRSError, match="wrist point"):
        SRSArm.from_robot(rr.models.panda())


def endpoints(arcs: list[tuple[float, float]]) -> list[float]:
    """Endpoints of arcs that are not the whole circle."""
    return [x for lo, hi in arcs if hi - lo < 2 * np.pi - 1e-12 for x in (lo, hi)]


def test_endpoints_are_limits(arm_case: tuple[rr.Robot, SRSArm]) -> None:
    robot, arm = arm_case
    _, T = random_poses(robot, 60, 4)
    poses = arm.poses(T)
    arcs = poses.arcs()
    checked, worst = 0, 0.0
    for i in range(60):
        for b in range(8):
            for lo, hi in arcs[i][b]:
                if hi - lo >= 2 * np.pi - 1e-12:
                    continue
                for end, inward in ((lo, 1.0), (hi, -1.0)):
                    trio = np.array([[end, end + inward * EPS, end - inward * EPS]])
                    q = poses.joints(np.repeat(trio, 60, axis=0), b)[i]
                    at_limit = np.minimum(np.abs(q[0] - arm.q_min), np.abs(q[0] - arm.q_max))
                    worst = max(worst, at_limit.min())
                    assert at_limit.min() < 1e-9, (i, b, end)
                    assert robot.within_limits(q[1])
                    assert not robot.within_limits(q[2])
                    checked += 1
    print(
        f"\n{robot.name}: {checked} endpoints: a joint within {worst:.1e} rad of its limit; "
        f"inside at +{EPS} rad, outside at -{EPS} rad"
    )
    assert checked >= 100


def test_dense_sampling_agrees(arm_case: tuple[rr.Robot, SRSArm]) -> None:
    robot, arm = arm_case
    _, T = random_poses(robot, 30, 5)
    poses = arm.poses(T)
    arcs = poses.arcs()
    grid = np.linspace(-np.pi, np.pi, 4001)
    step = grid[1] - grid[0]
    disagreements = 0
    for b in range(8):
        q = poses.joints(np.tile(grid, (30, 1)), b)
        sampled = ((q >= arm.q_min) & (q <= arm.q_max)).all(axis=-1)
        for i in range(30):
            parts = np.array(pieces(arcs[i][b]) or np.zeros((0, 2))).reshape(-1, 2)
            claimed = (
                contains(parts[None], grid[None])[0] if len(parts) else np.zeros_like(grid, bool)
            )
            wrong = np.flatnonzero(sampled[i] != claimed)
            ends = np.array(endpoints(arcs[i][b]) or [np.inf])
            for k in wrong:
                assert np.abs(wrap(grid[k] - ends)).min() <= step, (i, b, grid[k])
            disagreements += len(wrong)
    print(
        f"\n{robot.name}: {disagreements} of {30 * 8 * len(grid)} samples disagree, each "
        f"within one step ({step:.1e} rad) of an endpoint"
    )
    assert disagreements < 0.001 * 30 * 8 * len(grid)


def test_stored_arrays_equal_the_arcs(arm_case: tuple[rr.Robot, SRSArm]) -> None:
    """The array path of the sweep (:meth:`SRSPoses.intervals`) gives the pieces of the
    per-pose path (:meth:`SRSPoses.arcs`), and the union is the union of the branches."""
    robot, arm = arm_case
    _, T = random_poses(robot, 200, 9)
    poses = arm.poses(T)
    stored, arcs = poses.intervals(8), poses.arcs()
    for i in range(200):
        every = []
        for b in range(8):
            parts = pieces(arcs[i][b])
            every += parts
            assert stored["count"][i, b] == len(parts)
            k = min(len(parts), 8)
            np.testing.assert_allclose(stored["intervals"][i, b, :k], np.reshape(parts[:k], (k, 2)),
                                       rtol=0, atol=1e-12)  # fmt: skip
            assert abs(stored["width"][i, b] - sum(h - l for l, h in parts)) < 1e-12
        union = merge(every)
        assert stored["union_count"][i] == len(union)
        k = min(len(union), 8)
        np.testing.assert_allclose(stored["union"][i, :k], np.reshape(union[:k], (k, 2)),
                                   rtol=0, atol=1e-12)  # fmt: skip
        assert abs(stored["total_width"][i] - sum(h - l for l, h in union)) < 1e-12


def test_trace_agrees_with_closed_form() -> None:
    robot = rr.models.iiwa14()
    arm = SRSArm.from_robot(robot)
    q_true, T = random_poses(robot, 60, 6)
    poses = arm.poses(T)
    arcs = poses.arcs()
    traced = trace(robot, T, q_true, step=0.02)
    phi_true = arm_angles(robot, q_true)
    worst, compared = 0.0, 0
    for i in range(60):
        b = branch_of(arm, q_true[i], poses.q4[i, 0])
        mine = [
            a for a in arcs[i][b] if contains(np.array(pieces([a]))[None], phi_true[i : i + 1])[0]
        ]
        assert len(mine) == 1
        lo, hi = mine[0]
        t_lo, t_hi = traced.arc(i)
        if hi - lo >= 2 * np.pi - 1e-12:
            assert (traced.ends[i] == CLOSED).any() and traced.full[i]
            continue
        assert (traced.ends[i] == LIMIT).all()
        worst = max(worst, abs(wrap(t_lo - lo)), abs(wrap(t_hi - hi)))
        compared += 1
    print(
        f"\niiwa14: trace vs closed form on {compared} arcs: largest endpoint difference "
        f"{worst:.1e} rad"
    )
    assert worst < AGREE and compared >= 40


def test_trace_ends_at_limits_on_the_panda() -> None:
    """Off the closed form's arms: each traced direction that ends at a limit ends on the
    pose (FK), with a joint at its limit, at an arm angle inside the traced arc."""
    robot = rr.models.panda()
    q_true, T = random_poses(robot, 16, 8)
    traced = trace(robot, T, q_true, step=0.02)
    phi_ends = arm_angles(robot, traced.q_ends.reshape(-1, 7)).reshape(16, 2)
    limits = 0
    for i in range(16):
        assert traced.hi[i] > traced.lo[i]
        parts = np.array(pieces([traced.arc(i)])) + [-1e-12, 1e-12]  # an end may be lo or hi
        assert contains(parts[None], phi_ends[i][None])[0].all()
        for side in range(2):
            q = traced.q_ends[i, side]
            np.testing.assert_allclose(robot.fk(q), T[i], atol=1e-9)
            assert robot.within_limits(q)
            if traced.ends[i, side] == LIMIT:
                margin = np.minimum(q - robot.q_min, robot.q_max - q).min()
                assert margin <= 0.02 * 2.0**-16  # the bisection of a unit-speed step
                limits += 1
    assert limits >= 16


def test_intervals_from_arcs() -> None:
    cuts = np.array([-3.0, -1.0, 0.5, 2.0])
    # arcs [-3, -1] yes, [-1, 0.5] no, [0.5, 2] yes, [2, -3 + 2π] yes: one arc through ±π
    assert from_arcs(cuts, np.array([True, False, True, True])) == [(0.5, 2 * np.pi - 1.0)]
    assert from_arcs(cuts, np.ones(4, bool)) == [(-np.pi, np.pi)]
    assert from_arcs(cuts, np.zeros(4, bool)) == []
    assert pieces([(2.0, 4.0)]) == [(-np.pi, 4.0 - 2 * np.pi), (2.0, np.pi)]


SPEC = """
kind = "redundancy_map"
seed = 3
shard_size = 25
small_shards = true
[robot]
model = "{model}"
[redundancy_map]
poses = {poses}
method = "{method}"
manifolds = 2
"""


def test_sweep_closed_form(tmp_path: Path) -> None:
    (tmp_path / "r.toml").write_text(SPEC.format(model="iiwa14", poses=60, method="auto"))
    report = sweeps.run(tmp_path / "r.toml", tmp_path / "out", workers=1, progress=False)
    assert report.shards == 3
    m = sweeps.load_redundancy_map(tmp_path / "out")
    assert m.method == "closed_form" and m.done and m.intervals.shape == (60, 8, 8, 2)
    robot = rr.models.iiwa14()
    arm = SRSArm.from_robot(robot)
    q_true = m.extra["q_true"]
    np.testing.assert_allclose(np.array([robot.fk(q) for q in q_true]), m.pose, atol=1e-12)
    direct = arm.poses(m.pose).intervals(8)
    for key, stored in (("intervals", m.intervals), ("count", m.count), ("width", m.width),
                        ("union", m.union), ("total_width", m.total_width)):  # fmt: skip
        np.testing.assert_array_equal(stored, direct[key])
    assert m.reachable.all()  # each pose's own configuration is within the limits
    assert m.feasible(arm_angles(robot, q_true)).all()
    assert (m.total_width <= 2 * np.pi + 1e-12).all()
    assert (m.total_width >= m.width.max(axis=1) - 1e-12).all()
    again = sweeps.run(tmp_path / "r.toml", tmp_path / "out", workers=1, progress=False)
    assert again.computed == 0


def test_sweep_trace_panda(tmp_path: Path) -> None:
    (tmp_path / "r.toml").write_text(SPEC.format(model="panda", poses=6, method="trace"))
    sweeps.run(tmp_path / "r.toml", tmp_path / "out", workers=1, progress=False)
    m = sweeps.load_redundancy_map(tmp_path / "out")
    assert m.method == "trace" and m.intervals.shape == (6, 2, 8, 2)
    robot = rr.models.panda()
    assert m.feasible(arm_angles(robot, m.extra["q_true"])).all()
    assert ((m.extra["ends"] >= -1) & (m.extra["ends"] <= 3)).all()
    assert (m.width[:, 0] > 0).all()


def test_closed_form_refused_without_one() -> None:
    """``method = "closed_form"`` on an arm with neither closed form says why; ``auto``
    traces it."""
    from redres.sweeps.kinds.redundancy import RedundancyParams, _method

    links = [{"a": 0.1 * (j % 3), "alpha": 1.0 + 0.2 * j, "d": 0.2, "theta": 0.0,
              "joint": "revolute"} for j in range(7)]  # fmt: skip
    robot = rr.Robot.from_dh(links, convention="modified")
    points = ("link2", "link4", "link6")
    with pytest.raises(NotSRSError):
        _method(RedundancyParams(method="closed_form", points=points), robot, None)
    assert _method(RedundancyParams(method="auto", points=points), robot, None) == "trace"
    panda = rr.models.panda()
    assert _method(RedundancyParams(method="closed_form"), panda, None) == "closed_form_q7"
    assert _method(RedundancyParams(method="trace"), panda, None) == "trace"


def test_builtin_spec_listed() -> None:
    spec = sweeps.load_spec(sweeps.builtin_specs()["iiwa14_redundancy"])
    assert spec.kind == "redundancy_map" and spec.params.method == "closed_form"
    assert math.isclose(spec.params.reference[2], 1.0)


def test_two_workers_give_identical_bytes(tmp_path: Path) -> None:
    """The trace (IK seeds from each shard's generator, compiled kinematics) gives the same
    files in-process and on a pool of two workers."""
    digests = []
    for workers in (1, 2):
        folder = tmp_path / f"w{workers}"
        folder.mkdir()
        text = SPEC.format(model="panda", poses=6, method="trace").replace("= 25", "= 3")
        (folder / "r.toml").write_text(text)
        report = sweeps.run(folder / "r.toml", folder / "out", workers=workers, progress=False)
        assert report.shards == 2 and report.workers == workers
        digests.append(tree_digest(folder / "out"))
    assert digests[0] == digests[1]


def test_map_views(tmp_path: Path) -> None:
    """The HTML view draws a redundancy map's widths and a capability map's reachability
    index, with one slider step per slice plus the whole map."""
    import json
    import re

    from redres.cli import main
    from redres.report.sweep_page import map_figure

    from ..helpers import write_spec

    (tmp_path / "r.toml").write_text(SPEC.format(model="iiwa14", poses=30, method="auto"))
    page = tmp_path / "r.html"
    assert main(["sweep", str(tmp_path / "r.toml"), "--out", str(tmp_path / "r"), "--quiet",
                 "--html", str(page)]) == 0  # fmt: skip
    text = page.read_text()
    figure = json.loads(re.search(r'id="map-figure">(.*?)</script>', text,
                                  re.S).group(1))  # fmt: skip
    m = sweeps.load_redundancy_map(tmp_path / "r")
    whole = figure["data"][0]
    assert sorted(whole["marker"]["color"]) == sorted(np.round(m.total_width, 4).tolist())
    slices = figure["data"][1:]
    assert sum(len(t["x"]) for t in slices) == 30
    assert len(figure["layout"]["sliders"][0]["steps"]) == len(slices) + 1
    assert "Plotly.newPlot" in text

    cap = tmp_path / "cap"
    cap.mkdir()
    spec = write_spec(cap)
    sweeps.run(spec, cap / "out", workers=1, progress=False)
    figure = map_figure(cap / "out")
    cmap = sweeps.load_map(cap / "out")
    np.testing.assert_allclose(figure["data"][0]["marker"]["color"],
                               np.round(cmap.reachability_index, 4))  # fmt: skip
    levels = np.unique(cmap.centres[:, 2])
    assert len(figure["data"]) == len(levels) + 1


def test_grid_source(tmp_path: Path) -> None:
    """Poses from a capability map's grid: voxel centres x orientations; where the map
    gives an interval, the closed form's configuration at its middle is within the limits
    and places the frame at the pose; elsewhere no branch has an interval."""
    text = """
kind = "redundancy_map"
seed = 1
shard_size = 40
small_shards = true
[robot]
model = "iiwa14"
[redundancy_map]
source = "grid"
resolution = 0.15
bounds = [[0.3, 0.6], [-0.15, 0.15], [0.3, 0.6]]
directions = 6
fk_samples = 20000
"""
    (tmp_path / "g.toml").write_text(text)
    sweeps.run(tmp_path / "g.toml", tmp_path / "out", workers=1, progress=False)
    m = sweeps.load_redundancy_map(tmp_path / "out")
    assert len(m.pose) % 6 == 0 and len(m.pose) >= 6 and "q_true" not in m.extra
    assert m.reachable.any() and not m.reachable.all()
    robot = rr.models.iiwa14()
    poses = SRSArm.from_robot(robot).poses(m.pose)
    for i in range(len(m.pose)):
        assert m.reachable[i] == (m.count[i] > 0).any()
        for b in np.flatnonzero(m.count[i] > 0):
            lo, hi = m.intervals[i, b, 0]
            q = poses.joints(np.full((len(m.pose), 1), (lo + hi) / 2), int(b))[i, 0]
            assert robot.within_limits(q)
            np.testing.assert_allclose(robot.fk(q), m.pose[i], atol=1e-10)
