"""Make the screenshots of docs/img (run from the repository root, Debian's chromium and
the viewer extra installed): the report of the Panda circle with a ball and a pole, and
the live viewer showing the same runs.

    python docs/img/screenshots.py
"""

from __future__ import annotations

import io
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from PIL import Image

import redres as rr
from redres.objectives import CapsuleObstacle
from redres.report import write_report
from redres.scenarios.runner import run_scenario
from redres.scenarios.spec import builtin

HERE = Path(__file__).resolve().parent
CHROMIUM = "/usr/bin/chromium"
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--enable-unsafe-swiftshader",
         "--hide-scrollbars", "--disable-background-networking", "--no-first-run",
         "--disable-component-update", "--disable-sync"]  # fmt: skip


def shoot(url: str, out: Path, size: str, wait: str) -> None:
    """Screenshot ``url``; ``wait`` is ``--virtual-time-budget=MS`` for a page that settles,
    ``--timeout=MS`` (real time) for one that keeps a websocket open (the viewer)."""
    with tempfile.TemporaryDirectory() as profile:
        raw = Path(profile) / "shot.png"
        subprocess.run([CHROMIUM, *FLAGS, f"--user-data-dir={profile}", f"--window-size={size}",
                        wait, f"--screenshot={raw}", url],
                       check=True, capture_output=True, timeout=150)  # fmt: skip
        save(raw, out)


def shoot_live(url: str, out: Path, seconds: float = 12.0) -> None:
    """Screenshot a page that keeps a websocket open (the viewer), in real time, through
    Chromium's DevTools protocol (``--screenshot`` waits for it to settle, forever)."""
    import base64
    import json
    import urllib.request

    from websockets.sync.client import connect

    with tempfile.TemporaryDirectory(ignore_cleanup_errors=True) as profile:
        chromium = subprocess.Popen([CHROMIUM, *FLAGS, f"--user-data-dir={profile}",
                                     "--window-size=1280,800", "--remote-debugging-port=9333",
                                     "about:blank"], stdout=subprocess.DEVNULL,
                                    stderr=subprocess.DEVNULL)  # fmt: skip
        try:
            for _ in range(100):
                try:
                    tabs = json.load(urllib.request.urlopen("http://127.0.0.1:9333/json"))
                    break
                except OSError:
                    time.sleep(0.2)
            page = next(t for t in tabs if t["type"] == "page")["webSocketDebuggerUrl"]
            with connect(page, max_size=None) as ws:

                def call(i: int, method: str, **params: Any) -> Any:
                    ws.send(json.dumps({"id": i, "method": method, "params": params}))
                    while True:
                        message = json.loads(ws.recv())
                        if message.get("id") == i:
                            return message

                call(1, "Page.navigate", url=url)
                time.sleep(seconds)
                shot = call(2, "Page.captureScreenshot", format="png")
            raw = Path(profile) / "shot.png"
            raw.write_bytes(base64.b64decode(shot["result"]["data"]))
            save(raw, out)
        finally:
            chromium.kill()
            chromium.wait()


def save(raw: Path, out: Path) -> None:
    """``raw`` scaled to 3/4 and quantised to 128 colours (a small PNG), into ``out``."""
    image = Image.open(raw).convert("RGB")
    image = image.resize((image.width * 3 // 4, image.height * 3 // 4), Image.LANCZOS)
    buffer = io.BytesIO()
    image.quantize(colors=128, method=Image.Quantize.MEDIANCUT).save(buffer, "PNG", optimize=True)
    out.write_bytes(buffer.getvalue())
    print(out, f"{len(buffer.getvalue()) / 1e3:.0f} kB")


def main() -> None:
    spec = builtin("panda_joint_limit_circle")
    spec.duration = 4.0
    spec.obstacles.append(CapsuleObstacle([0.55, -0.25, 0.0], [0.55, -0.25, 0.7], 0.04, "pole"))
    spec.schemes = [s for s in spec.schemes if s.kind in ("pinv", "gradient_projection")]
    logs = run_scenario(spec, progress=False)
    if "--viewer-only" not in sys.argv:
        report(spec, logs)
    viewer = rr.Viewer(spec.robot, obstacles=spec.obstacles, port=8765)
    viewer.show_runs(logs)
    time.sleep(1.0)
    viewer.push(logs[-1].q[2500], logs[-1].target[2500])
    time.sleep(0.5)
    shoot_live(viewer.url, HERE / "viewer.png")
    viewer.close()


def report(spec: Any, logs: list[Any]) -> None:
    with tempfile.TemporaryDirectory() as folder:
        runs = [(spec.robot, log, spec.obstacles) for log in logs]
        page = write_report(Path(folder) / "report", runs, title="Panda circle, a ball and a pole")
        shoot(f"{page.as_uri()}#run-3", HERE / "report-obstacles.png", "1400,1500",
              "--virtual-time-budget=10000")  # fmt: skip


if __name__ == "__main__":
    main()
