"""Open a generated report in headless Chromium: no console errors, and the 3D view is
drawn with WebGL, obstacles at their place and size. Skipped where Debian's chromium is
not installed (CI installs it); how Chromium is run is in ``tests/_chromium.py``.
"""

from __future__ import annotations

import subprocess
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pytest
from _chromium import CHROMIUM, FLAGS, console_problems, dump_dom

import redres as rr
from redres.control import Circle, Hold, RunLog
from redres.objectives import JointLimitObjective
from redres.report import write_report
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.tasks import FrameTask

pytestmark = pytest.mark.skipif(
    not CHROMIUM.exists(), reason="needs Debian's chromium at /usr/bin/chromium"
)


class _Subtree(HTMLParser):
    """Tags and text inside the element with a given id."""

    def __init__(self, element_id: str) -> None:
        super().__init__()
        self.element_id = element_id
        self.depth = 0
        self.attrs: dict[str, str] = {}
        self.tags: list[str] = []
        self.text: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        values = {k: v or "" for k, v in attrs}
        if self.depth:
            self.tags.append(tag)
            if tag not in ("br", "img", "input", "meta", "link", "hr"):
                self.depth += 1
        elif values.get("id") == self.element_id:
            self.attrs, self.depth = values, 1

    def handle_endtag(self, tag: str) -> None:
        if self.depth and tag not in ("br", "img", "input", "meta", "link", "hr"):
            self.depth -= 1

    def handle_data(self, data: str) -> None:
        if self.depth:
            self.text.append(data)


def _runs() -> list[tuple[rr.Robot, RunLog]]:
    panda, iiwa = rr.models.panda(), rr.models.iiwa14()
    circle = Circle(panda.fk(panda.neutral()), 0.02, 0.1)
    scheme = GradientProjectionScheme([JointLimitObjective()])
    target = iiwa.fk(iiwa.neutral())
    target[:3, 3] += 0.02
    return [
        (panda, rr.run(panda, FrameTask(), circle, PseudoInverseScheme())),
        (panda, rr.run(panda, FrameTask(), circle, scheme)),
        (iiwa, rr.run(iiwa, FrameTask(), Hold(target, 0.1), PseudoInverseScheme())),
    ]


