"""The compiled plumbing (redres._compile): one owner of numba, a cache that cannot go stale.

numba checks a cached function against its own source file only, so a compiled function
calling a compiled function of another file keeps the callee's old code after an edit
(numba issue 1833). redres stamps every kernel with a digest of all kernel modules; these
tests walk the kernel sources, and show with a real edit in a copy of the package that
the caller is recompiled.
"""

from __future__ import annotations

import ast
import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
import time
import types
from pathlib import Path

import pytest

import redres
from redres import _compile as _jit
from redres import _warmup
from redres._compile import _cache, _estimates

PACKAGE = Path(redres.__file__).parent


def _modules() -> dict[str, ast.Module]:
    out = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        name = ".".join(("redres", *path.relative_to(PACKAGE).with_suffix("").parts))
        out[name.removesuffix(".__init__")] = ast.parse(path.read_text(encoding="utf-8"))
    return out


def _kernels(tree: ast.Module) -> set[str]:
    """Names of the functions of a module decorated with ``@kernel``."""
    return {
        node.name
        for node in tree.body
        if isinstance(node, ast.FunctionDef)
        and any(isinstance(d, ast.Name) and d.id == "kernel" for d in node.decorator_list)
    }


def _imported(name: str, tree: ast.Module) -> dict[str, str]:
    """Local name -> module it is imported from (``from x import y``), absolute."""
    out = {}
    package = name.rsplit(".", 1)[0] if not name.endswith("__init__") else name
    for node in tree.body:
        if isinstance(node, ast.ImportFrom) and node.module is not None:
            base = package.split(".")
            if node.level:
                base = base[: len(base) - node.level + 1]
                source = ".".join([*base, node.module])
            else:
                source = node.module
            for alias in node.names:
                out[alias.asname or alias.name] = source
    return out


def test_every_compiled_function_is_in_a_stamped_kernel_module_of_one_group() -> None:
    """Kernel modules are found by file name (the stamp covers exactly those), and each
    belongs to one declared kernel group, which has a warm-up workload."""
    modules = _modules()
    with_kernels = {name for name, tree in modules.items() if _kernels(tree)}
    stamped = set(_cache.kernel_modules())
    assert len(stamped) >= 11
    missing = sorted(with_kernels - stamped)
    assert not missing, (
        "these modules define @kernel functions but are not named _kernels.py or "
        f"_*_kernels.py (their edits would not invalidate the cache): {missing}"
    )
    owners: dict[str, list[str]] = {}
    for name, group in _warmup.groups().items():
        for module in group.modules:
            owners.setdefault(module, []).append(name)
    assert {m: g for m, g in owners.items() if len(g) != 1} == {}
    assert set(owners) == stamped, (
        "a kernel module outside every group, or a group's module missing"
    )


def test_kernel_modules_import_only_stamped_modules() -> None:
    """What a kernel module imports from redres (kernels, constants) is in the stamp: an
    edit to a constants file must recompile the kernels that baked its values in."""
    modules = _modules()
    stamped = {*_cache.kernel_modules(), *_cache.constant_modules(), "redres._compile"}
    for name in _cache.kernel_modules():
        sources = set(_imported(name, modules[name]).values())
        unstamped = {s for s in sources if s.startswith("redres")} - stamped
        assert not unstamped, f"{name} imports {unstamped}, which the cache stamp misses"


def test_compiled_calls_cross_files_only_between_stamped_kernel_modules() -> None:
    """Walk every kernel's body: a call to a kernel defined in another file is allowed only
    when both files are covered by the one cache stamp."""
    modules = _modules()
    kernels = {name: _kernels(tree) for name, tree in modules.items()}
    crossings = []
    for name, tree in modules.items():
        imported = _imported(name, tree)
        for node in tree.body:
            if not (isinstance(node, ast.FunctionDef) and node.name in kernels[name]):
                continue
            for call in ast.walk(node):
                if isinstance(call, ast.Call) and isinstance(call.func, ast.Name):
                    source = imported.get(call.func.id)
                    if source is not None and call.func.id in kernels.get(source, set()):
                        crossings.append((name, node.name, source, call.func.id))
    assert crossings, "the walk found no cross-file kernel call: it is not looking"
    stamped = set(_cache.kernel_modules())
    outside = [c for c in crossings if c[0] not in stamped or c[2] not in stamped]
    assert not outside, f"compiled calls into files the cache stamp does not cover: {outside}"


def test_only_the_plumbing_imports_numba() -> None:
    offenders = []
    for name, tree in _modules().items():
        for node in ast.walk(tree):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module:
                names = [node.module]
            if any(n == "numba" or n.startswith("numba.") for n in names):
                offenders.append(name)
    assert offenders and all(n.startswith("redres._compile") for n in offenders), (
        f"numba imported outside redres._compile: {offenders}"
    )


