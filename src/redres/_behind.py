"""Compiling behind (internal): the background compiler of :mod:`redres._jit`.

:func:`redres._jit.ready` calls :func:`compile_behind` for a kernel module whose cache
is cold: it starts, once for every process that shares the cache (a lock file holding
the compiler's process id), :func:`run` in a new interpreter (not through the ``redres``
command, whose parser imports the sweeps: 0.15 s more before the compilation starts), and
notices when it has ended or failed. :func:`run` compiles the warm-up group of that
module first (:data:`redres._warmup.GROUPS`), at normal priority and, when a core is idle,
with a :func:`helper` process that compiles callees deep in the group's call tree
(:data:`redres._warmup.HELPERS`); then the other groups, niced. docs/architecture.md,
"First use".
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from pathlib import Path

from . import _jit

#: The background compiler's program (argument: the kernel module to compile first).
_CHILD = "import sys; from redres._behind import run; run(sys.argv[1])"
#: The helper process's program (argument: the warm-up group).
_HELPER = "import sys; from redres._behind import helper; helper(sys.argv[1])"
#: The helper starts once the machine shows this much of a core idle (the caller's loop
#: and the main compilation running), measured over windows of ``_IDLE_WINDOW`` s; not
#: after ``_IDLE_UNTIL`` s (by then the main compilation is past the helper's kernels).
_IDLE_CORES, _IDLE_WINDOW, _IDLE_UNTIL = 0.5, 0.3, 6.0


def _lock_file() -> Path:
    return _jit._cache_root() / f"compiling-{_jit.stamp()[:16]}.pid"


def compile_behind(name: str) -> None:
    """Make sure a background process compiles the kernel modules into the cache, the
    group of ``name`` first (:mod:`redres._warmup`); notice when it has ended."""
    proc: subprocess.Popen[bytes] | None = _jit._state.get("behind")
    if proc is not None:
        if proc.poll() is not None and not _jit._marker(name).exists():
            if proc.returncode:
                _behind_failed(f"it exited with status {proc.returncode}")
            _jit.compile_on_first_use()  # it compiled everything but this: compile it here
        return
    if not _take_lock():
        return  # another process compiles into this cache: wait for its markers
    try:
        with open(_log_file(), "wb") as sink:
            proc = subprocess.Popen(
                [sys.executable, "-c", _CHILD, name],
                stdin=subprocess.DEVNULL, stdout=sink, stderr=sink, env=child_env(),
                start_new_session=True,
            )  # fmt: skip
        _lock_file().write_text(str(proc.pid))
    except OSError as exc:
        _lock_file().unlink(missing_ok=True)
        _behind_failed(f"it could not start ({exc})")
        return
    _jit._state["behind"] = proc
    # numba's import and CPU target (0.5 s) are needed at the switch: prepare them now.
    threading.Thread(target=_jit.prepare, name="redres-prepare-numba", daemon=True).start()
    from ._compile_times import cold_seconds

    seconds = cold_seconds(*_jit.KERNEL_MODULES)  # the child compiles them all
    print(
        f"redres: compiling kernels in a background process (about {seconds:.0f} s on one "
        f"core, cached in {_jit.cache_dir()}); until then results come from the reference path "
        "(same answers, slower); `redres warmup` compiles them up front",
        file=sys.stderr,
        flush=True,
    )


def child_env() -> dict[str, str]:
    """Environment of a compiling child process: this redres importable, compiling in
    its foreground."""
    env = dict(os.environ, REDRES_COMPILE="foreground")
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(_jit._PACKAGE.parent),
                                                      env.get("PYTHONPATH")]))  # fmt: skip
    return env


def _take_lock() -> bool:
    """Create the lock file of a background compilation (holding this process's id until
    the child's replaces it); False if a live process holds it."""
    for _ in range(2):
        try:
            fd = os.open(_lock_file(), os.O_CREAT | os.O_EXCL | os.O_WRONLY)
        except FileExistsError:
            if _lock_holder() is not None:
                return False
            _lock_file().unlink(missing_ok=True)  # its process died: stale
            continue
        except OSError:
            return False
        with os.fdopen(fd, "w") as f:
            f.write(str(os.getpid()))
        return True
    return False


def release_lock() -> None:
    """Remove the lock file if this process holds it (the background child, at its end)."""
    if _lock_holder() == os.getpid():
        _lock_file().unlink(missing_ok=True)


def _log_file() -> Path:
    return _jit._cache_root() / f"compiling-{_jit.stamp()[:16]}.log"


def _lock_holder() -> int | None:
    """Process id of a live background compilation into this cache, or None."""
    try:
        pid = int(_lock_file().read_text())
        os.kill(pid, 0)
    except (OSError, ValueError):
        return None
    return pid


def _behind_failed(why: str) -> None:
    _jit._state["foreground"] = True
    print(
        f"redres: the background compilation failed ({why}; see {_log_file()}); kernels "
        "are compiled on first use instead",
        file=sys.stderr,
        flush=True,
    )


# --------------------------------------------------------------------------- the child


def run(first: str) -> None:
    """The background process: the warm-up group caching module ``first``, then the rest
    (:mod:`redres._warmup`)."""
    from ._warmup import GROUPS, warmup

    # The group of `first`, then the serial-chain kernels (the controller's and IK's
    # readiness needs them; a short group), then the others.
    order = sorted(GROUPS, key=lambda g: (first not in GROUPS[g][0], g != "chain"))
    helpers: list[subprocess.Popen[bytes]] = []
    starter = _start_helper(order[0], helpers)
    try:
        warmup(order[:1], quiet=True, jobs=1)  # a caller waits for this one
        if hasattr(os, "nice"):
            os.nice(10)  # the rest: the user's process comes first
        warmup(order[1:], quiet=True, jobs=1)
    finally:
        release_lock()
        if starter is not None:
            starter.join()
        for proc in helpers:
            proc.wait()


def helper(group: str) -> None:
    """The helper process of :func:`run`: compile :data:`redres._warmup.HELPERS` of
    ``group`` (the two processes share the work through the cache's per-kernel locks,
    :mod:`redres._compile_lock`)."""
    from ._warmup import HELPERS

    for module, kernel, arguments in HELPERS.get(group, ()):
        _jit.precompile(module, kernel, *arguments())


def _start_helper(group: str, started: list[subprocess.Popen[bytes]]) -> threading.Thread | None:
    """Start :func:`helper` for ``group`` (into ``started``) from a thread, once the
    machine shows an idle core beside this compilation and the caller's loop. A caller
    that spins on the reference path takes the other core: three processes on two cores
    would only slow the group down."""
    from ._warmup import GROUPS, HELPERS

    if group not in HELPERS or _cores() < 2 or all(map(_jit.cached, GROUPS[group][0])):
        return None

    def start() -> None:
        deadline = time.monotonic() + _IDLE_UNTIL
        # The caller sets up (imports, its own numba) for about a second: its loop shows
        # what it leaves idle only then.
        while idle_cores(_IDLE_WINDOW) < _IDLE_CORES:
            if time.monotonic() > deadline:
                return
        try:
            started.append(subprocess.Popen([sys.executable, "-c", _HELPER, group],
                                            stdin=subprocess.DEVNULL, env=child_env()))  # fmt: skip
        except OSError:  # the group compiles in this process alone
            pass

    thread = threading.Thread(target=start, name="redres-helper-start", daemon=True)
    thread.start()
    return thread


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return len(os.sched_getaffinity(0))
    return os.cpu_count() or 1  # pragma: no cover - not Linux


def idle_cores(seconds: float) -> float:
    """Idle cores of the machine over the next ``seconds`` (``/proc/stat``); the count of
    usable cores where that cannot be read."""

    def ticks() -> tuple[int, int]:
        with open("/proc/stat") as f:
            counts = [int(x) for x in f.readline().split()[1:]]
        return counts[3] + counts[4], sum(counts)  # idle + iowait, all

    try:
        idle0, total0 = ticks()
        time.sleep(seconds)
        idle1, total1 = ticks()
    except (OSError, ValueError, IndexError):  # pragma: no cover - no /proc/stat
        return float(_cores())
    return (os.cpu_count() or 1) * (idle1 - idle0) / max(total1 - total0, 1)
