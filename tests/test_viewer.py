"""The live viewer (viser): a loop pushes configurations without waiting, the latest one
reaches the scene, and headless Chromium renders the page without console errors with
the pushed configuration in it. Skipped without viser (the ``viewer`` extra) or, for the
browser check, without Debian's chromium."""

from __future__ import annotations

import re
import socket
import time
from pathlib import Path

import numpy as np
import pytest

import redres as rr
from redres.objectives import CapsuleObstacle, SphereObstacle

viser = pytest.importorskip("viser")

CHROMIUM = Path("/usr/bin/chromium")

#: What viser's page logs on a healthy start (its own console.log lines, and a deprecation
#: note of the three.js it bundles); any other message, and any error, fails the test.
VISER_INFO = (
    "Detected chrome version",
    "WebGL support: true",
    "Connecting to: ws://",
    "Connected! ws://",
    "THREE.Clock: This module has been deprecated",
)


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _wait(predicate, seconds: float = 5.0) -> bool:  # type: ignore[no-untyped-def]
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.02)
    return False


@pytest.fixture
def viewer():  # type: ignore[no-untyped-def]
    from redres.viewer import Viewer

    panda = rr.models.panda()
    obstacles = [SphereObstacle([0.4, 0.2, 0.4], 0.06, "ball"),
                 CapsuleObstacle([0.5, -0.3, 0.0], [0.5, -0.3, 0.6], 0.03, "pole")]  # fmt: skip
    v = Viewer(panda, obstacles=obstacles, port=_free_port(), rate=50.0)
    yield v
    v.close()


def test_the_latest_push_reaches_the_scene_and_the_rest_are_dropped(viewer) -> None:  # type: ignore[no-untyped-def]
    robot = viewer.robot
    rng = np.random.default_rng(3)
    sent = []
    original = viewer._send

    def counting(q, target):  # type: ignore[no-untyped-def]
        sent.append(q.copy())
        original(q, target)

    viewer._send = counting
    qs = [robot.random_configuration(rng) for _ in range(2000)]
    for q in qs:
        viewer.push(q)  # a 1 kHz loop would call this every step
    assert _wait(lambda: viewer.shown is not None and np.array_equal(viewer.shown, qs[-1]))
    assert len(sent) < len(qs) / 10  # dropped, not queued
    assert viewer.geometry == "capsules"


@pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium")
def test_chromium_renders_the_viewer_with_the_pushed_configuration(
    viewer,
    tmp_path: Path,  # type: ignore[no-untyped-def]
) -> None:
    from _chromium import live_page

    q = viewer.robot.neutral() + np.array([0.1, -0.2, 0.3, 0.1, -0.1, 0.2, 0.05])
    viewer.push(q)
    assert _wait(lambda: viewer.shown is not None and np.array_equal(viewer.shown, q))
    done = 'document.body.innerText.includes("q = [") && document.querySelector("canvas")'
    text, console = live_page(viewer.url, tmp_path / "profile", done, seconds=90.0)
    shown = re.search(r"q = \[([^\]]*)\]", text)
    assert shown is not None, text[-2000:]
    np.testing.assert_allclose([float(x) for x in shown.group(1).split(",")], q, atol=1e-4)
    assert [m for m in console if m[0] in ("error", "exception", "assert")] == []
    assert [m for m in console if not m[1].startswith(VISER_INFO)] == []  # nothing else
    assert any("contextCreationFailed: false" in m[1] for m in console)  # WebGL is up


def _shown_q(text: str) -> np.ndarray | None:
    """The configuration the page's side panel shows (``q = [...]``)."""
    found = re.search(r"q = \[([^\]]*)\]", text)
    return None if found is None else np.array([float(x) for x in found.group(1).split(",")])


def _circle_run(robot: rr.Robot, **kwargs):  # type: ignore[no-untyped-def]
    from redres.control import Circle
    from redres.resolution import PseudoInverseScheme
    from redres.tasks import FrameTask

    circle = Circle(robot.fk(robot.neutral()), 0.05, 1.0, ramp=0.2)
    return rr.run(robot, FrameTask(), circle, PseudoInverseScheme(damping=0.01), **kwargs)


