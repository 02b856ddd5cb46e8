"""Compiling behind (internal): the background compiler of :mod:`redres._jit`.

:func:`redres._jit.ready` calls :func:`compile_behind` for a kernel module whose cache
is cold: it starts, once for every process that shares the cache (a lock file holding
the compiler's process id), :func:`redres._warmup.behind` in a new interpreter (not
through the ``redres`` command, whose parser imports the sweeps: 0.15 s more before the
compilation starts), and notices when it has ended or failed. docs/architecture.md, "First use".
"""

from __future__ import annotations

import os
import subprocess
import sys
import threading
from pathlib import Path

from . import _jit

#: The background compiler's program (argument: the kernel module to compile first).
_CHILD = "import sys; from redres._warmup import behind; behind(sys.argv[1])"


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
    seconds = _jit.cold_seconds(*_jit.KERNEL_MODULES)  # the child compiles them all
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
