"""The link capsules in the 3D view of a robot that also has visual meshes: a second
moving mesh trace, hidden until its legend entry is clicked, posed frame by frame as
forward kinematics poses the capsules (the clearance is measured to them).

The Chromium test is skipped where Debian's chromium is not installed; how Chromium is run
is in ``tests/_chromium.py``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from _chromium import CHROMIUM

import redres as rr
from redres.control import Hold, RunLog
from redres.report import animation_figure, arm_animation, write_report
from redres.report.html import share_meshes
from redres.report.scene3d import capsule_mesh
from redres.report.view3d import MESH_DECIMALS
from redres.resolution import PseudoInverseScheme
from redres.tasks import FrameTask

#: The page rounds posed vertices to MESH_DECIMALS after posing local vertices rounded
#: the same: half a unit each, the first turned by the rotation (√3 at most).
ROUNDING = (1.0 + np.sqrt(3.0)) * 0.5 * 10.0**-MESH_DECIMALS + 1e-9


def _file_robot(fixtures_dir: Path, name: str) -> rr.Robot:
    path = fixtures_dir / name
    return rr.Robot.from_urdf(path) if name.endswith(".urdf") else rr.Robot.from_mjcf(path)


def _reach(robot: rr.Robot, offset: tuple[float, float, float]) -> RunLog:
    """The tip held at ``offset`` (m) from where it starts, 0.1 s: the arm moves."""
    q0 = np.array([0.4, 0.5, -0.7])
    target = robot.fk(q0)
    target[:3, 3] += offset
    return rr.run(robot, FrameTask(rows=[0, 1, 2]), Hold(target, 0.1), PseudoInverseScheme(),
                  q0=q0)  # fmt: skip


def _capsules_by_fk(robot: rr.Robot, q: np.ndarray) -> list[np.ndarray]:
    """Oracle: each link capsule's mesh in its link's frame, posed by Pinocchio's forward
    kinematics at ``q``, shape ``(V, 3)`` each, m."""
    out = []
    for cap in robot.capsules:
        local, _ = capsule_mesh(cap.a, cap.b, cap.radius, latitudes=6, longitudes=12)
        T = robot.fk(q, cap.frame)
        out.append(local @ T[:3, :3].T + T[:3, 3])
    return out


def _page_pose(rigid: list, k: int, f: int) -> np.ndarray:
    """The vertices the page script draws at frame ``f`` for entry ``k`` of ``rigid``: the
    local vertices under frame ``f``'s link poses (an earlier entry's, when ``poses`` is
    its index), rounded as the script rounds them."""
    spec = rigid[k]
    poses = rigid[spec["poses"]]["poses"] if isinstance(spec["poses"], int) else spec["poses"]
    local = np.column_stack([spec["x"], spec["y"], spec["z"]])
    world = local.copy()
    for start, count, link in spec["parts"]:
        if link >= 0:
            T = np.array(poses[f][link]).reshape(3, 4)
            world[start : start + count] = local[start : start + count] @ T[:, :3].T + T[:, 3]
    return np.round(world, spec["decimals"])


def _segment_distances(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance of each point to segment [a, b] (closed form, clamped projection)."""
    ab = b - a
    s = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
    return np.linalg.norm(a + s[:, None] * ab - points, axis=1)


