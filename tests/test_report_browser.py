"""Open a generated report in headless Chromium: no console errors, and the 3D view is
drawn with WebGL. Skipped where Debian's chromium is not installed (CI installs it).

Chromium runs with the page's virtual time (``--virtual-time-budget``) so the scripts
finish before the DOM is dumped. WebGL needs a GPU or SwiftShader: with ``--disable-gpu``
recent Chromium only falls back to SwiftShader given ``--enable-unsafe-swiftshader``
(trusted local content). Every console message counts as a failure, except Chromium's
own performance advice listed in ``BENIGN``.
"""

from __future__ import annotations

import re
import subprocess
from html.parser import HTMLParser
from pathlib import Path

import pytest

import redres as rr
from redres.control import Circle, Hold, RunLog
from redres.objectives import JointLimitObjective
from redres.report import write_report
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme
from redres.tasks import FrameTask

CHROMIUM = Path("/usr/bin/chromium")

pytestmark = pytest.mark.skipif(
    not CHROMIUM.exists(), reason="needs Debian's chromium at /usr/bin/chromium"
)

FLAGS = (
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--enable-unsafe-swiftshader",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--no-first-run",
    "--enable-logging=stderr",
    "--v=0",
    "--virtual-time-budget=10000",
    "--window-size=1400,1800",
)

# Chromium's console line: [pid:tid:time:INFO:CONSOLE:line] "message", source: url (line)
# (older builds: ...:INFO:CONSOLE(line)] "message", source: ...).
CONSOLE = re.compile(r':CONSOLE(?::\d+|\(\d+\))\] "(?P<message>.*)", source: (?P<source>\S*)')
BENIGN = (
    "GPU stall due to ReadPixels",  # SwiftShader performance note when plotly reads pixels
    "willReadFrequently",  # Canvas2D advice on getImageData, from plotly's text sizing
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


def _console_problems(stderr: str) -> list[str]:
    messages = [m.group("message") for m in CONSOLE.finditer(stderr)]
    problems = [m for m in messages if not any(b in m for b in BENIGN)]
    problems += [line for line in stderr.splitlines() if "Uncaught" in line]
    return problems


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
    assert _console_problems(proc.stderr) == []
    view = _Subtree("arm-view")
    view.feed(proc.stdout)
    assert view.attrs.get("data-status") == "rendered"  # Plotly.react resolved
    assert view.attrs.get("data-run") == str(last)  # the #run-N link picked the run
    assert "canvas" in view.tags  # the WebGL scene ...
    text = " ".join(view.text)
    assert "WebGL is not supported" not in text  # ... and plotly did not give up on it
    assert "t = " in text  # the time slider is drawn
    assert proc.stdout.count('<img alt="') == 7  # every plot is in the page
