"""The one owner of numba in redres (internal): compile switch, cache, warm-up, messages.

Every compiled function of the package is written as plain Python in one of the kernel
modules listed in :data:`KERNEL_MODULES` and marked with :func:`kernel`. Nothing else in
redres imports numba, and nothing imports a kernel module but through :func:`load`, so
``import redres`` never pays for numba.

**Switch.** ``REDRES_DISABLE_JIT=1`` in the environment (read once, at import) turns every
kernel into the plain Python function it is written as: same results, much slower, and
numba is never imported. :mod:`redres.linalg` then takes its NumPy paths.

**Cache.** Compiled code is cached on disk so that a process loads, rather than
compiles, what an earlier one compiled. The cache lives in ``REDRES_CACHE_DIR`` if set,
else in ``__pycache__/numba`` inside the installed package when that is writable, else
in the per-user cache directory (``$XDG_CACHE_HOME/redres/numba``, by default
``~/.cache/redres/numba``). Where none is writable the kernels are compiled in memory.

**Staleness.** numba checks a cached function against the source file that defines it,
so a compiled function that calls a compiled function of *another* file would keep
running the callee's old code after an edit (numba issue 1833). Here the freshness stamp
of every kernel is one digest of *all* kernel modules (and the redres version): an edit
to any of them invalidates every cached kernel, and kernels may call kernels of other
kernel modules safely. ``tests/test_jit.py`` checks that every compiled call crosses
only between modules of :data:`KERNEL_MODULES` and that an edited callee in another file
is recompiled.

**Messages.** The first time a kernel module is compiled into a cache (a fresh install,
an edit, a new Python), :func:`load` prints one line on standard error saying what is
being compiled, about how long it takes and where it is cached — never in silence.
"""

from __future__ import annotations

import hashlib
import importlib
import os
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterable
from pathlib import Path
from types import ModuleType
from typing import Any, ClassVar

__all__ = [
    "KERNEL_MODULES",
    "cache_dir",
    "cached",
    "compiled",
    "enabled",
    "entry_point",
    "is_compiled",
    "kernel",
    "load",
    "parallel_range",
    "pending",
    "precompile",
    "ready",
    "threads",
    "warmup",
]

#: Every module of redres with compiled code (dotted names). The cache stamp covers them
#: all; a kernel module missing here fails ``tests/test_jit.py``.
KERNEL_MODULES: tuple[str, ...] = (
    "redres.linalg._dense_kernels",
    "redres.linalg._eigen_kernels",
    "redres.linalg._kernels",
    "redres.control._kernels",
    "redres.robot._kernels",
    "redres.robot._chain_kernels",
    "redres._batch_kernels",
    "redres._ik_kernels",
    "redres.resolution.hard_limits._kernels",
    "redres.resolution.hard_limits._lp_kernels",
    "redres.resolution.hard_limits._qp_kernels",
)

#: Plain modules whose values kernels compile in (status codes, layouts): covered by the
#: cache stamp too, since numba bakes their constants into the cached code.
CONSTANT_MODULES: tuple[str, ...] = (
    "redres.linalg._codes",
    "redres.resolution.hard_limits._codes",
    "redres.robot._chain_codes",
)

_ENABLED = os.environ.get("REDRES_DISABLE_JIT", "") in ("", "0")
_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}
_PACKAGE = Path(__file__).resolve().parent
_state: dict[str, Any] = {}


def enabled() -> bool:
    """Whether kernels are compiled (``REDRES_DISABLE_JIT`` unset or ``0``)."""
    return _ENABLED


# --------------------------------------------------------------------------- cache


def cache_dir() -> Path | None:
    """The directory compiled kernels are cached in (module docstring), or None when no
    candidate is writable (then they are compiled in memory, every process)."""
    if "cache_dir" in _state:
        found: Path | None = _state["cache_dir"]
        return found
    candidates = []
    if os.environ.get("REDRES_CACHE_DIR"):
        candidates.append(Path(os.environ["REDRES_CACHE_DIR"]))
    else:
        candidates.append(_PACKAGE / "__pycache__" / "numba")
        base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
        candidates.append(Path(base) / "redres" / "numba")
    _state["cache_dir"] = next((p for p in candidates if _writable(p)), None)
    return _state["cache_dir"]  # type: ignore[no-any-return]


def _writable(path: Path) -> bool:
    try:
        path.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=path).close()
    except OSError:
        return False
    return True


def _module_file(name: str) -> Path:
    """Source file of kernel module ``name`` (found without importing it)."""
    parts = name.split(".")[1:]
    return _PACKAGE.joinpath(*parts[:-1], parts[-1] + ".py")


