"""The background compiler's helper process and the per-kernel compile lock.

For each group with :data:`redres._warmup.HELPERS`, two fresh processes on one empty cache
at once, as the background compiler runs them: the helper's precompiles and the group's
workload. The helper's argument types must be those the workload's callers pass (else it
compiles signatures nobody uses), and with the lock (:mod:`redres._compile._lock`) each
signature is compiled once across both processes: whichever comes second loads it from
the cache. Compilations are counted with numba's dispatcher statistics (cache misses per
signature).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from redres import _compile as _jit
from redres import _warmup

pytestmark = pytest.mark.skipif(not _jit.enabled(), reason="the compiled kernels are disabled")

_REPORT = """
import json
import redres._compile as jit
import redres._warmup as warm
{call}
kernels = {{(m, k) for m, k, _ in warm.HELPERS[{group!r}]}}
found = {{}}
for module, dispatchers in jit._dispatchers.items():
    for d in dispatchers:
        if (module, d.py_func.__name__) in kernels:
            key = module + "." + d.py_func.__name__
            found[key] = {{str(s): d.stats.cache_misses.get(s, 0) for s in d.signatures}}
print(json.dumps(found))
"""


@pytest.mark.parametrize("group", sorted(_warmup.HELPERS))
def test_the_helper_compiles_what_the_group_calls_once_across_processes(
    group: str, tmp_path: Path
) -> None:
    env = {**os.environ, "REDRES_CACHE_DIR": str(tmp_path), "REDRES_COMPILE": "foreground"}
    calls = {
        "helper": f"warm.helper({group!r})",
        "workload": f"warm.WORKLOADS[{group!r}]()",
    }
    procs = {}
    for name, call in calls.items():
        code = textwrap.dedent(_REPORT.format(call=call, group=group))
        procs[name] = subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE,
                                       stderr=subprocess.PIPE, text=True, env=env)  # fmt: skip
    found = {}
    for name, proc in procs.items():
        out, err = proc.communicate(timeout=900)
        assert proc.returncode == 0, err
        found[name] = json.loads(out.strip().splitlines()[-1])
    helper, workload = found["helper"], found["workload"]
    assert len(helper) == len(_warmup.HELPERS[group])
    for kernel, made in helper.items():
        assert len(made) == 1, kernel
        [(signature, compiled)] = made.items()
        # the workload's callers asked for the very signature the helper compiled ...
        used = workload.get(kernel, {})
        assert signature in used, (kernel, signature, list(used))
        # ... and it was compiled once across the two processes (the other loaded it)
        assert compiled + used[signature] == 1, (kernel, compiled, used[signature])


def test_a_machine_with_every_core_busy_reads_as_not_idle() -> None:
    """The helper starts only on an idle core: with a spinning process per core the
    machine's idle share stays under the helper's threshold."""
    import time

    assert 0.0 <= _jit.idle_cores(0.1) <= (os.cpu_count() or 1) + 1e-9
    spin = [sys.executable, "-c", "while True: pass"]
    spinners = [subprocess.Popen(spin) for _ in range(os.cpu_count() or 1)]
    try:
        time.sleep(0.3)
        assert _jit.idle_cores(0.3) < _warmup._IDLE_CORES
    finally:
        for proc in spinners:
            proc.kill()
            proc.wait()
