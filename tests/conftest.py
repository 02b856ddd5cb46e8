"""Shared fixtures: seeded generators and the built-in robots (built once per session);
under pytest-xdist (``make test`` runs the suite on every core), one compilation of each
kernel at a time across the workers, and the tests that start fresh processes first."""

from __future__ import annotations

import contextlib
import hashlib
import os
import threading
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

# Compile on first use in the tests' own process (a cold cache must not route them to the
# reference paths while a background process compiles); tests/test_first_use.py covers
# compiling behind in processes of its own.
os.environ.setdefault("REDRES_COMPILE", "foreground")

import numpy as np
import pytest

import redres as rr
from redres import _jit

FIXTURES = Path(__file__).parent / "fixtures"

#: Files of the tests that each start fresh processes on empty compiled-code caches (minutes
#: of compiling each): run first under xdist, so that the other worker takes the rest of
#: the suite meanwhile instead of one of them coming last, alone on the machine.
FRESH_PROCESS_FILES = ("test_first_use.py", "test_readonly_install.py", "test_jit.py")


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if os.environ.get("PYTEST_XDIST_WORKER") is None:
        return  # one process: the files' own order
    first = [i for i in items if i.path.name in FRESH_PROCESS_FILES]
    items[:] = first + [i for i in items if i.path.name not in FRESH_PROCESS_FILES]


def _one_compile_at_a_time_across_workers() -> None:
    """The xdist workers share the kernels' on-disk cache (``REDRES_CACHE_DIR`` or the
    package's). numba saves a compiled signature as read index, add entry, write index:
    two processes saving signatures of one function at once can pair an index entry with
    the other's code, and two compiling the same kernel at once do the work twice. So each
    worker takes an exclusive lock file per kernel (in the cache, beside what it guards)
    around numba's ``Dispatcher.compile``: the second worker waits, then loads from the
    cache what the first compiled. Taken inside numba's own compiler lock, so that within a
    process one thread holds such locks (re-entered as callees compile); kernels call
    callees only (no cycle), so the workers cannot wait on each other in a ring."""
    import fcntl

    from numba.core import dispatcher
    from numba.core.compiler_lock import global_compiler_lock

    cache = _jit.cache_dir()
    if cache is None:
        return  # compiled in memory, per process: nothing shared to guard
    folder = cache / "test-compile-locks"
    folder.mkdir(exist_ok=True)
    held: dict[str, int] = {}
    guard = threading.Lock()

    @contextlib.contextmanager
    def exclusive(key: str) -> Iterator[None]:
        with guard:
            depth = held.get(key, 0)
            held[key] = depth + 1
        if depth:  # re-entered by this process (a recursive compile): it holds the lock
            try:
                yield
            finally:
                with guard:
                    held[key] -= 1
            return
        name = hashlib.sha256(key.encode()).hexdigest()[:24]
        with open(folder / name, "w") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)
            try:
                yield
            finally:
                with guard:
                    del held[key]
                fcntl.flock(lock, fcntl.LOCK_UN)

    original: Callable[..., Any] = dispatcher.Dispatcher.compile

    def compile_alone(self: Any, sig: Any) -> Any:
        func = self.py_func
        key = f"{func.__module__}.{func.__qualname__}:{func.__code__.co_firstlineno}"
        with global_compiler_lock, exclusive(key):
            return original(self, sig)

    dispatcher.Dispatcher.compile = compile_alone


if os.environ.get("PYTEST_XDIST_WORKER") is not None and _jit.enabled():
    _one_compile_at_a_time_across_workers()


@pytest.fixture
def rng() -> np.random.Generator:
    return np.random.default_rng(20261121)


@pytest.fixture(scope="session")
def builtin_robots() -> dict[str, rr.Robot]:
    return {name: rr.models.load(name) for name in rr.models.names()}


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    return FIXTURES
