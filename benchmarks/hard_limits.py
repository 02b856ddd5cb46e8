"""Hard limits (issue 8): the QP and SNS schemes on 10,000 random steps and the Panda circle.

1. 10,000 random viable states of the Panda near its limits with random task velocities
   (the generator of tests/resolution/test_sns.py, seeded): for each scheme, the largest
   limit violation, the task residual where the task is feasible (feasibility decided by
   SciPy's HiGHS), SNS's scale against HiGHS' largest feasible scale, and the median time
   of ``scheme.step`` by path.
2. The Panda joint-limit circle, 10 s at 1 kHz: violations, tracking, loop step time.

Run: ``python benchmarks/hard_limits.py`` (about a minute).
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
from scipy.optimize import linprog

sys.path.insert(0, str(Path(__file__).parent))

from _common import machine, table

import redres as rr
from redres.resolution import (
    JointLimits,
    PseudoInverseScheme,
    QPScheme,
    SNSScheme,
    run_violation,
    step_violation,
)
from redres.scenarios.spec import builtin
from redres.testing import random_limit_states

DT = 1e-3
STEPS = 10_000


def highs_scale(J: np.ndarray, xd: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> float | None:
    """Largest s in [0, 1] with J q̇ = s ẋ in the box (None: none), by HiGHS."""
    c = np.zeros(J.shape[1] + 1)
    c[-1] = -1.0
    res = linprog(c, A_eq=np.hstack([J, -xd[:, None]]), b_eq=np.zeros(J.shape[0]),
                  bounds=[*zip(lo, hi), (0.0, 1.0)], method="highs")  # fmt: skip
    return float(res.x[-1]) if res.status == 0 else None


def timed(scheme: QPScheme | SNSScheme, robot: rr.Robot, states: list) -> list:
    """``scheme.step`` on every state (previous velocity set first): results and µs."""
    out = []
    for q, prev, J, xd in states:
        scheme.qd_prev = prev
        t0 = time.perf_counter_ns()
        result = scheme.step(robot, q, J, xd)
        out.append((result, (time.perf_counter_ns() - t0) / 1e3))
    return out


def random_steps(robot: rr.Robot) -> None:
    lim = JointLimits.from_robot(robot)
    states = random_limit_states(robot, np.random.default_rng(8), STEPS)
    rows = []
    for scheme in (QPScheme(dt=DT), SNSScheme(dt=DT)):
        timed(scheme, robot, states[:500])  # warm-up
        runs = timed(scheme, robot, states)
        worst, residual, scale_err, mismatch = 0.0, 0.0, 0.0, 0
        paths: dict[str, list[float]] = {}
        for (q, prev, J, xd), (r, elapsed) in zip(states, runs):
            path = getattr(r.details, "method", "exact" if r.feasible else "least violating")
            paths.setdefault(path, []).append(elapsed)
            worst = max(worst, step_violation(lim, q, r.qd, prev, DT).worst)
            s_ref = highs_scale(J, xd, *r.details.bounds)
            mismatch += (s_ref is not None and s_ref >= 1.0 - 1e-9) != r.feasible
            if r.feasible:
                residual = max(residual, float(np.linalg.norm(J @ r.qd - xd)))
            if isinstance(scheme, SNSScheme) and s_ref is not None:
                scale_err = max(scale_err, abs(r.details.scale - s_ref))
        every = [t for _, t in runs]
        timing = ", ".join(f"{p} {len(t)} × {np.median(t):.1f}" for p, t in paths.items())
        sns = isinstance(scheme, SNSScheme)
        rows.append([scheme.name, f"{worst:.1e}", f"{residual:.1e}", str(mismatch),
                     f"{scale_err:.1e}" if sns else "-", f"{np.median(every):.1f}",
                     timing])  # fmt: skip
    print(f"{STEPS} random steps near the limits (Panda), {machine()}")
    headers = ["scheme", "max violation", "max residual if feasible", "feasible ≠ HiGHS",
               "|s − s_HiGHS|", "step median µs", "by path: count × median µs"]  # fmt: skip
    print(table(headers, rows))


def circle() -> None:
    scenario = builtin("panda_joint_limit_circle")
    robot = scenario.robot
    lim = JointLimits.from_robot(robot)
    rows = []
    for scheme in (PseudoInverseScheme(), QPScheme(dt=DT), SNSScheme(dt=DT)):
        log = rr.control.run(robot, scenario.task(), scenario.trajectory, scheme,
                             q0=scenario.q0, dt=DT)  # fmt: skip
        v, s = run_violation(lim, log.q, log.qd, DT), log.summary()
        rows.append([scheme.name, f"{v.position:.1e}", f"{v.velocity:.1e}",
                     f"{v.acceleration:.1e}", f"{1e3 * s['max_position_error_m']:.2f}",
                     f"{1e3 * s['rms_position_error_m']:.3f}",
                     f"{s['min_joint_limit_margin_rad']:.4f}",
                     f"{s['step_time_us_median']:.1f}"])  # fmt: skip
    print(f"\nPanda joint-limit circle, {scenario.trajectory.duration:.0f} s at 1 kHz")
    headers = ["scheme", "position viol rad", "velocity viol rad/s", "accel viol rad/s/step",
               "max err mm", "rms err mm", "min margin rad", "loop step median µs"]  # fmt: skip
    print(table(headers, rows))


def main() -> int:
    robot = rr.models.panda()
    random_steps(robot)
    circle()
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
