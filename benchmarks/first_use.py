"""First use: how long a new user waits for the first answer, cold and warm.

Every case runs in fresh Python processes: *cold* with an empty compiled-code cache
(``REDRES_CACHE_DIR`` set to a new, empty folder, as on a fresh install), then *warm*,
three times, in new processes with the cache the first one filled (after the background
compilation the cold run started has finished). The time is measured inside the child,
from before its first import to its first answer, so interpreter start-up (the same for
every library) is left out. The peers' first solves run the same way:

* ``import redres`` alone;
* the README example (Panda, Jacobian, ``damped_pinv``);
* the first step of the compiled controller (``rr.Controller``, gradient projection with a
  joint-limit cost, the 1 kHz loop of ``examples/09_controller_loop.py``);
* the first hard-limit step (``SNSScheme.step``);
* the first ``rr.ik`` on a reachable Panda pose;
* pink's and mink's first ``solve_ik`` (frame + posture task, DAQP) and robotics-toolbox's
  first ``ik_LM``, each including its own imports and model loading.

Run from the repository root: ``python benchmarks/first_use.py`` (``--repeat N`` runs each
case N times and reports the median; ``--switch-repeat N``, 3 by default, each switch loop).
"""

from __future__ import annotations

import argparse
import json
import os
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

from _common import machine, table  # noqa: E402

_PANDA = """
import redres as rr
robot = rr.models.panda()
q = robot.neutral()
"""

CASES: dict[str, str] = {
    "import redres": "import redres",
    "README example": """
import numpy as np
import redres as rr
robot = rr.models.panda()
q = robot.neutral()
J = robot.jacobian(q)
qd = rr.linalg.damped_pinv(J, 0.01) @ np.array([0.1, 0, 0, 0, 0, 0])
""",
    "first controller step": _PANDA
    + """
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme
from redres.tasks import FrameTask
scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0, damping=0.01)
controller = rr.Controller(robot, FrameTask(), scheme, gain=50.0, dt=1e-3)
controller.step(q)
""",
    "first hard-limit step": _PANDA
    + """
import numpy as np
from redres.resolution import SNSScheme
SNSScheme(dt=1e-3).step(robot, q, robot.jacobian(q), np.zeros(6))
""",
    "first rr.ik": _PANDA
    + """
rr.ik(robot, robot.fk(q + 0.2), seed=0)
""",
    "pink first solve_ik": f"""
import sys
sys.path.insert(0, {str(HERE)!r})
import numpy as np
import pinocchio as pin
import pink
from pink import tasks
import redres as rr
robot = rr.models.panda()
q = robot.neutral()
model = pin.Model(robot.model)
configuration = pink.Configuration(model, model.createData(), q.copy())
frame = tasks.FrameTask("tcp", position_cost=1.0, orientation_cost=1.0)
T = robot.fk(q + 0.1)
frame.set_target(pin.SE3(T[:3, :3], T[:3, 3]))
posture = tasks.PostureTask(cost=1e-3)
posture.set_target(q)
pink.solve_ik(configuration, [frame, posture], 1e-3, solver="daqp", damping=1e-6)
""",
    "mink first solve_ik": f"""
import sys
sys.path.insert(0, {str(HERE)!r})
import mink
import mujoco
import peers
model = peers.mujoco_panda(mujoco)
configuration = mink.Configuration(model)
frame = mink.FrameTask("panda_hand_tcp", "body", position_cost=1.0, orientation_cost=1.0)
frame.set_target(configuration.get_transform_frame_to_world("panda_hand_tcp", "body"))
posture = mink.PostureTask(model, cost=1e-3)
posture.set_target(configuration.q)
limits = [mink.ConfigurationLimit(model)]
mink.solve_ik(configuration, [frame, posture], 1e-3, "daqp", damping=1e-6, limits=limits)
""",
    "robotics-toolbox first ik_LM": f"""
import sys
import tempfile
import time
from pathlib import Path
sys.path.insert(0, {str(HERE)!r})
import numpy as np
import roboticstoolbox as rtb
import peers
ets = peers.rtb_robot(rtb, peers.write_urdf("panda", Path(tempfile.mkdtemp()))).ets(
    end=peers.TIP_LINK["panda"])
q = np.array([0.0, -0.785, 0.0, -2.356, 0.0, 1.571, 0.785])
ets.ik_LM(ets.fkine(q + 0.2).A, q0=q, ilimit=30, slimit=1, tol=1e-13)
""",
}