def stamp() -> str:
    """The freshness stamp of every cached kernel: a digest of the redres version and the
    sources of all :data:`KERNEL_MODULES` and :data:`CONSTANT_MODULES`."""
    if "stamp" not in _state:
        from . import __version__

        digest = hashlib.sha256(__version__.encode())
        for name in (*KERNEL_MODULES, *CONSTANT_MODULES):
            digest.update(name.encode())
            digest.update(_module_file(name).read_bytes())
        _state["stamp"] = digest.hexdigest()
    return _state["stamp"]  # type: ignore[no-any-return]


def _cache_class() -> Any:
    """numba's per-function cache with this module's locator (built on first use)."""
    if "cache_class" in _state:
        return _state["cache_class"]
    from numba.core import caching

    class Locator(caching._CacheLocator):  # type: ignore[misc]
        """Cache files under :func:`cache_dir`, fresh while :func:`stamp` is unchanged."""

        def __init__(self, py_func: Any, py_file: str) -> None:
            self._py_file = py_file
            self._lineno = py_func.__code__.co_firstlineno
            self._path = str(_cache_root() / py_func.__module__)

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
        _impl_class = Impl

    _state["cache_class"] = Cache
    return Cache


def _cache_root() -> Path:
    root = cache_dir()
    assert root is not None  # only called when caching
    return root


# --------------------------------------------------------------------------- kernels


def kernel(
    func: Callable[..., Any] | None = None,
    *,
    parallel: bool = False,
    inline: bool = False,
    nogil: bool = True,
) -> Any:
    """Mark ``func`` as a kernel: compiled by numba (``nogil``, NumPy error model, cached
    as the module docstring says) on its first call, or left as plain Python when the
    switch is off or its module is imported as the reference path. Typed ``Any`` so that
    kernels calling kernels type-check. ``@kernel(parallel=True)``: numba's
    ``parallel=True``, loops over :func:`parallel_range` on its threads (:func:`threads`).
    ``@kernel(inline=True)``: numba's ``inline="always"``, a helper compiled into each
    kernel that calls it (no call, as if written there; callable from Python as well).
    ``@kernel(nogil=False)``: a kernel called from Python for about a microsecond keeps
    the GIL (releasing and taking it back costs some 30 ns a call)."""
    if func is None:
        return lambda f: kernel(f, parallel=parallel, inline=inline, nogil=nogil)
    if not _ENABLED or _state.get("plain_import"):
        return func
    import numba

    options = dict(_OPTIONS, parallel=parallel, inline="always" if inline else "never", nogil=nogil)
    dispatcher = numba.njit(**options)(func)
    if cache_dir() is not None:
        try:
            dispatcher._cache = _cache_class()(dispatcher.py_func)
        except Exception:  # pragma: no cover - numba's caching internals changed
            pass  # compiled in memory: correct, only slower to start
        from numba.core.compiler_lock import global_compiler_lock

        from . import _compile_lock  # one process at a time

        _compile_lock.guard(dispatcher, _cache_root() / "locks", global_compiler_lock)
    _state.setdefault("kernels", {}).setdefault(func.__module__, []).append(dispatcher)
    return dispatcher


def parallel_range() -> Any:
    """``numba.prange`` for ``@kernel(parallel=True)`` loops, ``range`` in plain Python;
    a kernel module takes it at import (``prange = parallel_range()``), once per twin."""
    plain = not _ENABLED or _state.get("plain_import")
    return range if plain else importlib.import_module("numba").prange


def threads(count: int | None) -> int:
    """Threads of the parallel kernels launched from this thread from now on (``None``:
    all of numba's); returns the previous count (no-op, 1, when kernels are plain)."""
    if not _ENABLED:
        return 1
    import numba

    previous: int = numba.get_num_threads()
    top: int = numba.config.NUMBA_NUM_THREADS  # type: ignore[attr-defined]
    numba.set_num_threads(top if count is None else max(1, min(int(count), top)))
    return previous


# --------------------------------------------------------------------------- loading

_LOCK = threading.RLock()
#: Imported kernel modules by (name, compiled): the compiled module and its plain-Python
#: twin (the reference path while it compiles behind) are separate module objects.
_modules: dict[tuple[str, bool], ModuleType] = {}


def load(name: str, *, plain: bool = False) -> ModuleType | None:
    """Kernel module ``name`` (of :data:`KERNEL_MODULES`): compiled when it is ready
    (:func:`ready`), else its plain-Python twin while it compiles behind (``plain``: the
    twin in any case); None when numba cannot be imported (the caller says what it falls
    back to)."""
    return _get(name, compiled=not plain and ready(name))


