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


def live_page(
    url: str, profile: Path, done_js: str, *, seconds: float = 60.0, size: str = "800,600"
) -> tuple[str, list[tuple[str, str]]]:
    """Open ``url`` in headless Chromium in real time, through the DevTools protocol (for a
    page that holds a websocket open and so never settles, as virtual time needs), until
    the JavaScript expression ``done_js`` is true or ``seconds`` pass.

    Returns:
        ``(text, console)``: the page's ``document.body.innerText`` and its console
        messages and uncaught exceptions as ``(level, text)`` pairs (levels as the
        protocol names them: ``log``, ``info``, ``warning``, ``error``, ``exception``).
    """
    import json
    import socket
    import time
    import urllib.request

    from websockets.sync.client import connect

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    flags = [f for f in FLAGS if not f.startswith(("--virtual-time", "--window-size"))]
    chromium = subprocess.Popen(
        [str(CHROMIUM), *flags, f"--window-size={size}", f"--remote-debugging-port={port}",
         f"--user-data-dir={profile}", "about:blank"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
    )  # fmt: skip
    console: list[tuple[str, str]] = []
    try:
        deadline = time.monotonic() + seconds
        tabs: list[dict[str, str]] = []
        while not tabs and time.monotonic() < deadline:
            try:
                with urllib.request.urlopen(f"http://127.0.0.1:{port}/json") as answer:
                    tabs = [t for t in json.load(answer) if t.get("type") == "page"]
            except OSError:
                time.sleep(0.2)
        with connect(tabs[0]["webSocketDebuggerUrl"], max_size=None) as ws:
            ids = iter(range(1, 1_000_000))

            def call(method: str, **params: object) -> dict:  # type: ignore[type-arg]
                i = next(ids)
                ws.send(json.dumps({"id": i, "method": method, "params": params}))
                while True:
                    message = json.loads(ws.recv(timeout=max(1.0, deadline - time.monotonic())))
                    if message.get("method") == "Runtime.consoleAPICalled":
                        p = message["params"]
                        text = " ".join(str(a.get("value", a.get("description", "")))
                                        for a in p.get("args", []))  # fmt: skip
                        console.append((p.get("type", "log"), text))
                    elif message.get("method") == "Runtime.exceptionThrown":
                        details = message["params"]["exceptionDetails"]
                        console.append(("exception", str(details.get("exception", details))))
                    if message.get("id") == i:
                        return message  # type: ignore[no-any-return]

            call("Runtime.enable")
            call("Page.navigate", url=url)
            text = ""
            while time.monotonic() < deadline:
                found = call("Runtime.evaluate", expression=f"Boolean({done_js})")
                if found.get("result", {}).get("result", {}).get("value") is True:
                    break
                time.sleep(0.25)
            body = call("Runtime.evaluate", expression="document.body.innerText")
            text = str(body.get("result", {}).get("result", {}).get("value", ""))
        return text, console
    finally:
        chromium.kill()
        chromium.wait()