#: Loops that step until the compiled path is taken, on a cold cache (compiling behind),
#: against the first step compiled on the caller's path (``REDRES_COMPILE=foreground``).
SWITCH: dict[str, str] = {
    "controller (fused path)": CASES["first controller step"].replace(
        "controller.step(q)\n",
        "while True:\n    q = controller.step(q)\n    if controller.compiled:\n        break\n",
    ),
    "SNS hard-limit step": _PANDA
    + """
import numpy as np
from redres.resolution import SNSScheme
scheme, J = SNSScheme(dt=1e-3), robot.jacobian(q)
while True:
    scheme.step(robot, q, J, np.zeros(6))
    if not scheme._pending:
        break
""",
}
# A real-time loop does not spin: the same loops paced at 1 kHz (a sleep of 1 ms per step),
# so that the caller's loop leaves the other core to the background compiler.
SWITCH.update({
    f"{name}, paced at 1 kHz": body.replace(
        "while True:\n", "import time as _pace\nwhile True:\n    _pace.sleep(1e-3)\n")
    for name, body in list(SWITCH.items())
})  # fmt: skip

#: Warm runs after each cold one (a second is cheap; the median of three steadies it).
WARM_RUNS = 3

_WRAP = """
import time as _t
_t0, _wall = _t.perf_counter(), _t.time()
{body}
print("FIRST_USE_SECONDS", _t.perf_counter() - _t0, _wall)
"""


def marker_lag(cache: Path, started: float, seconds: float) -> float | None:
    """Seconds from the background compiler's last marker before a loop's switch (the
    kernel it waited for, cached) to the switch, from the markers' file times."""
    switched = started + seconds
    times = [m.stat().st_mtime for m in cache.glob("*/compiled-*")]
    before = [t for t in times if t <= switched + 0.005]
    return switched - max(before) if before else None