_CALLER = """
from ._compile import kernel
from ._callee_kernels import inner


@kernel
def outer(x):
    return inner(x) * 10.0
"""
_CALLEE = """
from ._compile import kernel


@kernel
def inner(x):
    return x + {value}
"""
_RUN = """
import redres._compile as jit
group = jit.KernelGroup("probe", ("redres._probe_kernels", "redres._callee_kernels"))
module = group.module()
print(module.outer(1.0), module.outer.stats.cache_hits.get(module.outer.signatures[0], 0))
"""


@pytest.mark.skipif(not _jit.enabled(), reason="the compiled kernels are disabled")
def test_an_edit_to_a_callee_in_another_file_recompiles_the_caller(tmp_path: Path) -> None:
    """A copy of the package with a caller and a callee in two kernel files: after the
    callee is edited, a new process computes with the new callee (numba's own cache would
    return the old result), and an unchanged package loads from the cache."""
    copy = tmp_path / "redres"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "_probe_kernels.py").write_text(_CALLER)
    callee = copy / "_callee_kernels.py"
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "REDRES_CACHE_DIR": str(tmp_path / "c")}

    def run() -> tuple[float, int]:
        out = subprocess.run(
            [sys.executable, "-c", textwrap.dedent(_RUN)],
            capture_output=True, text=True, env=env, timeout=1200, check=True,
        ).stdout.split()  # fmt: skip
        return float(out[0]), int(out[1])

    callee.write_text(_CALLEE.format(value="1.0"))
    assert run() == (20.0, 0)  # compiled
    assert run() == (20.0, 1)  # loaded from the cache
    callee.write_text(_CALLEE.format(value="2.0"))
    assert run() == (30.0, 0)  # the edited callee, recompiled


def test_the_cache_falls_back_to_the_user_directory(tmp_path: Path) -> None:
    """A read-only install: the cache goes to $XDG_CACHE_HOME/redres/numba."""
    without_cache_dir = {k: v for k, v in os.environ.items() if k != "REDRES_CACHE_DIR"}
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent("""
            from pathlib import Path
            import redres._compile as jit
            jit._cache.PACKAGE = Path("/proc/redres-read-only")  # not writable
            print(jit.cache_dir())
        """)],
        capture_output=True, text=True, timeout=600, check=True,
        env={**without_cache_dir, "XDG_CACHE_HOME": str(tmp_path)},
    ).stdout.strip()  # fmt: skip
    assert out == str(tmp_path / "redres" / "numba")


@pytest.mark.skipif(not _jit.enabled(), reason="the compiled kernels are disabled")
def test_a_first_compilation_is_announced_once(tmp_path: Path) -> None:
    env = {**os.environ, "REDRES_CACHE_DIR": str(tmp_path)}
    code = "import redres, numpy as np; redres.linalg.rate_step(np.eye(2, 3), np.ones(2))"

    def stderr() -> str:
        return subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, env=env,
            timeout=1200, check=True,
        ).stderr  # fmt: skip

    first = stderr()
    assert "redres: compiling linalg._kernels kernels on first use" in first
    assert str(tmp_path) in first
    assert "compiling" not in stderr()  # cached: silent


@pytest.mark.skipif(not _jit.enabled(), reason="the compiled kernels are disabled")
def test_without_a_writable_cache_the_kernels_compile_in_memory() -> None:
    out = subprocess.run(
        [sys.executable, "-c", textwrap.dedent("""
            import numpy as np
            import redres._compile as jit, redres.linalg as rl
            print(jit.cache_dir(), round(rl.damped_pinv(np.eye(2), 1.0)[0, 0], 12))
        """)],
        capture_output=True, text=True, timeout=1200, check=True,
        env={**os.environ, "REDRES_CACHE_DIR": "/proc/redres-read-only"},
    ).stdout.split()  # fmt: skip
    assert out == ["None", "0.5"]


