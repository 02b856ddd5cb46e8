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