def test_rr_run_pushes_its_configurations_to_a_viewer_at_its_rate(viewer) -> None:  # type: ignore[no-untyped-def]
    from redres.control import final_configuration

    pushed: list[tuple[float, np.ndarray]] = []
    original = viewer.push

    def recording(q, target=None):  # type: ignore[no-untyped-def]
        pushed.append((time.perf_counter(), np.array(q)))
        original(q, target)

    viewer.push = recording
    started = time.perf_counter()
    log = _circle_run(viewer.robot, viewer=viewer)
    wall = time.perf_counter() - started
    final = final_configuration(log)
    assert len(pushed) >= 2 and np.array_equal(pushed[-1][1], final)  # the last one, always
    after_steps = np.vstack([log.q[1:], final])  # the configuration after each step
    for _, q in pushed:  # each push is one of the run's configurations, as it computed
        assert (after_steps == q).all(axis=1).any()
    # at most `rate` a second while it computes (plus the last one), never one per step
    assert len(pushed) <= wall * viewer.rate + 2 < log.steps
    gaps = np.diff([t for t, _ in pushed[:-1]])  # a period, less one step's own time
    assert gaps.size == 0 or gaps.min() >= 0.5 / viewer.rate
    assert _wait(lambda: viewer.shown is not None and np.array_equal(viewer.shown, final))


def test_rr_run_refuses_what_is_not_a_viewer_of_its_robot(viewer) -> None:  # type: ignore[no-untyped-def]
    from redres.errors import InvalidParameterError

    with pytest.raises(InvalidParameterError, match="must be a redres.viewer.Viewer"):
        _circle_run(viewer.robot, viewer="yes")
    with pytest.raises(InvalidParameterError, match="7 joints.*has 3"):
        from redres.resolution import PseudoInverseScheme
        from redres.tasks import FrameTask

        rr.run(rr.models.planar([1.0, 1.0, 1.0]), FrameTask(rows=[0, 1]), None,
               PseudoInverseScheme(), duration=0.01, viewer=viewer)  # fmt: skip


def test_a_run_shown_live_is_then_scrubbed() -> None:
    from redres.control import final_configuration

    robot = rr.models.panda()
    opened = rr.view(robot)
    try:
        log = _circle_run(robot, viewer=opened, duration=0.2)
        opened.show_runs([log])
        assert len(opened._runs) == 1 and opened._runs[0] is log
        # the run pushed its last configuration, then show_runs put the slider at t = 0
        assert _wait(lambda: opened.shown is not None and np.array_equal(opened.shown, log.q[0]))
        assert not np.array_equal(log.q[0], final_configuration(log))
    finally:
        opened.close()


def _link_positions(viewer) -> dict[str, np.ndarray]:  # type: ignore[no-untyped-def]
    return {frame: np.array(h.position) for frame, h in viewer._links.items()}


def _fk_positions(viewer, q: np.ndarray) -> dict[str, np.ndarray]:  # type: ignore[no-untyped-def]
    return {frame: viewer.robot.fk(q, frame)[:3, 3] for frame in viewer._links}


@pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium")
def test_chromium_scrubs_a_finished_run_with_the_slider(viewer, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from _chromium import LivePage

    log = _circle_run(viewer.robot, dt=0.01)  # 0.01 s steps: the slider's 1 ms is finer
    viewer.show_runs([log])
    slider = viewer._slider
    assert slider.max == pytest.approx(log.t[-1])

    def shows(page: LivePage, k: int) -> bool:
        """The page shows step k's configuration and the scene's links are at its pose."""
        q = _shown_q(page.text)
        if q is None or not np.allclose(q, log.q[k], atol=1e-4):
            return False
        links, expected = _link_positions(viewer), _fk_positions(viewer, log.q[k])
        return all(np.allclose(links[f], expected[f], atol=1e-6) for f in links)

    def settle(page: LivePage, k: int) -> bool:
        return _wait(lambda: shows(page, k), seconds=20.0)

    with LivePage(viewer.url, tmp_path / "profile", seconds=120.0) as page:
        ready = (
            'document.querySelector("[role=slider]") && document.body.innerText.includes("q = [")'
        )
        assert page.wait(ready), page.text[-2000:]
        assert settle(page, 0)  # show_runs starts at t = 0
        page.evaluate('document.querySelector("[role=slider]").focus()')
        page.press("End")  # the browser moves the slider; viser tells Python
        assert _wait(lambda: slider.value == pytest.approx(log.t[-1]), seconds=20.0)
        assert settle(page, log.steps - 1)
        for _ in range(30):  # 30 slider steps of 1 ms back: three steps of the run
            page.press("ArrowLeft")
        assert _wait(lambda: slider.value == pytest.approx(log.t[-1] - 0.030), seconds=20.0)
        k = round(slider.value / log.dt)
        assert k not in (0, log.steps - 1) and not np.allclose(log.q[k], log.q[-1], atol=1e-3)
        assert settle(page, k)
        page.press("Home")
        assert _wait(lambda: slider.value == 0.0, seconds=20.0)
        assert settle(page, 0)
        problems = [m for m in page.console if m[0] in ("error", "exception", "assert")]
    assert problems == []


def test_a_moving_obstacle_is_drawn_where_the_loop_says(viewer) -> None:  # type: ignore[no-untyped-def]
    """`push(q, obstacles=...)` moves the obstacles' scene nodes (the gallery's approaching
    ball, watched live); a capsule of a new shape is drawn anew; a wrong count is refused."""
    q = viewer.robot.neutral()
    ball = SphereObstacle([0.4, 0.0, 0.5], 0.06, "ball")
    pole = CapsuleObstacle([0.2, -0.3, 0.0], [0.2, -0.3, 0.8], 0.03, "pole")
    viewer.push(q, obstacles=[ball, pole])
    node_ball, node_pole = viewer._obstacle_nodes
    # the side panel's line is written last: once it names the new place, all is placed
    assert _wait(lambda: "ball at (0.4000, 0.0000, 0.5000)" in viewer._obstacle_status.content)
    np.testing.assert_allclose(node_ball.position, ball.center)
    np.testing.assert_allclose(node_pole.position, pole.a)
    np.testing.assert_allclose(viewer._obstacle_shapes[1], [0.0, 0.0, 0.8, 0.03])
    with pytest.raises(rr.errors.InvalidParameterError, match="draws 2 obstacles"):
        viewer.push(q, obstacles=[ball])


@pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium")
def test_chromium_shows_the_obstacle_where_it_was_pushed(viewer, tmp_path: Path) -> None:  # type: ignore[no-untyped-def]
    from _chromium import live_page

    pole = CapsuleObstacle([0.5, -0.3, 0.0], [0.5, -0.3, 0.6], 0.03, "pole")
    ball = SphereObstacle([0.35, -0.05, 0.45], 0.06, "ball")
    viewer.push(viewer.robot.neutral(), obstacles=[ball, pole])
    assert _wait(lambda: np.allclose(viewer._obstacle_nodes[0].position, ball.center))
    done = 'document.body.innerText.includes("ball at (0.3500") && document.querySelector("canvas")'
    text, console = live_page(viewer.url, tmp_path / "profile", done, seconds=90.0)
    assert "ball at (0.3500, -0.0500, 0.4500)" in text, text[-2000:]
    assert [m for m in console if m[0] in ("error", "exception", "assert")] == []


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"port": 70000}, "port must be an integer from 0 to 65535; got 70000"),
        ({"port": "8080"}, "port must be an integer"),
        ({"host": "no.such.host.invalid"}, "host 'no.such.host.invalid' is not an address"),
        ({"host": 5}, "host must be a host name or address"),
        ({"rate": 1e-300}, "rate must be >= 0.01"),
        ({"rate": 1e9}, "rate must be <= 1000"),
    ],
)
def test_an_address_or_rate_the_server_cannot_use_is_refused_at_once(
    options: dict, message: str
) -> None:
    """viser's server thread failed on these and left the caller waiting for good (a bad
    port or host), or the sender thread died on its first wait (a rate of 1e-300)."""
    from redres.viewer import Viewer

    with pytest.raises(rr.errors.InvalidParameterError, match=message):
        Viewer(rr.models.panda(), **options)


def test_a_malformed_push_is_refused_in_the_caller_not_in_the_sender(viewer) -> None:  # type: ignore[no-untyped-def]
    for bad, error in ((np.eye(3), rr.errors.ShapeError), ([np.nan] * 3, rr.errors.NonFiniteError)):
        with pytest.raises(error, match="target"):
            viewer.push(viewer.robot.neutral(), target=bad)
    q = viewer.robot.neutral() + 0.1
    viewer.push(q, target=np.eye(4))  # the sender is still alive: this one arrives
    assert _wait(lambda: viewer.shown is not None and np.allclose(viewer.shown, q))


