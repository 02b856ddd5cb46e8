"""
MuJoCo as the plant
===================

redres' controllers on a robot redres did not simulate: the MuJoCo Menagerie's Franka
Panda (shipped with redres without its meshes), simulated by MuJoCo with its own
integrator, joint damping, armature and actuators. The controllers compute with redres'
robot of the same file; the tracking error is measured by MuJoCo's kinematics.

Three runs on a 5 cm circle: the kinematic ``Controller`` through the joints' position
servos (``run_on_mujoco``), operational-space control through joint torques
(``simulate_on_mujoco``), and the same law with a 1.5 kg load fixed to the flange that
the law does not know about.

Run: python examples/15_mujoco_plant.py   (REDRES_EXAMPLE_STEPS shortens it; needs mujoco)
"""

# %%
# The runs
# --------
import os

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.dynamics import OperationalSpaceController, Payload
from redres.objectives import JointLimitObjective, PostureObjective
from redres.resolution import GradientProjectionScheme
from redres.sim import MujocoPlant, run_on_mujoco, simulate_on_mujoco

STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "3000"))
DURATION = STEPS * 1e-3
plant = MujocoPlant(rr.models.menagerie_path("panda"), timestep=1e-3)
robot = plant.robot()
q0 = robot.neutral()
circle = rr.control.Circle(robot.fk(q0), 0.05, 4.0, ramp=0.5, normal=(1.0, 0.0, 0.0))
law = OperationalSpaceController(kp=400.0, objectives=[(PostureObjective(q0), 1.0)])
logs = {
    "Controller → position servos": run_on_mujoco(
        plant, rr.tasks.FrameTask(), circle, GradientProjectionScheme([JointLimitObjective()]),
        q0=q0, duration=DURATION, progress=False,
    ),
    "operational space → torques": simulate_on_mujoco(
        plant, law, circle, q0=q0, duration=DURATION, progress=False
    ),
}  # fmt: skip
plant.add_payload(Payload(1.5, com=(0.0, 0.0, 0.05), frame=plant.frame))
logs["operational space, 1.5 kg it does not know"] = simulate_on_mujoco(
    plant, law, circle, q0=q0, duration=DURATION, progress=False
)
for name, log in logs.items():
    settled = log.position_error[min(500, STEPS - 1) :]
    print(f"{name:45s} max error after 0.5 s {1e3 * settled.max():7.3f} mm")

# %%
# Tracking error, measured by MuJoCo
# ----------------------------------
fig, ax = plt.subplots(figsize=(8, 3.6))
for name, log in logs.items():
    ax.semilogy(log.t, np.maximum(log.position_error, 1e-9) * 1e3, label=name)
ax.set(xlabel="time (s)", ylabel="position error (mm)", title="the Menagerie Panda in MuJoCo")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()