@pytest.mark.parametrize("name", ["arm3.urdf", "arm3.xml"])
def test_file_robot_carries_its_link_capsules_hidden_and_posed_by_fk(
    fixtures_dir: Path, name: str
) -> None:
    robot = _file_robot(fixtures_dir, name)
    assert robot.visuals and len(robot.capsules) == 3
    log = _reach(robot, (0.0, 0.03, 0.03))
    anim = arm_animation(robot, log, frames=7)
    figure = json.loads(json.dumps(animation_figure(anim), allow_nan=False))
    names = [t["name"] for t in figure["data"]]
    meshes, capsules = figure["rigid"]  # one entry per moving mesh trace
    assert names[meshes["trace"]] == "robot meshes" and names[capsules["trace"]] == "link capsules"
    trace = figure["data"][capsules["trace"]]
    assert trace["visible"] == "legendonly" and trace["showlegend"] is True
    assert trace["type"] == "mesh3d" and trace["meta"]["kind"] == "robot"
    assert trace["uid"] == "link capsules"  # plotly keeps a legend click by uid across runs
    assert "visible" not in figure["data"][meshes["trace"]]  # the meshes are shown
    assert len(capsules["parts"]) == len(robot.capsules)
    assert capsules["poses"] == 0  # the same frames as the meshes: their poses, not a copy
    drawn = np.column_stack([trace["x"], trace["y"], trace["z"]])  # frame 0, as sent
    for f, k in enumerate(anim.steps):
        oracle = np.concatenate(_capsules_by_fk(robot, log.q[k]))
        posed = _page_pose(figure["rigid"], 1, f)
        np.testing.assert_allclose(posed, oracle, rtol=0, atol=ROUNDING)
        if f == 0:
            np.testing.assert_allclose(drawn, oracle, rtol=0, atol=0.5e-4 + 1e-9)
        # and on each capsule's surface, whatever mesh the oracle would build
        for (start, count, _), cap in zip(capsules["parts"], robot.capsules):
            T = robot.fk(log.q[k], cap.frame)
            a, b = T[:3, :3] @ cap.a + T[:3, 3], T[:3, :3] @ cap.b + T[:3, 3]
            d = _segment_distances(posed[start : start + count], a, b)
            np.testing.assert_allclose(d, cap.radius, rtol=0, atol=ROUNDING)
    first, last = (_page_pose(figure["rigid"], 1, f) for f in (0, len(anim.steps) - 1))
    assert np.abs(last - first).max() > 5e-3  # they move with the arm


def test_runs_of_a_file_robot_share_its_meshes_and_its_capsules(fixtures_dir: Path) -> None:
    robot = _file_robot(fixtures_dir, "arm3.urdf")
    log = _reach(robot, (0.0, 0.02, 0.0))
    figures = [animation_figure(arm_animation(robot, log, frames=f)) for f in (4, 6)]
    shared, slim = share_meshes(figures)
    assert len(shared) == 2  # the meshes and the capsules, each written once
    for fig, small in zip(figures, slim):
        assert [s["mesh"] for s in small["rigid"]] == [0, 1]
        for spec, entry in zip(fig["rigid"], small["rigid"]):
            mesh, trace = shared[entry["mesh"]], fig["data"][spec["trace"]]
            assert all(mesh[c] == spec[c] for c in "xyz") and "x" not in entry
            assert all(mesh[c] == trace[c] for c in "ijk")
            kept = small["data"][spec["trace"]]
            assert "i" not in kept and kept["x"] == trace["x"]  # frame 0 stays with the run
            assert kept.get("visible") == trace.get("visible")


def test_a_built_in_robot_still_shows_its_capsules_alone(runs: list) -> None:
    robot, log = runs[0]  # the Panda: link capsules, no visual meshes
    assert not robot.visuals
    figure = animation_figure(arm_animation(robot, log, frames=5))
    (spec,) = figure["rigid"]
    robot_traces = [t for t in figure["data"] if t.get("meta", {}).get("kind") == "robot"]
    assert [t["name"] for t in robot_traces] == ["link capsules"]
    assert figure["data"][spec["trace"]] is robot_traces[0]
    assert "visible" not in robot_traces[0]  # shown


