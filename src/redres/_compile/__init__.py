"""The one owner of numba in redres (internal): kernels, their groups, cache and first use.

Every compiled function of the package is plain Python marked :func:`kernel` in a *kernel
module* (a file named ``_kernels.py`` or ``_*_kernels.py``). Each owner declares its kernel
modules once, as a :class:`KernelGroup`, and gets everything through it: the module
compiled or as its plain-Python twin, an entry point, whether it is ready. This package
imports no owner and no workload: it finds kernel modules by file name
(:mod:`._cache`), and the warm-up workloads that compile them behind run as a process of
their own (``python -m redres._warmup``, :mod:`._background`). Nothing else in redres
imports numba, so ``import redres`` never pays for it.

**Switch.** ``REDRES_DISABLE_JIT=1`` (read once, at import) turns every kernel into the
plain Python function it is written as: same results, much slower; numba is never
imported. :mod:`redres.linalg` then takes its NumPy paths.

**First use.** ``REDRES_COMPILE`` (read once, at import): ``background`` (default)
compiles a cold group in a second process while the caller answers through its
reference path and switches, for good, once the group's marker appears;
``foreground`` compiles on the caller's path, on first use, after one line on standard
error saying what is compiled, about how long it takes and where it is cached.
"""

from __future__ import annotations

import importlib
import os
import subprocess
import sys
import time
from collections.abc import Callable, Iterable
from types import ModuleType
from typing import Any

from . import _background, _cache, _estimates, _lock, _twins
from ._background import child_env, cores, idle_cores, release_lock
from ._cache import cache_dir

__all__ = [
    "KernelGroup",
    "cache_dir",
    "child_env",
    "compile_on_first_use",
    "cores",
    "enabled",
    "entry_point",
    "groups",
    "idle_cores",
    "is_compiled",
    "kernel",
    "parallel_range",
    "precompile",
    "quiet",
    "release_lock",
    "threads",
    "warm",
]

_ENABLED = os.environ.get("REDRES_DISABLE_JIT", "") in ("", "0")
_OPTIONS: dict[str, Any] = {"nogil": True, "error_model": "numpy"}
#: ``REDRES_COMPILE``: ``background`` (default) or ``foreground`` (module docstring).
_POLICY = os.environ.get("REDRES_COMPILE", "background").strip().lower() or "background"
_POLL_SECONDS = 0.02  # how often a waiting caller looks for the compiled cache (a stat)
_state: dict[str, Any] = {"foreground": _POLICY == "foreground"}
#: Dispatchers of each kernel module compiled in this process, by module name.
_dispatchers: dict[str, list[Any]] = {}


def enabled() -> bool:
    """Whether kernels are compiled (``REDRES_DISABLE_JIT`` unset or ``0``)."""
    return _ENABLED


# --------------------------------------------------------------------------- kernels


def kernel(
    func: Callable[..., Any] | None = None,
    *,
    parallel: bool = False,
    inline: bool = False,
    nogil: bool = True,
) -> Any:
    """Mark ``func`` as a kernel: compiled by numba (``nogil``, NumPy error model, cached
    as :mod:`._cache` says) on its first call, or left as plain Python when the switch is
    off or its module is imported as the twin. ``parallel=True``: numba's, loops over
    :func:`parallel_range` on its threads (:func:`threads`). ``inline=True``: numba's
    ``inline="always"`` (no call, as if written there; callable from Python as well).
    ``nogil=False``: a kernel called from Python for about a microsecond keeps the GIL
    (releasing and taking it back costs some 30 ns a call)."""
    if func is None:
        return lambda f: kernel(f, parallel=parallel, inline=inline, nogil=nogil)
    if not _ENABLED or _twins.state["plain_import"]:
        return func
    import numba

    options = dict(_OPTIONS, parallel=parallel, inline="always" if inline else "never", nogil=nogil)
    dispatcher = numba.njit(**options)(func)
    if cache_dir() is not None:
        try:
            dispatcher._cache = _cache.cache_class()(dispatcher.py_func)
        except Exception:  # pragma: no cover - numba's caching internals changed
            pass  # compiled in memory: correct, only slower to start
        from numba.core.compiler_lock import global_compiler_lock

        _lock.guard(dispatcher, _cache.root() / "locks", global_compiler_lock)
    _dispatchers.setdefault(func.__module__, []).append(dispatcher)
    return dispatcher


def parallel_range() -> Any:
    """``numba.prange`` for ``@kernel(parallel=True)`` loops, ``range`` in plain Python;
    a kernel module takes it at import (``prange = parallel_range()``), once per twin."""
    plain = not _ENABLED or _twins.state["plain_import"]
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


def is_compiled(module: ModuleType) -> bool:
    """Whether ``module`` (from :meth:`KernelGroup.module`) is the compiled form."""
    return _twins.is_compiled(module)


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


