"""Compiling behind (internal): the background compiler's process, its lock and its log.

:func:`redres._compile.KernelGroup.ready` calls :func:`compile_behind` for a kernel module
whose cache is cold: it starts, once for every process that shares the cache (a lock file
holding the compiler's process id), ``python -m redres._warmup --behind MODULE`` (the
warm-up workloads live at the top of the package; the compiler starts them as a process
and never imports them), and notices when it has ended or failed. docs/architecture.md,
"Compiled code".
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from . import _cache

_state: dict[str, subprocess.Popen[bytes]] = {}


def _lock_file() -> Path:
    return _cache.root() / f"compiling-{_cache.stamp()[:16]}.pid"


def compile_behind(name: str, seconds: Callable[[], float]) -> str | None:
    """Make sure a background process compiles the kernel modules into the cache, the
    group of module ``name`` first; say so (``seconds()``: about how long, for the message).
    Returns None while that is under way (or another process compiles into this cache),
    else why the caller should compile on its own path from now on: ``"done"`` (the
    process ended without caching ``name``) or ``"failed"`` (it could not start or failed,
    said on standard error)."""
    proc = _state.get("proc")
    if proc is not None:
        if proc.poll() is None or _cache.marker(name).exists():
            return None
        if proc.returncode:
            _failed(f"it exited with status {proc.returncode}")
            return "failed"
        return "done"  # it compiled everything but this: compile it on the caller's path
    if not _take_lock():
        return None  # another process compiles into this cache: wait for its markers
    try:
        with open(_log_file(), "wb") as sink:
            proc = subprocess.Popen(
                [sys.executable, "-m", "redres._warmup", "--behind", name],
                stdin=subprocess.DEVNULL, stdout=sink, stderr=sink, env=child_env(),
                start_new_session=True,
            )  # fmt: skip
        _lock_file().write_text(str(proc.pid))
    except OSError as exc:
        _lock_file().unlink(missing_ok=True)
        _failed(f"it could not start ({exc})")
        return "failed"
    _state["proc"] = proc
    # numba's import and CPU target (0.5 s) are needed at the switch: prepare them now.
    threading.Thread(target=prepare, name="redres-prepare-numba", daemon=True).start()
    print(
        f"redres: compiling kernels in a background process ({name.removeprefix('redres.')} "
        f"first, about {seconds():.0f} s on one core; cached in {_cache.cache_dir()}); until "
        "then results come from the reference path (same answers, slower); `redres warmup` "
        "compiles them up front",
        file=sys.stderr,
        flush=True,
    )
    return None


def prepare() -> None:
    """Import numba and build its CPU target (their type and lowering registries, SciPy's
    LAPACK among them: 0.5 s, paid once per process before a first kernel loads), under
    numba's compiler lock, so that the switch to the compiled path only loads kernels."""
    try:
        from numba.core.compiler_lock import global_compiler_lock
        from numba.core.registry import cpu_target

        with global_compiler_lock:
            cpu_target.target_context.refresh()
    except Exception:  # pragma: no cover - only a head start: the first load does it anyway
        pass


def child_env() -> dict[str, str]:
    """Environment of a compiling child process: this redres importable, compiling in
    its foreground."""
    env = dict(os.environ, REDRES_COMPILE="foreground")
    path = [str(_cache.PACKAGE.parent), env.get("PYTHONPATH", "")]
    env["PYTHONPATH"] = os.pathsep.join(filter(None, path))
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
    return _cache.root() / f"compiling-{_cache.stamp()[:16]}.log"


def _lock_holder() -> int | None:
    """Process id of a live background compilation into this cache, or None: the lock
    file's process exists and is one (a lock left by a compiler that died, whose id a
    later process took, after a reboot say, stopped compiling behind for good)."""
    path = _lock_file()
    try:
        pid = int(path.read_text())
        os.kill(pid, 0)
        age = time.time() - path.stat().st_mtime
    except (OSError, ValueError):
        return None
    if age < _HANDOVER_S or _is_compiler(pid):  # just taken: the starter's own id first
        return pid
    return None


#: How long the starter's own process id may stand in the lock file before the child's
#: replaces it, s.
_HANDOVER_S = 30.0


def _is_compiler(pid: int) -> bool:
    """Whether process ``pid`` runs redres's background compiler (its command line, from
    ``/proc``; True where that cannot be read)."""
    try:
        command = Path(f"/proc/{pid}/cmdline").read_bytes()
    except OSError:
        return not Path("/proc/self/cmdline").exists()  # no /proc: trust the id
    return b"redres._warmup" in command and b"--behind" in command


def _failed(why: str) -> None:
    print(
        f"redres: the background compilation failed ({why}; see {_log_file()}); kernels "
        "are compiled on first use instead",
        file=sys.stderr,
        flush=True,
    )


def cores() -> int:
    """Cores this process may run on."""
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
        return float(cores())
    return (os.cpu_count() or 1) * (idle1 - idle0) / max(total1 - total0, 1)
