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
from typing import ClassVar

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


class LivePage:
    """Headless Chromium on one page in real time, driven through the DevTools protocol
    (for a page that holds a websocket open and so never settles, as virtual time needs):
    evaluate JavaScript, wait for a condition, press keys. A context manager; ``console``
    collects the page's console messages and uncaught exceptions as ``(level, text)``
    pairs (levels as the protocol names them: ``log``, ``info``, ``warning``, ``error``,
    ``exception``)."""

    #: The keys :meth:`press` knows, with their virtual key codes.
    KEYS: ClassVar[dict[str, int]] = {
        "End": 35, "Home": 36, "ArrowLeft": 37, "ArrowUp": 38, "ArrowRight": 39, "ArrowDown": 40
    }  # fmt: skip

    def __init__(
        self, url: str, profile: Path, *, seconds: float = 60.0, size: str = "800,600"
    ) -> None:
        self.url, self.profile, self.seconds, self.size = url, profile, seconds, size
        self.console: list[tuple[str, str]] = []

    def __enter__(self) -> LivePage:
        import json
        import socket
        import time
        import urllib.request

        from websockets.sync.client import connect

        with socket.socket() as s:
            s.bind(("127.0.0.1", 0))
            port = s.getsockname()[1]
        flags = [f for f in FLAGS if not f.startswith(("--virtual-time", "--window-size"))]
        self._chromium = subprocess.Popen(
            [str(CHROMIUM), *flags, f"--window-size={self.size}",
             f"--remote-debugging-port={port}", f"--user-data-dir={self.profile}",
             "about:blank"],
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
        )  # fmt: skip
        try:
            self.deadline = time.monotonic() + self.seconds
            tabs: list[dict[str, str]] = []
            while not tabs and time.monotonic() < self.deadline:
                try:
                    with urllib.request.urlopen(f"http://127.0.0.1:{port}/json") as answer:
                        tabs = [t for t in json.load(answer) if t.get("type") == "page"]
                except OSError:
                    time.sleep(0.2)
            self._ws = connect(tabs[0]["webSocketDebuggerUrl"], max_size=None)
            self._ids = iter(range(1, 1_000_000))
            self.call("Runtime.enable")
            self.call("Page.navigate", url=self.url)
        except BaseException:
            self._kill()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self._ws.close()
        self._kill()

    def _kill(self) -> None:
        self._chromium.kill()
        self._chromium.wait()

    def call(self, method: str, **params: object) -> dict:  # type: ignore[type-arg]
        """One DevTools command; its answer (console messages on the way are kept)."""
        import json
        import time

        i = next(self._ids)
        self._ws.send(json.dumps({"id": i, "method": method, "params": params}))
        while True:
            message = json.loads(self._ws.recv(timeout=max(1.0, self.deadline - time.monotonic())))
            if message.get("method") == "Runtime.consoleAPICalled":
                p = message["params"]
                text = " ".join(str(a.get("value", a.get("description", "")))
                                for a in p.get("args", []))  # fmt: skip
                self.console.append((p.get("type", "log"), text))
            elif message.get("method") == "Runtime.exceptionThrown":
                details = message["params"]["exceptionDetails"]
                self.console.append(("exception", str(details.get("exception", details))))
            if message.get("id") == i:
                return message  # type: ignore[no-any-return]

    def evaluate(self, expression: str) -> object:
        """The value of a JavaScript expression in the page (``None`` if not JSON-able)."""
        answer = self.call("Runtime.evaluate", expression=expression, returnByValue=True)
        return answer.get("result", {}).get("result", {}).get("value")

    def wait(self, expression: str, seconds: float | None = None) -> bool:
        """Whether ``expression`` became true within ``seconds`` (default: until the
        page's deadline)."""
        import time

        end = self.deadline if seconds is None else min(self.deadline, time.monotonic() + seconds)
        while time.monotonic() < end:
            if self.evaluate(f"Boolean({expression})") is True:
                return True
            time.sleep(0.1)
        return False

    def press(self, key: str) -> None:
        """Press and release ``key`` (one of :attr:`KEYS`) in the focused element."""
        code = self.KEYS[key]
        for kind in ("keyDown", "keyUp"):
            self.call("Input.dispatchKeyEvent", type=kind, key=key, code=key,
                      windowsVirtualKeyCode=code, nativeVirtualKeyCode=code)  # fmt: skip

    @property
    def text(self) -> str:
        """The page's ``document.body.innerText``."""
        return str(self.evaluate("document.body.innerText") or "")


def live_page(
    url: str, profile: Path, done_js: str, *, seconds: float = 60.0, size: str = "800,600"
) -> tuple[str, list[tuple[str, str]]]:
    """Open ``url`` in a :class:`LivePage` until the JavaScript expression ``done_js`` is
    true or ``seconds`` pass.

    Returns:
        ``(text, console)``: the page's ``document.body.innerText`` and its console
        messages (:class:`LivePage`).
    """
    with LivePage(url, profile, seconds=seconds, size=size) as page:
        page.wait(done_js)
        return page.text, page.console