def compiled(name: str) -> ModuleType | None:
    """Kernel module ``name`` compiled, if it is ready (:func:`ready`); None while it
    compiles behind (the caller takes its NumPy path meanwhile) or when numba cannot be
    imported (:func:`pending` tells the two apart)."""
    return _get(name, compiled=True) if ready(name) else None


def _get(name: str, *, compiled: bool, announce: bool = True) -> ModuleType | None:
    if name not in KERNEL_MODULES:
        raise ValueError(f"{name} is not a kernel module of redres._jit.KERNEL_MODULES")
    compiled = compiled and _ENABLED
    found = _modules.get((name, compiled))
    if found is not None:
        return found
    if announce and compiled and cache_dir() is not None and not _marker(name).exists():
        _announce(name)
    try:
        return _import(name, compiled)
    except ImportError:
        return None


def _import(name: str, compiled: bool) -> ModuleType:
    """Import kernel module ``name`` (and the kernel modules it imports) compiled or as
    plain Python. ``sys.modules`` shows each kernel module in one form only, so during the
    import it holds only modules of the form asked for; afterwards the compiled ones."""
    with _LOCK:
        if (name, compiled) in _modules:
            return _modules[(name, compiled)]
        for other in KERNEL_MODULES:
            sys.modules.pop(other, None)
            if (other, compiled) in _modules:
                sys.modules[other] = _modules[(other, compiled)]
        _state["plain_import"] = not compiled
        try:
            importlib.import_module(name)
        finally:
            _state["plain_import"] = False
            for other in KERNEL_MODULES:
                if other in sys.modules:
                    _modules.setdefault((other, compiled), sys.modules.pop(other))
                shown = _modules.get((other, True)) or _modules.get((other, False))
                if shown is not None:
                    sys.modules[other] = shown
        return _modules[(name, compiled)]


def precompile(name: str, kernel: str, *args: Any) -> None:
    """Compile kernel ``kernel`` of module ``name`` for the types of ``args`` (or load it
    from the cache) without running it: a kernel that other kernels call, compiled ahead
    of them (:mod:`redres._warmup`'s helper). A no-op when kernels are plain Python. Says
    nothing and marks nothing (a part of a module: its warm-up group marks it whole)."""
    module = _get(name, compiled=True, announce=False) if _ENABLED else None
    dispatcher = getattr(module, kernel, None)
    if dispatcher is None or not hasattr(dispatcher, "compile"):
        return
    import numba

    dispatcher.compile(tuple(numba.typeof(arg) for arg in args))  # type: ignore[no-untyped-call]


def is_compiled(module: ModuleType) -> bool:
    """Whether ``module`` (from :func:`load`) is the compiled form of its kernel module."""
    return _modules.get((module.__name__, True)) is module


def _marker(name: str, part: str | None = None) -> Path:
    """File that says module ``name`` (or its ``part``: an entry point and what it calls)
    has been compiled into the cache at this stamp."""
    suffix = "" if part is None else f"-{part}"
    return _cache_root() / name / f"compiled-{stamp()[:16]}{suffix}"


def _announce(name: str) -> None:
    """One line on standard error before a module's first compilation on the caller's
    path (none during :func:`redres.warmup`, which says what it compiles); its marker is
    written when this process exits, if it compiled something of it."""
    pending = _state.setdefault("pending", set())
    if not pending:
        import atexit

        atexit.register(lambda: mark_cached(pending))
    pending.add(name)
    if _state.get("quiet"):
        return
    from ._compile_times import cold_seconds

    seconds = cold_seconds(name)
    about = f", about {seconds:.0f} s" if seconds >= 0.5 else ""
    print(
        f"redres: compiling {name.removeprefix('redres.')} kernels on first use{about}; "
        f"cached in {cache_dir()} for later runs (`redres warmup` compiles them up front)",
        file=sys.stderr,
        flush=True,
    )


# --------------------------------------------------------------------------- compile behind

#: ``REDRES_COMPILE`` (read once, at import): ``background`` (default) compiles a cold
#: kernel module in a second process while the caller answers through the reference
#: path; ``foreground`` compiles it on the caller's path, on first use.
_POLICY = os.environ.get("REDRES_COMPILE", "background").strip().lower() or "background"
_POLL_SECONDS = 0.02  # how often a waiting caller looks for the compiled cache (a stat)
if _POLICY == "foreground":
    _state["foreground"] = True


def prepare() -> None:
    """Import numba and build its CPU target (their type and lowering registries, SciPy's
    LAPACK among them: 0.5 s, paid once per process before a first kernel loads), under
    numba's compiler lock. :mod:`redres._behind` runs it in a thread while the kernels
    compile behind, so that the switch to the compiled path only loads them."""
    try:
        from numba.core.compiler_lock import global_compiler_lock
        from numba.core.registry import cpu_target

        with global_compiler_lock:
            cpu_target.target_context.refresh()
    except Exception:  # pragma: no cover - only a head start: the first load does it anyway
        pass


