"""First use: answer at once through the reference path, compile behind, switch for good.

Each test runs fresh processes on an empty compiled-code cache (``REDRES_CACHE_DIR`` in
``tmp_path``). Compilations are counted through numba's own dispatcher statistics (cache
hits and misses), never by time.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

from redres import _compile as _jit

pytestmark = pytest.mark.skipif(not _jit.enabled(), reason="the compiled kernels are disabled")

LINALG = "redres.linalg._kernels"


def _script(*parts: str) -> str:
    return "\n".join(textwrap.dedent(part) for part in parts)


def _run(code: str, cache: Path, policy: str = "background", timeout: float = 1500) -> Any:
    """Run ``code`` in a fresh process on ``cache``; it prints one JSON line last."""
    env = {**os.environ, "REDRES_CACHE_DIR": str(cache), "REDRES_COMPILE": policy}
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True, text=True, env=env, timeout=timeout,
    )  # fmt: skip
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


_STOP_BEHIND = """
def stop_behind():
    proc = jit._background._state.get("proc")
    if proc is not None:
        proc.kill()
        proc.wait()
"""


def test_a_cold_process_answers_at_once_and_switches_when_compiled(tmp_path: Path) -> None:
    out, err = _run(
        _script(
            """
        import json, sys, time
        import numpy as np
        import redres as rr
        import redres._compile as jit
        """,
            _STOP_BEHIND,
            """
        J = rr.models.panda().jacobian(rr.models.panda().neutral())
        first = rr.linalg.damped_pinv(J, 0.01)
        compiled_at_first = any(compiled for _, compiled in jit._twins.modules)
        deadline = time.monotonic() + 400
        while not jit.groups()["linalg"].ready() and time.monotonic() < deadline:
            time.sleep(0.2)
        after = rr.linalg.damped_pinv(J, 0.01)
        module = jit.groups()["linalg"].compiled()
        hits = sum(sum(d.stats.cache_hits.values()) for d in jit._dispatchers[module.__name__])
        misses = sum(sum(d.stats.cache_misses.values())
                     for d in jit._dispatchers[module.__name__])
        stop_behind()
        print(json.dumps({"compiled_at_first": compiled_at_first,
                          "compiled": jit.is_compiled(module),
                          "hits": hits, "misses": misses,
                          "diff": float(np.abs(first - after).max())}))
        """,
        ),
        tmp_path,
    )
    assert "compiling kernels in a background process" in err
    # The first answer came from the NumPy path: no compiled kernel module was loaded (numba
    # itself may be: the caller prepares its CPU target in a thread meanwhile,
    # _compile._background.prepare).
    assert out["compiled_at_first"] is False
    assert out["compiled"] is True
    assert out["hits"] > 0 and out["misses"] == 0  # loaded what the background compiled
    assert out["diff"] <= 1e-12


def test_a_loop_that_crosses_the_switch_does_not_jump(tmp_path: Path) -> None:
    """The compiled controller in a loop while its kernels compile behind: the path it
    took each step, and the configurations, against a run compiled up front."""
    loop = _script(
        """
        import json, time
        import numpy as np
        import redres as rr
        import redres._compile as jit
        from redres.objectives import JointLimitObjective
        from redres.resolution import GradientProjectionScheme
        from redres.tasks import FrameTask
        """,
        _STOP_BEHIND,
        """
        robot = rr.models.panda()
        task = FrameTask()
        scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0, damping=0.01)
        controller = rr.Controller(robot, task, scheme, dt=1e-3)
        q = robot.neutral()
        target = robot.fk(q)
        qs, compiled = [], []
        deadline = time.monotonic() + 400
        k = 0
        while time.monotonic() < deadline:
            T = target.copy()
            T[:3, 3] += 0.05 * np.array([np.sin(1e-3 * k), 1 - np.cos(1e-3 * k), 0])
            task.set_target(T)
            q = controller.step(q)
            qs.append(q.tolist())
            compiled.append(controller.compiled)
            k += 1
            if k >= 4000 and (compiled[-1] or STEPS_FIXED):
                break
        stop_behind()
        print(json.dumps({"qs": qs, "compiled": compiled}))
        """,
    )
    crossing, _ = _run(loop.replace("STEPS_FIXED", "False"), tmp_path / "behind")
    steps = len(crossing["qs"])
    up_front, _ = _run(
        loop.replace("STEPS_FIXED", "True").replace("k >= 4000", f"k >= {steps}"),
        tmp_path / "up_front",
        policy="foreground",
    )
    assert crossing["compiled"][0] is False and crossing["compiled"][-1] is True
    switch = crossing["compiled"].index(True)
    assert all(crossing["compiled"][switch:])  # for good
    assert all(up_front["compiled"])
    import numpy as np

    gap = np.abs(np.array(crossing["qs"]) - np.array(up_front["qs"])).max()
    assert gap <= 1e-9, f"the run that switched at step {switch} departs by {gap:.1e} rad"


def test_opting_out_compiles_on_the_callers_path(tmp_path: Path) -> None:
    out, err = _run(
        textwrap.dedent("""
        import json, sys
        import numpy as np
        import redres as rr
        import redres._compile as jit
        rr.linalg.damped_pinv(np.eye(2, 3), 0.1)
        print(json.dumps({"compiled": ("redres.linalg._kernels", True) in jit._twins.modules,
                          "behind": "proc" in jit._background._state}))
        """),
        tmp_path,
        policy="foreground",
    )
    assert out == {"compiled": True, "behind": False}
    assert "compiling linalg._kernels kernels on first use" in err
    assert not list(tmp_path.glob("compiling-*"))  # no background process


GROUPS = ("linalg", "derivatives", "chain", "controller", "shaping", "dynamics", "hard limits",
          "ik", "analytic ik", "batch", "plan")  # fmt: skip


def test_warmup_fills_the_cache_so_that_a_second_process_compiles_nothing(
    tmp_path: Path,
) -> None:
    env = {**os.environ, "REDRES_CACHE_DIR": str(tmp_path)}
    first = subprocess.run(
        [sys.executable, "-m", "redres", "warmup"],
        capture_output=True, text=True, env=env, timeout=1500, check=True,
    )  # fmt: skip
    lines = first.stderr.splitlines()
    # each group that takes over a second is announced in words and closed with its time
    announced = set(re.findall(r"redres: compiling .* \((.+?)\) for its first use", first.stderr))
    closed = set(re.findall(r"redres: compiled .* \((.+?)\) in", first.stderr))
    assert announced == closed and "linalg" in closed, first.stderr  # (hard limits: a second
    # process, announced only if this one has to wait for it)
    assert closed <= set(GROUPS), first.stderr
    assert lines[-1].startswith("redres: warm-up done in"), first.stderr
    out, err = _run(
        textwrap.dedent("""
        import json
        import redres._compile as jit
        import redres._warmup as warm
        for call in warm.WORKLOADS.values():
            call()
        kernels = [d for ds in jit._dispatchers.values() for d in ds]
        print(json.dumps({
            "misses": sum(sum(d.stats.cache_misses.values()) for d in kernels),
            "hits": sum(sum(d.stats.cache_hits.values()) for d in kernels),
            "modules": sorted(jit._dispatchers),
            "uncached": [m for g in warm.groups().values() for m in g.modules if not jit.cached(m)],
        }))
        """),
        tmp_path,
    )
    assert out["misses"] == 0 and out["hits"] > 0
    assert set(out["modules"]) == set(_jit._cache.kernel_modules())
    assert out["uncached"] == []  # every module marked, those compiled into callers too
    assert "compiling" not in err


@pytest.mark.parametrize("noticed", ["on a later call", "within the first call"])
def test_a_background_compile_that_fails_falls_back_to_compiling_on_first_use(
    tmp_path: Path, noticed: str
) -> None:
    # "within the first call": the child has exited before the first call asks again
    # whether it is still compiling (a slow machine; CI once took this for numba missing)
    at_once = noticed == "within the first call"
    out, err = _run(
        textwrap.dedent(f"""
        import json, sys, time
        import numpy as np
        import redres._compile as jit
        jit.sys.executable = "/bin/false"  # the background process exits at once
        if {at_once}:
            import subprocess
            jit._POLL_SECONDS = 0.0
            popen = subprocess.Popen
            def exited(*args, **kwargs):
                proc = popen(*args, **kwargs)
                proc.wait()
                return proc
            subprocess.Popen = exited
        import redres as rr
        rr.linalg.damped_pinv(np.eye(2, 3), 0.1)
        deadline = time.monotonic() + 60
        while not jit.groups()["linalg"].ready() and time.monotonic() < deadline:
            time.sleep(0.1)
        rr.linalg.damped_pinv(np.eye(2, 3), 0.1)
        print(json.dumps({{"compiled": ("redres.linalg._kernels", True) in jit._twins.modules}}))
        """),
        tmp_path,
    )
    assert "the background compilation failed (it exited with status 1" in err
    assert "numba cannot be imported" not in err
    assert out == {"compiled": True}


def test_the_warm_up_skips_the_qp_kernels_up_front_without_the_qp_extra(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    import importlib.util

    from redres import _warmup
    from redres.errors import install_hint

    real = importlib.util.find_spec
    hidden = {"qpsolvers"}
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name in hidden else real(name, *a))  # fmt: skip
    assert _warmup.WORKLOADS["hard limits"]() == ("_kernels",)
    said = capsys.readouterr().err
    assert "QPScheme's kernels skipped" in said and install_hint("qp") in said
