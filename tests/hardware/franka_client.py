"""One run of ``redres.hardware.run_on_franka`` against a Franka protocol simulator at
127.0.0.1, for ``test_franka.py`` (which starts both in a private network namespace).

Usage: ``python franka_client.py MODE SECONDS OUT.json [--stall]``; ``--stall`` stops the
Python side for 100 ms at 1 s of robot time. Writes what the test asserts on.
"""

from __future__ import annotations

import json
import sys
import time

import numpy as np

import redres as rr
from redres.dynamics import OperationalSpaceController
from redres.errors import RobotStoppedError
from redres.hardware import franka_robot, run_on_franka
from redres.objectives import JointLimitObjective, PostureObjective
from redres.resolution import GradientProjectionScheme
from redres.testing import command_violations

WINDOW = 100  # cycles of the robot's success-rate window
SETTLED = 1000  # cycles after which the tracking error is judged (the ramp is 0.5 s)


class Stalling(rr.control.Trajectory):
    """A circle whose sample at 1 s of robot time takes 100 ms (the client stalls)."""

    def __init__(self, inner: rr.control.Trajectory) -> None:
        self.inner, self.duration, self.stalled = inner, inner.duration, False

    def sample(self, t: float) -> rr.control.Sample:
        if t >= 1.0 and not self.stalled:
            self.stalled = True
            time.sleep(0.1)
        return self.inner.sample(t)


def main() -> int:
    mode, seconds, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
    stall = "--stall" in sys.argv

    def circle(T0: np.ndarray) -> rr.control.Trajectory:
        path = rr.control.Circle(T0, 0.05, 4.0, ramp=0.5, normal=(1.0, 0.0, 0.0), turns=3)
        return Stalling(path) if stall else path

    robot = franka_robot("fr3")
    if mode == "torque":
        posture = [(PostureObjective(), 1.0)]
        task, law = None, OperationalSpaceController(kp=400.0, objectives=posture)
    else:
        task, law = rr.tasks.FrameTask(), GradientProjectionScheme([JointLimitObjective()])
    result: dict[str, object] = {"stopped": None}
    try:
        log = run_on_franka("127.0.0.1", task, circle, law, mode=mode, duration=seconds,  # type: ignore[arg-type]
                            progress=False)  # fmt: skip
    except RobotStoppedError as exc:
        result["stopped"] = str(exc)
        log = exc.log
    if log is not None and log.steps:
        moving = slice(0, min(log.steps, round(seconds * 1000)))
        commands = log.extra["command"]
        if mode == "position":
            commands = np.diff(np.vstack([log.q[:1], commands]), axis=0) / 1e-3
        limits = (robot.qd_max, robot.qdd_max, robot.qddd_max)
        compute = log.extra["compute_us"]
        # Checked between missed cycles only: across one the robot differences against its
        # own carried-on command, which the log does not hold.
        cuts = np.flatnonzero(log.extra["lost_cycles"][: len(commands)])
        pieces = np.split(commands, cuts)
        refused = len(command_violations(pieces[0], 1e-3, limits))  # from rest
        for p in pieces[1:]:  # from the piece's own first two commands
            if len(p) > 2:
                qdd0 = (p[1] - p[0]) / 1e-3
                refused += len(command_violations(p[2:], 1e-3, limits, p[1], qdd0))
        result.update(
            cycles=log.steps,
            lost=int(log.extra["lost_cycles"].sum()),
            # the robot's rate is "the share of the last 100 control commands received"
            # (libfranka's RobotState): its minimum once that window is full
            success_min=float(log.extra["success_rate"][WINDOW:].min())
            if log.steps > WINDOW else 1.0,
            error_settled_mm=float(1e3 * log.position_error[SETTLED : moving.stop].max())
            if moving.stop > SETTLED else None,
            refused=refused if mode != "torque" else 0,
            lost_max=int(log.extra["lost_cycles"].max()),
            compute_median_us=float(np.median(compute)),
            compute_p99_us=float(np.percentile(compute, 99)),
            write_median_us=float(np.median(log.extra["write_us"])),
            robot_time=float(log.extra["robot_time"][-1]),
        )  # fmt: skip
    with open(out, "w") as f:
        json.dump(result, f)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