def compile_on_first_use() -> None:
    """From now on compile cold kernel modules on this process's path, on first use (as
    ``REDRES_COMPILE=foreground``): :func:`redres.warmup` and the background process."""
    _state["foreground"] = True


def mark_cached(names: Iterable[str], *, workload: bool = False, part: str | None = None) -> None:
    """Write the markers of the kernel modules ``names`` that this process has compiled
    something of, so that other processes see them cached (:func:`ready`). ``workload``:
    a warm-up group's workload has run through: mark them all (a module whose kernels are
    all compiled into their callers, or not on this workload's path, has no signature of
    its own, yet nothing of it is left to compile for the group). ``part``: mark only
    that part of them (:func:`ready` with ``part``), ahead of the rest of the group."""
    for name in names:
        if (workload and _ENABLED) or any(
            d.signatures for d in _state.get("kernels", {}).get(name, ())
        ):
            try:
                _marker(name).parent.mkdir(parents=True, exist_ok=True)
                _marker(name, part).touch()
            except OSError:  # pragma: no cover - the cache went read-only meanwhile
                pass


def ready(name: str, *, start: bool = True, part: str | None = None) -> bool:
    """Whether kernel module ``name`` can run compiled without compiling on the caller's
    path: it is loaded, or cached at this stamp, or compiling happens on first use anyway
    (``REDRES_COMPILE=foreground``, no writable cache, a failed background compile). Else
    starts (once; not with ``start=False``, for a caller with a NumPy path as fast) the
    background compilation and returns False until it has cached the module; callers
    keep asking on each call and switch when it says True. ``part``: the caller needs only
    that part of the module (an entry point the background compiler marks as soon as it
    is cached, :func:`mark_cached`)."""
    found: set[tuple[str, str | None]] = _state.setdefault("ready", set())
    key = (name, part)
    if not _ENABLED or key in found or _state.get("foreground") or cache_dir() is None:
        return True
    now = time.monotonic()
    if now < _state.setdefault("next_poll", {}).get(key, 0.0):
        return False
    _state["next_poll"][key] = now + _POLL_SECONDS
    if (
        (name, True) in _modules
        or _marker(name).exists()
        or (part is not None and _marker(name, part).exists())
    ):
        found.add(key)
        return True
    if not start:
        return False
    from . import _behind  # the background process and its lock (not needed before)

    _behind.compile_behind(name)
    return bool(_state.get("foreground"))


def cached(name: str) -> bool:
    """Whether kernel module ``name`` is compiled into the cache at this stamp (its marker
    exists); also True when nothing would be cached (kernels disabled, no writable cache)."""
    return not _ENABLED or cache_dir() is None or _marker(name).exists()


def pending(name: str) -> bool:
    """Whether kernel module ``name`` is compiling behind (not ready, numba importable)."""
    return _ENABLED and not ready(name)


def entry_point(dispatcher: Any, args: tuple[Any, ...]) -> Callable[..., Any]:
    """The native entry point of a kernel for exactly the types of ``args``.

    Calls ``dispatcher(*args)`` once (compiling, or loading from the cache), then returns
    the compiled function for those types, which skips numba's per-call type dispatch
    (about 1–2 µs for a dozen arguments). Callers must then pass arguments of the same
    types and layouts (C-contiguous float64 arrays, Python floats, ints and bools). Returns
    the kernel itself when it is plain Python or numba's internals differ.
    """
    dispatcher(*args)
    if not hasattr(dispatcher, "overloads"):  # plain Python (disabled, or compiling behind)
        return dispatcher  # type: ignore[no-any-return]
    try:
        import numba

        signature = tuple(numba.typeof(arg) for arg in args)  # type: ignore[no-untyped-call]
        entry: Callable[..., Any] = dispatcher.overloads[signature].entry_point
    except Exception:  # pragma: no cover - numba internals changed: use the dispatcher
        return dispatcher  # type: ignore[no-any-return]
    return entry


def warmup(tasks: Iterable[tuple[str, Callable[[], object]]], *, quiet: bool = False) -> float:
    """Run warm-up calls (``(label, call)`` pairs that compile what they touch), printing
    what each compiled and how long it took unless ``quiet``; returns the total, s."""
    total = 0.0
    for label, call in tasks:
        start = time.perf_counter()
        call()
        seconds = time.perf_counter() - start
        total += seconds
        if not quiet:
            print(f"redres: {label}: {seconds:.1f} s", file=sys.stderr, flush=True)
    return total
