"""Plants redres did not write: a MuJoCo model as the robot a controller drives.

:class:`~redres.sim.MujocoPlant` holds an MJCF model simulated by MuJoCo (its own integrator, joint
damping, armature, friction and actuators); :func:`~redres.sim.run_on_mujoco` drives it with a
kinematic :class:`~redres.control.Controller` through its position actuators, and
:func:`~redres.sim.simulate_on_mujoco` with a torque law (``OperationalSpaceController``, the
acceleration controller) through joint torques. Both return a
:class:`~redres.control.RunLog` whose tracking error is measured by MuJoCo's kinematics.
Needs the ``mujoco`` extra (``pip install -e '.[mujoco]'``).
"""

from .mujoco import MujocoPlant, run_on_mujoco, simulate_on_mujoco

__all__ = ["MujocoPlant", "run_on_mujoco", "simulate_on_mujoco"]
