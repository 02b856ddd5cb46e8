"""One compilation of a kernel at a time across processes (internal, for :mod:`redres._compile`).

Processes that share a compiled-code cache (a user's programs, the background compiler and
its helper, test workers) may want the same kernel at once. numba saves a compiled
signature as read index, add entry, write index: two processes saving signatures of one
function at once can pair an index entry with the other's code, and two compiling the
same kernel do the work twice. So every kernel's ``compile`` takes an exclusive lock file
(in the cache, one per kernel) around numba's own: a second process waits, then loads from
the cache what the first compiled. This is also what lets the background compiler's two
processes share one call tree (:mod:`redres._warmup`): each compiles a part, and takes the
other's from the cache.

The lock is taken inside numba's compiler lock, so that within a process one thread holds
such locks (re-entered as callees compile). Kernels call callees only (no cycle), so the
locks are always taken in caller-to-callee order and processes cannot wait on each other
in a ring; a process that dies releases its locks (``flock``).
"""

from __future__ import annotations

import contextlib
import hashlib
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

_held: dict[str, int] = {}
_guard = threading.Lock()


@contextlib.contextmanager
def _exclusive(folder: Path, key: str) -> Iterator[None]:
    """Hold the lock file of ``key`` in ``folder`` (re-entered freely by this process)."""
    import fcntl

    with _guard:
        depth = _held.get(key, 0)
        _held[key] = depth + 1
    try:
        if depth:  # a recursive compile in this process: it holds the lock already
            yield
            return
        name = hashlib.sha256(key.encode()).hexdigest()[:24]
        try:
            lock = open(folder / name, "w")
        except OSError:  # the cache went read-only: compile unguarded, as numba would
            lock = None
        if lock is None:
            yield
            return
        with lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                yield
            finally:
                fcntl.flock(lock, fcntl.LOCK_UN)
    finally:
        with _guard:
            _held[key] -= 1
            if not _held[key]:
                del _held[key]


def guard(dispatcher: Any, folder: Path, compiler_lock: Any) -> None:
    """Make ``dispatcher.compile`` (numba's, called for every new signature, from Python
    or from another kernel's compilation) hold the kernel's lock file in ``folder``,
    inside ``compiler_lock`` (numba's, from :mod:`redres._compile`). A no-op where ``fcntl``
    is missing (Windows): compiling stays correct, only unguarded against a second
    process."""
    try:
        import fcntl  # noqa: F401
    except ImportError:  # pragma: no cover - not POSIX
        return
    folder.mkdir(parents=True, exist_ok=True)
    func = dispatcher.py_func
    key = f"{func.__module__}.{func.__qualname__}:{func.__code__.co_firstlineno}"
    original: Callable[..., Any] = dispatcher.compile

    def compile_alone(sig: Any) -> Any:
        with compiler_lock, _exclusive(folder, key):
            return original(sig)

    dispatcher.compile = compile_alone