def precompile(name: str, kernel: str, *args: Any) -> None:
    """Compile kernel ``kernel`` of module ``name`` for the types of ``args`` (or load it
    from the cache) without running it: a callee compiled ahead of its callers (the
    background compiler's helper). A no-op when kernels are plain Python. Says nothing and
    marks nothing (a part of a module: its warm-up group marks it whole)."""
    if not _ENABLED:
        return
    try:
        dispatcher = getattr(_twins.get(name, True), kernel, None)
    except ImportError:
        return
    if dispatcher is None or not hasattr(dispatcher, "compile"):
        return
    import numba

    dispatcher.compile(tuple(numba.typeof(arg) for arg in args))  # type: ignore[no-untyped-call]


# --------------------------------------------------------------------------- groups

_GROUPS: dict[str, KernelGroup] = {}
_FIGURES: dict[str, float] = {}  # cold-compile seconds by module, from the groups


class KernelGroup:
    """The kernel modules of one owner, declared once where the owner loads them.

    Args:
        name: the group's name (the warm-up group of ``redres warmup`` that compiles it).
        modules: its kernel modules (dotted names); the first is the group's main one.
        cold_seconds: roughly how long a first compilation of the first module's own
            kernels takes with its callees in other groups cached, s (the first-use
            message adds the callees' figures); ``others`` the same for the rest.
        others: cold seconds of the other modules, by name (default 0).
    """

    def __init__(
        self,
        name: str,
        modules: tuple[str, ...],
        *,
        cold_seconds: float = 0.0,
        others: dict[str, float] | None = None,
    ) -> None:
        self.name, self.modules = name, tuple(modules)
        _FIGURES.update({m: 0.0 for m in self.modules} | (others or {}))
        _FIGURES[self.modules[0]] = float(cold_seconds)
        _GROUPS[name] = self

    def __repr__(self) -> str:
        return f"KernelGroup({self.name!r}, {self.modules})"

    def _name(self, module: str | None) -> str:
        if module is None:
            return self.modules[0]
        for full in self.modules:
            if full == module or full.endswith("." + module):
                return full
        raise ValueError(f"{module!r} is not a module of kernel group {self.name!r}")

    def module(self, module: str | None = None, *, plain: bool = False) -> ModuleType | None:
        """Kernel module ``module`` (default: the first; a full or last-component name):
        compiled when it is :meth:`ready`, else its plain-Python twin while it compiles
        behind (``plain``: the twin in any case); None when numba cannot be imported."""
        name = self._name(module)
        return _get(name, compiled=not plain and self.ready(name))

    def required(
        self,
        what: str,
        module: str | None = None,
        *,
        plain: bool = False,
        otherwise: str = "set REDRES_DISABLE_JIT=1 to run them as plain Python",
    ) -> ModuleType:
        """:meth:`module`, for an owner that has no path without it: a
        :class:`~redres.errors.MissingDependencyError` naming ``what`` (the owner's
        feature) and ``otherwise`` (what the user can do instead) when numba cannot be
        imported."""
        found = self.module(module, plain=plain)
        if found is None:
            from ..errors import MissingDependencyError

            raise MissingDependencyError(
                f"{what}: numba (a dependency of redres) cannot be imported; reinstall it, "
                f"or {otherwise}"
            )
        return found

    def compiled(self, module: str | None = None) -> ModuleType | None:
        """Kernel module ``module`` compiled, if it is :meth:`ready`; None while it compiles
        behind (the owner's own reference path answers) or when numba cannot be imported
        (:meth:`pending` tells the two apart)."""
        name = self._name(module)
        return _get(name, compiled=True) if self.ready(name) else None

    def entry(
        self, kernel: str, args: tuple[Any, ...], module: str | None = None
    ) -> Callable[..., Any] | None:
        """:func:`entry_point` of kernel ``kernel`` of :meth:`module` for the types of
        ``args`` (plain Python while it compiles behind); None without numba."""
        found = self.module(module)
        return None if found is None else entry_point(getattr(found, kernel), args)

    def ready(
        self, module: str | None = None, *, start: bool = True, part: str | None = None
    ) -> bool:
        """Whether kernel module ``module`` can run compiled without compiling on the
        caller's path: loaded, or cached at this stamp, or compiling happens on first use
        anyway (``REDRES_COMPILE=foreground``, no writable cache, a failed background
        compile). Else starts (once; not with ``start=False``, for a caller whose own path
        is as fast) the background compilation and says False until it has cached the
        module; callers ask on each call and switch when it says True. ``part``: only that
        part of the module is needed (an entry point marked ahead, :meth:`mark`)."""
        return _ready(self._name(module), start=start, part=part)

    def pending(self, module: str | None = None) -> bool:
        """Whether ``module`` is compiling behind (not ready, numba importable)."""
        return _ENABLED and not self.ready(module)

    def cached(self) -> bool:
        """Whether every module of the group is compiled into the cache at this stamp."""
        return all(map(cached, self.modules))

    def cold_estimate(self) -> float:
        """Roughly how long compiling what of the group is not cached takes now, s (its
        modules and the kernels of other groups they call; 0 when cached)."""
        return _estimates.cold_seconds(_FIGURES, self.modules, cached)

    def mark(
        self,
        *,
        part: str | None = None,
        workload: bool = False,
        modules: Iterable[str] | None = None,
    ) -> None:
        """Write the markers of the group's modules (or ``modules`` of it) that this
        process has compiled something of, so that other processes see them cached.
        ``workload``: a warm-up workload ran through, mark them all (a module compiled
        only into its callers has no signature of its own). ``part``: only that part."""
        names = self.modules if modules is None else tuple(map(self._name, modules))
        mark_cached(names, workload=workload, part=part)


