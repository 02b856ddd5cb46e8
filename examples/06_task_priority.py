"""
Strict task priorities
======================

Pose first, elbow second, posture third; a camera kept on a target while the hand moves;
an algorithmic singularity, exact vs robust.

Run: python examples/06_task_priority.py
"""

from __future__ import annotations

import numpy as np

import redres as rr
from redres.resolution import PriorityScheme, prioritized_velocity
from redres.tasks import FrameTask, LookAtTask, PositionTask, PostureTask


def pose_elbow_posture() -> None:
    """Panda: the TCP pose follows a circle (level 1, from the loop), the elbow drops
    2 cm (level 2), the joints stay near the start (level 3)."""
    robot = rr.models.panda()
    q0 = robot.neutral()
    q0[2] += 0.5  # at the ready pose the elbow height is at an extremum of the self-motion
    circle = rr.control.Circle(robot.fk(q0), radius=0.05, period=2.0)
    T_elbow = robot.fk(q0, "elbow")
    T_elbow[2, 3] -= 0.02
    print("Panda, pose > elbow height > posture (1.5 s circle, 1 kHz):")
    for method in ("exact", "robust"):
        elbow = FrameTask("elbow", rows=["z"])
        elbow.set_target(T_elbow)
        scheme = PriorityScheme([elbow, PostureTask(q0)], method=method, gain=[3.0, 1.0])
        log = rr.run(robot, FrameTask(), circle, scheme, duration=1.5, q0=q0, label=method)
        s = log.summary()
        elbow_error = abs(robot.fk(log.extra["final_q"], "elbow")[2, 3] - T_elbow[2, 3])
        print(
            f"  {method:6}  max TCP error {s['max_position_error_m'] * 1e6:6.2f} um   "
            f"final elbow error {elbow_error * 1e3:6.3f} mm   "
            f"step {s['step_time_us_median']:6.1f} us (median)"
        )


def camera_on_target() -> None:
    """Panda with a camera on the hand: the TCP position follows a circle, the camera's
    optical axis (z) turns onto a point on the table and stays on it."""
    robot = rr.models.panda()
    robot.add_frame("camera", "hand", np.eye(4))
    q0 = robot.neutral()
    look = LookAtTask("camera", target=[0.5, 0.0, 0.0])
    circle = rr.control.Circle(robot.fk(q0), radius=0.08, period=2.0)
    scheme = PriorityScheme([look, PostureTask(q0)], gain=[6.0, 1.0])
    log = rr.run(robot, PositionTask(), circle, scheme, duration=1.5, q0=q0)
    angles = [np.degrees(look.angle(robot, q)) for q in log.q[::300]]
    print("\nCamera kept on a point while the hand circles (angle off target, deg):")
    print("  t = " + "  ".join(f"{t:4.1f} s" for t in log.t[::300]))
    print("      " + "  ".join(f"{a:6.3f}" for a in angles))
    print(f"  max TCP error {log.summary()['max_position_error_m'] * 1e6:.2f} um")


def algorithmic_singularity() -> None:
    """Planar 3R arm: level 1 the tip (x, y), level 2 the height of joint 3. With the tip
    fixed, joint 3 moves horizontally when the last link is vertical: J2 P1 = 0 there
    although J1 and J2 are fine. The exact recursion's joint speed grows like 1/distance;
    Chiaverini's singularity-robust scheme stays bounded (level 2 only approximately met)."""
    robot = rr.models.planar([1.0, 1.0, 1.0])
    print("\nAlgorithmic singularity (planar 3R), |qd| in rad/s:")
    print(f"  {'distance':>9} {'sigma(J2 P1)':>13} {'exact':>11} {'robust':>8} {'damped':>8}")
    for d in (1e-1, 1e-2, 1e-3, 1e-4, 1e-5):
        q = np.array([0.3, 1.1, np.pi / 2 - 1.4 + d])
        J1, J2 = robot.jacobian(q)[[0, 1]], robot.jacobian(q, "link2")[[1]]
        xs = [np.array([0.1, -0.05]), np.array([0.1])]
        speeds = {}
        for method in ("exact", "robust", "damped"):
            qd, levels = prioritized_velocity([J1, J2], xs, method=method)
            speeds[method] = np.linalg.norm(qd)
        print(
            f"  {d:9.0e} {levels[1].sigma_min:13.2e} {speeds['exact']:11.4g} "
            f"{speeds['robust']:8.4f} {speeds['damped']:8.4f}"
        )


def main() -> None:
    pose_elbow_posture()
    camera_on_target()
    algorithmic_singularity()


if __name__ == "__main__":
    main()
