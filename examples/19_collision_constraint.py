"""
Collision avoidance as a hard constraint
========================================

The built-in scenario ``panda_table_shelf`` drives the Panda's hand into a table and
under a shelf board, and past its own base. Two schemes follow it: the QP scheme with the
velocity damper of every pair closer than ``d_i`` as a constraint (Faverjon & Tournassoud,
ICRA 1987; Kanoun, Lamiraux & Wieber, IEEE T-RO 27(4), 2011), and gradient projection
with the soft obstacle penalty (Maciejewski & Klein 1985). The constrained arm never
comes closer than the safety distance ``d_s`` to anything, and pays in task error where
the path asks the impossible; the soft one follows the path into the obstacles.

Run: python examples/19_collision_constraint.py   (REDRES_EXAMPLE_STEPS shortens it)
"""

# %%
# The scenario's two schemes
# --------------------------
# ``run_scenario`` measures every run on the constraint's pairs (environment and self),
# so the two clearances below are of the same pairs.
import os
from dataclasses import replace

import matplotlib.pyplot as plt
import numpy as np

from redres.scenarios.runner import format_table, run_scenario, summarise
from redres.scenarios.spec import builtin

scenario = builtin("panda_table_shelf")
STEPS = int(os.environ.get("REDRES_EXAMPLE_STEPS", str(round(scenario.duration / scenario.dt))))
scenario = replace(scenario, duration=min(scenario.duration, STEPS * scenario.dt))
logs = run_scenario(scenario, progress=False)
print(format_table([summarise(scenario.robot, log) for log in logs]))

# %%
# Clearance over time
# -------------------
# The smallest distance of the arm to the table and the shelf, and between its own
# links, at every step; the dashed line is ``d_s``.
settings = next(s.build().collisions for s in scenario.schemes if s.kind == "qp")
fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 5.5), sharex=True)
for log in logs:
    top.plot(log.t, 1e3 * log.objectives["obstacle_distance_m"], label=log.label)
    bottom.plot(log.t, 1e3 * log.objectives["self_distance_m"], label=log.label)
for ax, title in ((top, "arm to table and shelf"), (bottom, "link to link")):
    ax.axhline(1e3 * settings.safety, color="k", ls="--", lw=0.8, label="d_s")
    ax.axhline(0.0, color="k", lw=0.5)
    ax.set(ylabel="clearance (mm)", title=title)
    ax.grid(alpha=0.3)
top.legend(fontsize=8)
bottom.set_xlabel("time (s)")
fig.tight_layout()
plt.show()

# %%
# The price: task error where the constraint binds
# ------------------------------------------------
# ``log.extra["collision_pairs"]`` records, per step, the pairs within ``d_i`` and which
# of them bound the velocity; the position error of the constrained run rises exactly
# there.
constrained = next(log for log in logs if log.extra["collision_pairs"].constrained)
record = constrained.extra["collision_pairs"]
bound = np.zeros(constrained.steps, dtype=bool)
bound[record.step[record.binding]] = True
print(f"{constrained.label}: a collision row bound the velocity in {bound.sum()} of "
      f"{constrained.steps} steps; largest position error there "
      f"{1e3 * constrained.position_error[bound].max(initial=0.0):.1f} mm, elsewhere "
      f"{1e3 * constrained.position_error[~bound].max(initial=0.0):.1f} mm")  # fmt: skip
fig, ax = plt.subplots(figsize=(7.5, 3.0))
ax.plot(constrained.t, 1e3 * constrained.position_error, label="position error")
ax.fill_between(constrained.t, 0, 1, where=bound, transform=ax.get_xaxis_transform(),
                color="#d62728", alpha=0.15, label="a collision row binds")  # fmt: skip
ax.set(xlabel="time (s)", ylabel="mm", title=constrained.label)
ax.legend(fontsize=8)
fig.tight_layout()
plt.show()
