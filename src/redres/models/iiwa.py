"""KUKA LBR iiwa 14 R820: 7-DOF S-R-S arm, from the URDF shipped in ``data/iiwa14.urdf``.

Sources (also in the URDF header): KUKA, "LBR iiwa 7 R800, LBR iiwa 14 R820
Specification" for the link lengths (0.36, 0.42, 0.40, 0.126 m) and the position,
velocity and torque limits; the iiwa_stack ROS description (Hennersperger et al.,
ICRA 2017) for the link frames and its approximate inertial values.
"""

from __future__ import annotations

from importlib import resources

import numpy as np

from ..robot import Robot
from .srs import sew_capsules

#: A bent-elbow pose away from singularities, rad.
HOME = (0.0, np.pi / 6, 0.0, -np.pi / 2, 0.0, np.pi / 3, 0.0)


def iiwa14() -> Robot:
    """The KUKA LBR iiwa 14 R820.

    Frames: ``link0`` … ``link7`` (URDF links), ``flange`` (default tip), and
    ``shoulder``, ``elbow``, ``wrist``: the centres of the spherical shoulder (axes 1–3),
    the elbow (axis 4) and the spherical wrist (axes 5–7).
    """
    urdf = resources.files("redres.models") / "data" / "iiwa14.urdf"
    with resources.as_file(urdf) as path:
        robot = Robot.from_urdf(path, tip="flange", name="iiwa14")
    robot.add_frame("shoulder", "link2", np.eye(4))
    robot.add_frame("elbow", "link4", np.eye(4))
    robot.add_frame("wrist", "link6", np.eye(4))
    robot = Robot(robot.model, tip="flange", name="iiwa14", home=HOME)
    robot.capsules = sew_capsules(robot, "link0", "flange", (0.09, 0.08, 0.07, 0.06))
    return robot