def test_report_renders_in_chromium(tmp_path: Path) -> None:
    runs = _runs()
    page = write_report(tmp_path / "report", runs, title="Browser check", frames=20)
    last = len(runs) - 1
    proc = subprocess.run(
        [
            str(CHROMIUM),
            *FLAGS,
            f"--user-data-dir={tmp_path / 'profile'}",
            "--dump-dom",
            f"{page.as_uri()}#run-{last}",
        ],
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert console_problems(proc.stderr) == []
    view = _Subtree("arm-view")
    view.feed(proc.stdout)
    assert view.attrs.get("data-status") == "rendered"  # Plotly.react resolved
    assert view.attrs.get("data-run") == str(last)  # the #run-N link picked the run
    assert "canvas" in view.tags  # the WebGL scene ...
    text = " ".join(view.text)
    assert "WebGL is not supported" not in text  # ... and plotly did not give up on it
    assert "t = " in text  # the time slider is drawn
    assert proc.stdout.count('<img alt="') == 7  # every plot is in the page


def _rendered_scene(page: Path, tmp_path: Path) -> tuple[dict, str]:
    """The 3D view's ``data-scene`` as Chromium rendered ``page`` (no console problem),
    and the page's DOM."""
    import json

    proc = dump_dom(page.as_uri(), tmp_path / "profile")
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert console_problems(proc.stderr) == []
    view = _Subtree("arm-view")
    view.feed(proc.stdout)
    assert view.attrs.get("data-status") == "rendered"
    return json.loads(view.attrs["data-scene"]), proc.stdout


def test_report_draws_the_obstacles_at_their_place_and_size(tmp_path: Path) -> None:
    from redres.objectives import CapsuleObstacle, ObstacleObjective, SphereObstacle

    panda = rr.models.panda()
    ball = SphereObstacle([0.35, 0.25, 0.45], 0.07, "ball")
    pole = CapsuleObstacle([0.45, -0.3, 0.1], [0.45, -0.3, 0.7], 0.04, "pole")
    circle = Circle(panda.fk(panda.neutral()), 0.02, 0.1)
    log = rr.run(panda, FrameTask(), circle, PseudoInverseScheme(),
                 log_objectives=[ObstacleObjective([ball, pole])])  # fmt: skip
    page = write_report(tmp_path / "report", [(panda, log, [ball, pole])], title="Obstacles")
    scene, html = _rendered_scene(page, tmp_path)
    drawn = {o["name"]: o for o in scene["drawn"] if o["kind"] == "obstacle"}
    assert set(drawn) == {"ball", "pole"}
    # What plotly holds for each mesh spans exactly the true body (oracle: the inputs).
    low, high = np.array(drawn["ball"]["min"]), np.array(drawn["ball"]["max"])
    np.testing.assert_allclose((low + high) / 2, ball.center, atol=2e-5)
    np.testing.assert_allclose((high - low) / 2, ball.radius, atol=2e-5)
    low, high = np.array(drawn["pole"]["min"]), np.array(drawn["pole"]["max"])
    np.testing.assert_allclose(low, np.minimum(pole.a, pole.b) - pole.radius, atol=2e-5)
    np.testing.assert_allclose(high, np.maximum(pole.a, pole.b) + pole.radius, atol=2e-5)
    assert drawn["ball"]["type"] == drawn["pole"]["type"] == "mesh3d"
    assert "min obstacle clearance" in html  # the table's column


def test_report_of_a_urdf_robot_draws_its_meshes(tmp_path: Path, fixtures_dir: Path) -> None:
    robot = rr.Robot.from_urdf(fixtures_dir / "arm3.urdf")
    assert len(robot.visuals) == 4  # base plate, cylinder, box and the STL mesh
    q0 = np.array([0.4, 0.5, -0.7])
    target = robot.fk(q0)
    target[:3, 3] += [0.0, 0.01, 0.01]
    log = rr.run(robot, FrameTask(rows=[0, 1, 2]), Hold(target, 0.05), PseudoInverseScheme(),
                 q0=q0)  # fmt: skip
    page = write_report(tmp_path / "report", [(robot, log)], title="Meshes", frames=10)
    scene, _ = _rendered_scene(page, tmp_path)
    meshes, capsules = [d for d in scene["drawn"] if d["kind"] == "robot"]
    assert meshes["name"] == "robot meshes" and meshes["type"] == "mesh3d"
    assert meshes["visible"] is True and capsules["visible"] == "legendonly"
    # oracle: the visual meshes placed by forward kinematics at the run's first step
    world = []
    for mesh in robot.visuals:
        T = np.eye(4) if mesh.frame is None else robot.fk(log.q[0], mesh.frame)
        world.append(mesh.vertices @ T[:3, :3].T + T[:3, 3])
    every = np.concatenate(world)
    assert meshes["vertices"] == len(every)
    np.testing.assert_allclose(meshes["min"], every.min(axis=0), atol=2e-4)
    np.testing.assert_allclose(meshes["max"], every.max(axis=0), atol=2e-4)
    assert scene["moving"] == scene["frames"] == 10  # every frame poses them


def test_report_draws_boxes_planes_and_the_collision_pairs(tmp_path: Path) -> None:
    """A constrained QP run into a box, with a floor: Chromium draws the box at its corners,
    the floor's square on its plane and the pairs' two traces, without a console error."""
    pytest.importorskip("daqp")
    from redres.collision import BoxObstacle, Collisions, PlaneObstacle
    from redres.control import Line
    from redres.control.analysis import collision_clearance
    from redres.resolution import QPScheme

    panda = rr.models.panda()
    start = panda.fk(panda.neutral())
    box = BoxObstacle(start[:3, 3] - [0.0, 0.0, 0.18], [0.15, 0.2, 0.08], name="box")
    floor = PlaneObstacle([0.0, 0.0, 1.0], -0.2, name="floor")
    settings = Collisions([box, floor])
    line = Line(start, start[:3, 3] - [0.0, 0.0, 0.15], 0.3)
    log = rr.run(panda, FrameTask(), line, QPScheme(dt=5e-3, collisions=settings), dt=5e-3,
                 gain=20.0)  # fmt: skip
    record = collision_clearance(log, panda, settings)
    page = write_report(tmp_path / "report", [(panda, log, [box, floor])], title="Pairs")
    scene, _ = _rendered_scene(page, tmp_path)
    drawn = {o["name"]: o for o in scene["drawn"] if o["kind"] == "obstacle"}
    assert (drawn["box"]["shape"], drawn["floor"]["shape"]) == ("box", "plane")
    np.testing.assert_allclose(drawn["box"]["min"], box.center - box.half_extents, atol=2e-5)
    np.testing.assert_allclose(drawn["box"]["max"], box.center + box.half_extents, atol=2e-5)
    assert drawn["floor"]["min"][2] == pytest.approx(-0.2) == drawn["floor"]["max"][2]
    pairs = [o for o in scene["drawn"] if o["kind"] == "pairs"]
    assert [o["name"] for o in pairs] == ["collision pairs within d_i", "binding collision pairs"]
    # frame 0: each pair within d_i at step 0 is one segment (two points and a gap)
    assert pairs[0]["vertices"] == 3 * (record.at(0).stop - record.at(0).start) > 0
