"""
Three schemes on the joint-limit circle
=======================================

The built-in Panda scenario: the TCP follows a 10 cm circle placed so that minimum-norm
control (Whitney 1969) drives joint 2 past its lower limit. Gradient projection of the
joint-limit cost (Liégeois 1977) and weighted least norm with joint-limit weights (Chan &
Dubey 1995) use the redundant degree of freedom to stay inside. All three track the
circle equally well; they differ in what the seventh joint does.

Run: python examples/12_joint_limit_circle.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The runs
# --------
import os

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme, PseudoInverseScheme, WeightedLeastNormScheme
from redres.scenarios.spec import builtin

STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "10000"))
scenario = builtin("panda_joint_limit_circle")
robot = scenario.robot
schemes = {
    "minimum norm": PseudoInverseScheme(),
    "gradient projection": GradientProjectionScheme([JointLimitObjective()], k_null=5.0),
    "weighted least norm": WeightedLeastNormScheme(),
}
logs = {}
for label, scheme in schemes.items():
    logs[label] = rr.run(robot, scenario.task(), scenario.trajectory, scheme, q0=scenario.q0,
                         duration=STEPS * 1e-3, gain=scenario.gain)  # fmt: skip
    s = logs[label].summary()
    print(f"{label:20s} max error {1e3 * s['max_position_error_m']:.4f} mm, "
          f"min joint-limit margin {s['min_joint_limit_margin_rad']:+.3f} rad")  # fmt: skip

# %%
# Joint 2 against its limit, and the tracking error
# -------------------------------------------------
fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10, 3.8))
for label, log in logs.items():
    ax1.plot(log.t, log.q[:, 1], label=label)
    ax2.semilogy(log.t, np.maximum(log.position_error, 1e-9) * 1e3, label=label)
ax1.axhline(robot.q_min[1], color="k", ls="--", lw=0.8, label="q_min of joint 2")
ax1.set(xlabel="time (s)", ylabel="q₂ (rad)", title="joint 2")
ax2.set(xlabel="time (s)", ylabel="position error (mm)", title="tracking")
ax1.legend(fontsize=8)
fig.tight_layout()
plt.show()