def test_boxes_planes_and_the_pairs_within_d_i_are_drawn() -> None:
    """A box and a half-space get nodes at their place and meshes of their size; with
    ``collisions=`` the pairs closer than ``d_i`` at the pushed configuration are drawn
    as segments between witness points, counted in the side panel (checked against a
    collision model of the viewer's own)."""
    from redres.collision import BoxObstacle, CollisionModel, Collisions, PlaneObstacle
    from redres.viewer import Viewer

    panda = rr.models.panda()
    hand = panda.fk(panda.neutral())[:3, 3]
    box = BoxObstacle(hand - [0.0, 0.0, 0.18], [0.15, 0.2, 0.08], name="box")
    floor = PlaneObstacle([0.0, 0.0, 1.0], -0.2, name="floor")
    settings = Collisions([box, floor])
    v = Viewer(panda, obstacles=[box, floor], collisions=settings, port=_free_port(), rate=50.0)
    try:
        np.testing.assert_allclose(v._obstacle_nodes[0].position, box.center)
        np.testing.assert_allclose(v._obstacle_nodes[1].position, [0.0, 0.0, -0.2])
        corners = np.asarray(v._obstacle_meshes[0].vertices) + box.center
        np.testing.assert_allclose(np.abs(corners - box.center).max(axis=0), box.half_extents,
                                   atol=1e-6)  # fmt: skip
        floor_z = np.asarray(v._obstacle_meshes[1].vertices)[:, 2] - 0.2
        np.testing.assert_allclose(floor_z, -0.2, atol=1e-6)
        rng = np.random.default_rng(7)
        model = CollisionModel(panda, [box, floor], safety=settings.safety)
        for q in (panda.neutral(), panda.neutral() + rng.normal(0.0, 0.05, 7)):
            q = np.clip(q, panda.q_min, panda.q_max)
            expected = int(np.sum(model.distances(q) < settings.influence))
            v.push(q)
            assert _wait(lambda q=q: v.shown is not None and np.array_equal(v.shown, q))
            assert v._pair_status.content.startswith(f"pairs within d_i: {expected}, binding: 0")
            assert expected > 0
            node = v._pair_nodes["free"]
            assert node.visible and np.asarray(node.points).shape == (expected, 2, 3)
        v._pair_toggle.value = False  # the checkbox hides them at once
        assert _wait(lambda: not v._pair_nodes["free"].visible)
        v._pair_toggle.value = True
        assert _wait(lambda: v._pair_nodes["free"].visible)
    finally:
        v.close()
    with pytest.raises(rr.errors.InvalidParameterError, match="collisions must be"):
        Viewer(panda, collisions=[box], port=_free_port())
    with pytest.raises(rr.errors.InvalidParameterError, match="obstacles must be"):
        Viewer(panda, obstacles=["table"], port=_free_port())  # type: ignore[list-item]


def test_a_scrubbed_run_shows_its_binding_pairs() -> None:
    """``show_runs`` of a run that recorded its pairs (a constrained QP run into a box):
    at a step where a row bound, the binding node holds that step's binding segments."""
    pytest.importorskip("daqp")
    from redres.collision import BoxObstacle, Collisions
    from redres.control import Line
    from redres.control.analysis import collision_clearance
    from redres.resolution import QPScheme
    from redres.tasks import FrameTask
    from redres.viewer import Viewer

    panda = rr.models.panda()
    start = panda.fk(panda.neutral())
    box = BoxObstacle(start[:3, 3] - [0.0, 0.0, 0.18], [0.15, 0.2, 0.08], name="box")
    settings = Collisions([box])
    dt = 5e-3
    line = Line(start, start[:3, 3] - [0.0, 0.0, 0.15], 0.3)
    log = rr.run(panda, FrameTask(), line, QPScheme(dt=dt, collisions=settings), dt=dt, gain=20.0)
    record = collision_clearance(log, panda, settings)
    k = int(record.step[record.binding][-1])
    rows = record.at(k)
    bound = np.stack([record.point_a[rows], record.point_b[rows]], axis=1)[record.binding[rows]]
    v = Viewer(panda, obstacles=[box], port=_free_port(), rate=50.0)
    try:
        v.show_runs([log])
        v._slider.value = float(log.t[k])
        node = v._pair_nodes["bound"]
        assert _wait(lambda: v.shown is not None and np.array_equal(v.shown, log.q[k]))
        assert _wait(lambda: node.visible)
        np.testing.assert_allclose(np.asarray(node.points), bound, atol=1e-6)
        assert f"binding: {len(bound)}" in v._pair_status.content
    finally:
        v.close()


@pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium")
def test_chromium_shows_boxes_planes_and_pairs(tmp_path: Path) -> None:
    """The page renders a box, a half-space and the pair segments without a console error,
    and its side panel counts the pairs."""
    from _chromium import live_page

    from redres.collision import BoxObstacle, Collisions, PlaneObstacle
    from redres.viewer import Viewer

    panda = rr.models.panda()
    box = BoxObstacle(panda.fk(panda.neutral())[:3, 3] - [0.0, 0.0, 0.18], [0.15, 0.2, 0.08],
                      name="box")  # fmt: skip
    floor = PlaneObstacle([0.0, 0.0, 1.0], -0.2, name="floor")
    v = Viewer(panda, obstacles=[box, floor], collisions=Collisions([box, floor]),
               port=_free_port(), rate=50.0)  # fmt: skip
    try:
        assert _wait(lambda: v._pair_status.content.startswith("pairs within d_i: "))
        done = 'document.querySelector("canvas") && document.body.innerText.includes("pairs wi")'
        text, console = live_page(v.url, tmp_path / "profile", done, seconds=90.0)
    finally:
        v.close()
    assert "pairs within d_i" in text and "box at (" in text, text[-2000:]
    assert [m for m in console if m[0] in ("error", "exception", "assert")] == []