def warm(names: Iterable[str], *, quiet: bool | None = None) -> None:
    """Make the kernel groups ``names`` compiled into the cache, then compile on this
    process's path from now on (a sweep's shards, which must not answer through the
    reference path). Groups not cached yet compile in a warm-up process
    (``python -m redres._warmup``; one line per group unless ``quiet``, by default said
    only when something compiles); waits for it."""
    if not _ENABLED:
        return
    names = tuple(names)
    known = [_GROUPS.get(name) for name in names]
    compile_on_first_use()
    if all(group is not None and group.cached() for group in known):
        return
    args = [sys.executable, "-m", "redres._warmup", "--jobs", "1", *names]
    if quiet:
        args.append("--quiet")
    proc = subprocess.run(args, stdin=subprocess.DEVNULL, env=_background.child_env())
    if proc.returncode:
        raise RuntimeError(f"redres: the warm-up process failed (status {proc.returncode})")


def groups() -> dict[str, KernelGroup]:
    """The kernel groups declared so far (their owners imported), by name."""
    return dict(_GROUPS)


def compile_on_first_use() -> None:
    """From now on compile cold kernel modules on this process's path, on first use (as
    ``REDRES_COMPILE=foreground``): :func:`redres.warmup` and the background process."""
    _state["foreground"] = True


def quiet(value: bool) -> None:
    """Whether a first compilation on this process's path goes unannounced (a warm-up
    says what it compiles itself)."""
    _state["quiet"] = bool(value)


def cached(name: str) -> bool:
    """Whether kernel module ``name`` is compiled into the cache at this stamp; also True
    when nothing would be cached (kernels disabled, no writable cache)."""
    return not _ENABLED or cache_dir() is None or _cache.marker(name).exists()


def mark_cached(names: Iterable[str], *, workload: bool = False, part: str | None = None) -> None:
    """:meth:`KernelGroup.mark` for modules ``names``."""
    for name in names:
        if (workload and _ENABLED) or any(d.signatures for d in _dispatchers.get(name, ())):
            try:
                _cache.marker(name).parent.mkdir(parents=True, exist_ok=True)
                _cache.marker(name, part).touch()
            except OSError:  # pragma: no cover - the cache went read-only meanwhile
                pass


def _get(name: str, *, compiled: bool) -> ModuleType | None:
    compiled = compiled and _ENABLED
    found = _twins.modules.get((name, compiled))
    if found is not None:
        return found
    if compiled and cache_dir() is not None and not _cache.marker(name).exists():
        _announce(name)
    try:
        return _twins.get(name, compiled)
    except ImportError:  # numba cannot be imported: the owner says what it falls back to
        return None


def _announce(name: str) -> None:
    """One line on standard error before a module's first compilation on the caller's
    path; its marker is written when this process exits, if it compiled something of it."""
    pending = _state.setdefault("pending", set())
    if not pending:
        import atexit

        atexit.register(lambda: mark_cached(pending))
    pending.add(name)
    if _state.get("quiet"):
        return
    seconds = _estimates.cold_seconds(_FIGURES, (name,), cached)
    about = f", about {seconds:.0f} s" if seconds >= 0.5 else ""
    print(
        f"redres: compiling {name.removeprefix('redres.')} kernels on first use{about}; "
        f"cached in {cache_dir()} for later runs (`redres warmup` compiles them up front)",
        file=sys.stderr,
        flush=True,
    )


def _ready(name: str, *, start: bool, part: str | None) -> bool:
    found: set[tuple[str, str | None]] = _state.setdefault("ready", set())
    key = (name, part)
    if not _ENABLED or key in found or _state["foreground"] or cache_dir() is None:
        return True
    now = time.monotonic()
    if now < _state.setdefault("next_poll", {}).get(key, 0.0):
        return False
    _state["next_poll"][key] = now + _POLL_SECONDS
    if (
        (name, True) in _twins.modules
        or _cache.marker(name).exists()
        or (part is not None and _cache.marker(name, part).exists())
    ):
        found.add(key)
        return True
    if not start:
        return False

    def seconds() -> float:  # what this caller waits for (the child goes on with the rest)
        return _estimates.cold_seconds(_FIGURES, (name,), cached)

    if _background.compile_behind(name, seconds) is not None:
        compile_on_first_use()  # it failed, or ended without this: compile it here
    return bool(_state["foreground"])
