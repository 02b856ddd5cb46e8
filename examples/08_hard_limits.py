"""
Hard joint limits: QP and SNS
=============================

Hard joint limits — soft avoidance against QP and SNS guarantees.

The Panda's TCP follows a 10 cm circle placed so that the minimum-norm pseudo-inverse
drives joint 2 past its limit. Gradient projection avoids the limits softly (a cost); the
QP scheme and saturation in the null space (SNS) keep position, velocity and acceleration
limits as hard constraints over every 1 ms step. The table reports, for each scheme, by
how much the run broke each limit and how well it tracked the circle.

Run: python examples/08_hard_limits.py
"""

from __future__ import annotations

import numpy as np

import redres as rr
from redres.objectives import JointLimitObjective
from redres.resolution import (
    GradientProjectionScheme,
    JointLimits,
    PseudoInverseScheme,
    QPScheme,
    SNSScheme,
    run_violation,
)
from redres.scenarios.spec import builtin

DT = 1e-3


def main() -> None:
    scenario = builtin("panda_joint_limit_circle")
    duration = 6.5  # s: the pseudo-inverse leaves joint 2's range at t = 6.3 s
    robot = scenario.robot
    limits = JointLimits.from_robot(robot)
    schemes = [
        PseudoInverseScheme(),
        GradientProjectionScheme([JointLimitObjective()], k_null=5.0),
        QPScheme(dt=DT),  # the loop's dt: the bounds look one step ahead
        SNSScheme(dt=DT),
    ]
    print(f"{scenario.description}; first {duration} s at 1 kHz")
    header = ("scheme", "pos viol rad", "vel viol", "acc viol", "max err mm", "rms err mm",
              "min margin rad", "median µs")  # fmt: skip
    print(f"{header[0]:<19} | " + " | ".join(f"{h:>14}" for h in header[1:]))
    for scheme in schemes:
        log = rr.control.run(robot, scenario.task(), scenario.trajectory, scheme,
                             q0=scenario.q0, dt=DT, duration=duration)  # fmt: skip
        v = run_violation(limits, log.q, log.qd, DT)
        s = log.summary()
        row = (
            scheme.name,
            *(f"{x:.2e}" for x in (v.position, v.velocity, v.acceleration)),
            f"{1e3 * s['max_position_error_m']:.3f}",
            f"{1e3 * s['rms_position_error_m']:.3f}",
            f"{s['min_joint_limit_margin_rad']:.4f}",
            f"{s['step_time_us_median']:.1f}",
        )
        print(f"{row[0]:<19} | " + " | ".join(f"{c:>14}" for c in row[1:]))

    # One infeasible step, reported rather than raised: 1 m/s from rest.
    q = robot.neutral()
    J = robot.jacobian(q)
    xd = np.array([1.0, 0.0, 0.0, 0.0, 0.0, 0.0])
    qp_step = QPScheme(dt=DT).step(robot, q, J, xd)
    sns_step = SNSScheme(dt=DT).step(robot, q, J, xd)
    print("\n1 m/s along x from rest (the acceleration limits allow a few mm/s in 1 ms):")
    print(f"  qp : feasible={qp_step.feasible}, residual "
          f"{qp_step.details.residual:.3f} m/s, binding {len(qp_step.binding)} "
          f"bounds, e.g. {qp_step.binding[0]}")  # fmt: skip
    print(
        f"  sns: same direction, scaled by {sns_step.details.scale:.4f} "
        f"(J q̇ = s ẋ to {np.abs(J @ sns_step.qd - sns_step.details.scale * xd).max():.1e})"
    )


if __name__ == "__main__":
    main()
