"""
Your own URDF in ten lines
==========================

Load an arm from a URDF file, pick its tool frame, and drive the tool along a circle with
gradient projection (the joint-limit cost in the null space, Liégeois 1977). The URDF here
is the Panda description committed as a test fixture; use your own file and tip link.

Run: python examples/10_your_own_urdf.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The ten lines
# -------------
# ``from_urdf`` parses the file without executing anything and keeps the base-to-tip
# chain (joints off it, here the fingers, are locked). The run follows a 10 cm circle
# at 1 kHz; ``REDRES_EXAMPLE_STEPS`` sets how many milliseconds.
import os
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.control import Circle
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme
from redres.tasks import FrameTask

# sphinx-gallery runs the script from its folder and without __file__
HERE = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
URDF = HERE.parent / "tests" / "fixtures" / "panda_description.urdf"
STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "5000"))

robot = rr.Robot.from_urdf(URDF, tip="panda_hand_tcp")
q0 = np.array([0.0, -0.3, 0.0, -2.2, 0.0, 2.0, 0.8])
circle = Circle(robot.fk(q0), radius=0.1, period=2.5, ramp=0.25, turns=2)
scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0)
log = rr.run(robot, FrameTask(), circle, scheme, q0=q0, duration=STEPS * 1e-3)

print(f"{robot}: {robot.n} joints; tip frame {robot.tip}")
print(
    f"{log.steps} steps: max position error {1e3 * log.position_error.max():.3f} mm, "
    f"closest joint limit {log.joint_limit_margin.min():.3f} rad"
)

# %%
# What the run did
# ----------------
# Each joint against its range (0 and 1 are the limits), and the tracking error.
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.6))
ax1.plot(log.t, (log.q - robot.q_min) / (robot.q_max - robot.q_min))
for limit in (0.0, 1.0):
    ax1.axhline(limit, color="k", ls="--", lw=0.8)
ax1.set(xlabel="time (s)", ylabel="(q − q_min) / range", title="joints within their limits")
ax2.semilogy(log.t, np.maximum(log.position_error, 1e-9) * 1e3)
ax2.set(xlabel="time (s)", ylabel="position error (mm)", title="tracking")
fig.tight_layout()
plt.show()
