"""
Position inverse kinematics
===========================

Put the tool at a pose.

Run: python examples/07_position_ik.py
"""

from __future__ import annotations

import time

import numpy as np

import redres as rr
from redres.ik import IKResult, ik
from redres.tasks import ArmAngleTask


def show(label: str, r: IKResult) -> None:
    print(
        f"  {label:28} converged={r.converged!s:5}  iterations={r.iterations:4d}  "
        f"restarts={r.restarts:2d}  position error={r.position_error:.1e} m  "
        f"orientation error={r.orientation_error:.1e} rad  ({r.time_s * 1e3:.2f} ms)"
    )


def main() -> None:
    robot = rr.models.panda()
    rng = np.random.default_rng(2026)
    q_true = robot.random_configuration(rng)
    T = robot.fk(q_true)  # a reachable 4x4 target
    ik(robot, T)  # the first call loads the compiled kernels

    print("Panda, from the ready pose:")
    result = ik(robot, T, seed=0)
    show("pose target", result)
    print("  q =", np.round(result.q, 4), " within limits:", robot.within_limits(result.q))
    show("position-only target", ik(robot, T[:3, 3], seed=0))

    q_pref = robot.neutral()
    near = ik(robot, T[:3, 3], q_preferred=q_pref, seed=0)
    show("position, closest to ready", near)
    print(f"  distance to the ready pose: {np.linalg.norm(near.q - q_pref):.3f} rad")

    iiwa = rr.models.iiwa14()
    arm = ArmAngleTask()
    q_iiwa = iiwa.random_configuration(rng, margin=0.3)
    wanted = arm.value(iiwa, q_iiwa) + 0.2
    swung = ik(iiwa, iiwa.fk(q_iiwa), arm_angle=wanted, q0=q_iiwa, seed=0)
    print("\niiwa 14, same pose, arm angle swung by 0.2 rad:")
    show("pose + arm angle", swung)
    print(f"  arm angle error: {abs(arm.value(iiwa, swung.q) - wanted):.1e} rad")

    print("\nBad input ends with converged=False, not an exception:")
    far = T.copy()
    far[:3, 3] = [5.0, 0.0, 0.5]
    show("5 m away", ik(robot, far, max_restarts=5, seed=0))
    nan = T.copy()
    nan[0, 3] = np.nan
    print("  NaN target:", ik(robot, nan).message)

    targets = [robot.fk(robot.random_configuration(rng)) for _ in range(100)]
    t0 = time.perf_counter()
    results = [ik(robot, target, seed=k) for k, target in enumerate(targets)]
    elapsed = time.perf_counter() - t0
    solved = sum(r.converged and robot.within_limits(r.q) for r in results)
    times = np.array([r.time_s for r in results]) * 1e3
    print(
        f"\n100 random reachable poses: {solved} solved, median {np.median(times):.2f} ms, "
        f"mean {elapsed * 10:.2f} ms per solve (benchmarks/ik.py runs 1,000 per arm)"
    )


if __name__ == "__main__":
    main()
