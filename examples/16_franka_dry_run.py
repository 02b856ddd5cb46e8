"""
A Franka arm's 1 kHz loop, as a dry run
=======================================

``redres.hardware.run_on_franka`` runs a controller in a Franka FR3's (or Panda's) own
1 kHz loop over libfranka. With the address ``None`` it runs the very same loop on redres'
model: the trajectory built from where the arm stands, command shaping to the FR3's
published limits, the stop to rest at the end. Try every scenario this way first, then
against the protocol simulator, then on the robot (docs/franka.md).

Run: python examples/16_franka_dry_run.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The same circle in velocity and position mode
# ---------------------------------------------
import os

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.hardware import franka_robot, run_on_franka
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme
from redres.testing import command_violations

STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "4000"))
robot = franka_robot("fr3")
limits = (robot.qd_max, robot.qdd_max, robot.qddd_max)
logs = {}
for mode in ("velocity", "position"):
    logs[mode] = run_on_franka(
        None, rr.tasks.FrameTask(), lambda T0: rr.control.Circle(T0, 0.05, 4.0, ramp=0.5),
        GradientProjectionScheme([JointLimitObjective()]), mode=mode, arm="fr3",
        duration=STEPS * 1e-3, progress=False,
    )  # fmt: skip
    log = logs[mode]
    sent = log.extra["command"]
    stream = sent if mode == "velocity" else np.diff(np.vstack([log.q[:1], sent]), axis=0) / 1e-3
    print(f"{mode:8s}: {log.steps} cycles of motion, {len(sent) - log.steps} to stop; "
          f"{len(command_violations(stream, 1e-3, limits))} commands the robot would refuse; "
          f"compute {np.median(log.extra['compute_us']):.0f} µs a cycle (median)")  # fmt: skip

# %%
# The commanded joint velocities, the stop to rest included
# ---------------------------------------------------------
fig, ax = plt.subplots(figsize=(8, 3.4))
sent = logs["velocity"].extra["command"]
t = np.arange(len(sent)) * 1e-3
ax.plot(t, sent, lw=1)
ax.axvline(logs["velocity"].steps * 1e-3, color="k", ls="--", lw=0.8, label="end of the motion")
ax.set(xlabel="robot time (s)", ylabel="q̇ command (rad/s)", title="FR3, velocity mode (dry run)")
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()
