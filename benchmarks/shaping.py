"""Command shaping on the Panda: redres' shaper next to Ruckig, and what shaping costs a
closed loop, in one run.

1. **One cycle.** The same stream of wanted joint velocities (a new random target every
   40 ms, up to 1.5x the velocity limits) shaped to the Panda's published velocity,
   acceleration and jerk limits at 1 kHz by ``redres.control.CommandShaper`` and by
   Ruckig's online generator (velocity interface, joints not synchronised: each joint
   time-optimal, as the shaper). Median µs per cycle from interleaved batches, the
   commands a robot would refuse (``redres.testing.command_violations``) and the mean lag
   behind the wanted velocity.
2. **The closed loop.** The random Panda runs of ``tests/control/test_shaping.py``
   (``random_run``: the built-in joint-limit-circle scenario's start and circle, or a
   random start and circle with a ramp; one of its kinematic schemes, a gain of 10–100/s,
   the robot started 1–5 mrad per joint away from the trajectory's start), each with and
   without shaping: runs whose commands break a limit, and the position error over the
   whole run and after its first 0.25 s.

Run: ``python benchmarks/shaping.py [--runs 200] [--quick]``.
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
sys.path.insert(0, str(Path(__file__).parents[1] / "tests" / "control"))
from _common import interleaved, load_text, machine, median, table
from test_shaping import random_run  # the runs the test checks

import redres as rr
from redres.models.franka import PANDA
from redres.scenarios.spec import builtin
from redres.testing import command_violations

DT = 1e-3
LIMITS = (np.array(PANDA.qd_max), np.array(PANDA.qdd_max), np.array(PANDA.qddd_max))


def _wanted(rng: np.random.Generator, cycles: int) -> np.ndarray:
    v = LIMITS[0]
    targets = rng.uniform(-1.5, 1.5, (cycles // 40 + 1, 7)) * v
    return np.ascontiguousarray(np.repeat(targets, 40, axis=0)[:cycles])


def _ruckig() -> object | None:
    try:
        import ruckig
    except ImportError:
        return None
    return ruckig


def one_cycle(cycles: int) -> str:
    """Section 1: per-cycle time, refused commands and lag of each shaper."""
    wanted = _wanted(np.random.default_rng(0), cycles)
    shaper = rr.control.CommandShaper(*LIMITS, DT)
    streams = {"redres CommandShaper": np.array([shaper(u) for u in wanted])}
    contenders = {}
    state = {"k": 0}

    def redres_cycle() -> None:
        state["k"] = (state["k"] + 1) % cycles
        shaper(wanted[state["k"]])

    contenders["redres CommandShaper"] = redres_cycle
    ruckig = _ruckig()
    if ruckig is not None:
        otg = ruckig.Ruckig(7, DT)  # type: ignore[attr-defined]
        inp, out = ruckig.InputParameter(7), ruckig.OutputParameter(7)  # type: ignore[attr-defined]
        inp.control_interface = ruckig.ControlInterface.Velocity  # type: ignore[attr-defined]
        inp.synchronization = ruckig.Synchronization.No  # type: ignore[attr-defined]
        aim = 1.0 - rr.control.shaping.MARGIN  # the same margin inside each limit
        inp.max_velocity, inp.max_acceleration, inp.max_jerk = (list(x * aim) for x in LIMITS)
        v_aim = LIMITS[0] * aim
        inp.current_position = inp.current_velocity = inp.current_acceleration = [0.0] * 7
        inp.target_acceleration = [0.0] * 7

        def ruckig_cycle(u: np.ndarray | None = None) -> list[float]:
            if u is None:
                state["k"] = (state["k"] + 1) % cycles
                u = wanted[state["k"]]
            inp.target_velocity = np.clip(u, -v_aim, v_aim).tolist()
            otg.update(inp, out)
            out.pass_to_input(inp)
            return list(out.new_velocity)

        streams["Ruckig (velocity, not synchronised)"] = np.array([ruckig_cycle(u) for u in wanted])
        contenders["Ruckig (velocity, not synchronised)"] = ruckig_cycle
    times = interleaved(contenders, rounds=5, batch=500, batches=5)
    base = median(times["redres CommandShaper"])
    rows = []
    for name, stream in streams.items():
        refused = len(command_violations(stream, DT, LIMITS))
        lag = float(np.mean(np.abs(stream - np.clip(wanted, -LIMITS[0], LIMITS[0]))))
        t = median(times[name])
        rows.append([name, f"{t:.2f}", f"{t / base:.1f}x", str(refused), f"{lag:.4f}"])
    note = (
        "" if ruckig is not None else "\n\nRuckig is not installed (`pip install ruckig`): skipped."
    )
    head = ["shaper", "median µs / cycle", "time / redres", "refused commands", "mean lag rad/s"]
    return table(head, rows) + note


def closed_loop(runs: int, duration: float) -> str:
    """Section 2: random Panda runs with and without shaping."""
    spec = builtin("panda_joint_limit_circle")
    refused = {False: 0, True: 0}
    late = {False: 0, True: 0}  # runs with a refused command after the first 100 ms
    err: dict[bool, list[tuple[float, float, float]]] = {False: [], True: []}
    settle = int(0.25 / DT)
    for seed in range(runs):
        for shaping in (False, True):
            log = random_run(seed, spec, shaping, duration)
            found = command_violations(log.qd, DT, LIMITS)
            refused[shaping] += bool(found)
            late[shaping] += any(v.cycle >= 100 for v in found)
            e = log.position_error
            late_e = e[settle:]
            err[shaping].append((float(e.max()), float(late_e.max()),
                                 float(np.sqrt(late_e @ late_e / late_e.size))))  # fmt: skip
        print(f"run {seed + 1}/{runs}", file=sys.stderr, end="\r")  # fmt: skip
    print(file=sys.stderr)
    rows = []
    for shaping in (False, True):
        e = np.array(err[shaping]) * 1e3
        rows.append([
            "shaped" if shaping else "not shaped", f"{refused[shaping]} / {runs}",
            f"{late[shaping]} / {runs}",
            f"{np.median(e[:, 0]):.3f}", f"{e[:, 0].max():.3f}",
            f"{np.median(e[:, 1]):.4f}", f"{e[:, 1].max():.4f}", f"{np.median(e[:, 2]):.4f}",
        ])  # fmt: skip
    cost = (np.array(err[True]) - np.array(err[False])) * 1e3
    head = ["commands", "runs refused", "refused after 100 ms", "max error mm (median)",
            "max error mm (worst)",
            f"max after {settle} ms (median)", f"max after {settle} ms (worst)",
            f"RMS after {settle} ms (median)"]  # fmt: skip
    return table(head, rows) + (
        f"\n\nShaping's cost per run (shaped − not shaped), mm: max error median "
        f"{np.median(cost[:, 0]):+.4f}, worst {cost[:, 0].max():+.4f}; max after "
        f"{settle} ms median {np.median(cost[:, 1]):+.5f}, worst {cost[:, 1].max():+.5f}."
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200, help="closed-loop runs (default 200)")
    parser.add_argument("--duration", type=float, default=1.0, help="s per run (default 1)")
    parser.add_argument("--quick", action="store_true", help="20 runs of 0.5 s")
    args = parser.parse_args()
    runs, duration = (20, 0.5) if args.quick else (args.runs, args.duration)
    before = os.getloadavg()
    rr.control.CommandShaper(*LIMITS, DT)(np.zeros(7))  # compile (or load) the kernel first
    first = one_cycle(20_000)
    second = closed_loop(runs, duration)
    after = os.getloadavg()
    print("## Command shaping (Panda limits, 1 kHz)\n")
    print(f"{machine()}; {load_text(before, after)}\n")
    print("### One cycle, 7 joints\n")
    print(first)
    print(f"\n### Closed loop: {runs} random runs of {duration:g} s, with and without shaping\n")
    print(second)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
