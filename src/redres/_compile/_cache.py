"""Where compiled kernels are cached, and when a cached kernel is still fresh (internal).

**Location.** ``REDRES_CACHE_DIR`` if set, else ``__pycache__/numba`` inside the installed
package when that is writable, else the per-user cache (``$XDG_CACHE_HOME/redres/numba``,
by default ``~/.cache/redres/numba``); in memory when none is writable.

**Freshness.** numba checks a cached function against the source file that defines it, so
a kernel that calls a kernel of *another* file would keep running the callee's old code
after an edit (numba issue 1833). Here the stamp of every kernel is one digest of the
redres version and of *every* kernel and constant module of the package, found by their
file names (:func:`kernel_modules`): an edit to any of them invalidates every cached
kernel, so kernels may call kernels of other modules safely. The compiler finds them by
name, never by importing their owners.

**Markers.** An empty file per kernel module (or part of one: an entry point and what it
calls) says that it is compiled into the cache at this stamp; other processes read it to
switch from the reference path to the compiled one.
"""

from __future__ import annotations

import functools
import glob
import hashlib
import os
import sys
import tempfile
from pathlib import Path
from typing import Any, ClassVar

from .._version import __version__

#: The package directory (kernel modules are found below it, by file name).
PACKAGE = Path(__file__).resolve().parent.parent


def is_kernel_file(path: Path) -> bool:
    """Whether ``path`` is a kernel module by its name: ``_kernels.py`` or ``_*_kernels.py``."""
    return path.name.startswith("_") and path.name.endswith("_kernels.py")


def is_constant_file(path: Path) -> bool:
    """Whether ``path`` holds constants kernels compile in: ``_codes.py``, ``_*_codes.py`` or
    ``_layout.py`` (numba bakes their values into the cached code)."""
    return path.name.startswith("_") and path.name.endswith(("_codes.py", "_layout.py"))


@functools.cache
def kernel_modules() -> tuple[str, ...]:
    """Every kernel module of the package (dotted names, sorted), found by file name."""
    return _scan(is_kernel_file)


@functools.cache
def constant_modules() -> tuple[str, ...]:
    """Every constants module of the package (dotted names, sorted), found by file name."""
    return _scan(is_constant_file)


def _scan(keep: Any) -> tuple[str, ...]:
    found = []
    for path in PACKAGE.rglob("*.py"):
        if keep(path) and "__pycache__" not in path.parts:
            parts = path.relative_to(PACKAGE.parent).with_suffix("").parts
            found.append(".".join(parts))
    return tuple(sorted(found))


def module_file(name: str) -> Path:
    """Source file of module ``name`` (found without importing it)."""
    parts = name.split(".")[1:]
    return PACKAGE.joinpath(*parts[:-1], parts[-1] + ".py")


@functools.cache
def cache_dir() -> Path | None:
    """The directory compiled kernels are cached in (module docstring), or None when no
    candidate is writable (then they are compiled in memory, every process)."""
    candidates = []
    if os.environ.get("REDRES_CACHE_DIR"):
        candidates.append(Path(os.environ["REDRES_CACHE_DIR"]))
    else:
        candidates.append(PACKAGE / "__pycache__" / "numba")
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        candidates.append(Path(base) / "redres" / "numba")
    return next((p for p in candidates if _writable(p)), None)


def root() -> Path:
    """:func:`cache_dir`, for callers that cache (it is not None)."""
    found = cache_dir()
    assert found is not None  # only called when caching
    return found


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


@functools.cache
def stamp() -> str:
    """The freshness stamp of every cached kernel: a digest of the redres version and the
    sources of every kernel and constant module."""
    digest = hashlib.sha256(__version__.encode())
    for name in (*kernel_modules(), *constant_modules()):
        digest.update(name.encode())
        digest.update(module_file(name).read_bytes())
    return digest.hexdigest()


def marker(name: str, part: str | None = None) -> Path:
    """File that says module ``name`` (or its ``part``) is compiled into the cache at this
    stamp."""
    suffix = "" if part is None else f"-{part}"
    return root() / name / f"compiled-{stamp()[:16]}{suffix}"


@functools.cache
def cache_class() -> Any:
    """numba's per-function cache with this module's locator (built on first use)."""
    from numba.core import caching

    class Locator(caching._CacheLocator):  # type: ignore[misc]
        """Cache files under :func:`cache_dir`, fresh while :func:`stamp` is unchanged."""

        def __init__(self, py_func: Any, py_file: str) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._path = str(root() / py_func.__module__)

        def get_cache_path(self) -> str:
            return self._path

        def get_source_stamp(self) -> str:
            return stamp()

        def get_disambiguator(self) -> str:
            return str(self._lineno)

        @classmethod
        def from_function(cls, py_func: Any, py_file: str) -> Locator:
            return cls(py_func, py_file)

    class Impl(caching.CompileResultCacheImpl):  # type: ignore[misc]
        _locator_classes: ClassVar[list[Any]] = [Locator]  # type: ignore[misc]

    class Cache(caching.FunctionCache):  # type: ignore[misc]
        """numba's cache, which discards a damaged file instead of raising from it."""

        _impl_class = Impl

        def load_overload(self, sig: Any, target_context: Any) -> Any:
            try:
                return super().load_overload(sig, target_context)  # type: ignore[no-untyped-call]
            except Exception as exc:
                func = self._py_func
                discard(
                    Path(self._cache_file._index_path), f"{func.__module__}.{func.__name__}", exc
                )
                return None  # not cached: numba compiles it and saves it afresh

    return Cache


def discard(index: Path, name: str, why: BaseException) -> None:
    """Remove a kernel's cache files (its index ``index`` and the data files beside it)
    after loading them failed with ``why``, and say so in one line: numba then compiles
    the kernel and writes them anew (a damaged file made every later run fail)."""
    base = index.name.removesuffix(".nbi")
    for path in (index, *index.parent.glob(f"{glob.escape(base)}.*.nbc")):
        path.unlink(missing_ok=True)
    print(
        f"redres: a damaged compiled-code file of {name} ({type(why).__name__}) was discarded "
        f"from {index.parent}; compiling it again",
        file=sys.stderr,
        flush=True,
    )
