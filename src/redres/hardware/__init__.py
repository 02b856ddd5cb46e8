"""Real robots: redres' controllers in a robot's own control loop.

:func:`run_on_franka` drives a Franka FR3 or Panda at 1 kHz over libfranka (the ``franka``
extra), or its model in a dry run; docs/franka.md says how to run it safely.
"""

from .franka import franka_robot, run_on_franka

__all__ = ["franka_robot", "run_on_franka"]