def time_case(
    body: str, cache: Path, policy: str = "background", lags: list[float] | None = None
) -> float | None:
    """Seconds from first import to first answer in a fresh process; None if it failed
    (a peer not installed). ``lags``: append the :func:`marker_lag` of the run."""
    env = dict(os.environ, REDRES_CACHE_DIR=str(cache), REDRES_COMPILE=policy)
    proc = subprocess.run(
        [sys.executable, "-c", _WRAP.format(body=body)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
    )
    for line in proc.stdout.splitlines():
        if line.startswith("FIRST_USE_SECONDS"):
            seconds, started = map(float, line.split()[1:3])
            lag = marker_lag(cache, started, seconds) if lags is not None else None
            if lag is not None and lags is not None:
                lags.append(lag)
            return seconds
    last = (proc.stderr.strip().splitlines() or ["no output"])[-1]
    print(f"  note: failed ({last})", file=sys.stderr)
    return None


def wait_for_background(cache: Path, limit: float = 900.0) -> None:
    """Wait until the background compilation a cold run started has filled ``cache`` (its
    lock file is gone), so that the warm run finds the cache complete and the next case
    does not share the cores with it."""
    deadline = time.monotonic() + limit
    while list(cache.glob("compiling-*.pid")) and time.monotonic() < deadline:
        time.sleep(0.5)


def stop_background(cache: Path) -> None:
    """End the background compilation a switch loop started (its own session, the lock
    file's process id): the loop has switched, and the rest of the kernels would take the
    cores from the next run for minutes (the cache is thrown away)."""
    for lock in cache.glob("compiling-*.pid"):
        try:
            os.killpg(int(lock.read_text()), signal.SIGTERM)
        except (ValueError, ProcessLookupError, PermissionError):
            pass
        lock.unlink(missing_ok=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs per case (median)")
    parser.add_argument("--json", type=Path, help="also write the figures here")
    parser.add_argument("--switch-only", action="store_true", help="only the switch loops")
    parser.add_argument("--switch-repeat", type=int, default=3,
                        help="runs per switch loop and policy, interleaved (median)")  # fmt: skip
    args = parser.parse_args()
    results: dict[str, dict[str, float | None]] = {}
    for name, body in {} if args.switch_only else CASES.items():
        cold: list[float] = []
        warm: list[float] = []
        for _ in range(args.repeat):
            with tempfile.TemporaryDirectory(prefix="redres-first-use-") as tmp:
                for sink in (cold, *[warm] * WARM_RUNS):
                    seconds = time_case(body, Path(tmp))
                    if seconds is not None:
                        sink.append(seconds)
                    wait_for_background(Path(tmp))
        results[name] = {
            "cold_s": statistics.median(cold) if cold else None,
            "warm_s": statistics.median(warm) if warm else None,
        }
        print(f"  {name}: {results[name]}", file=sys.stderr)

    def cell(value: float | None) -> str:
        return "not installed" if value is None else f"{value:.2f}"

    load = os.getloadavg()
    print(f"First answer in a fresh process, {machine()}; load average {load[0]:.2f}.")
    print("Seconds from the first import to the first answer; cold: empty compiled-code "
          f"cache (median of {args.repeat}); warm: the cache the cold run filled (median of "
          f"{args.repeat * WARM_RUNS}).\n")  # fmt: skip
    if results:
        rows = [[name, cell(r["cold_s"]), cell(r["warm_s"])] for name, r in results.items()]
        print(table(["first use", "cold, s", "warm, s"], rows))
    switch: dict[str, dict[str, float | None]] = {}
    for name, body in SWITCH.items():
        runs: dict[str, list[float]] = {"background": [], "foreground": []}
        lags: list[float] = []
        for _ in range(args.switch_repeat):  # the policies interleaved: the same load for both
            for policy, sink in runs.items():
                with tempfile.TemporaryDirectory(prefix="redres-first-use-") as tmp:
                    behind = lags if policy == "background" else None
                    seconds = time_case(body, Path(tmp), policy, behind)
                    stop_background(Path(tmp))
                if seconds is not None:
                    sink.append(seconds)
        row = {policy: statistics.median(v) if v else None for policy, v in runs.items()}
        lead = [f - b for b, f in zip(runs["background"], runs["foreground"])]
        row["lead"] = statistics.median(lead) if lead else None
        row["lag"] = max(lags) if lags else None
        switch[name] = row
        print(f"  {name}: {runs}, lags {lags}", file=sys.stderr)
    print(f"\nCold cache (median of {args.switch_repeat}): seconds from the first import until the "
          "loop's step runs compiled code (compiling behind, answering through the reference "
          "path meanwhile), and until the first step returns when it compiles on the caller's "
          "path (`REDRES_COMPILE=foreground`); the lead is the second minus the first, run "
          "by run (positive: the compiled path came before a foreground compile would have "
          "ended); the last column is the longest wait, over the runs, from the background "
          "compiler's marker of the loop's kernel (its compilation done) to the switch."
          "\n")  # fmt: skip
    rows = [[name, cell(r["background"]), cell(r["foreground"]), cell(r["lead"]),
             "—" if r["lag"] is None else f"{r['lag']:.3f}"]
            for name, r in switch.items()]  # fmt: skip
    print(table(["loop", "compiled path from, s (behind)", "first step, s (foreground)",
                 "lead, s", "switch after its compilation ended, s"], rows))  # fmt: skip
    if args.json:
        args.json.write_text(json.dumps({**results, "switch": switch}, indent=2))


if __name__ == "__main__":
    main()
