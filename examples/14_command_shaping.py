"""
Commands a real robot accepts: command shaping
==============================================

A Franka arm checks every joint command of its 1 kHz loop: the finite differences of the
command stream must stay within the published velocity, acceleration and jerk limits, or
the robot stops the motion at that cycle. A CLIK controller does not know about them: the
robot here starts 4 mrad per joint away from where the circle begins, and the controller's
first command asks for that whole correction at once.

``rr.run(..., shaping=True)`` (or ``Controller(..., shaping=True)``) ends every step in a
:class:`~redres.control.CommandShaper` of the robot's ``qd_max``, ``qdd_max`` and
``qddd_max`` (the Panda model carries Franka's published values): the commands then start
from rest and keep every limit, checked below by
:func:`redres.testing.command_violations`, which differences the stream as the robot does.

Run: python examples/14_command_shaping.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The same run, with and without shaping
# --------------------------------------
import os

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.objectives import JointLimitObjective
from redres.resolution import GradientProjectionScheme
from redres.scenarios.spec import builtin
from redres.testing import command_violations

STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "1500"))
DT = 1e-3
scenario = builtin("panda_joint_limit_circle")
robot = scenario.robot
limits = (robot.qd_max, robot.qdd_max, robot.qddd_max)
q0 = scenario.q0 + 0.004 * np.array([1, -1, 1, -1, 1, -1, 1])  # 4 mrad off the start
logs = {}
for shaping in (False, True):
    scheme = GradientProjectionScheme([JointLimitObjective()], k_null=5.0)
    log = rr.run(robot, scenario.task(), scenario.trajectory, scheme, q0=q0, gain=scenario.gain,
                 duration=STEPS * DT, shaping=shaping, progress=False)  # fmt: skip
    logs[shaping] = log
    refused = command_violations(log.qd, DT, limits)
    first = ""
    if refused:
        c = refused[0]
        first = f"(first: cycle {c.cycle}, {c.quantity} of joint {c.joint + 1}, {c.ratio:.0f}x)"
    settled = log.position_error[min(300, STEPS - 1) :]
    print(f"{'shaped' if shaping else 'not shaped':10s}: {len(refused):4d} commands over a "
          f"limit {first}; max error {1e3 * log.position_error.max():.3f} mm, after 0.3 s "
          f"{1e3 * settled.max():.4f} mm")  # fmt: skip

# %%
# Joint 2's command stream against its limits
# -------------------------------------------
# Velocity, acceleration and jerk of the commands as the robot computes them (differences
# at 1 kHz, the first against the robot at rest) over the first 60 ms, as a fraction of
# the limit: the robot refuses a cycle above 1.
window = min(60, STEPS)
fig, axes = plt.subplots(1, 3, figsize=(11, 3.4), sharey=True)
names = ("velocity", "acceleration", "jerk")
for shaping, log in logs.items():
    v = log.qd[:window, 1]
    a = np.diff(np.r_[0.0, v]) / DT
    j = np.diff(np.r_[0.0, a]) / DT
    for ax, values, limit in zip(axes, (v, a, j), (lim[1] for lim in limits)):
        ratio = np.maximum(np.abs(values) / limit, 1e-4)
        ax.semilogy(np.arange(1, window + 1), ratio, label="shaped" if shaping else "not shaped")
for ax, name in zip(axes, names):
    ax.axhline(1.0, color="k", ls="--", lw=0.8)
    ax.set(xlabel="cycle (ms)", title=f"joint 2 {name} / its limit")
axes[0].legend(fontsize=8)
fig.tight_layout()
plt.show()
