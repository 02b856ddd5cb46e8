"""
The global optimum against the local schemes
============================================

Every scheme of the scenario ``panda_joint_limit_circle`` decides its joint velocity from
the present configuration. ``rr.plan_path`` plans the whole circle at once: at each sample
every IK solution at 360 values of ``q7`` (8 branches), then the joint path, within the
velocity limits, whose smallest joint-limit margin is the largest (dynamic programming,
Ferrentino, Salvioli & Chiacchio, Robotics 10(1):42, 2021). From the scenario's start
configuration, the table gives each local scheme's smallest margin as a share of that
optimum (``redres.scenarios.planned.compare_with_plan``, or ``redres plan SCENARIO``);
then a controller tracks the plan.

Run: python examples/18_global_plan.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The plan and the scenario's schemes
# -----------------------------------
import os
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np

import redres as rr
from redres.resolution import PriorityScheme
from redres.scenarios.planned import compare_with_plan
from redres.scenarios.spec import builtin
from redres.tasks import PostureTask

STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", "10000"))  # of 1 ms
scenario = builtin("panda_joint_limit_circle")
scenario = replace(scenario, duration=min(scenario.duration, STEPS * 1e-3))
robot, path = scenario.robot, scenario.trajectory
found = compare_with_plan(scenario, objective="joint_limit_margin", parameter="q7",
                          resolution=360, dt=0.01)  # fmt: skip
plan, logs = found.plan, found.logs
print(f"global plan: min margin {plan.objective:.3f} rad ({plan.stats.feasible_nodes:,} "
      f"feasible nodes of {plan.stats.nodes:,}, {plan.stats.components} component(s))")  # fmt: skip
print(found.table())

# %%
# A controller tracks the plan
# ----------------------------
# The circle is the frame task; the plan's ``q(t)`` a posture level below it.
posture = PostureTask(plan.q[0])
task = scenario.task()
controller = rr.Controller(robot, task, PriorityScheme([posture], gain=100.0),
                           gain=scenario.gain, dt=1e-3)  # fmt: skip
q = scenario.q0.copy()
t = np.arange(round(scenario.duration / 1e-3)) * 1e-3
tracked, error = np.zeros((len(t), robot.n)), np.zeros(len(t))
for k, now in enumerate(t):
    sample = path.sample(float(now))
    task.set_target(sample.pose, sample.twist)
    posture.q_ref[:] = plan.at(float(now))[0]  # type: ignore[index]
    q = controller.step(q)
    tracked[k], error[k] = q, np.linalg.norm(controller.error[:3])
margin = np.minimum(tracked - robot.q_min, robot.q_max - tracked).min()
print(f"tracked: max position error {1e3 * error.max():.4f} mm, min margin {margin:.3f} rad")

# %%
# Margins over time
# -----------------
fig, ax = plt.subplots(figsize=(7, 3.8))
ax.plot(t, np.minimum(tracked - robot.q_min, robot.q_max - tracked).min(axis=1), "k", lw=2,
        label="global plan, tracked")  # fmt: skip
for log in logs:
    ax.plot(log.t, log.joint_limit_margin, lw=1, label=log.label or log.scheme)
ax.axhline(0.0, color="grey", lw=0.8)
ax.set(xlabel="time (s)", ylabel="smallest joint-limit margin (rad)")
ax.legend(fontsize=7)
fig.tight_layout()
plt.show()
