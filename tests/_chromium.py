"""Headless Chromium for the browser tests (Debian's chromium; the CI installs it).

Chromium runs with the page's virtual time (``--virtual-time-budget``) so the scripts
finish before the DOM is dumped. WebGL needs a GPU or SwiftShader: with ``--disable-gpu``
recent Chromium only falls back to SwiftShader given ``--enable-unsafe-swiftshader``
(trusted local content). Every console message counts as a failure, except Chromium's
own performance advice listed in ``BENIGN``.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

CHROMIUM = Path("/usr/bin/chromium")

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


def console_problems(stderr: str) -> list[str]:
    """Console messages of the page in Chromium's log, but the benign ones."""
    messages = [m.group("message") for m in CONSOLE.finditer(stderr)]
    problems = [m for m in messages if not any(b in m for b in BENIGN)]
    problems += [line for line in stderr.splitlines() if "Uncaught" in line]
    return problems


def dump_dom(
    url: str, profile: Path, *extra: str, budget_ms: int = 10000
) -> subprocess.CompletedProcess[str]:
    """Load ``url`` in headless Chromium and return the process (DOM on stdout)."""
    flags = [f for f in FLAGS if not f.startswith("--virtual-time-budget")]
    return subprocess.run(
        [str(CHROMIUM), *flags, f"--virtual-time-budget={budget_ms}",
         f"--user-data-dir={profile}", *extra, "--dump-dom", url],
        capture_output=True,
        text=True,
        timeout=180,
        check=False,
    )  # fmt: skip