def _box(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return points.min(axis=0), points.max(axis=0)


@pytest.mark.skipif(not CHROMIUM.exists(), reason="needs Debian's chromium at /usr/bin/chromium")
def test_chromium_shows_the_capsules_on_a_legend_click_and_moves_them(
    fixtures_dir: Path, tmp_path: Path
) -> None:
    """The legend entry is clicked with the mouse (DevTools ``Input.dispatchMouseEvent``);
    the page's own Play button takes the view to the last frame; the click holds in the
    robot's next run, whose traces a ball shifts by one."""
    from _chromium import LivePage

    from redres.objectives import SphereObstacle

    robot = _file_robot(fixtures_dir, "arm3.urdf")
    log = _reach(robot, (0.0, 0.03, 0.03))
    ball = SphereObstacle(robot.fk(log.q[-1])[:3, 3] + [0.1, 0.0, 0.0], 0.03, "ball")
    frames = 8
    page_file = write_report(tmp_path / "report", [(robot, log), (robot, log, [ball])],
                             title="Capsules", frames=frames)  # fmt: skip
    steps = arm_animation(robot, log, frames=frames).steps
    oracle = [np.concatenate(_capsules_by_fk(robot, log.q[k])) for k in steps]
    scene_js = 'JSON.parse(document.getElementById("arm-view").dataset.scene || "{}")'

    def capsules(page: LivePage) -> dict:  # type: ignore[type-arg]
        scene = page.evaluate(scene_js)
        assert isinstance(scene, dict)
        (found,) = [d for d in scene["drawn"] if d["name"] == "link capsules"]
        return {**found, "frame": scene["frame"]}

    def click(page: LivePage, element_js: str) -> None:
        """Scroll the element into view and click its centre with the mouse."""
        rect = page.evaluate(
            "(function () { var e = " + element_js + "; e.scrollIntoView("
            "{block: 'center'}); var r = e.getBoundingClientRect();"
            " return [r.left + r.width / 2, r.top + r.height / 2]; })()"
        )
        assert isinstance(rect, list), rect
        x, y = rect
        page.call("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y)
        for kind in ("mousePressed", "mouseReleased"):
            page.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left",
                      clickCount=1)  # fmt: skip

    legend = ('Array.from(document.querySelectorAll("#arm-view .legend .traces")).find('
              'function (g) { return g.textContent === "link capsules"; })'
              '.querySelector(".legendtoggle")')  # fmt: skip
    with LivePage(page_file.as_uri(), tmp_path / "profile", seconds=150.0,
                  size="1400,1000") as page:  # fmt: skip
        assert page.wait('document.getElementById("arm-view").dataset.status === "rendered"')
        before = capsules(page)
        assert before["visible"] == "legendonly" and before["frame"] == "0"
        assert before["vertices"] == len(oracle[0]) and before["type"] == "mesh3d"
        low, high = _box(oracle[0])
        np.testing.assert_allclose(before["min"], low, rtol=0, atol=ROUNDING)
        np.testing.assert_allclose(before["max"], high, rtol=0, atol=ROUNDING)

        click(page, legend)
        shown = f"{scene_js}.drawn.some(function (d) {{ return d.name === 'link capsules'"
        assert page.wait(f"{shown} && d.visible === true; }})", seconds=60.0)
        click(page, 'document.getElementById("play")')
        last = str(frames - 1)
        assert page.wait(f'{scene_js}.frame === "{last}"', seconds=60.0)
        after = capsules(page)
        assert after["visible"] is True and after["vertices"] == before["vertices"]
        moved = np.abs(np.array(after["min"] + after["max"]) - (before["min"] + before["max"]))
        assert moved.max() > 5e-3  # the box moved with the arm
        low, high = _box(oracle[-1])
        np.testing.assert_allclose(after["min"], low, rtol=0, atol=ROUNDING)
        np.testing.assert_allclose(after["max"], high, rtol=0, atol=ROUNDING)

        # every frame, through the slider's own call: what plotly holds is the oracle
        walk = """(async function () {
          var view = document.getElementById("arm-view"), out = [];
          var k = view.data.findIndex(function (t) { return t.name === "link capsules"; });
          for (const step of view.layout.sliders[0].steps) {
            await Plotly.animate(view, step.args[0], step.args[1]);
            var t = view.data[k];
            out.push([Array.from(t.x), Array.from(t.y), Array.from(t.z)]);
          }
          return out;
        })()"""
        answer = page.call("Runtime.evaluate", expression=walk, awaitPromise=True,
                           returnByValue=True)  # fmt: skip
        held = answer["result"]["result"]["value"]
        assert len(held) == frames
        for f, xyz in enumerate(held):
            np.testing.assert_allclose(np.array(xyz).T, oracle[f], rtol=0, atol=ROUNDING)
        page.evaluate('var s = document.getElementById("run-select"); s.value = "1";'
                      ' s.dispatchEvent(new Event("change"))')  # fmt: skip
        run1 = 'document.getElementById("arm-view").dataset.run === "1"'
        assert page.wait(f"{run1} && {shown} && d.visible === true; }})", seconds=60.0)
        problems = [m for m in page.console if m[0] in ("error", "exception", "assert", "warning")]
    assert problems == []
