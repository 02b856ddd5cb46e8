"""The joint limits Franka Robotics publishes for its arms, the Panda (FER) and the FR3.

Sources:
    Franka Robotics, "Robot and interface specifications", sections "Limits for Panda" and
    "Limits for Franka Research 3" (position, velocity, acceleration, jerk, torque and
    torque-rate limits per joint); the same numbers, less a margin of 1e-3, are libfranka's
    rate-limiter constants ``kMaxJointAcceleration`` and ``kMaxJointJerk`` in
    ``include/franka/rate_limiting.h`` (Panda up to libfranka 0.9, FR3 from 0.10).

The robot checks each joint command's finite differences at its 1 kHz period against the
velocity, acceleration and jerk limits and aborts the motion at the first cycle over one
(:mod:`redres.control.shaping` keeps a command within them). The FR3 also lowers its
velocity limits near the ends of joint travel (a function of ``q`` in the same document);
``qd_max`` here is the largest value.
"""

from __future__ import annotations

from typing import NamedTuple, TypedDict


class Rates(TypedDict):
    """The keywords of :meth:`redres.Robot.with_limits` that :meth:`JointLimits.rates`
    gives."""

    qd_max: tuple[float, ...]
    qdd_max: tuple[float, ...]
    qddd_max: tuple[float, ...]
    tau_max: tuple[float, ...]


class JointLimits(NamedTuple):
    """Per-joint limits of a seven-joint arm (rad, rad/s, rad/s², rad/s³, N·m, N·m/s)."""

    q_min: tuple[float, ...]
    q_max: tuple[float, ...]
    qd_max: tuple[float, ...]
    qdd_max: tuple[float, ...]
    qddd_max: tuple[float, ...]
    tau_max: tuple[float, ...]
    taud_max: tuple[float, ...]

    def rates(self) -> Rates:
        """The velocity, acceleration, jerk and torque limits as keywords of
        :meth:`redres.Robot.with_limits`: ``robot.with_limits(**FR3.rates())``."""
        return Rates(
            qd_max=self.qd_max, qdd_max=self.qdd_max, qddd_max=self.qddd_max, tau_max=self.tau_max
        )


#: Franka Emika Panda (FER), "Limits for Panda".
PANDA = JointLimits(
    q_min=(-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973),
    q_max=(2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973),
    qd_max=(2.1750, 2.1750, 2.1750, 2.1750, 2.6100, 2.6100, 2.6100),
    qdd_max=(15.0, 7.5, 10.0, 12.5, 15.0, 20.0, 20.0),
    qddd_max=(7500.0, 3750.0, 5000.0, 6250.0, 7500.0, 10000.0, 10000.0),
    tau_max=(87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0),
    taud_max=(1000.0,) * 7,
)

#: Franka Research 3 (FR3), "Limits for Franka Research 3".
FR3 = JointLimits(
    q_min=(-2.7437, -1.7837, -2.9007, -3.0421, -2.8065, 0.5445, -3.0159),
    q_max=(2.7437, 1.7837, 2.9007, -0.1518, 2.8065, 4.5169, 3.0159),
    qd_max=(2.62, 2.62, 2.62, 2.62, 5.26, 4.18, 5.26),
    qdd_max=(10.0,) * 7,
    qddd_max=(5000.0,) * 7,
    tau_max=(87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0),
    taud_max=(1000.0,) * 7,
)