def test_warmup_says_what_compiles_and_how_far_and_nothing_when_cached(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """A call still running after a second is announced in a user's words, then ticks every
    TICK seconds (new lines: the test's standard error is not a terminal), then says how
    long it took; a call done at once (a cached group) prints nothing."""
    monkeypatch.setattr(_warmup, "TICK", 0.2)
    calls: list[str] = []
    total = _warmup.timed(
        [
            ("linalg", lambda: (calls.append("a"), time.sleep(3.0))),
            ("chain", lambda: calls.append("b")),
        ]
    )
    assert calls == ["a", "b"] and total >= 3.0
    err = capsys.readouterr().err.splitlines()
    assert err[0].startswith("redres: compiling inverses and projectors (linalg) for its first use")
    ticks = [line for line in err if line.startswith("redres:   ... ")]
    assert len(ticks) >= 2 and all(line.split()[2].isdigit() for line in ticks)
    # the time it took, as measured (at least the 3 s slept; more on a loaded machine)
    took = re.fullmatch(
        r"redres: compiled inverses and projectors \(linalg\) in (\d+\.\d) s .*", err[-1]
    )
    assert took is not None and float(took.group(1)) >= 3.0, err[-1]
    assert len(err) == 2 + len(ticks)  # nothing about the cached "chain"
    assert _warmup.timed([("quiet", lambda: time.sleep(1.2))], quiet=True) >= 1.2
    assert capsys.readouterr().err == ""


def test_progress_says_when_compiling_takes_longer_than_its_estimate(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Ticks say "N s of about E s on one core" while within the estimate, then that it runs
    longer than an idle core takes (a busy machine), never "12 s of about 5 s". The clock
    the ticks read is a counter (one second a reading), so no wall time is asserted."""
    readings = iter(range(10_000))
    clock = types.SimpleNamespace(perf_counter=lambda: float(next(readings)))
    monkeypatch.setattr(_warmup, "time", clock)
    monkeypatch.setattr(_warmup, "TICK", 0.01)
    group = types.SimpleNamespace(cold_estimate=lambda: 2.5)
    monkeypatch.setattr(_jit, "groups", lambda: {"linalg": group})
    err: list[str] = []
    with _warmup._progress("linalg", quiet=False):
        deadline = time.monotonic() + 120.0  # generous: only how many ticks matters
        while sum(line.startswith("redres:   ... ") for line in err) < 4:
            assert time.monotonic() < deadline, err
            time.sleep(0.02)
            err += capsys.readouterr().err.splitlines()
    ticks = [line for line in err if line.startswith("redres:   ... ")]
    assert err[0].endswith("for its first use, about 2 s on one core...")  # 2.5 s, rounded
    assert ticks[:2] == ["redres:   ... 1 s of about 2 s on one core",
                         "redres:   ... 2 s of about 2 s on one core"]  # fmt: skip
    assert ticks[2] == "redres:   ... 3 s, longer than the 2 s it takes on an idle core"
    assert all("of about" not in line for line in ticks[2:])


def test_import_redres_loads_only_what_a_program_touches() -> None:
    """``import redres`` imports neither numba nor SciPy's linear algebra (0.2 s each; the
    compiled paths load them on first use) nor the controller, torque laws or viewer; each
    public name then loads its module on first access."""
    code = """
import json, sys
import redres
before = sorted(m for m in ("numba", "scipy.linalg", "redres.control", "redres.dynamics",
                            "redres.viewer", "redres._warmup") if m in sys.modules)
objects = {name: type(getattr(redres, name)).__name__ for name in redres.__all__}
after = [m for m in ("redres.control", "redres.dynamics", "redres.viewer") if m in sys.modules]
print(json.dumps([before, objects, after, sorted(set(redres.__all__) - set(dir(redres)))]))
"""
    env = {k: v for k, v in os.environ.items() if k != "REDRES_DISABLE_JIT"}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          env=env, timeout=600)  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    before, objects, after, missing = json.loads(proc.stdout)
    assert before == []
    assert objects["Controller"] == "type" and objects["control"] == "module"
    assert objects["ik"] == "function" and objects["run"] == "function"
    assert after == ["redres.control", "redres.dynamics", "redres.viewer"]
    assert missing == []
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        redres.nonexistent  # noqa: B018


def test_a_first_use_waits_for_what_its_module_imports() -> None:
    """A kernel module's first compilation compiles the kernel modules it imports: the
    estimate sums their groups' figures, once each, leaving out what is cached."""
    needed = _estimates.needs("redres.ik._kernels")
    assert needed[0] == "redres.ik._kernels"
    assert {
        "redres.robot._chain_kernels",
        "redres.linalg._kernels",
        "redres.linalg._dense_kernels",
        "redres.linalg._eigen_kernels",
    } <= set(needed)
    assert "redres.control._kernels" not in needed
    assert set(needed) <= set(_cache.kernel_modules())
    figures = {m: float(i + 1) for i, m in enumerate(_cache.kernel_modules())}
    cold = _estimates.cold_seconds(figures, ("redres.ik._kernels",), lambda name: False)
    assert cold == sum(figures[m] for m in needed) > figures[needed[0]]
    both = set(needed) | set(_estimates.needs("redres.batch._kernels"))  # counted once each
    names = ("redres.ik._kernels", "redres.batch._kernels")
    assert _estimates.cold_seconds(figures, names, lambda name: False) == sum(
        figures[m] for m in both
    )
    only_ik = _estimates.cold_seconds(
        figures, ("redres.ik._kernels",), lambda name: name != "redres.ik._kernels"
    )
    assert only_ik == figures["redres.ik._kernels"]
    declared = {m for g in _warmup.groups().values() for m in g.modules}
    assert declared == set(_cache.kernel_modules())  # every module has a figure


def test_an_owner_without_numba_says_what_needs_it_and_what_to_do(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    from redres.errors import MissingDependencyError
    from redres.ik import analytic
    from redres.robot import chain

    for group in (analytic.KERNELS, chain.KERNELS):
        monkeypatch.setattr(group, "module", lambda *a, **k: None)  # numba not importable
    with pytest.raises(MissingDependencyError, match=r"^analytic IK: numba .* REDRES_DISABLE_JIT"):
        analytic._module()
    with pytest.raises(MissingDependencyError, match="or use Robot.fk and Robot.jacobian$"):
        chain._module()


@pytest.mark.skipif(not _jit.enabled(), reason="the compiled kernels are disabled")
@pytest.mark.parametrize("damage", ["truncate data", "flip data", "truncate index"])
def test_a_damaged_cache_file_is_discarded_and_compiled_again(tmp_path: Path, damage: str) -> None:
    """One damaged compiled-code file made every later run fail with a raw traceback
    (a truncated pickle, LLVM's bitcode error): now it is discarded with one line, the
    kernel compiled again, and the run after that loads it silently."""
    copy = tmp_path / "redres"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "_probe_kernels.py").write_text(_CALLER)
    (copy / "_callee_kernels.py").write_text(_CALLEE.format(value="1.0"))
    env = {**os.environ, "PYTHONPATH": str(tmp_path), "REDRES_CACHE_DIR": str(tmp_path / "c")}

    def run() -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-c", textwrap.dedent(_RUN)],
            capture_output=True, text=True, env=env, timeout=1200, check=False,
        )  # fmt: skip

    assert run().stdout.split() == ["20.0", "0"]  # compiled
    folder = tmp_path / "c" / "redres._probe_kernels"
    suffix = ".nbi" if "index" in damage else ".nbc"
    (victim,) = [p for p in folder.iterdir() if p.name.endswith(suffix)]
    data = victim.read_bytes()
    if damage.startswith("truncate"):
        victim.write_bytes(data[: len(data) // 3])
    else:
        victim.write_bytes(data[:-40] + bytes(b ^ 0xFF for b in data[-40:]))
    damaged = run()
    assert damaged.returncode == 0 and damaged.stdout.split() == ["20.0", "0"], damaged.stderr
    assert "Traceback" not in damaged.stderr
    assert "a damaged compiled-code file of redres._probe_kernels.outer" in damaged.stderr
    again = run()
    assert again.stdout.split() == ["20.0", "1"] and "damaged" not in again.stderr


def test_a_lock_left_by_a_dead_compiler_does_not_stop_compiling_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The background compiler's lock file names a process id; once that compiler is
    gone, a later process may have the id (after a reboot): a live process that is not
    the compiler no longer holds the lock (it stopped compiling behind for good)."""
    from redres._compile import _background

    lock = tmp_path / "compiling-x.pid"
    monkeypatch.setattr(_background, "_lock_file", lambda: lock)
    code = "import time; time.sleep(120)"
    other = subprocess.Popen([sys.executable, "-c", code])
    compiler = subprocess.Popen([sys.executable, "-c", code, "redres._warmup", "--behind", "x"])
    deadline = time.monotonic() + 60  # its command line in /proc (set at its exec)
    while not _background._is_compiler(compiler.pid) and time.monotonic() < deadline:
        time.sleep(0.05)
    try:
        old = time.time() - 3600
        lock.write_text(str(other.pid))
        assert _background._lock_holder() == other.pid  # just written: the starter's id
        os.utime(lock, (old, old))
        assert _background._lock_holder() is None  # an hour old, not a compiler: stale
        assert _background._take_lock() and int(lock.read_text()) == os.getpid()
        lock.write_text(str(compiler.pid))
        os.utime(lock, (old, old))
        assert _background._lock_holder() == compiler.pid  # a compiler, however old
        assert not _background._take_lock()
    finally:
        for process in (other, compiler):
            process.kill()
            process.wait()
    assert _background._lock_holder() is None  # dead
