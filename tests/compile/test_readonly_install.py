"""A read-only, non-editable install run by an unprivileged user (issue 18, item 9).

Such an install cannot cache compiled kernels next to its sources (the first candidate of
:func:`redres._compile.cache_dir`); it must fall back to the per-user cache
(``$XDG_CACHE_HOME/redres/numba``, by default ``~/.cache/redres/numba``), so that each
kernel compiles at most once across processes, not in every process (40–51 s per run
before). The package is installed with ``pip install --no-deps --target`` from a copy of
the sources, made read-only, and imported by two processes of the user ``nobody``; numba's
dispatcher statistics count the compilations (``cache_misses``) and the loads
(``cache_hits``). Only the kernels of one call (``rr.linalg.damped_pinv``) compile.

The interpreter and its environment may live where ``nobody`` cannot search
(``/root/.pyenv``, a checkout under a private folder): the processes then keep
``CAP_DAC_READ_SEARCH`` only — reading and searching anywhere, writing nowhere that
``nobody`` may not (the read-only install among them).
"""

from __future__ import annotations

import json
import os
import pwd
import shutil
import stat
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]

_SCRIPT = """
import json, sys
sys.path.insert(0, sys.argv[1])
import numpy as np
import redres as rr
import redres._compile as jit
rr.linalg.damped_pinv(np.eye(3, 4), 0.1)
kernels = [d for ds in jit._dispatchers.values() for d in ds]
print(json.dumps({
    "file": rr.__file__,
    "cache": str(jit.cache_dir()),
    "misses": sum(sum(d.stats.cache_misses.values()) for d in kernels),
    "hits": sum(sum(d.stats.cache_hits.values()) for d in kernels),
}))
"""


#: What the unprivileged process must find: this interpreter, with this environment's
#: packages (the probe prints its prefix; numpy and numba must import).
_PROBE = "import sys, numpy, numba; print(sys.prefix)"


def _unprivileged_prefix() -> list[str]:
    """The command prefix that runs this interpreter, with this environment's packages, as
    ``nobody``; or a skip saying why that cannot be arranged.

    Where ``nobody`` cannot reach the interpreter or its environment (a checkout under a
    private folder such as root's home or a ``mktemp -d`` folder; issue 43), the process
    keeps ``CAP_DAC_READ_SEARCH``: it reads and searches anywhere and writes nowhere that
    ``nobody`` may not. A process that starts but finds another Python (the path of an
    unreachable interpreter can resolve to the system's) is not taken for this one."""
    if os.name != "posix" or os.geteuid() != 0:
        pytest.skip("needs root to switch to an unprivileged user (run as root, e.g. in CI)")
    try:
        pwd.getpwnam("nobody")
    except KeyError:
        pytest.skip("no user 'nobody' on this machine")
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        pytest.skip("setpriv (util-linux) is not installed")
    plain = [setpriv, "--reuid=nobody", "--regid=nogroup", "--clear-groups"]
    caps = ["--inh-caps=+dac_read_search", "--ambient-caps=+dac_read_search"]
    why = ""
    for prefix in (plain, plain + caps):
        probe = subprocess.run([*prefix, sys.executable, "-c", _PROBE], capture_output=True,
                               text=True, timeout=600, cwd="/")  # fmt: skip
        found = probe.stdout.strip()
        if probe.returncode == 0 and found == sys.prefix:
            return prefix
        why = probe.stderr.strip().splitlines()[-1:] or [f"found the Python of {found}"]
    pytest.skip(f"cannot run {sys.executable} with its packages as nobody: {why[0][-200:]}")


def _tree(root: Path) -> set[str]:
    return {str(p.relative_to(root)) for p in root.rglob("*")}


@pytest.fixture
def scratch() -> Iterator[Path]:
    """A folder that ``nobody`` can search (pytest's tmp_path is private to root)."""
    path = Path(tempfile.mkdtemp(prefix="redres-ro-"))
    path.chmod(0o755)
    try:
        yield path
    finally:
        for p in path.rglob("*"):  # the install is read-only: make it removable again
            if not p.is_symlink():
                p.chmod(p.stat().st_mode | stat.S_IWUSR)
        shutil.rmtree(path, ignore_errors=True)


def test_read_only_install_compiles_each_kernel_once_across_processes(scratch: Path) -> None:
    prefix = _unprivileged_prefix()
    source = scratch / "source"
    for name in ("pyproject.toml", "README.md", "LICENSE"):
        (source / name).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(REPO / name, source / name)
    shutil.copytree(REPO / "src", source / "src", ignore=shutil.ignore_patterns("__pycache__"))
    site = scratch / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps",
         "--no-compile", "--quiet", "--target", str(site), str(source)],
        check=True, capture_output=True, timeout=1200,
    )  # fmt: skip
    assert not (site / "redres" / "__editable__").exists()
    for p in site.rglob("*"):  # read-only for everyone, readable by everyone
        p.chmod(0o555 if p.is_dir() else 0o444)
    site.chmod(0o555)
    before = _tree(site)
    home = scratch / "home"
    home.mkdir()
    os.chown(home, pwd.getpwnam("nobody").pw_uid, pwd.getpwnam("nobody").pw_gid)
    env = {
        "PATH": os.environ.get("PATH", "/usr/bin:/bin"),
        "HOME": str(home),
        "REDRES_COMPILE": "foreground",  # compile in the process, no background helper
        "PYTHONDONTWRITEBYTECODE": "1",
    }
    runs = []
    for _ in range(2):
        done = subprocess.run(
            [*prefix, sys.executable, "-c", _SCRIPT, str(site)],
            capture_output=True, text=True, env=env, timeout=1200, cwd=scratch,
        )  # fmt: skip
        assert done.returncode == 0, done.stderr[-2000:]
        runs.append(json.loads(done.stdout.splitlines()[-1]))
    first, second = runs
    assert first["file"] == str(site / "redres" / "__init__.py")
    assert first["cache"] == str(home / ".cache" / "redres" / "numba")
    assert first["misses"] > 0  # the first process compiled (into the per-user cache)
    assert second["misses"] == 0 and second["hits"] > 0, second  # the second only loaded
    assert _tree(site) == before  # nothing written into the install
